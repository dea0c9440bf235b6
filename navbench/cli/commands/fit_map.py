"""``navbench fit-map``: fit a voxel world model to a level's views, or to any views (a file, a
TUM RGB-D directory, a cache key), and report its quality."""

from __future__ import annotations

import dataclasses

import typer

from navbench.cli import _tum
from navbench.cli._common import console, print_json
from navbench.cli._help import DB_HELP, SET_HELP, SIM_HELP, default, profile_default, profile_help
from navbench.pipeline.profiles import MAX_FIT_STEPS, MAX_VIEWS  # light


def register(app: typer.Typer) -> None:
    @app.command("fit-map")
    def fit_map(
        level: str = typer.Argument(None, help="Level name (levels/NAME.json). Optional with "
                                    "--views PATH|KEY; given, the slice scores are added."),
        steps: int = typer.Option(None, "--steps", min=1, max=MAX_FIT_STEPS, help=f"Adam steps {profile_default('fit_steps')}."),
        views: str = typer.Option(None, "--views", help="Training views: a views artifact (what "
                                  "import-views --out writes), a TUM RGB-D directory, a key (>= 6 "
                                  "hex digits) of an import-views or collect-views artifact, or "
                                  "'auto' (collect on LEVEL with the profile's settings, cached) "
                                  f"{default('auto when LEVEL is given')}."),
        heldout: str = typer.Option(None, "--heldout", help="Held-out views for the map's quality "
                                    "(path, TUM directory or key, as --views) "
                                    f"{default('every --heldout-every-th view of --views')}."),
        heldout_every: int = typer.Option(10, "--heldout-every", min=2, max=MAX_VIEWS, help="Without --heldout: "
                                          "views N-1, 2N-1, ... of --views are held out, the rest fitted."),
        seed: int = typer.Option(None, "--seed", min=0, max=2**63 - 1, help=f"Batch sampling seed {profile_default('fit_seed')}."),
        camera: str = typer.Option(None, "--camera", help=f"half or paper, for LEVEL's collected views {profile_default('camera')}."),
        profile: str = typer.Option(None, "--profile", help=profile_help("Profile for defaults")),
        sets: list[str] = typer.Option(None, "--set", metavar="KEY=VALUE", help=SET_HELP),
        sim: str = typer.Option(None, "--sim", help=f"{SIM_HELP}: of LEVEL's views {profile_default('sim')}."),
        device: str = typer.Option(None, "--device", help="Where the fit runs: auto (= cpu, the numba path: "
                                   "faster than cuda even on an H100, docs/notebook/gpu.md), cpu, cuda[:N] (the "
                                   "GPU path), or torch-cpu (the GPU path's code on the CPU, slow) "
                                   f"{profile_default('fit', fit_key='device', otherwise='auto')}."),
        fx: float = _tum.FX, fy: float = _tum.FY, cx: float = _tum.CX, cy: float = _tum.CY,
        camera_height: float = _tum.CAMERA_HEIGHT, depth_scale: float = _tum.DEPTH_SCALE,
        max_dt: float = _tum.MAX_DT, max_tilt: float = _tum.MAX_TILT,
        max_height_dev: float = _tum.MAX_HEIGHT,
        json_out: bool = typer.Option(False, "--json", help="Print one JSON object with the quality metrics."),
        force: bool = typer.Option(False, "--force", help="Refit even when cached."),
        db: str = typer.Option(None, "--db", envvar="NAVBENCH_DB",
                               help=DB_HELP),
    ):
        """Fit M_occ and M_col (eq. 3) and evaluate the map on held-out views.

        LEVEL alone (or --views auto / a collect-views key of LEVEL): the profile's views of the
        level, evaluated on the profile's held-out views (views.eval_count, seed
        views.eval_seed) and the level's true slice. --views PATH|DIR|KEY: any views, no level
        needed (the map's box is the views' box: the poses and observed points of an import);
        quality on --heldout, else on every --heldout-every-th view (held out of the fit); the
        slice precision and recall only when LEVEL is given. TUM directories are read with the
        import-views options. Quality: depth MAE (m) and RGB L1 on the held-out views, fit time
        and steps.
        """
        from navbench.cli.commands._pipeline_ui import PipelineUI, load_profile_with, warn_ignored_textures
        from navbench.errors import ConfigError
        from navbench.pipeline.run import open_db, stage_context
        from navbench.pipeline.stages import LevelConfig, MAP_METRIC_KEYS, fit_map_for_profile, make_level_stage

        if level is None and views in (None, "auto"):
            raise ConfigError("fit-map: give a LEVEL, or --views PATH|DIR|KEY (a views file, a "
                              "TUM RGB-D directory or a cached views key)")
        opts = _tum.import_options(fx, fy, cx, cy, camera_height, depth_scale, max_dt, max_tilt,
                                   max_height_dev)
        prof = load_profile_with(profile, sets, fit_steps=steps, fit_seed=seed, camera=camera, sim=sim)
        warn_ignored_textures(prof)
        if device is not None:  # checked as the option the user typed, not as the profile's [fit]
            from navbench.pipeline.checks import _check_fit, _Invalid

            try:
                _check_fit({**prof.fit, "device": device})
            except _Invalid as e:
                raise ConfigError(f"--device {device}: {str(e).removeprefix('device: ')}") from None
            prof = dataclasses.replace(prof, fit={**prof.fit, "device": device})
        from navbench.pipeline.stages.imported import check_views_spec

        for spec, what in ((views, "--views"), (heldout, "--heldout")):
            if spec is not None:
                check_views_spec(spec, what)  # before the database is opened
        with open_db(db) as rdb, PipelineUI(json_mode=json_out) as ui:
            ctx = stage_context(ui, rdb, force={"fit-map"} if force else set())
            if _profile_route(ctx, level, views):
                if heldout is not None:
                    raise ConfigError("--heldout: only with --views PATH|DIR|KEY of your own views "
                                      "(LEVEL's collected views are evaluated on the profile's)")
                lv = make_level_stage(ctx, LevelConfig.for_profile(level, prof))
                ref = fit_map_for_profile(ctx, prof, lv, None if views in (None, "auto") else views)
            else:
                ref = _fit_given_views(ctx, prof, level, views, heldout, heldout_every, opts, camera)
        m = ref.meta
        out = {k: m.get(k) for k in MAP_METRIC_KEYS}
        out.update(level=level, map_key=ref.key, cached=ref.cached, path=str(ref.path),
                   coverage=m.get("coverage"), heldout_views=m.get("heldout_views"),
                   device=m.get("device", "cpu"))
        for k in ("device_name", "cuda_graph", "graph_error", "ms_per_step"):  # how a device fit ran
            if k in m:
                out[k] = m[k]
        if "train_views" in m:
            out.update(views=ref.name, train_views=m["train_views"], split=m.get("split"),
                       views_key=m.get("views_key"))
        if json_out:
            print_json(out)
            return
        from rich.markup import escape
        from rich.table import Table

        t = Table(title=escape(f"map {ref.key[:12]} of {level or ref.name} ({'cached' if ref.cached else 'fitted'})"))
        t.add_column("metric")
        t.add_column("value", justify="right")
        units = {"depth_mae_m": "m", "fit_seconds": "s", "rgb_l1": "(0-1)"}
        for k in (*MAP_METRIC_KEYS, "coverage", "heldout_views", "train_views", "split", "device"):
            if k not in out or (k.startswith("slice_") and out.get(k) is None and "train_views" in m):
                continue  # no level: no slice scores
            v = out.get(k)
            t.add_row(f"{k} {units.get(k, '')}".strip(), "-" if v is None else
                      escape(f"{v:.4f}" if isinstance(v, float) else str(v)))
        console.print(t)
        if out.get("depth_mae_m") is None:  # a score of nothing is no score: marked, not 0
            console.print("note: no held-out pixel is both observed and rendered by the map "
                          "(coverage 0, or nothing within its max_range): depth MAE and RGB L1 "
                          "are undefined (-), not 0", markup=False, highlight=False)


