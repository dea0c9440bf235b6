"""Paired differences between two sides on the same episodes: the math under ``navbench compare``,
``score``'s claim rows and the report's comparisons (issue 35).

A *side* is an episodes frame (:func:`navbench.results.score.select_episodes` scored under one
preset) and an estimator variant of it; a *pair* is an episode of side A and one of side B with
equal values of the join ``keys`` (for two estimators of one selection: the same level, map,
noise, episode config, task and seed; for two sets of runs: the same level, noise, task and
seed). Every difference is **B - A**, the mean over pairs of ``b_i - a_i`` (which equals
``mean(b) - mean(a)`` over the paired episodes).

Per (level, noise[, conditions]) and pooled over levels (``level = "all"``):

* ``pairs``, and the episodes without a partner (``unpaired_a``, ``unpaired_b``);
* success: both rates, ``success_diff`` with the bootstrap interval below, the discordant
  counts ``only_a`` (A succeeded, B did not) and ``only_b``, and ``mcnemar_p``, the exact
  two-sided McNemar test (:func:`mcnemar_exact_p`);
* SPL, SoftSPL and location RMSE: both means and the difference with its 95 % interval.
  SoftSPL and RMSE are taken over the pairs where both values are finite (``soft_spl_pairs``,
  ``loc_rmse_pairs``); an RMSE difference below zero means B tracks better.

Intervals are stratified by level: every resample draws each level's pairs with replacement and
keeps their count. ``method="bca"`` (the default, as ``score``):
:func:`navbench.nav.metrics.stratified_bootstrap_ci` (scipy's BCa, ``n_boot`` resamples, seeded
per metric). ``method="percentile"``: :func:`percentile_ci`, the percentile interval that
``scripts/paired_runs.py`` printed (the README's Table 4), one generator seeded per row and
drawn in the order SPL, success, SoftSPL, RMSE, each level's pairs in side A's stored order
(its ``id`` column).
"""

from __future__ import annotations

from math import comb
from typing import TYPE_CHECKING, Iterable

import numpy as np

from navbench.nav.metrics import stratified_bootstrap_ci

if TYPE_CHECKING:  # pragma: no cover
    import pandas

CI_LEVEL = 0.95
METHODS = ("bca", "percentile")
#: Resamples when none are given: score's 2000 for BCa, the script's 4000 for the percentile method.
DEFAULT_BOOT = {"bca": 2000, "percentile": 4000}
#: (name, episode column) in the order the percentile method draws them.
METRICS: tuple[tuple[str, str], ...] = (("spl", "spl_term"), ("success", "success"),
                                        ("soft_spl", "soft_spl_term"), ("loc_rmse", "loc_rmse_m"))
COLUMNS = ["comparison", "estimator_a", "estimator_b", "level", "noise", "conditions", "pairs",
           "unpaired_a", "unpaired_b",
           "success_a", "success_b", "success_diff", "success_diff_ci_low", "success_diff_ci_high",
           "only_a", "only_b", "mcnemar_p",
           "spl_a", "spl_b", "spl_diff", "spl_diff_ci_low", "spl_diff_ci_high",
           "soft_spl_pairs", "soft_spl_a", "soft_spl_b", "soft_spl_diff", "soft_spl_diff_ci_low",
           "soft_spl_diff_ci_high",
           "loc_rmse_pairs", "loc_rmse_a", "loc_rmse_b", "loc_rmse_diff", "loc_rmse_diff_ci_low",
           "loc_rmse_diff_ci_high"]


def mcnemar_exact_p(only_a: int, only_b: int) -> float:
    """Exact two-sided McNemar test: the probability, under no difference (each discordant pair
    is A's or B's with probability 1/2), of a split of the ``n = only_a + only_b`` discordant
    pairs at least as uneven as the one seen: ``min(1, 2 * sum_{i <= min} C(n, i) / 2^n)``.
    1.0 when no pair is discordant."""
    n = int(only_a) + int(only_b)
    if n == 0:
        return 1.0
    k = min(int(only_a), int(only_b))
    return min(1.0, 2 * sum(comb(n, i) for i in range(k + 1)) / 2 ** n)


def percentile_ci(strata: Iterable, rng: np.random.Generator, n_resamples: int = 4000,
                  level: float = CI_LEVEL) -> tuple[float, float]:
    """Percentile bootstrap interval of the pooled mean of ``strata`` (1D arrays, one per level):
    each of ``n_resamples`` resamples draws every stratum's values with replacement
    (``rng.choice(g, len(g))``, strata in the given order) and keeps their counts. Empty strata
    are left out; none left: ``(nan, nan)``. The draws are those of ``scripts/paired_runs.py``'s
    ``stratified_ci``, so the same generator state gives its numbers."""
    groups = [np.asarray(g, dtype=float) for g in strata]
    groups = [g for g in groups if g.size]
    if not groups:
        return (float("nan"), float("nan"))
    boots = [np.mean(np.concatenate([rng.choice(g, len(g)) for g in groups])) for _ in range(n_resamples)]
    tail = round(100 * (1 - level) / 2, 10)
    lo, hi = np.percentile(boots, [tail, 100 - tail])
    return float(lo), float(hi)


def method_label(method: str, n_boot: int, seed: int) -> str:
    """The interval method in words, as the output states it."""
    kind = "BCa" if method == "bca" else "percentile"
    return (f"95 % {kind} bootstrap stratified by level ({n_boot} resamples, seed {seed}); "
            "success also exact McNemar p")


def _nan_mean(x: np.ndarray) -> float:
    return float(x.mean()) if x.size else float("nan")


