"""``navbench all``: the whole pipeline of a profile, every stage cached."""

from __future__ import annotations

from pathlib import Path

import typer

from navbench.cli._common import console
from navbench.cli._help import (DB_HELP, DEFAULT_PROFILE, OVERLAP_HELP, RUN_VERSION_HELP, SET_HELP, SIM_HELP,
                                profile_default, profile_help)
from navbench.cli.commands._pipeline_ui import command_line
from navbench.pipeline.artifacts import PAIRED_FILE  # light
from navbench.pipeline.profiles import MAX_WORKERS  # light


def _print_scores(path: Path) -> None:
    import csv

    from rich.markup import escape
    from rich.table import Table

    import pandas as pd

    from navbench.cli.commands.score import conditions_caption
    from navbench.results.score import conditions_in, short_conditions

    rows = list(csv.DictReader(open(path)))
    frame = pd.DataFrame(rows)
    several = len(conditions_in(frame)) > 1
    preset = rows[0].get("preset") or "paper" if rows else "paper"  # issue 15: the scoring preset
    t = Table(title=f"scores, preset {escape(preset)} (95% bootstrap intervals in the report)",
              caption=escape(conditions_caption(frame)))
    cols = [("level", "level"), ("estimator", "estimator"), ("noise", "noise"),
            *((("conditions", "conditions"),) if several else ()), ("episodes", "n"),
            ("success_rate", "success"), ("spl", "SPL"), ("loc_rmse_m", "loc RMSE m"),
            ("rot_rmse_deg", "rot RMSE deg"), ("step_hz", "Hz")]
    digits = {"step_hz": 1}
    text = ("level", "estimator", "noise", "conditions", "episodes")
    for _, title in cols:
        t.add_column(title, justify="left" if title in text[:4] else "right")
    for r in rows:
        cells = []
        for key, _ in cols:
            v = r.get(key) or ""
            v = escape(short_conditions(v) if key == "conditions" else v)
            try:
                cells.append(v if key in text else f"{float(v):.{digits.get(key, 3)}f}")
            except ValueError:
                cells.append(v)
        t.add_row(*cells)
    console.print(t)


def _print_claim(path: Path, preset: str = "paper") -> None:
    """The paired differences the score stage stored (``ours`` minus each ablation), if any."""
    import pandas as pd
    from rich.markup import escape

    from navbench.cli.commands.score import _paired_table

    try:
        paired = pd.read_csv(path)
    except (FileNotFoundError, pd.errors.EmptyDataError):
        return
    if not paired.empty:
        console.print(_paired_table(paired, escape, preset))


def register(app: typer.Typer) -> None:
    @app.command("all")
    def all_(
        profile: str = typer.Option(DEFAULT_PROFILE, "--profile", help=profile_help("Profile", shows_default=True)),
        sets: list[str] = typer.Option(None, "--set", metavar="KEY=VALUE", help=SET_HELP),
        benchmark_version: str = typer.Option(None, "--benchmark-version", metavar="NAME", help=RUN_VERSION_HELP,
                                              show_default=False),
        sim: str = typer.Option(None, "--sim", help=f"{SIM_HELP} {profile_default('sim')}."),
        workers: int = typer.Option(None, "--workers", min=0, max=MAX_WORKERS, help="Worker processes; 0 = CPU count "
                                 f"{profile_default('workers')}."),
        executor: str = typer.Option("local", "--executor", help="local (process pool) or ray."),
        address: str = typer.Option(None, "--address", help="Ray cluster address (with --executor ray)."),
        report_dir: Path = typer.Option(Path("results/report"), "--report", help="Where the report is published."),
        condition: list[str] = typer.Option(None, "--condition", metavar="NAME=VALUE", help="A simulator "
                                            "condition of the paper, repeatable: pose_quantisation=off|round|"
                                            "truncate, direction_limit=believed|true, collision_check=swept|"
                                            "endpoint (overrides the profile's \\[conditions] table)."),
        db: str = typer.Option(None, "--db", envvar="NAVBENCH_DB",
                               help=DB_HELP),
        overlap: bool = typer.Option(True, "--overlap/--no-overlap", help=OVERLAP_HELP),
    ):
        """make-level -> collect-views -> fit-map -> sample-tasks -> run-navigation -> score -> report.

        Every stage is cached by the hash of its config and inputs; episodes already in the
        database are skipped, so a rerun with nothing changed only verifies the cache.
        """
        import time

        from rich.markup import escape

        from navbench.cli.commands._pipeline_ui import run_with_ui
        from navbench.pipeline.run import run_profile

        if condition or sets or benchmark_version is not None or sim is not None:  # checked before any work
            from navbench.pipeline.overrides import apply_sets
            from navbench.pipeline.profiles import load_profile, override
            from navbench.pipeline.versioning import with_version
            from navbench.sim.conditions import conditions_to_episode, parse_condition_args

            prof = load_profile(profile)
            if benchmark_version is not None:
                prof = with_version(prof, benchmark_version, "command line", "--benchmark-version")
            prof = apply_sets(prof, sets)
            if condition:
                chosen = conditions_to_episode(parse_condition_args(condition), "--condition")
                prof = override(prof, episode={**prof.episode, **chosen})
            prof = override(prof, sim=sim)  # after the conditions it is checked against
            profile = prof
        t0 = time.perf_counter()
        result = run_with_ui(lambda ui: run_profile(profile, db=db, executor=executor, workers=workers,
                                                    address=address, progress=ui, report_dir=report_dir,
                                                    command=command_line(), ref_name="all",
                                                    overlap=overlap))
        _print_scores(result.score.path)
        _print_claim(result.score.path.parent / PAIRED_FILE, result.profile.scoring_preset)
        from navbench.results.breakdown import format_breakdown

        console.print(f"where the time went (run {result.run_id}; stored in the database's run_timings):",
                      highlight=False)
        console.print(escape(format_breakdown(result.breakdown)), highlight=False)
        from navbench.config import to_jsonable
        from navbench.results.score import conditions_label
        from navbench.results.labels import online_label

        nav = result.navigation
        label = conditions_label(dict(result.profile.episode)) + online_label(to_jsonable(result.profile))
        console.print(f"conditions: {escape(label)}", highlight=False)
        from navbench.pipeline.versioning import version_line

        console.print(escape(version_line(result.profile)), highlight=False)
        console.print(f"profile [bold]{escape(result.profile.name)}[/bold]: {nav.stored} new episodes, "
                      f"{nav.already_done + nav.stored}/{nav.total} stored; "
                      f"report {escape(str(result.report_path))}; {time.perf_counter() - t0:.1f} s")
