"""``navbench fit-map``: fit a voxel world model to a level's views and report its quality."""

from __future__ import annotations

import dataclasses

import typer

from navbench.cli._common import console, print_json
from navbench.cli._help import DB_HELP, profile_default, profile_help
from navbench.pipeline.profiles import MAX_FIT_STEPS  # light


def register(app: typer.Typer) -> None:
    @app.command("fit-map")
    def fit_map(
        level: str = typer.Argument(..., help="Level name (levels/NAME.json, generated if absent)."),
        steps: int = typer.Option(None, "--steps", min=1, max=MAX_FIT_STEPS, help=f"Adam steps {profile_default('fit_steps')}."),
        views: str = typer.Option("auto", "--views", help="Training views: a collect-views key (>= 6 "
                                  "hex digits, see `navbench cache ls`) or 'auto' (collect with the "
                                  "profile's settings, cached)."),
        seed: int = typer.Option(None, "--seed", min=0, help=f"Batch sampling seed {profile_default('fit_seed')}."),
        camera: str = typer.Option(None, "--camera", help=f"half or paper {profile_default('camera')}."),
        profile: str = typer.Option(None, "--profile", help=profile_help("Profile for defaults")),
        device: str = typer.Option(None, "--device", help="Where the fit runs: auto (CUDA when torch sees "
                                   "a GPU, else cpu), cpu (numba path), cuda[:N], or torch-cpu (the GPU "
                                   "path's code on the CPU, slow) "
                                   f"{profile_default('fit', fit_key='device', otherwise='auto')}."),
        json_out: bool = typer.Option(False, "--json", help="Print one JSON object with the quality metrics."),
        force: bool = typer.Option(False, "--force", help="Refit even when cached."),
        db: str = typer.Option(None, "--db", envvar="NAVBENCH_DB",
                               help=DB_HELP),
    ):
        """Fit M_occ and M_col (eq. 3) and evaluate the map on the profile's held-out views.

        The held-out views (the profile's views.eval_count, seed views.eval_seed) are a
        separate cached collection with another seed. Quality:
        depth MAE (m) and RGB L1 on the held-out views, precision and recall of the map's
        horizontal occupancy slice against the true level, fit time and steps.
        """
        from navbench.cli.commands._pipeline_ui import PipelineUI, load_profile_with
        from navbench.pipeline.run import open_db, stage_context
        from navbench.pipeline.stages import LevelConfig, MAP_METRIC_KEYS, fit_map_for_profile, make_level_stage

        prof = load_profile_with(profile, fit_steps=steps, fit_seed=seed, camera=camera)
        if device is not None:
            prof = dataclasses.replace(prof, fit={**prof.fit, "device": device})
        with open_db(db) as rdb, PipelineUI(json_mode=json_out) as ui:
            ctx = stage_context(ui, rdb, force={"fit-map"} if force else set())
            lv = make_level_stage(ctx, LevelConfig(level, prof.level_seed))
            ref = fit_map_for_profile(ctx, prof, lv, None if views == "auto" else views)
        m = ref.meta
        out = {k: m.get(k) for k in MAP_METRIC_KEYS}
        out.update(level=level, map_key=ref.key, cached=ref.cached, path=str(ref.path),
                   coverage=m.get("coverage"), heldout_views=m.get("heldout_views"),
                   device=m.get("device", "cpu"))
        if json_out:
            print_json(out)
            return
        from rich.table import Table

        from rich.markup import escape

        t = Table(title=escape(f"map {ref.key[:12]} of {level} ({'cached' if ref.cached else 'fitted'})"))
        t.add_column("metric")
        t.add_column("value", justify="right")
        units = {"depth_mae_m": "m", "fit_seconds": "s", "rgb_l1": "(0-1)"}
        for k in (*MAP_METRIC_KEYS, "coverage", "heldout_views", "device"):
            v = out.get(k)
            t.add_row(f"{k} {units.get(k, '')}".strip(), "-" if v is None else
                      escape(f"{v:.4f}" if isinstance(v, float) else str(v)))
        console.print(t)
