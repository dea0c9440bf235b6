"""``navbench collect-views`` (alias ``collect-5000-views``): pose-labelled RGB-D views of a level."""

from __future__ import annotations

import typer

from navbench.cli._common import console
from navbench.cli._help import SET_HELP, SIM_HELP, profile_default, profile_help


def _collect(level: str, count: int | None, camera: str | None, seed: int | None, profile: str | None,
             force: bool, sets: list[str] | None = None, sim: str | None = None) -> None:
    from navbench.cli.commands._pipeline_ui import PipelineUI, load_profile_with, warn_ignored_textures
    from navbench.pipeline.run import stage_context
    from navbench.pipeline.stages import LevelConfig, ViewsConfig, collect_views_stage, make_level_stage

    prof = load_profile_with(profile, sets, camera=camera, sim=sim)
    warn_ignored_textures(prof)
    cfg = ViewsConfig(count if count is not None else prof.views, prof.camera,
                      seed if seed is not None else prof.views_seed, texture=prof.views_texture, sim=prof.sim)
    # refuse a collection that cannot fit in memory before the level or anything else is written
    cfg.check_memory("--count" if count is not None else f"profile {prof.name}: [views] count")
    with PipelineUI() as ui:
        ctx = stage_context(ui, force={"collect-views"} if force else set())
        lv = make_level_stage(ctx, LevelConfig.for_profile(level, prof))
        ref = collect_views_stage(ctx, lv, cfg)
    state = "cached" if ref.cached else "collected"
    on = "" if cfg.sim == "pymunk" else f" on {cfg.sim}"
    console.print(f"{level}: {cfg.count} {cfg.camera} views (seed {cfg.seed}){on} {state}, "
                  f"key [bold]{ref.key[:12]}[/bold] -> {ref.path}")


def register(app: typer.Typer) -> None:
    @app.command("collect-views")
    def collect_views(
        level: str = typer.Argument(..., help="Level name (levels/NAME.json, generated if absent)."),
        count: int = typer.Option(None, "--count", min=1, help=f"Number of views {profile_default('views')}."),
        camera: str = typer.Option(None, "--camera", help="half (160x120) or paper (320x240) "
                                   f"{profile_default('camera')}."),
        seed: int = typer.Option(None, "--seed", min=0, max=2**63 - 1, help=f"Pose sampling seed {profile_default('views_seed')}."),
        profile: str = typer.Option(None, "--profile", help=profile_help("Profile for defaults")),
        force: bool = typer.Option(False, "--force", help="Recollect even when cached."),
        sets: list[str] = typer.Option(None, "--set", metavar="KEY=VALUE", help=SET_HELP),
        sim: str = typer.Option(None, "--sim", help=f"{SIM_HELP} {profile_default('sim')}."),
    ):
        """Collect views uniformly in the level's free space into the cache (keyed, reused)."""
        _collect(level, count, camera, seed, profile, force, sets, sim)

    @app.command("collect-5000-views")
    def collect_5000_views(
        level: str = typer.Argument(..., help="Level name (levels/NAME.json, generated if absent)."),
        count: int = typer.Option(5000, "--count", min=1, help="Number of views."),
        camera: str = typer.Option(None, "--camera", help=f"half or paper {profile_default('camera')}."),
        seed: int = typer.Option(None, "--seed", min=0, max=2**63 - 1, help=f"Pose sampling seed {profile_default('views_seed')}."),
        profile: str = typer.Option(None, "--profile", help=profile_help("Profile for defaults")),
        force: bool = typer.Option(False, "--force", help="Recollect even when cached."),
        sets: list[str] = typer.Option(None, "--set", metavar="KEY=VALUE", help=SET_HELP),
        sim: str = typer.Option(None, "--sim", help=f"{SIM_HELP} {profile_default('sim')}."),
    ):
        """Alias of collect-views with --count 5000 (the paper's view count)."""
        _collect(level, count, camera, seed, profile, force, sets, sim)
