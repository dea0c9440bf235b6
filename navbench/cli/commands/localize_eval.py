"""``navbench localize-eval``: image-based localisation with no initial pose (RNR-Map C.2-C.3)."""

from __future__ import annotations

import typer
from rich.markup import escape

from navbench.cli._common import console, print_json
from navbench.cli._help import DB_HELP, SET_HELP, SIM_HELP, profile_help

#: The object-change difficulties ``--changes`` accepts (RNR-Map Table 2).
OC_NAMES = ("OC1", "OC2", "OC3", "OC4")


def register(app: typer.Typer) -> None:
    @app.command("localize-eval")
    def localize_eval(
        level: str = typer.Argument(..., help="Level name (levels/NAME.json) or path to a level file."),
        queries: int = typer.Option(1000, "--queries", min=1, max=100_000, help="Query views."),
        map_: str = typer.Option("fit", "--map", help="fit: the profile's fitted world model (built "
                                 "if missing); true: the voxelised true geometry; or a map file."),
        profile: str = typer.Option(None, "--profile", help=profile_help("Profile whose fit settings "
                                                                          "build the map with --map fit")),
        sets: list[str] = typer.Option(None, "--set", metavar="KEY=VALUE", help=SET_HELP),
        changes: str = typer.Option(None, "--changes", help="Object-change difficulty OC1..OC4: "
                                    "queries rendered in a changed level (furniture added, moved, "
                                    "removed), localised in the original's map."),
        sampling: str = typer.Option("uniform", "--sampling", help="Query poses: uniform (free "
                                     "space, uniform headings) or trajectory (views along the "
                                     "tracking trajectories, RNR-Map's protocol)."),
        camera: str = typer.Option("half", "--camera", help="half or paper."),
        seed: int = typer.Option(0, "--seed", min=0, max=2**63 - 1, help="Query (and changed-level) seed."),
        option: list[str] = typer.Option([], "--option", "-o", help="Localiser setting KEY=VALUE "
                                         "(a LocalizerConfig field, repeatable), e.g. min_candidates=5."),
        sim: str = typer.Option(None, "--sim", help=SIM_HELP + " The query frames are its; on vizdoom "
                                "the pose the engine shows is the query's true pose \\[default: the "
                                "profile's sim with --map fit, else pymunk]."),
        json_out: bool = typer.Option(False, "--json", help="Print one JSON object."),
        db: str = typer.Option(None, "--db", help=DB_HELP),
        no_store: bool = typer.Option(False, "--no-store", help="Do not store the per-query rows "
                                      "in the results database."),
    ):
        """Localise held-out views (uniform free poses and headings) in the map with no prior.

        Reports recall within 25 / 50 / 100 cm and within 50 cm and 10 deg, median errors,
        query time (median, p90) and the signature bank's build time and size.
        """
        import time
        from contextlib import nullcontext

        from navbench.cli.commands._pipeline_ui import command_line, run_with_ui
        from navbench.errors import ConfigError
        from navbench.geometry import camera_by_name
        from navbench.pipeline.profiles import load_profile
        from navbench.pipeline.run import open_db, recorded_run, stage_context
        from navbench.pipeline.stages import study_level, study_map
        from navbench.pipeline.stages.localize import (LocalizeEvalConfig, load_localize_results,
                                                       localize_eval_stage, localize_key_config,
                                                       summarise_localization)

        if changes is not None and changes.upper() not in OC_NAMES:
            raise ConfigError(f"--changes: expected one of {', '.join(OC_NAMES)}, got {changes!r}")
        changes = changes.upper() if changes else None
        camera_by_name(camera)
        from navbench.errors import ConfigError
        from navbench.pipeline.stages.track_eval import check_map_spec

        check_map_spec(map_)  # before the database is opened (no level row, no run row)
        if sets and map_ != "fit":
            raise ConfigError(f"--set: changes the profile's map settings, which only --map fit reads (--map {map_})")
        from navbench.pipeline.overrides import apply_sets

        prof = apply_sets(load_profile(profile), sets) if map_ == "fit" else None
        from navbench.sim.backends import require_sim

        if sim is None:
            sim = prof.sim if prof is not None else "pymunk"
        require_sim(sim)  # a known name, and vizdoom installed: before anything is built
        if prof is not None:  # --map fit: the map of the same simulator's views (as track-eval)
            from navbench.pipeline.profiles import override

            prof = override(prof, sim=sim)
        cfg = LocalizeEvalConfig(queries=queries, seed=seed, camera=camera, changes=changes,
                                 localizer=_localizer_config(option), sampling=sampling, sim=sim).resolved()
        t0 = time.perf_counter()

        def body(ui):
            with (nullcontext() if no_store else open_db(db)) as rdb:
                ctx = stage_context(ui, rdb)
                level_ref = study_level(ctx, level, prof)
                vmap = study_map(ctx, map_, level_ref, prof)
                # the study as keyed: its sim only when not pymunk (a pymunk run's config as before)
                config = {"level": level_ref.key, "map": vmap.key,
                          "localize": localize_key_config(cfg)["study"]}
                record = nullcontext() if rdb is None else recorded_run(
                    rdb, "localize-eval", command_line(), config, ctx, f"localize-eval-{level_ref.name}",
                    sim=sim)  # the run's benchmark version names the simulator (navbench-1+vizdoom)
                with record as run_id:
                    ref = localize_eval_stage(ctx, level_ref, vmap, cfg)
                    res = load_localize_results(ref.path)
                    stored = None if rdb is None else _store(rdb, run_id, res, ref, level_ref.name,
                                                             vmap.key, changes)
                return level_ref, vmap, ref, res, stored

        level_ref, vmap, ref, res, stored = run_with_ui(body, json_mode=json_out)
        s = summarise_localization(res)
        if json_out:
            print_json({**s, "meta": {"level": level_ref.name, "map": map_, "map_key": vmap.key,
                                      "study_key": ref.key, "bank_key": ref.meta["bank_key"],
                                      "cached": ref.cached, "bank_cached": ref.meta["bank_cached"],
                                      "camera": camera, "changes": changes, "seed": seed,
                                      "sampling": sampling, "sim": sim,
                                      "wall_s": round(time.perf_counter() - t0, 3), "stored": stored}})
            return
        from rich.table import Table

        title = f"localisation on {level_ref.name} ({queries} queries, map {map_}, camera {camera}"
        title += f", changes {changes}" if changes else ""
        title += f", {sampling} queries" + (f", sim {sim})" if sim != "pymunk" else ")")
        t = Table(title=escape(title))
        t.add_column("figure")
        t.add_column("value", justify="right")
        rows = [("recall <= 25 / 50 / 100 cm", f"{100 * s['recall_25cm']:.1f} / {100 * s['recall_50cm']:.1f} / "
                 f"{100 * s['recall_100cm']:.1f} %"),
                ("recall <= 50 cm and 10 deg", f"{100 * s['recall_50cm_10deg']:.1f} %"),
                ("heading <= 10 deg", f"{100 * s['heading_10deg']:.1f} %"),
                ("median error", f"{100 * s['median_loc_err_m']:.2f} cm, {s['median_heading_err_deg']:.3f} deg"),
                ("query time median / p90", f"{s['query_ms_median']:.1f} / {s['query_ms_p90']:.1f} ms"),
                ("query CPU time median / p90", f"{s['query_cpu_ms_median']:.1f} / {s['query_cpu_ms_p90']:.1f} ms"),
                ("bank build / size", f"{s['bank_build_s']:.1f} s / {s['bank_mb']:.1f} MB")]
        if changes:
            rows.append(("mean image difference", f"{100 * s['image_diff_mean']:.1f} %"))
        for r in rows:
            t.add_row(*r)
        console.print(t)
        if stored:
            console.print(f"stored {stored['rows']} new localisation rows (run {stored['run_id']}) in "
                          f"{stored['db']}", markup=False)


