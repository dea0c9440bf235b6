"""``navbench report``: one self-contained HTML page with the paper's figures, plus CSV tables."""

from __future__ import annotations

import typer

from navbench.cli._common import console
from navbench.cli._help import DB_HELP, VERSION_HELP
from navbench.cli.commands.score import MAX_BOOT


def report(
    out: str = typer.Option("results/report", "--out", help="Output folder (index.html + CSV files)."),
    db: str = typer.Option(None, "--db", envvar="NAVBENCH_DB",
                           help=DB_HELP),
    cache: str = typer.Option("results/cache", "--cache", envvar="NAVBENCH_CACHE",
                              help="Stage cache holding the trajectories and maps."),
    levels: str = typer.Option("levels", "--levels", help="Folder of the level files."),
    boot: int = typer.Option(2000, "--boot", min=1, max=MAX_BOOT, help="Bootstrap resamples for the 95% intervals."),
    trajectories: int = typer.Option(3, "--trajectories", min=0, max=1000, help="Trajectories drawn per level."),
    run: str = typer.Option("all", "--run", help="Episodes of one run (an id, or 'latest' with the "
                       "interrupted runs it resumed), of several (comma-separated ids), or 'all'."),
    preset: str = typer.Option(None, "--preset", help="Scoring preset: paper, nrns or habitat "
                               "(navbench score --help). Default: paper; nrns when every selected "
                               "episode is an unknown-house one.", show_default=False),
    benchmark_version: str = typer.Option(None, "--benchmark-version", help=VERSION_HELP, show_default=False),
    pair: list[str] = typer.Option(None, "--pair", metavar="A:B", help="Also show B - A of these two "
                                   "estimators on the same episodes, as navbench compare --pair (repeatable)."),
    b_db: str = typer.Option(None, "--b-db", metavar="URL", help="Another database (e.g. the other simulator's "
                             "run of the same grid): its episodes of the report's benchmark version on another "
                             "simulator are set beside the report's in the Simulators section, paired as "
                             "navbench compare --b-db (never pooled).", show_default=False),
):
    """Write a self-contained HTML report (figures embedded) and CSV tables from the database.

    Runs, a leaderboard and SPL (Fig. 5a), scores, RMSE CDFs + runtime (Fig. 4), levels (Fig. 3),
    maps (Fig. 1); with --pair A:B, the paired comparison of A and B; with --b-db URL (or one
    database holding two simulators' episodes), the backends side by side.
    """
    from rich.markup import escape

    import shutil

    from navbench.report.publish import check_report_dir, protected_paths, publish
    from navbench.results.db import ResultsDB
    from navbench.pipeline.loaders import store_loaders
    from navbench.report.build import build_report

    from navbench.nav.presets import get_preset
    from navbench.outpath import make_build_dir, remove_stale_build_dirs, writing

    if preset is not None:
        get_preset(preset, "--preset")
    from navbench.results.compare import parse_pair

    pairs = [parse_pair(p) for p in pair or []]
    from pathlib import Path as _Path

    from navbench.errors import ConfigError

    if _Path(levels).exists() and not _Path(levels).is_dir():  # was silently ignored (P-020)
        raise ConfigError(f"--levels {levels}: not a folder (the folder of the level files, e.g. levels)")
    # only into a new, empty or earlier report folder; built beside it, then swapped in whole,
    # so a write that fails (disk full) leaves the earlier report as it was
    protected = protected_paths(db, cache, levels)
    if b_db is not None:  # never written over either
        protected += [p for p in protected_paths(b_db, cache, levels) if p not in protected]
    dest = check_report_dir(out, "--out", protected)
    load_trajectory, load_map = store_loaders(cache)
    with ResultsDB(db, create=False) as rdb, _other_db(b_db) as bdb:
        from navbench.cli._common import err_console
        from navbench.results.db.resume import resolve_selection

        selection, chain = resolve_selection(rdb, run)
        if chain:
            err_console.print(escape(chain), markup=True)
        if preset is None:  # score's default: nrns for unknown-house episodes alone, else paper
            from navbench.results.score import select_episodes
            from navbench.results.presets import default_preset

            preset, mixed = default_preset(select_episodes(rdb, run=selection,
                                                           benchmark_version=benchmark_version))
            if mixed:
                err_console.print(f"[yellow]warning:[/] {escape(mixed)}", markup=True)
        with writing(dest, "--out", "the report"):
            dest.parent.mkdir(parents=True, exist_ok=True)
            # a report killed by SIGKILL left its build folder: remove those whose maker is
            # provably dead (their owner file), then build in a new one that records us
            remove_stale_build_dirs(dest)
            build = make_build_dir(dest)
        try:
            with writing(dest, "--out", "the report"):  # a write that still fails: one line
                build_report(rdb, build, load_trajectory=load_trajectory, load_map=load_map,
                             levels_dir=levels, n_boot=boot, trajectories_per_level=trajectories,
                             run=selection, preset=preset, pairs=pairs,
                             benchmark_version=benchmark_version, b_db=bdb)
            publish(build, dest, protected, option="--out")
        finally:
            shutil.rmtree(build, ignore_errors=True)
    index = dest / "index.html"
    console.print(f"report written to {escape(str(index))}")


def _other_db(url: str | None):
    """``--b-db``: the database opened read-only (a context manager; ``None`` passes through), or
    a one-line error naming the option when it cannot be opened or holds no episodes."""
    import contextlib

    from navbench.errors import ConfigError, DatabaseError
    from navbench.results.db import ResultsDB

    if url is None:
        return contextlib.nullcontext(None)
    try:
        bdb = ResultsDB(url, create=False)
    except DatabaseError as e:  # it suggests --db: the option here is --b-db
        raise DatabaseError(f"--b-db: {str(e).split('; run `navbench all`')[0]}") from None
    if bdb.episodes_frame().empty:
        name = bdb.display_url
        bdb.close()
        raise ConfigError(f"--b-db {name}: no navigation episodes to set beside the report's")
    return bdb


def register(app: typer.Typer) -> None:
    app.command("report")(report)
