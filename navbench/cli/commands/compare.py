"""``navbench compare``: paired differences between two estimators, two sets of runs or two databases."""

from __future__ import annotations

from enum import Enum

import typer

from navbench.cli._common import console, parse_list
from navbench.cli._help import DB_HELP, default


class Format(str, Enum):
    table = "table"
    csv = "csv"
    json = "json"
    markdown = "markdown"


class Interval(str, Enum):
    bca = "bca"
    percentile = "percentile"


def compare(
    pair: list[str] = typer.Option(None, "--pair", metavar="A:B", help="Two estimators to compare, B - A "
                                   "(repeatable): ours-every-k:ours. With --b or --b-db: estimator A of "
                                   "side A against estimator B of side B " + default("each estimator with itself") + "."),
    a: str = typer.Option(None, "--a", metavar="RUNS", help="Side A: run ids (35,54), 'latest' or 'all' "
                          "of --db " + default("all") + "."),
    b: str = typer.Option(None, "--b", metavar="RUNS", help="Side B: run ids, 'latest' or 'all' of --b-db "
                          "(else --db). Without --b and --b-db both estimators of --pair come from side A."),
    b_db: str = typer.Option(None, "--b-db", metavar="URL", help="Database of side B " + default("--db") + "."),
    preset: str = typer.Option(None, "--preset", help="Scoring preset of both sides: paper, nrns or habitat. "
                               "Default: paper; nrns when every episode is an unknown-house one.",
                               show_default=False),
    level: str = typer.Option(None, "--level", help="Only these levels (comma-separated)."),
    interval: Interval = typer.Option(Interval.bca, "--interval", help="Bootstrap interval: bca (as score) or "
                                      "percentile (the interval of the paired_runs script compare replaced: the README's Table 4)."),
    boot: int = typer.Option(None, "--boot", min=1, max=100_000, help="Bootstrap resamples "
                             + default("2000 for bca, 4000 for percentile") + ".", show_default=False),
    seed: int = typer.Option(0, "--seed", min=0, max=2**63 - 1, help="Seed of the bootstrap."),
    fmt: Format = typer.Option(Format.table, "--format", help="Output format."),
    db: str = typer.Option(None, "--db", envvar="NAVBENCH_DB", help=DB_HELP + " Side A's database."),
    benchmark_version: str = typer.Option(None, "--benchmark-version", help="Benchmark version read on both "
                                          "sides " + default("each side's newest; every side names its "
                                                             "version") + ".", show_default=False),
    accept: bool = typer.Option(False, "--acceptance", help="The acceptance test of a benchmark version "
                                "change: --db holds the grid under the old version, --b-db under the new; "
                                "prints every estimator and noise's SPL difference and the paper's claim "
                                "under both, and exits 1 when the new version is not accepted "
                                "(docs/changelog.md)."),
    tolerance: float = typer.Option(0.01, "--tolerance", min=0.0, max=1.0, help="With --acceptance: how far "
                                    "a cell's mean SPL may move without its interval showing the new "
                                    "version better."),
):
    """Paired differences B - A on the same episodes: two estimators, two sets of runs, two databases.

    Episodes pair when they ran the same level, noise, task and seed (two estimators of one
    selection: also the same map and simulator conditions). Per pair and level, and pooled over
    levels: pairs and unpaired counts, both success rates and SPLs, and B - A of success, SPL,
    SoftSPL and location RMSE with 95% bootstrap intervals stratified by level; for success also
    the discordant pairs (only A / only B succeeded) and the exact McNemar p.

    Examples: --pair no-map:ours --pair ours-every-k:ours (two estimators of every stored
    episode); --a 35,54 --b 95 (two sets of runs, estimator by estimator); --a 1 --b-db
    sqlite:///other.db --pair ours:gt (two databases). Tutorial: docs/tutorials/compare.md.
    """
    import sys

    from rich.markup import escape

    from navbench.cli._common import err_console
    from navbench.results.compare import compare as run_compare
    from navbench.results.compare import markdown, record_rows
    from navbench.results.score import table_records

    if accept:
        _acceptance(db, b_db, pair, a, b, fmt, level, interval, boot, seed, tolerance)
        return
    result = run_compare(db=db, pairs=pair or [], a=a, b=b, b_db=b_db, preset=preset,
                         level=parse_list(level) or None, method=interval.value, n_boot=boot, seed=seed,
                         benchmark_version=benchmark_version)
    for w in result.warnings:
        err_console.print(f"[yellow]warning:[/] {escape(w)}", markup=True)
    t = result.table
    if fmt is Format.json:
        from navbench.cli._common import print_json

        print_json({"preset": result.preset, "interval": result.interval, "difference": "B - A",
                    "a": result.side_a, "b": result.side_b, "comparisons": table_records(t)})
        return
    if fmt is Format.csv:
        t.to_csv(sys.stdout, index=False, float_format="%.6g")
        return
    sides = (f"of {result.side_a}" if result.side_a == result.side_b
             else f"A: {result.side_a}; B: {result.side_b}")
    header = f"B - A on paired episodes {sides}; preset {result.preset}; intervals: {result.interval}"
    if fmt is Format.markdown:
        sys.stdout.write(f"{header}\n\n{markdown(t)}")
        return
    from rich import box
    from rich.table import Table

    several = t["conditions"].nunique() > 1
    console.print(escape(header))
    if t.empty:
        return
    if several:
        console.print("conditions: those not at their default (defaults: "
                      + escape(_default_conditions()) + ")")
    else:
        console.print(escape(f"conditions: {t['conditions'].iloc[0]}"))
    for title, rows in record_rows(t, conditions=several):
        out = Table(title=escape(f"{title}  (B - A)"), box=box.SIMPLE_HEAD, title_justify="left",
                    pad_edge=False, collapse_padding=True)
        for h in ("level", "noise", "", "A", "B", "B - A [95 %]"):
            out.add_column(h, justify="right" if h in ("A", "B", "B - A [95 %]") else "left", no_wrap=True)
        for i, cells in enumerate(rows):
            if i and cells[0]:
                out.add_section()
            out.add_row(*(escape(c) for c in cells))
        console.print(out)