def _profile_route(ctx, level, views) -> bool:
    """Whether fit-map runs the profile's pipeline on LEVEL (no --views, ``auto``, or a
    collect-views key with LEVEL: the original command, whose keys stay) rather than fitting
    the given views."""
    from pathlib import Path

    if level is None:
        return False
    if views in (None, "auto"):
        return True
    if Path(views).exists():
        return False
    try:
        ctx.store.find(views, "collect-views")
    except Exception:  # not a collect-views key: the given-views route names the problem
        return False
    return True


def _fit_given_views(ctx, prof, level, views, heldout, heldout_every, opts, camera):
    """``fit-map --views PATH|DIR|KEY [LEVEL] [--heldout ...]``: the level-free fit stage."""
    from navbench.errors import ConfigError
    from navbench.pipeline.stages import LevelConfig, make_level_stage
    from navbench.pipeline.stages.imported import FitViewsConfig, fit_views_stage, resolve_views

    if camera is not None:
        raise ConfigError("--camera: given views carry their own camera (intrinsics); it applies "
                          "only to LEVEL's collected views")
    cfg = FitViewsConfig(prof.fit_steps, prof.fit_seed, dict(prof.fit), heldout_every)
    cfg.fit_config()  # a bad fit option fails before any views are read
    train, train_key = resolve_views(views, ctx, opts, "--views")
    held, held_key = resolve_views(heldout, ctx, opts, "--heldout") if heldout is not None else (None, None)
    # the level (recorded in the database) only once the views read: bad views record nothing
    lv = make_level_stage(ctx, LevelConfig.for_profile(level, prof)) if level is not None else None
    return fit_views_stage(ctx, train, train_key, cfg, held, held_key, lv)