def _localizer_config(items: list[str]):
    """``--option KEY=VALUE`` items applied to the default :class:`LocalizerConfig` (values read
    as JSON when they parse, else kept as strings)."""
    from navbench.errors import ConfigError
    from navbench.localize import LocalizerConfig
    from navbench.safeio import parse_option_value
    from navbench.track.base import config_from_options

    opts = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"--option expects KEY=VALUE, got {item!r}")
        opts[key.strip()] = parse_option_value(value, f"--option {key.strip()}")
    from navbench.pipeline.checks import check_localizer_options

    # the ranges of [navigation] goal_localizer: a lattice_step of 1e-9 m is refused before the
    # bank allocates its lattice (issue 34)
    check_localizer_options({k: v for k, v in opts.items() if hasattr(LocalizerConfig, k)}, "--option")
    base = LocalizerConfig()
    for k, v in list(opts.items()):
        d = getattr(base, k, None)
        if d is None:
            continue  # unknown: named below
        if isinstance(d, float) and isinstance(v, (int, float)) and not isinstance(v, bool):
            opts[k] = float(v)
        elif type(v) is not type(d):
            raise ConfigError(f"--option {k}: expected a {type(d).__name__}, got {v!r}")
    try:
        return config_from_options(base, opts, "--option localizer")
    except Exception as e:  # TrackingError for an unknown name: say which option
        raise ConfigError(str(e)) from None


def _store(rdb, run_id: int, res: dict, ref, level: str, map_key: str, changes: str | None) -> dict:
    """One row per query under the study's key (a rerun adds no duplicates)."""
    import numpy as np

    from navbench.geometry import wrap_angle

    err = np.hypot(*(res["est"][:, :2] - res["true"][:, :2]).T)
    herr = np.degrees(np.abs(wrap_angle(res["est"][:, 2] - res["true"][:, 2])))
    rows = [{"study_key": ref.key, "level": level, "map_key": map_key, "changes": changes,
             "query_id": i, "true_x": t[0], "true_y": t[1], "true_theta": t[2],
             "est_x": e[0], "est_y": e[1], "est_theta": e[2], "loc_err_m": float(err[i]),
             "heading_err_deg": float(herr[i]), "confidence": float(res["confidence"][i]),
             "query_ms": float(res["query_ms"][i]), "query_cpu_ms": float(res["query_cpu_ms"][i]),
             "image_diff": float(res["diff"][i])}
            for i, (t, e) in enumerate(zip(res["true"].tolist(), res["est"].tolist()))]
    n = rdb.add_localize_rows(run_id, rows)
    return {"run_id": run_id, "rows": n, "db": rdb.display_url}
