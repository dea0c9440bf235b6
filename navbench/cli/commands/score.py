"""``navbench score``: success rate, SPL, RMSE and step time per (level, estimator, noise)."""

from __future__ import annotations

from enum import Enum

import typer

from navbench.cli._common import console, parse_list
from navbench.cli._help import DB_HELP

#: bootstrap resamples allocate resamples x episodes numbers; 100 000 is 50x the default
MAX_BOOT = 100_000


class Format(str, Enum):
    table = "table"
    csv = "csv"
    json = "json"
    markdown = "markdown"


def _fmt(value: float, ci_low: float, ci_high: float, digits: int) -> str:
    if value != value:  # NaN
        return "-"
    return f"{value:.{digits}f} [{ci_low:.{digits}f}, {ci_high:.{digits}f}]"


def score(
    run: str = typer.Option("all", "--run", help="A run id, 'latest' (the newest run that stored "
                            "episodes) or 'all' (every stored episode, once per cell/task/seed)."),
    level: str = typer.Option(None, "--level", help="Only these levels (comma-separated)."),
    fmt: Format = typer.Option(Format.table, "--format", help="Output format."),
    boot: int = typer.Option(2000, "--boot", min=1, max=MAX_BOOT, help="Bootstrap resamples for the 95% intervals."),
    seed: int = typer.Option(0, "--seed", help="Seed of the bootstrap."),
    db: str = typer.Option(None, "--db", envvar="NAVBENCH_DB",
                           help=DB_HELP),
):
    """Score the stored navigation episodes offline, with 95% intervals.

    One row per (level, estimator, noise) and pooled rows with level 'all'; then the paired
    differences ours - no-map and ours - dynamics on the same tasks and seeds. Success: exact
    (Clopper-Pearson) interval; SPL and differences: BCa bootstrap stratified by level. Every
    stored episode counts once per setup, task and seed; --run narrows to one run. --format json
    prints {"scores": [...], "paired_differences": [...]}; csv prints the score table; markdown
    prints the pooled SPL and success tables beside the paper's (the README's results table).
    """
    import sys

    from rich.markup import escape

    from navbench.pipeline.db import ResultsDB
    from navbench.cli._common import err_console
    from navbench.pipeline.score import (conditions_in, mixed_setups_warning, score_tables, short_conditions,
                                         table_records)

    with ResultsDB(db, create=False) as rdb:
        table, paired = score_tables(rdb, run=run, level=parse_list(level) or None, n_boot=boot, seed=seed)
    warning = mixed_setups_warning(table)
    if warning:
        err_console.print(f"[yellow]warning:[/] {escape(warning)}", markup=True)
    if fmt is Format.json:
        from navbench.cli._common import print_json

        print_json({"scores": table_records(table), "paired_differences": table_records(paired)})
        return
    if fmt is Format.csv:
        table.to_csv(sys.stdout, index=False, float_format="%.6g")
        return
    if fmt is Format.markdown:  # the README's results table (pooled rows), beside the paper's
        from navbench.pipeline.results_table import markdown_results

        sys.stdout.write(markdown_results(table, paired))
        return
    from rich.table import Table

    # level, estimator and noise names come from the database: printed literally, never as markup
    out = Table(title=f"navbench score ({escape(run)}): mean or median [95% interval: success exact "
                      "binomial, SPL bootstrap stratified by level, medians bootstrap]",
                caption=escape(conditions_caption(table)))
    several = len(conditions_in(table)) > 1
    for col, just in (("level", "left"), ("estimator", "left"), ("noise", "left"),
                      *((("conditions", "left"),) if several else ()), ("n", "right"),
                      ("success", "right"), ("SPL", "right"), ("loc RMSE m", "right"),
                      ("rot RMSE deg", "right"), ("step ms", "right"), ("Hz", "right")):
        out.add_column(col, justify=just)
    previous = None
    for _, r in table.iterrows():
        if previous is not None and r["level"] != previous:
            out.add_section()
        previous = r["level"]
        hz = "-" if r["step_hz"] != r["step_hz"] else f"{r['step_hz']:.1f}"
        idle = not bool(r.get("tracking_work", True))  # dynamics, gt: no tracking rate to show
        out.add_row(escape(str(r["level"])), escape(str(r["estimator"])), escape(str(r["noise"])),
                    *((escape(short_conditions(r["conditions"])),) if several else ()),
                    str(r["episodes"]),
                    _fmt(r["success_rate"], r["success_rate_ci_low"], r["success_rate_ci_high"], 2),
                    _fmt(r["spl"], r["spl_ci_low"], r["spl_ci_high"], 2),
                    _fmt(r["loc_rmse_m"], r["loc_rmse_m_ci_low"], r["loc_rmse_m_ci_high"], 3),
                    _fmt(r["rot_rmse_deg"], r["rot_rmse_deg_ci_low"], r["rot_rmse_deg_ci_high"], 2),
                    "-" if idle else _fmt(r["step_ms"], r["step_ms_ci_low"], r["step_ms_ci_high"], 1), hz)
    console.print(out)
    if not paired.empty:
        console.print(_paired_table(paired, escape))


def conditions_caption(table) -> str:
    """The line under a table that states its simulator conditions (every one named)."""
    from navbench.pipeline.score import conditions_in

    found = conditions_in(table)
    if len(found) == 1:
        return f"conditions: {found[0]}"
    return ("rows of different simulator conditions, never pooled (conditions column: those not "
            "at their default): " + " | ".join(found)) if found else ""


def _paired_table(paired, escape):
    """The paper's claim: reference - other on the same tasks and seeds, one section per noise
    (and per conditions, when the table holds several)."""
    from rich.table import Table

    from navbench.pipeline.score import NOISE_ORDER, _order_key, conditions_in, short_conditions

    out = Table(title="paired differences on the same (task, seed): mean [95% bootstrap interval, "
                      "stratified by level]", caption=escape(conditions_caption(paired)))
    found = conditions_in(paired) or [None]
    several = len(found) > 1
    for col, just in (("noise", "left"), *((("conditions", "left"),) if several else ()),
                      ("level", "left"), ("comparison", "left"), ("pairs", "right"),
                      ("unpaired", "right"), ("SPL ref / other", "right"), ("SPL diff", "right"),
                      ("success diff", "right")):
        out.add_column(col, justify=just)
    noises = sorted(paired["noise"].unique(), key=lambda n: _order_key(n, NOISE_ORDER))
    sections = [(n, c) for c in found for n in noises]
    first = True
    for noise, conds in sections:
        rows = paired[(paired["noise"] == noise)
                      & ((paired["conditions"] == conds) if conds is not None else True)]
        if rows.empty:
            continue
        if not first:
            out.add_section()
        first = False
        for _, r in rows.iterrows():
            both = f"{r['reference_spl']:.2f} / {r['other_spl']:.2f}" if r["pairs"] else "-"
            out.add_row(escape(str(noise)), *((escape(short_conditions(conds)),) if several else ()),
                        escape(str(r["level"])), escape(str(r["comparison"])),
                        str(r["pairs"]), f"{r['unpaired_reference']} / {r['unpaired_other']}", both,
                        _fmt(r["spl_diff"], r["spl_diff_ci_low"], r["spl_diff_ci_high"], 3),
                        _fmt(r["success_diff"], r["success_diff_ci_low"], r["success_diff_ci_high"], 3))
    return out


def register(app: typer.Typer) -> None:
    app.command("score")(score)
