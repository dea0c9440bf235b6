"""Offline scoring: the stored episodes -> per (level, estimator, noise) metrics with intervals.

Which episodes count: every stored episode, once. The ``episodes`` table is unique on
(cell_key, task_id, seed) and inserts never overwrite, so each (cell, task, seed) contributes the
single value recorded the first time it completed (reruns skip done keys); when several rows of a
key could ever be present, the latest one (highest row id) is kept. ``run`` narrows this to the
episodes a given run inserted (``"latest"``: the newest run that stored episodes) -- note that a
resumed run owns only the episodes it added.

Per group (level, estimator, noise; plus ``level = "all"`` pooled over levels):

* ``success_rate`` -- mean of the success flags;
* ``spl`` -- mean of ``s_i l_i / max(p_i, l_i)`` (eq. 8; Anderson et al. 2018, "On evaluation of
  embodied navigation agents");
* ``loc_rmse_m``, ``rot_rmse_deg`` -- median over episodes of the per-trajectory RMSE;
* ``step_ms`` -- median over episodes of the per-episode median step time; ``step_hz`` = 1000 /
  ``step_ms``.

Each with a 95 % percentile-bootstrap interval (:func:`bootstrap_ci`, seeded, 2000 resamples of
the group's episodes). An estimator run with several option sets is split into variants labelled
``name{key=value,...}``.

``setups`` counts the cells a group pools within one level: 1 unless the database holds the same
(level, estimator, noise) under several maps, task sets or episode settings (say a quick run and
a paper run). Such a row mixes experiments; :func:`mixed_setups` lists them, and ``score`` and the
report warn. Narrow with ``run`` (or keep experiments in separate databases).
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from navbench.errors import DatabaseError

if TYPE_CHECKING:  # pragma: no cover
    import pandas

    from navbench.pipeline.db import ResultsDB

NOISE_ORDER = ("none", "tracking", "low", "mid", "high")
ESTIMATOR_ORDER = ("ours", "no-map", "dynamics", "emission", "gt")
N_BOOT = 2000
CI_LEVEL = 0.95

# (output column, episode column, statistic name)
METRICS: tuple[tuple[str, str, str], ...] = (
    ("success_rate", "success", "mean"),
    ("spl", "spl_term", "mean"),
    ("loc_rmse_m", "loc_rmse_m", "median"),
    ("rot_rmse_deg", "rot_rmse_deg", "median"),
    ("step_ms", "step_ms", "median"),
)
_STATS: dict[str, Callable] = {"mean": np.mean, "median": np.median}


def bootstrap_ci(values, stat: Callable | str = np.mean, n: int = N_BOOT, seed: int = 0,
                 level: float = CI_LEVEL) -> tuple[float, float]:
    """Percentile-bootstrap interval of ``stat`` over ``values`` (1D; NaNs dropped).

    Draws ``n`` resamples of the values with replacement from ``np.random.default_rng(seed)``
    and returns the ``(1 - level) / 2`` and ``(1 + level) / 2`` quantiles of ``stat`` over them
    (the percentile method). ``stat`` must accept ``axis=1`` on a (n, m) array (``np.mean``,
    ``np.median``, or their names). No values: ``(nan, nan)``.
    """
    if isinstance(stat, str):
        stat = _STATS[stat]
    x = np.asarray(values, dtype=float).ravel()
    x = x[np.isfinite(x)]
    if x.size == 0:
        return (float("nan"), float("nan"))
    if n < 1:
        raise ValueError("n must be >= 1")
    rng = np.random.default_rng(seed)
    stats = np.empty(n)
    rows = max(1, 4_000_000 // x.size)  # bound the (rows, m) resample block
    for start in range(0, n, rows):
        k = min(rows, n - start)
        idx = rng.integers(0, x.size, size=(k, x.size))
        stats[start:start + k] = stat(x[idx], axis=1)
    alpha = (1.0 - level) / 2.0
    low, high = np.quantile(stats, [alpha, 1.0 - alpha])
    return (float(low), float(high))


def _point(values, stat: str) -> float:
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    return float(_STATS[stat](x)) if x.size else float("nan")


def _order_key(value: str, order: tuple[str, ...]) -> tuple[int, str]:
    return (order.index(value), "") if value in order else (len(order), str(value))


def estimator_variants(frame: "pandas.DataFrame") -> "pandas.Series":
    """Per-row label: the estimator name, or ``name{k=v,...}`` when the frame holds the same
    estimator with several option sets."""
    import pandas as pd

    if frame.empty:
        return pd.Series([], dtype=object, index=frame.index)
    opts = frame["estimator_options"].map(
        lambda o: json.dumps(o if isinstance(o, dict) else {}, sort_keys=True))
    counts = pd.DataFrame({"e": frame["estimator"], "o": opts}).groupby("e")["o"].nunique()
    labels = []
    for est, o in zip(frame["estimator"], opts):
        if counts.get(est, 1) > 1:
            d = json.loads(o)
            labels.append(est + "{" + ",".join(f"{k}={d[k]}" for k in sorted(d)) + "}")
        else:
            labels.append(est)
    return pd.Series(labels, index=frame.index, dtype=object)


def select_episodes(db: "ResultsDB", run: int | str | None = None,
                    level: str | list[str] | None = None) -> "pandas.DataFrame":
    """The episodes that count (see the module docstring), optionally of one run and level(s)."""
    run_ids = None
    if run is not None and str(run) != "all":
        if str(run) == "latest":
            runs = db.episodes_frame()["run_id"]
            if runs.empty:
                raise DatabaseError(f"no episodes stored in {db.display_url}")
            run_ids = [int(runs.max())]
        else:
            try:
                run_ids = [int(run)]
            except ValueError:
                raise DatabaseError(f"--run must be a run id, 'latest' or 'all', not {run!r}") from None
            if run_ids[0] not in set(db.runs_frame()["id"]):
                raise DatabaseError(f"no run with id {run_ids[0]} in {db.display_url}")
    levels = [level] if isinstance(level, str) else level
    frame = db.episodes_frame(run_ids=run_ids, level=levels or None)
    if not frame.empty:
        frame = (frame.sort_values("id")
                 .drop_duplicates(["cell_key", "task_id", "seed"], keep="last")
                 .reset_index(drop=True))
    return frame


def summarise(frame: "pandas.DataFrame", n_boot: int = N_BOOT, seed: int = 0,
              pooled: bool = True) -> "pandas.DataFrame":
    """Per (level, estimator, noise) metrics with bootstrap intervals from an episodes frame.

    ``pooled`` adds ``level = "all"`` rows over every level. Columns: level, estimator, noise,
    episodes, then for each metric ``m``: ``m``, ``m_ci_low``, ``m_ci_high``; and ``step_hz``
    with its interval. Rows sorted by level ("all" last), noise, estimator.
    """
    import pandas as pd

    columns = ["level", "estimator", "noise", "episodes", "setups"]
    for name, _, _ in METRICS:
        columns += [name, f"{name}_ci_low", f"{name}_ci_high"]
    columns += ["step_hz", "step_hz_ci_low", "step_hz_ci_high"]
    if frame.empty:
        return pd.DataFrame(columns=columns)
    f = frame.copy()
    f["variant"] = estimator_variants(f)
    f["success"] = f["success"].astype(float)
    groups = [(lvl, g) for lvl, g in f.groupby("level", sort=True)]
    if pooled:
        groups.append(("all", f))
    out = []
    for lvl, g in groups:
        for (est, noise), cell in g.groupby(["variant", "noise"], sort=False):
            setups = int(cell.groupby("level")["cell_key"].nunique().max())
            row: dict[str, Any] = {"level": lvl, "estimator": est, "noise": noise,
                                   "episodes": int(len(cell)), "setups": setups}
            for name, col, stat in METRICS:
                vals = cell[col].to_numpy(dtype=float)
                row[name] = _point(vals, stat)
                row[f"{name}_ci_low"], row[f"{name}_ci_high"] = bootstrap_ci(vals, stat, n_boot, seed)
            with np.errstate(divide="ignore"):
                row["step_hz"] = 1000.0 / row["step_ms"] if row["step_ms"] > 0 else float("nan")
                hi, lo = row["step_ms_ci_low"], row["step_ms_ci_high"]
                row["step_hz_ci_low"] = 1000.0 / lo if lo > 0 else float("nan")
                row["step_hz_ci_high"] = 1000.0 / hi if hi > 0 else float("nan")
            out.append(row)
    table = pd.DataFrame(out, columns=columns)
    key = table.apply(lambda r: (r["level"] == "all", r["level"],
                                 _order_key(r["noise"], NOISE_ORDER),
                                 _order_key(r["estimator"].split("{")[0], ESTIMATOR_ORDER),
                                 r["estimator"]), axis=1)
    return table.iloc[sorted(range(len(table)), key=lambda i: key.iloc[i])].reset_index(drop=True)


def mixed_setups(table: "pandas.DataFrame") -> list[str]:
    """``"level/estimator/noise"`` of every per-level row of a score table that pools episodes
    of more than one setup (cell): a warning's worth, see the module docstring."""
    if table.empty or "setups" not in table.columns:
        return []
    rows = table[(table["level"] != "all") & (table["setups"] > 1)]
    return [f"{r.level}/{r.estimator}/{r.noise}" for r in rows.itertuples()]


