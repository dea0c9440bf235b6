"""``navbench score``: success rate, SPL, RMSE and step time per (level, estimator, noise)."""

from __future__ import annotations

from enum import Enum

import typer

from navbench.cli._common import console, parse_list
from navbench.cli._help import DB_HELP, VERSION_HELP

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
    run: str = typer.Option("all", "--run", help="A run id, comma-separated run ids (a measurement "
                            "resumed over several runs: 4,5,6), 'latest' (the newest run that stored "
                            "episodes, with the interrupted runs of its setup that it resumed) or 'all' "
                            "(every stored episode, once per cell/task/seed)."),
    level: str = typer.Option(None, "--level", help="Only these levels (comma-separated)."),
    fmt: Format = typer.Option(Format.table, "--format", help="Output format."),
    boot: int = typer.Option(2000, "--boot", min=1, max=MAX_BOOT, help="Bootstrap resamples for the 95% intervals."),
    seed: int = typer.Option(0, "--seed", min=0, max=2**63 - 1, help="Seed of the bootstrap."),
    preset: str = typer.Option(None, "--preset", help="Scoring preset: paper (within 2 L, no stop), "
                               "nrns (stopped within 1 m, 500 steps) or habitat (stopped within 0.2 m "
                               "geodesic, 500 steps). Default: paper; nrns when every selected episode "
                               "is an unknown-house one (--map online|online-fused).",
                               show_default=False),
    by_difficulty: bool = typer.Option(False, "--by-difficulty", help="Also print success, SPL, SoftSPL "
                                       "and final distance by NRNS difficulty and goal."),
    db: str = typer.Option(None, "--db", envvar="NAVBENCH_DB",
                           help=DB_HELP),
    benchmark_version: str = typer.Option(None, "--benchmark-version", help=VERSION_HELP, show_default=False),
):
    """Score the stored navigation episodes offline, with 95% intervals.

    One row per (level, estimator, noise) and pooled rows with level 'all'; then the paired
    differences ours - no-map and ours - dynamics on the same tasks and seeds. Success: exact
    (Clopper-Pearson) interval; SPL and differences: BCa bootstrap stratified by level. Every
    stored episode counts once per setup, task and seed; --run narrows to one run. --format json
    prints {"scores": [...], "paired_differences": [...]} (and "by_difficulty" with
    --by-difficulty); csv prints the score table; markdown prints the pooled SPL and success
    tables beside the paper's (the README's results table). Every table names its --preset and
    the benchmark version it scores (one only: results of two versions are never pooled).
    """
    import sys

    from rich.markup import escape

    from navbench.results.db import ResultsDB
    from navbench.results.db.resume import resolve_selection
    from navbench.cli._common import err_console
    from navbench.nav.presets import get_preset
    from navbench.results.score import (conditions_in, difficulty_table, mixed_setups_warning, score_tables,
                                         select_versioned, short_conditions, table_records)
    from navbench.results.presets import apply_preset, default_preset, missing_distances

    if preset is not None:
        get_preset(preset, "--preset")  # before opening the database
    with ResultsDB(db, create=False) as rdb:
        selection, chain = resolve_selection(rdb, run)
        frame, version, version_note = select_versioned(rdb, run=selection, level=parse_list(level) or None,
                                                        benchmark_version=benchmark_version)
        preset, mixed = (preset, None) if preset is not None else default_preset(frame)
        table, paired = score_tables(rdb, run=selection, level=parse_list(level) or None, n_boot=boot,
                                     seed=seed, preset=preset, benchmark_version=version)
    if chain:
        err_console.print(escape(chain), markup=True)
    if version_note:
        err_console.print(f"[yellow]note:[/] {escape(version_note)}", markup=True)
    if mixed:
        err_console.print(f"[yellow]warning:[/] {escape(mixed)}", markup=True)
    warning = mixed_setups_warning(table)
    if warning:
        err_console.print(f"[yellow]warning:[/] {escape(warning)}", markup=True)
    missing = missing_distances(frame)
    if missing and preset != "paper":
        err_console.print(f"[yellow]warning:[/] {missing} episode(s) were stored without their final "
                          f"distance (before scoring presets); under --preset {escape(preset)} they "
                          "count as failures", markup=True)
    by_diff = difficulty_table(apply_preset(frame, preset)) if by_difficulty else None
    if fmt is Format.json:
        from navbench.cli._common import print_json

        doc = {"benchmark_version": version, "scores": table_records(table),
               "paired_differences": table_records(paired)}
        if by_diff is not None:
            doc["by_difficulty"] = table_records(by_diff)
        print_json(doc)
        return
    if fmt is Format.csv:
        table.to_csv(sys.stdout, index=False, float_format="%.6g")
        return
    if fmt is Format.markdown:  # the README's results table (pooled rows), beside the paper's
        from navbench.report.tables import markdown_results

        sys.stdout.write(markdown_results(table, paired))
        return
    from rich.table import Table

    # level, estimator and noise names come from the database: printed literally, never as markup
    out = Table(title=f"navbench score ({escape(run)}), {escape(str(version))}, preset {escape(preset)}: mean or median [95% "
                      "interval: success exact binomial, SPL bootstrap stratified by level, medians bootstrap]",
                caption=escape(conditions_caption(table)))
    goals = bool((table["goal"] != "point").any())  # a goal column only where image goals are stored
    several = len(conditions_in(table)) > 1
    cols = [("level", "left"), ("estimator", "left"), ("noise", "left")] + ([("goal", "left")] if goals else []) \
        + ([("conditions", "left")] if several else []) \
        + [("n", "right"), ("success", "right"), ("SPL", "right"), ("loc RMSE m", "right"),
           ("rot RMSE deg", "right"), ("step ms", "right"), ("Hz", "right")]
    for col, just in cols:
        out.add_column(col, justify=just)
    previous = None
    for _, r in table.iterrows():
        if previous is not None and r["level"] != previous:
            out.add_section()
        previous = r["level"]
        hz = "-" if r["step_hz"] != r["step_hz"] else f"{r['step_hz']:.1f}"
        idle = not bool(r.get("tracking_work", True))  # dynamics, gt: no tracking rate to show
        out.add_row(escape(str(r["level"])), escape(str(r["estimator"])), escape(str(r["noise"])),
                    *((escape(str(r["goal"])),) if goals else ()),
                    *((escape(short_conditions(r["conditions"])),) if several else ()),
                    str(r["episodes"]),
                    _fmt(r["success_rate"], r["success_rate_ci_low"], r["success_rate_ci_high"], 2),
                    _fmt(r["spl"], r["spl_ci_low"], r["spl_ci_high"], 2),
                    _fmt(r["loc_rmse_m"], r["loc_rmse_m_ci_low"], r["loc_rmse_m_ci_high"], 3),
                    _fmt(r["rot_rmse_deg"], r["rot_rmse_deg_ci_low"], r["rot_rmse_deg_ci_high"], 2),
                    "-" if idle else _fmt(r["step_ms"], r["step_ms_ci_low"], r["step_ms_ci_high"], 1), hz)
    console.print(out)
    if not paired.empty:
        console.print(_paired_table(paired, escape, preset))
    if by_diff is not None:
        console.print(_difficulty_table(by_diff, escape, preset))


