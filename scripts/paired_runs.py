"""Paired SPL and success differences between two sets of runs of the same tasks (issue 16).

    python scripts/paired_runs.py --a 35,54 --b 95        # quick-budget maps vs the paper's budget
    python scripts/paired_runs.py --a 95 --b 1 --b-db results/gt-ceiling.db --estimators ours:gt

Matches episodes of runs A and B on (level, task id, seed, noise, estimator): within A or B a
(task, seed) counted twice keeps its last stored row, as `navbench score` does. Prints per
estimator and noise the number of pairs, both mean SPLs and successes, and the mean of B − A SPL
with a 95 % percentile bootstrap interval stratified by level (4000 resamples, seed 0).
``--b-db``: runs B from another SQLite file; ``--estimators A:B``: pair estimator A of runs A
with estimator B of runs B on the same (level, task id, seed, noise) instead. ``--preset``
(paper, nrns, habitat): success and SPL recomputed under that scoring preset from the stored
columns (:func:`navbench.nav.presets.preset_terms`, as ``navbench score --preset``) instead of
the stored (paper) ones; then the success difference gets the same bootstrap interval.

    python scripts/paired_runs.py --db results/table4.db --a 1 --b 2 --preset nrns   # Table 4's rows
"""

from __future__ import annotations

import argparse
import sqlite3

import numpy as np
import pandas as pd

KEY = ["level", "task_id", "seed", "noise", "estimator"]


def runs_frame(con, runs: list[int], estimator: str | None = None, preset: str | None = None) -> pd.DataFrame:
    extra = (", end_reason, steps, path_length, optimal_length, final_dist_m, final_geo_m"  # a preset's inputs
             if preset is not None else "")
    q = (f"SELECT id AS row_id, run_id, level, task_id, seed, noise, estimator, spl_term, success{extra} "
         f"FROM episodes WHERE run_id IN ({','.join('?' * len(runs))}) ORDER BY id")
    df = pd.read_sql(q, con, params=runs).drop_duplicates(KEY, keep="last")
    if preset is not None:
        from navbench.nav.presets import preset_terms

        t = preset_terms(preset, end_reason=df.end_reason.to_numpy(), steps=df.steps.to_numpy(),
                         path_length=df.path_length.to_numpy(), optimal_length=df.optimal_length.to_numpy(),
                         final_dist_m=df.final_dist_m.to_numpy(float), final_geo_m=df.final_geo_m.to_numpy(float))
        df["success"], df["spl_term"] = t["success"].astype(float), t["spl_term"]
    if estimator is not None:  # pair across estimators: the key without it, under a joint name
        df = df[df.estimator == estimator]
    return df.set_index(KEY)


def stratified_ci(d: pd.Series, rng) -> tuple[float, float]:
    """95 % percentile interval of the mean of ``d`` (indexed by level among others): 4000
    resamples, each drawing every level's pairs with replacement and keeping their count."""
    groups = [g.to_numpy() for _, g in d.groupby(level="level")]
    boots = [np.mean(np.concatenate([rng.choice(g, len(g)) for g in groups])) for _ in range(4000)]
    lo, hi = np.percentile(boots, [2.5, 97.5])
    return float(lo), float(hi)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--a", required=True, help="run ids, comma-separated")
    ap.add_argument("--b", required=True, help="run ids, comma-separated")
    ap.add_argument("--db", default="results/navbench.db", help="SQLite file")
    ap.add_argument("--b-db", default=None, help="SQLite file of runs B [default: --db]")
    ap.add_argument("--estimators", default=None, metavar="A:B",
                    help="pair estimator A of runs A with estimator B of runs B")
    ap.add_argument("--preset", default=None, choices=["paper", "nrns", "habitat"],
                    help="recompute success and SPL under this scoring preset")
    args = ap.parse_args()
    ea = eb = None
    if args.estimators is not None:
        if args.estimators.count(":") != 1:
            ap.error("--estimators: give A:B, e.g. ours:gt")
        ea, eb = args.estimators.split(":")
    con = sqlite3.connect(args.db)
    a = runs_frame(con, [int(r) for r in args.a.split(",")], ea, args.preset)
    b = runs_frame(sqlite3.connect(args.b_db) if args.b_db else con, [int(r) for r in args.b.split(",")], eb,
                   args.preset)
    if ea is not None:
        a = a.rename(index={ea: f"{ea}:{eb}"}, level="estimator")
        b = b.rename(index={eb: f"{ea}:{eb}"}, level="estimator")
    j = a.add_suffix("_a").join(b.add_suffix("_b"), how="inner")
    rng = np.random.default_rng(0)
    for (est, noise), s in j.groupby(level=["estimator", "noise"], sort=True):
        d = s.spl_term_b - s.spl_term_a
        lo, hi = stratified_ci(d, rng)
        line = (f"{est:9s} {noise:5s} pairs {len(d):4d}  SPL A {s.spl_term_a.mean():.3f} B {s.spl_term_b.mean():.3f} "
                f"B-A {d.mean():+.3f} [{lo:+.3f}, {hi:+.3f}]  success A {s.success_a.mean():.3f} B {s.success_b.mean():.3f}")
        if args.preset is not None:
            ds = s.success_b.astype(float) - s.success_a.astype(float)
            slo, shi = stratified_ci(ds, rng)
            line += (f" B-A {ds.mean():+.3f} [{slo:+.3f}, {shi:+.3f}]; only A {(ds < 0).sum()}, only B {(ds > 0).sum()}"
                     f"  ({args.preset})")
        print(line)


if __name__ == "__main__":
    main()
