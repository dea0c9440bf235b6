"""How the report shows a table to a person (issue 35 §6): labels instead of column names, numbers
at consistent decimals per column, counts with their plurals. The CSV files keep the column names
and full precision; only the page uses these."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    import pandas

#: Significant figures of a column's largest value (:func:`decimals`); its other values get its decimals.
SIG = 3

#: Column name -> the label the page shows (units in brackets).
LABELS = {
    # runs
    "config_hash": "config hash", "navbench_version": "navbench", "git_commit": "commit",
    "benchmark_version": "benchmark",
    # tracking summary
    "trajectories": "trajectories", "loc_rmse_median_m": "median location RMSE (m)",
    "frac_loc_rmse_below_0.1m": "location RMSE < 0.1 m (share)", "rot_rmse_median_deg": "median orientation RMSE (°)",
    # runtime
    "sim": "sim (ms)", "render": "render (ms)", "estimate": "estimate (ms)", "plan": "plan (ms)",
    "control": "control (ms)", "step_ms": "step (ms)", "step_hz": "rate (Hz)",
    # maps
    "map_key": "map", "depth_mae_m": "depth MAE (m)", "rgb_l1": "RGB L1", "slice_precision": "slice precision",
    "slice_recall": "slice recall", "fit_seconds": "fit (s)", "steps": "steps",
    # episodes, bench
    "end_reason": "end reason", "run_id": "run", "task_id": "task", "spl_term": "SPL term",
    "loc_rmse_m": "location RMSE (m)", "rot_rmse_deg": "orientation RMSE (°)",
}


def plural(n: int, word: str, many: str | None = None) -> str:
    """``"1 run"``, ``"2 runs"``, ``"0 runs"`` (``many``: an irregular plural)."""
    return f"{n} {word if n == 1 else (many or word + 's')}"


def decimals(values, sig: int = SIG) -> int:
    """Decimals for a column of numbers: the largest finite ``|value|`` at ``sig`` significant
    figures and the smallest non-zero one at two at least (``31.0`` and ``0.012`` give 3), at most
    4; fewer where every value is already that round (``0.3``, ``500``)."""
    finite = [abs(float(v)) for v in values if v is not None and math.isfinite(float(v))]
    nonzero = [v for v in finite if v > 0]
    if not nonzero:
        return 0
    big = sig - 1 - math.floor(math.log10(max(nonzero)))
    small = 1 - math.floor(math.log10(min(nonzero)))
    d = max(0, min(4, max(big, small)))
    for k in range(d):
        if all(abs(v - round(v, k)) < 1e-9 * max(1.0, v) for v in finite):
            return k
    return d


def shown(frame: "pandas.DataFrame", sig: int = SIG) -> "pandas.DataFrame":
    """``frame`` for the page: float columns as strings at one number of decimals each
    (:func:`decimals`; non-finite values ``"–"``), columns renamed by :data:`LABELS`."""
    import numpy as np

    out = frame.copy()
    for col in out.columns:
        if out[col].dtype.kind == "f":
            vals = out[col].to_numpy(dtype=float)
            d = decimals(vals, sig)
            out[col] = [f"{v:.{d}f}" if np.isfinite(v) else "–" for v in vals]
    names = [LABELS.get(c, c) if isinstance(c, str) else c for c in out.columns]
    if out.index.name in LABELS:
        out.index.name = LABELS[out.index.name]
    out.columns = names if not hasattr(out.columns, "levels") else out.columns
    return out


def by_rows(frame: "pandas.DataFrame", sig: int = SIG) -> "pandas.DataFrame":
    """``frame`` (numbers, one quantity per row) as strings at one number of decimals per row
    (:func:`decimals` of the row; non-finite values ``"–"``): a table whose rows carry the units."""
    import numpy as np

    out = frame.astype(object).copy()
    for i in range(len(frame)):
        vals = frame.iloc[i].to_numpy(dtype=float)
        d = decimals(vals, sig)
        out.iloc[i] = [f"{v:.{d}f}" if np.isfinite(v) else "–" for v in vals]
    return out


def mark_column(table_html: str, position: int, cls: str) -> str:
    """``table_html`` (pandas' ``to_html``) with ``class="cls"`` on the ``position``-th ``<td>``
    (0-based, index cells are ``<th>``) of every body row."""
    import re

    def row(m):
        cells = m.group(0).split("<td")
        if len(cells) > position + 1:
            cells[position + 1] = f' class="{cls}"' + cells[position + 1]
        return "<td".join(cells)

    return re.sub(r"<tr>.*?</tr>", row, table_html, flags=re.S)