def conditions_caption(table) -> str:
    """The line under a table that states its simulator conditions (every one named)."""
    from navbench.results.score import conditions_in

    found = conditions_in(table)
    if len(found) == 1:
        return f"conditions: {found[0]}"
    return ("rows of different simulator conditions, never pooled (conditions column: those not "
            "at their default): " + " | ".join(found)) if found else ""


def _difficulty_table(by_diff, escape, preset: str):
    """Issue 15: success, SPL, SoftSPL and final distance by goal kind and NRNS difficulty."""
    from rich.table import Table

    from navbench.results.score import short_conditions

    out = Table(title=f"by NRNS difficulty (geodesic easy 1.5-3 m, medium 3-5 m, hard 5-10 m), preset "
                      f"{escape(preset)}: success [95% exact interval], means")
    # several conditions (simulator conditions, --map online's sensing model): a column of them
    several = "conditions" in by_diff.columns and by_diff["conditions"].nunique() > 1
    text = ("level", "estimator", "noise", *(("conditions",) if several else ()), "goal", "difficulty")
    for col in (*text, "n", "success", "SPL", "SoftSPL", "final d m"):
        out.add_column(col, justify="right" if col in ("n", "success", "SPL", "SoftSPL", "final d m") else "left")
    for _, r in by_diff.iterrows():
        out.add_row(*(escape(short_conditions(r[c]) if c == "conditions" else str(r[c])) for c in text),
                    str(r["episodes"]),
                    _fmt(r["success_rate"], r["success_rate_ci_low"], r["success_rate_ci_high"], 2),
                    f"{r['spl']:.2f}", "-" if r["soft_spl"] != r["soft_spl"] else f"{r['soft_spl']:.2f}",
                    "-" if r["final_dist_m"] != r["final_dist_m"] else f"{r['final_dist_m']:.2f}")
    return out


def _paired_table(paired, escape, preset: str = "paper"):
    """The paper's claim: reference - other on the same tasks and seeds, one section per noise
    (and per conditions, when the table holds several)."""
    from rich.table import Table

    from navbench.results.score import NOISE_ORDER, _order_key, conditions_in, short_conditions

    out = Table(title=f"paired differences on the same (task, seed), preset {escape(preset)}: mean "
                      "[95% bootstrap interval, stratified by level]", caption=escape(conditions_caption(paired)))
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
