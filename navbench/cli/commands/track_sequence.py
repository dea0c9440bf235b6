"""``navbench track-sequence``: track a TUM RGB-D sequence against a map with odometry."""

from __future__ import annotations

from pathlib import Path

import typer

from navbench.cli import _tum
from navbench.cli._common import console, print_json
from navbench.cli._help import DB_HELP, default


def register(app: typer.Typer) -> None:
    @app.command("track-sequence")
    def track_sequence_cmd(
        directory: Path = typer.Argument(..., metavar="DIR", help="TUM RGB-D directory (rgb.txt, "
                                         "depth.txt, groundtruth.txt, rgb/, depth/, intrinsics.json)."),
        map_: str = typer.Option(None, "--map", metavar="PATH|KEY", help="Map file (map.npz), map "
                                 "artifact directory or fit-map/true-map cache key; not needed by "
                                 "no-map and dynamics."),
        estimator: str = typer.Option("ours", "--estimator", help="ours, no-map, dynamics or "
                                      "emission (or a plugin's estimator)."),
        odometry: str = typer.Option("gt+mid", "--odometry", metavar="FILE|gt+NOISE", help="A TUM "
                                     "file of odometry poses (one per frame, matched by timestamp), "
                                     "or gt+none|low|mid|high|tracking: the ground truth's increments "
                                     "with that noise level, seeded by --seed."),
        out: Path = typer.Option(None, "--out", metavar="EST.txt", help="Where the estimate goes (strict TUM) "
                                 + default("results/sequences/NAME/EST_ODOM_seedS.txt, NAME the "
                                           "sequence's folder") + "."),
        seed: int = typer.Option(0, "--seed", min=0, max=2**63 - 1, help="Odometry noise and pixel-sampling seed."),
        option: list[str] = typer.Option([], "--option", "-o", help="Estimator option KEY=VALUE "
                                         "(repeatable), e.g. -o optimizer=adam."),
        fx: float = _tum.FX, fy: float = _tum.FY, cx: float = _tum.CX, cy: float = _tum.CY,
        camera_height: float = _tum.CAMERA_HEIGHT, depth_scale: float = _tum.DEPTH_SCALE,
        max_dt: float = _tum.MAX_DT, max_tilt: float = _tum.MAX_TILT,
        max_height_dev: float = _tum.MAX_HEIGHT,
        json_out: bool = typer.Option(False, "--json", help="Print one JSON object."),
        db: str = typer.Option(None, "--db", help=DB_HELP),
        no_store: bool = typer.Option(False, "--no-store", help="Do not store the row in the "
                                      "results database."),
    ):
        """Track a sequence from its known first pose with odometry; write the estimate as TUM.

        Prints ATE RMSE (translation, no alignment), RPE per frame (translation and rotation),
        the odometry's own ATE (dead reckoning) and the median ms per frame; stores one row in
        the database's sequence_tracking table.
        """
        from contextlib import nullcontext

        from navbench.cli.commands._pipeline_ui import command_line
        from navbench.pipeline.run import open_db
        from navbench.pipeline.stages.sequence import TrackSequenceConfig
        from navbench.pipeline.tracking import track_sequence

        if out is not None:  # checked before the sequence is read and tracked
            _check_out(out, directory, odometry)
        if not odometry.startswith("gt+"):  # an odometry file: regular, before the database opens
            from navbench.errors import ConfigError
            from navbench.safeio import check_regular_file

            check_regular_file(odometry, ConfigError, "odometry file")
        reading = _tum.import_options(fx, fy, cx, cy, camera_height, depth_scale, max_dt, max_tilt,
                                      max_height_dev)
        options = _parse_options(option)
        if options:  # the checks of track-eval -o (types, ranges), before the sequence is read
            from navbench.pipeline.checks import check_estimator_options
            from navbench.track.registry import check_estimator_names

            check_estimator_names([estimator], "--estimator")
            check_estimator_options({estimator: options}, "--option")
        cfg = TrackSequenceConfig(estimator=estimator, odometry=odometry, seed=seed,
                                  options=options, max_tilt_deg=max_tilt,
                                  max_dt=max_dt)
        with (nullcontext() if no_store else open_db(db)) as rdb:
            res = track_sequence(directory, map_, cfg, out=out if out is not None else "default",
                                 db=rdb, command=command_line(), reading=reading)
        summary = {**res.summary(), "out": str(res.out), "stored": res.stored}
        from navbench.pipeline.stages.sequence import motion_warning

        warning = motion_warning(res.true_poses)
        if warning is not None:  # on stderr: the JSON on stdout stays one object
            from navbench.cli._common import err_console

            err_console.print(warning, style="yellow", markup=False, highlight=False)
        if json_out:
            print_json(summary)
            return
        s = summary
        console.print(f"{s['estimator']} on {directory} ({s['frames']} frames, odometry "
                      f"{s['odometry']}, seed {s['seed']})", markup=False)
        console.print(f"  ATE RMSE        {s['ate_m']:.4f} m   (odometry alone {s['odometry_ate_m']:.4f} m)",
                      markup=False)
        console.print(f"  RPE per frame   {s['rpe_m']:.4f} m, {s['rpe_deg']:.3f} deg", markup=False)
        console.print(f"  rotation RMSE   {s['rot_rmse_deg']:.3f} deg", markup=False)
        console.print(f"  time per frame  {s['ms_per_frame']:.2f} ms (median)", markup=False)
        console.print(f"  estimate        {s['out']}", markup=False)
        if res.stored is not None:
            console.print(f"  stored {res.stored} new sequence_tracking row(s)", markup=False)


def _check_out(out: Path, directory: Path, odometry: str) -> None:
    """Refuse an ``--out`` that is not a TUM text file or that would overwrite an input: the
    sequence's rgb.txt, depth.txt, groundtruth.txt or the odometry file."""
    from navbench.errors import ConfigError
    from navbench.outpath import check_output

    check_output(out, "--out", kind="file", suffixes=(".txt", ".tum"), example="est.txt")
    inputs = [directory / n for n in ("rgb.txt", "depth.txt", "groundtruth.txt")]
    if not odometry.startswith("gt+"):
        inputs.append(Path(odometry))
    target = out.resolve()
    for p in inputs:
        if p.resolve() == target:
            raise ConfigError(f"--out {out}: is an input of this command ({p}); the estimate "
                              f"goes to a new file, e.g. est.txt")


def _parse_options(items: list[str]) -> dict:
    """``["optimizer=adam", "gn_pixels=2000"]`` -> a dict; values read as JSON when possible."""
    from navbench.errors import ConfigError
    from navbench.safeio import parse_option_value

    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"--option expects KEY=VALUE, got {item!r}")
        out[key.strip()] = parse_option_value(value, f"--option {key.strip()}")
    return out
