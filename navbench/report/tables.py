"""The README's results table as Markdown: navbench's Fig. 5a figures with their intervals beside
the paper's, the paper's claim as paired differences, and the simulator conditions they ran
under (``navbench score --format markdown``).

Inputs are the two tables of :func:`navbench.results.score.score_tables`; one block per set of
conditions (episodes of different conditions are never pooled), each from the pooled
(``level = "all"``) rows. Pure formatting: no database, no I/O.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from navbench.results.score import (
    CLAIM_REFERENCE,
    ESTIMATOR_ORDER,
    NOISE_ORDER,
    _order_key,
    conditions_in,
)

if TYPE_CHECKING:  # pragma: no cover
    import pandas


def _ci(v: float, lo: float, hi: float, sign: bool = False) -> str:
    if v is None or not np.isfinite(v):
        return "–"
    f = "+.3f" if sign else ".3f"
    return f"{v:{f}} [{lo:{f}}, {hi:{f}}]"


def _paper(v: float | None, sign: bool = False) -> str:
    if v is None or not np.isfinite(v):
        return ""
    return f" ({v:+.2f})" if sign else f" ({v:.2f})"


def _for(frame: "pandas.DataFrame", conds: str | None, level: str) -> "pandas.DataFrame":
    f = frame[frame["level"] == level]
    if conds is not None and "conditions" in f.columns:
        f = f[f["conditions"] == conds]
    return f


def markdown_results(table: "pandas.DataFrame", paired: "pandas.DataFrame", level: str = "all") -> str:
    """Markdown tables of ``level``'s rows (default: pooled over levels), per set of conditions:

    1. per noise level, each estimator's SPL ``v [lo, hi]`` (the level-stratified BCa interval)
       with the paper's Fig. 5a value in brackets, then the paired SPL differences
       ``ours − other`` with their intervals and the paper's margin;
    2. per noise level, each estimator's success rate with its exact (Clopper-Pearson) interval
       (the paper gives none), and the episodes and pairs behind each figure.
    """
    from navbench.report.plots import PAPER_SPL

    blocks = []
    for conds in conditions_in(table) or [None]:
        t = _for(table, conds, level)
        if t.empty:
            continue
        p = _for(paired, conds, level) if paired is not None and not paired.empty else paired
        ests = sorted(t["estimator"].unique(), key=lambda e: (_order_key(e.split("{")[0], ESTIMATOR_ORDER), e))
        noises = sorted(t["noise"].unique(), key=lambda n: _order_key(n, NOISE_ORDER))
        others = [] if p is None or p.empty else sorted(
            p["other"].unique(), key=lambda e: (_order_key(e.split("{")[0], ESTIMATOR_ORDER), e))
        cell = {(r["noise"], r["estimator"]): r for _, r in t.iterrows()}
        pair = {} if p is None or p.empty else {(r["noise"], r["other"]): r for _, r in p.iterrows()}
        where = "pooled over levels" if level == "all" else f"level {level}"
        head = f"Conditions: {conds}." if conds is not None else "Conditions: not recorded."
        blocks.append(f"{head} SPL {where} with its 95 % interval (BCa bootstrap stratified by "
                      "level); the paper's Fig. 5a in brackets:")
        cols = ["noise"] + [f"`{e}` SPL" for e in ests] + [f"`{CLAIM_REFERENCE} − {o}` SPL" for o in others]
        rows = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
        for n in noises:
            cells = [n]
            for e in ests:
                r = cell.get((n, e))
                cells.append("–" if r is None else
                             _ci(r["spl"], r["spl_ci_low"], r["spl_ci_high"]) + _paper(PAPER_SPL.get((n, e))))
            for o in others:
                r = pair.get((n, o))
                a, b = PAPER_SPL.get((n, CLAIM_REFERENCE)), PAPER_SPL.get((n, o.split("{")[0]))
                margin = a - b if a is not None and b is not None else None
                cells.append("–" if r is None or not r["pairs"] else
                             _ci(r["spl_diff"], r["spl_diff_ci_low"], r["spl_diff_ci_high"], sign=True)
                             + _paper(margin, sign=True))
            rows.append("| " + " | ".join(cells) + " |")
        blocks.append("\n".join(rows))
        blocks.append("Success rate with its exact (Clopper-Pearson) 95 % interval (the paper "
                      "reports none); episodes per cell; pairs per difference:")
        cols = ["noise"] + [f"`{e}` success" for e in ests] + ["episodes"] + (["pairs"] if others else [])
        rows = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
        for n in noises:
            cells = [n]
            for e in ests:
                r = cell.get((n, e))
                cells.append("–" if r is None else
                             _ci(r["success_rate"], r["success_rate_ci_low"], r["success_rate_ci_high"]))
            cells.append(" / ".join(str(int(cell[(n, e)]["episodes"])) if (n, e) in cell else "–" for e in ests))
            if others:
                cells.append(" / ".join(str(int(pair[(n, o)]["pairs"])) if (n, o) in pair else "–"
                                        for o in others))
            rows.append("| " + " | ".join(cells) + " |")
        blocks.append("\n".join(rows))
    return "\n\n".join(blocks) + "\n"