def mixed_setups_warning(table: "pandas.DataFrame") -> str | None:
    """One line naming the rows of :func:`mixed_setups`, or ``None``."""
    mixed = mixed_setups(table)
    if not mixed:
        return None
    shown = ", ".join(mixed[:4]) + (f" and {len(mixed) - 4} more" if len(mixed) > 4 else "")
    return (f"{len(mixed)} row(s) pool episodes of several setups (maps, task sets or episode "
            f"settings): {shown}; narrow with --run, or keep experiments in separate databases")


def score_table(db: "ResultsDB", run: int | str | None = None, level: str | list[str] | None = None,
                n_boot: int = N_BOOT, seed: int = 0) -> "pandas.DataFrame":
    """Score the stored episodes: :func:`select_episodes` then :func:`summarise`.

    Raises :class:`DatabaseError` when no episode matches.
    """
    frame = select_episodes(db, run=run, level=level)
    if frame.empty:
        what = [f"run {run}" if run not in (None, "all") else "", f"level {level}" if level else ""]
        detail = " for " + " and ".join(w for w in what if w) if any(what) else ""
        raise DatabaseError(f"no episodes{detail} in {db.display_url}; run `navbench run-navigation` first")
    return summarise(frame, n_boot=n_boot, seed=seed)


def spl_matrix(table: "pandas.DataFrame", level: str = "all", digits: int = 2) -> "pandas.DataFrame":
    """The paper's Fig. 5a layout: rows noise (high, mid, low...), columns estimators, cells
    ``"0.92 [0.89, 0.95]"`` (SPL with its 95 % interval) for one ``level`` of a score table."""
    import pandas as pd

    t = table[table["level"] == level]
    noises = sorted(t["noise"].unique(), key=lambda n: _order_key(n, NOISE_ORDER), reverse=True)
    ests = sorted(t["estimator"].unique(),
                  key=lambda e: (_order_key(e.split("{")[0], ESTIMATOR_ORDER), e))
    cells = {}
    for _, r in t.iterrows():
        cells[(r["noise"], r["estimator"])] = (
            f"{r['spl']:.{digits}f} [{r['spl_ci_low']:.{digits}f}, {r['spl_ci_high']:.{digits}f}]")
    data = [[cells.get((n, e), "") for e in ests] for n in noises]
    return pd.DataFrame(data, index=pd.Index(noises, name="noise"), columns=ests)


def table_records(table: "pandas.DataFrame") -> list[dict]:
    """JSON-ready records (NaN -> None, numpy scalars -> Python)."""
    records = []
    for rec in table.to_dict(orient="records"):
        clean = {}
        for k, v in rec.items():
            if isinstance(v, np.generic):
                v = v.item()
            if isinstance(v, float) and not np.isfinite(v):
                v = None
            clean[k] = v
        records.append(clean)
    return records
