"""``navbench run-navigation``: the episode grid levels x estimators x noise x tasks x seeds."""

from __future__ import annotations

import typer

from navbench.cli._common import console, parse_list
from navbench.cli._help import (DB_HELP, OVERLAP_HELP, RUN_VERSION_HELP, SET_HELP, SIM_HELP, default, profile_default,
                                profile_help)
from navbench.pipeline.profiles import MAX_SEEDS, MAX_TASKS, MAX_WORKERS  # light


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
        map_source: str = typer.Option(None, "--map", help="fit (the fitted world model), true "
                                       "(the voxelized true geometry), a map file (.npz; {level} "
                                       "stands for the level's name), online (no prior map: the "
                                       "unknown-house loop maps as it goes, with --goal image; "
                                       "perfect mapping at the true pose, estimator gt, nrns preset) "
                                       "or online-fused (the same, its RGB-D frames fused into a "
                                       "TSDF map; --estimators gt: at the true pose, ours: tracked "
                                       "on the map it builds) "
                                       f"{profile_default('map_source')}."),
        goal: str = typer.Option(None, "--goal", help="point (the task's coordinates) or image (the "
                                 "goal image, localised in the map the agent plans on) "
                                 f"{profile_default('goal')}."),
        online_ablation: str = typer.Option(None, "--online-ablation", help="With --map online or "
                                            "online-fused, RNR-Map's Table 4 rows: full, no-goal "
                                            "(exploration without goal scoring), no-explore (goal scoring "
                                            "without exploration), gt-stopper (stopped by an oracle "
                                            "within 1 m of the goal), or the variant voronoi (the full "
                                            "model exploring places on a Voronoi graph of the seen free "
                                            f"space, not frontiers) {profile_default('online_ablation')}."),
        chunk: int = typer.Option(None, "--chunk", min=1, help="Episodes per worker task "
                                  f"{default('up to 8, a quarter of the work per worker')}."),
        condition: list[str] = typer.Option(None, "--condition", metavar="NAME=VALUE", help="A simulator "
                                            "condition of the paper, repeatable: pose_quantisation=off|round|"
                                            "truncate, direction_limit=believed|true, collision_check=swept|"
                                            "endpoint (overrides the profile's \\[conditions] table)."),
        profile: str = typer.Option(None, "--profile", help=profile_help("Profile")),
        sets: list[str] = typer.Option(None, "--set", metavar="KEY=VALUE", help=SET_HELP),
        benchmark_version: str = typer.Option(None, "--benchmark-version", metavar="NAME", help=RUN_VERSION_HELP,
                                              show_default=False),
        sim: str = typer.Option(None, "--sim", help=f"{SIM_HELP} {profile_default('sim')}."),
        option: list[str] = typer.Option(None, "--option", "-o", metavar="ESTIMATOR.KEY=VALUE",
                                         help="Estimator option, repeatable (as track-eval's): "
                                         "-o ours.optimizer=adam; over the profile's "
                                         "\\[navigation.options.<estimator>] table."),
        db: str = typer.Option(None, "--db", envvar="NAVBENCH_DB",
                               help=DB_HELP),
        overlap: bool = typer.Option(True, "--overlap/--no-overlap", help=OVERLAP_HELP),
    ):
        """Run navigation episodes and store them in the results database.

        Every cell uses the same tasks, and a (task, seed) gets the same simulator noise seed for
        every estimator. Missing inputs (level, views, map, tasks) are built first with the
        profile's settings (cached). Resumable: a rerun with the same arguments skips the
        episodes already stored and finishes the rest.
        """
        from navbench.cli._common import parse_estimator_options
        from navbench.cli.commands._pipeline_ui import command_line, run_with_ui
        from navbench.pipeline.overrides import apply_sets
        from navbench.pipeline.profiles import load_profile, override
        from navbench.pipeline.run import run_profile
        from navbench.sim.conditions import (CONDITIONS, conditions_to_episode, episode_conditions,
                                             parse_condition_args)

        from navbench.pipeline.stages.online import ONLINE_ESTIMATOR, is_online

        base = load_profile(profile)
        if benchmark_version is not None:
            from navbench.pipeline.versioning import with_version

            base = with_version(base, benchmark_version, "command line", "--benchmark-version")
        base = apply_sets(base, sets)
        from navbench.pipeline.stages.level import check_typed_levels

        check_typed_levels(levels, base.levels)  # a typo is not a new level from level_seed
        if estimators is None and is_online(map_source or base.map_source):
            estimators = ONLINE_ESTIMATOR  # the unknown-house loop's pose model: the true pose
        # an option given but empty (--estimators ',,') is an error, not the profile's list
        prof = override(base, levels=levels or None,
                        estimators=None if estimators is None else parse_list(estimators),
                        noise=None if noise is None else parse_list(noise),
                        tasks=tasks, seeds=seeds, workers=workers, map_source=map_source, goal=goal,
                        online_ablation=online_ablation)
        if condition:
            chosen = conditions_to_episode(parse_condition_args(condition), "--condition")
            prof = override(prof, episode={**prof.episode, **chosen})
        if option:
            prof = _with_options(prof, parse_estimator_options(option))
        prof = override(prof, sim=sim)  # after the conditions it is checked against

        result = run_with_ui(lambda ui: run_profile(prof, db=db, executor=executor, address=address,
                                                    chunk_size=chunk, progress=ui, until="navigation",
                                                    command=command_line(), ref_name="run-navigation",
                                                    overlap=overlap))
        summary = result.navigation
        console.print(f"stored {summary.stored} new episodes; {summary.already_done + summary.stored}"
                      f"/{summary.total} of the grid are in the database")
        changed = {k: v for k, v in episode_conditions(prof.episode).items() if v != CONDITIONS[k].default}
        if changed:
            console.print("conditions: " + ", ".join(f"{k}={v}" for k, v in changed.items()), markup=False)


def _with_options(prof, options: dict[str, dict]):
    """``prof`` with ``-o`` estimator options over its ``[navigation.options.<estimator>]``;
    an option of an estimator the run does not use is an error (it would change nothing)."""
    from navbench.errors import ConfigError
    from navbench.pipeline.profiles import override

    for est, opts in options.items():
        if est not in prof.estimators:
            from navbench.names import did_you_mean

            key = next(iter(opts))
            raise ConfigError(f"--option {est}.{key}: {est!r} is not among the run's estimators "
                              f"({', '.join(prof.estimators)}){did_you_mean(est, prof.estimators)}")
    from navbench.pipeline.checks import check_estimator_options

    check_estimator_options(options, "--option")  # named as typed, before the profile's label
    merged = {k: dict(v) for k, v in prof.estimator_options.items()}
    for est, opts in options.items():
        merged[est] = {**merged.get(est, {}), **opts}
    return override(prof, estimator_options=merged)