def _acceptance(db, b_db, pair, a, b, fmt, level, interval, boot, seed, tolerance) -> None:
    """``compare --acceptance`` (navbench.results.acceptance); exit 1 when not accepted."""
    import sys

    from rich.markup import escape

    from navbench.cli._common import err_console
    from navbench.errors import ConfigError
    from navbench.results.acceptance import acceptance, markdown

    if b_db is None:
        raise ConfigError("--acceptance compares two databases: give the new version's grid with --b-db URL "
                         "(--db holds the old one's)")
    if pair or a is not None or b is not None:
        raise ConfigError("--acceptance takes whole databases: leave out --pair, --a and --b")
    if fmt is Format.csv:
        raise ConfigError("--acceptance prints two tables: use --format table, markdown or json")
    result = acceptance(db, b_db, tolerance=tolerance, level=parse_list(level) or None, method=interval.value,
                        n_boot=boot, seed=seed)
    for w in result.warnings:
        err_console.print(f"[yellow]warning:[/] {escape(w)}", markup=True)
    if fmt is Format.json:
        from navbench.cli._common import print_json
        from navbench.results.score import table_records

        print_json({"old": result.old, "new": result.new, "accepted": result.accepted,
                    "tolerance": result.tolerance, "preset": result.preset, "interval": result.interval,
                    "difference": "new - old", "cells": table_records(result.cells),
                    "claim": table_records(result.claim), "failures": result.failures})
    else:
        text = markdown(result)
        if fmt is Format.markdown:
            sys.stdout.write(text)
        else:
            console.print(escape(text), markup=False, highlight=False, soft_wrap=True)
    if not result.accepted:
        raise typer.Exit(1)


def _default_conditions() -> str:
    from navbench.results.score import conditions_label

    return conditions_label({})


def register(app: typer.Typer) -> None:
    app.command("compare")(compare)
