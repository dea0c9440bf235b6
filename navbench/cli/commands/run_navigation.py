"""``navbench run-navigation``: the episode grid levels x estimators x noise x tasks x seeds."""

from __future__ import annotations

import typer

from navbench.cli._common import console, parse_list
from navbench.cli._help import DB_HELP, default, profile_default, profile_help
from navbench.pipeline.profiles import MAX_SEEDS, MAX_TASKS, MAX_WORKERS  # light


def navigate(ui, ctx, prof, run_id: int, executor: str = "local", address: str | None = None,
             chunk_size: int | None = None):
    """Build (or fetch) every level's inputs, then run the missing episodes with a progress bar.

    Returns ``(level inputs, NavigationSummary)``. Shared by ``run-navigation`` and ``all``.
    """
    from navbench.pipeline.executor import make_executor
    from navbench.pipeline.stages import NavigationConfig, build_level_inputs, run_navigation_stage

    inputs = [build_level_inputs(ctx, prof, name) for name in dict.fromkeys(prof.levels)]
    cfg = NavigationConfig(estimators=tuple(prof.estimators), noise=tuple(prof.noise), seeds=prof.seeds,
                           camera=prof.camera, episode=dict(prof.episode),
                           estimator_options=dict(prof.estimator_options))
    bar = {}

    def on_total(n: int) -> None:
        if n:
            bar["advance"], _ = ui.counter("episodes", n, unit="ep")

    def on_progress(n: int) -> None:
        if "advance" in bar:
            bar["advance"](n)

    with make_executor(executor, prof.workers, address) as ex:
        summary = run_navigation_stage(ctx, run_id, inputs, cfg, executor=ex, chunk_size=chunk_size,
                                       on_progress=on_progress, on_total=on_total)
    ui.log(f"run-navigation: {summary.total} episodes in {len(summary.cells)} cells: "
           f"{summary.already_done} already stored, {summary.from_cache} from stored trajectories, "
           f"{summary.ran} run now")
    return inputs, summary


def run_and_record(prof, ref_name: str, db_url: str | None, body, json_mode: bool = False):
    """Open the database, start a run row, call ``body(ui, ctx, run_id)``, and close the run as
    done, interrupted (Ctrl-C) or failed. The artifacts it touched become the cache ref
    ``<ref_name>-<profile>`` (the latest run of that command and profile; a gc root)."""
    from navbench.cli.commands._pipeline_ui import PipelineUI, command_line, database, make_context
    from navbench.config import config_hash, to_jsonable

    with database(db_url) as db:
        config = to_jsonable(prof)
        run_id = db.start_run(prof.name, command_line(), config, config_hash(config))
        ui = PipelineUI(json_mode=json_mode)
        ctx = make_context(ui, db)
        status = "failed"
        try:
            with ui:
                result = body(ui, ctx, run_id)
            status = "done"
            return result
        except KeyboardInterrupt:
            # exit 130 ourselves: the CLI shell would turn it into exit status 0
            status = "interrupted"
            ui.console.print("interrupted: rerun the same command to finish; stored episodes are kept",
                             style="yellow")
            raise SystemExit(130) from None
        finally:
            db.finish_run(run_id, status)
            if ctx.used:
                ctx.store.set_ref(f"{ref_name}-{prof.name}", ctx.used)


def register(app: typer.Typer) -> None:
    @app.command("run-navigation")
    def run_navigation(
        levels: list[str] = typer.Argument(None, help=f"Level names {profile_default('levels')}."),
        estimators: str = typer.Option(None, "--estimators", help="Comma-separated: ours, no-map, "
                                       f"dynamics, gt, emission {profile_default('estimators')}."),
        noise: str = typer.Option(None, "--noise", help="Comma-separated noise levels: low, mid, high "
                                  f"(also none, tracking) {profile_default('noise')}."),
        tasks: int = typer.Option(None, "--tasks", min=1, max=MAX_TASKS, help=f"Tasks per level {profile_default('tasks')}."),
        seeds: int = typer.Option(None, "--seeds", min=1, max=MAX_SEEDS, help=f"Episode seeds per task {profile_default('seeds')}."),
        workers: int = typer.Option(None, "--workers", min=0, max=MAX_WORKERS, help="Worker processes (local) or CPUs "
                                    f"(ray); 0 = CPU count, 1 = in this process {profile_default('workers')}."),
        executor: str = typer.Option("local", "--executor", help="local (process pool) or ray."),
        address: str = typer.Option(None, "--address", help="Ray cluster address (with --executor ray) "
                                    f"{default('start a local Ray instance')}."),
        map_source: str = typer.Option(None, "--map", help="fit (the fitted world model) or true "
                                       f"(the voxelized true geometry) {profile_default('map_source')}."),
        chunk: int = typer.Option(None, "--chunk", min=1, help="Episodes per worker task "
                                  f"{default('up to 8, a quarter of the work per worker')}."),
        profile: str = typer.Option(None, "--profile", help=profile_help("Profile")),
        db: str = typer.Option(None, "--db", envvar="NAVBENCH_DB",
                               help=DB_HELP),
    ):
        """Run navigation episodes and store them in the results database.

        Every cell uses the same tasks, and a (task, seed) gets the same simulator noise seed for
        every estimator. Missing inputs (level, views, map, tasks) are built first with the
        profile's settings (cached). Resumable: a rerun with the same arguments skips the
        episodes already stored and finishes the rest.
        """
        from navbench.pipeline.profiles import override, load_profile

        # an option given but empty (--estimators ',,') is an error, not the profile's list
        prof = override(load_profile(profile), levels=levels or None,
                        estimators=None if estimators is None else parse_list(estimators),
                        noise=None if noise is None else parse_list(noise),
                        tasks=tasks, seeds=seeds, workers=workers, map_source=map_source)

        def body(ui, ctx, run_id):
            return navigate(ui, ctx, prof, run_id, executor, address, chunk)

        _, summary = run_and_record(prof, "run-navigation", db, body)
        console.print(f"stored {summary.stored} new episodes; {summary.already_done + summary.stored}"
                      f"/{summary.total} of the grid are in the database")