def _row_stats(both: "pandas.DataFrame", method: str, n_boot: int, seed: int,
               metrics: tuple[str, ...]) -> dict:
    """Means, differences and intervals of one group of pairs (columns ``<col>_a``, ``<col>_b``
    and ``level``); metrics not in ``metrics`` are left NaN."""
    row: dict = {}
    rng = np.random.default_rng(seed) if method == "percentile" else None
    levels = sorted(both["level"].unique())
    for name, col in METRICS:
        if name not in metrics:
            continue
        if f"{col}_a" not in both.columns:
            a = b = np.array([])
            lv = np.array([], dtype=object)
        else:
            a = both[f"{col}_a"].to_numpy(dtype=float)
            b = both[f"{col}_b"].to_numpy(dtype=float)
            lv = both["level"].to_numpy(dtype=object)
            ok = np.isfinite(a) & np.isfinite(b)
            a, b, lv = a[ok], b[ok], lv[ok]
        d = b - a
        if name in ("soft_spl", "loc_rmse"):
            row[f"{name}_pairs"] = int(d.size)
        row[f"{name}_a"], row[f"{name}_b"], row[f"{name}_diff"] = _nan_mean(a), _nan_mean(b), _nan_mean(d)
        strata = [d[lv == lvl] for lvl in levels]
        if method == "percentile":
            ci = percentile_ci(strata, rng, n_boot)
        else:
            ci = stratified_bootstrap_ci(strata, CI_LEVEL, n_boot, seed)
        row[f"{name}_diff_ci_low"], row[f"{name}_diff_ci_high"] = ci
    sa = both["success_a"].to_numpy(dtype=float) if len(both) else np.array([])
    sb = both["success_b"].to_numpy(dtype=float) if len(both) else np.array([])
    row["only_a"] = int(((sa > 0) & ~(sb > 0)).sum())
    row["only_b"] = int(((sb > 0) & ~(sa > 0)).sum())
    row["mcnemar_p"] = mcnemar_exact_p(row["only_a"], row["only_b"]) if len(both) else float("nan")
    return row


def paired_table(a: "pandas.DataFrame", b: "pandas.DataFrame", pairs: list[tuple[str, str]],
                 keys: list[str], by_conditions: bool = True, method: str = "bca",
                 n_boot: int | None = None, seed: int = 0, pooled: bool = True,
                 metrics: tuple[str, ...] = tuple(m for m, _ in METRICS)) -> "pandas.DataFrame":
    """B - A on the paired episodes of every ``(variant of A, variant of B)`` in ``pairs``.

    ``a``, ``b``: episodes frames with columns ``variant`` (the estimator label), ``level``,
    ``noise``, ``conditions``, the join ``keys``, ``success``, ``spl_term`` and, where known,
    ``soft_spl_term`` and ``loc_rmse_m``; each key must occur once per variant. Rows (columns
    :data:`COLUMNS`): per pair, per level (sorted) then ``"all"`` when ``pooled``, per noise and,
    with ``by_conditions``, per conditions label (then the keys must hold ``conditions``, so only
    equal conditions pair); without it the conditions column names the labels of both sides
    (``"A: ...; B: ..."`` where they differ). ``metrics``: the names of :data:`METRICS` to compute
    (the others stay NaN; success's counts are always given). Order: as found; callers sort.
    """
    import pandas as pd

    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, not {method!r}")
    n_boot = DEFAULT_BOOT[method] if n_boot is None else int(n_boot)
    values = [col for _, col in METRICS]
    out = []
    for va, vb in pairs:
        sa = a[a["variant"] == va]
        sb = b[b["variant"] == vb]
        extra = [c for c in ("level", "noise", "conditions", "id") if c not in keys]
        cols_a = keys + [c for c in extra if c in sa.columns] + [c for c in values if c in sa.columns]
        cols_b = keys + [c for c in extra if c in sb.columns] + [c for c in values if c in sb.columns]
        m = sa[cols_a].merge(sb[cols_b], on=keys, how="outer", suffixes=("_a", "_b"), indicator=True)
        for c in ("level", "noise", "conditions"):
            if c not in keys:  # the side that has the episode says where it ran
                m[c] = m[f"{c}_a"].where(m[f"{c}_a"].notna(), m[f"{c}_b"])
        groups = [(lvl, g) for lvl, g in m.groupby("level", sort=True)]
        if pooled:
            groups.append(("all", m))
        by = ["noise", "conditions"] if by_conditions else ["noise"]
        for lvl, g in groups:
            for gk, c in g.groupby(by, sort=False):
                noise = gk[0] if isinstance(gk, tuple) else gk
                both = c[c["_merge"] == "both"]
                if method == "percentile" and "id_a" in both.columns:  # the script's order: A's rows as stored
                    both = both.sort_values("id_a", kind="stable")
                if by_conditions:
                    conds = gk[1]
                else:
                    ca = sorted(set(c.loc[c["_merge"] != "right_only", "conditions_a"].astype(str)))
                    cb = sorted(set(c.loc[c["_merge"] != "left_only", "conditions_b"].astype(str)))
                    conds = (" | ".join(ca) if ca == cb or not cb else " | ".join(cb) if not ca
                             else f"A: {' | '.join(ca)}; B: {' | '.join(cb)}")
                row = {"comparison": f"{vb} - {va}", "estimator_a": va, "estimator_b": vb, "level": lvl,
                       "noise": noise, "conditions": conds, "pairs": int(len(both)),
                       "unpaired_a": int((c["_merge"] == "left_only").sum()),
                       "unpaired_b": int((c["_merge"] == "right_only").sum())}
                row.update(_row_stats(both, method, n_boot, seed, metrics))
                out.append(row)
    return pd.DataFrame(out, columns=COLUMNS)
