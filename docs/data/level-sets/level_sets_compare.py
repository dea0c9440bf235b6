"""SPL and success of two level sets under the same profile settings, side by side (issue 16).

    python docs/data/level-sets/level_sets_compare.py --a-runs 35,54 --b-db results/dense.db --b-runs 1 --tasks 50
    python docs/data/level-sets/level_sets_compare.py ... --difficulty results/difficulty.json

Set A (``--a-db``, runs ``--a-runs``) and set B are different levels, so nothing is paired: per
estimator and noise it prints both pooled SPLs and successes and the difference B - A with a 95 %
percentile bootstrap interval that resamples tasks within each level, independently in A and B
(4000 resamples, seed 0). Within a set a (level, task, seed, noise, estimator) stored twice keeps
its last row, as ``navbench score`` does; ``--tasks N`` keeps task ids below N (the first N of
each task set). Then one row per level with every estimator's SPL per noise, and with
``--difficulty`` (the JSON of ``navbench level-difficulty --json`` covering both sets) the
Spearman correlation over all levels between each estimator's SPL and each difficulty measure.
"""

from __future__ import annotations

import argparse
import json
import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

KEY = ["level", "task_id", "seed", "noise", "estimator"]

NOISES = ["low", "mid", "high"]
MEASURES = {"geodesic_ratio": "geo/eucl", "narrowest_passage_median": "door med (m)",
            "narrowest_passage_min": "door min (m)", "free_clearance": "clearance (m)",
            "length": "length (m)", "planner_free": "planner free"}


def runs_frame(con, runs: list[int]) -> pd.DataFrame:
    """The episodes of ``runs``, a (level, task, seed, noise, estimator) stored twice keeping its
    last row (the rule of the paired_runs script that ``navbench compare`` replaced)."""
    q = (f"SELECT id AS row_id, run_id, level, task_id, seed, noise, estimator, spl_term, success "
         f"FROM episodes WHERE run_id IN ({','.join('?' * len(runs))}) ORDER BY id")
    return pd.read_sql(q, con, params=runs).drop_duplicates(KEY, keep="last").set_index(KEY)


def episodes(db: str, runs: list[int], tasks: int | None) -> pd.DataFrame:
    if not Path(db).is_file():
        raise SystemExit(f"error: {db}: no such database file")
    df = runs_frame(sqlite3.connect(f"file:{db}?mode=ro", uri=True), runs).reset_index()
    if tasks is not None:
        df = df[df.task_id < tasks]
    return df


def stratified_means(df: pd.DataFrame, rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` bootstrap means of ``spl_term``, tasks resampled within each level."""
    groups = [g.spl_term.to_numpy() for _, g in df.groupby("level")]
    total = sum(len(g) for g in groups)
    out = np.zeros(n)
    for g in groups:
        idx = rng.integers(0, len(g), size=(n, len(g)))
        out += g[idx].sum(axis=1)
    return out / total


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--a-db", default="results/navbench.db")
    ap.add_argument("--a-runs", required=True, help="run ids of set A, comma-separated")
    ap.add_argument("--b-db", default="results/navbench.db")
    ap.add_argument("--b-runs", required=True, help="run ids of set B, comma-separated")
    ap.add_argument("--tasks", type=int, default=None, help="keep task ids below this")
    ap.add_argument("--difficulty", default=None, help="level-difficulty --json output")
    args = ap.parse_args()
    a = episodes(args.a_db, [int(r) for r in args.a_runs.split(",")], args.tasks)
    b = episodes(args.b_db, [int(r) for r in args.b_runs.split(",")], args.tasks)
    if a.empty or b.empty:
        ap.error("no episodes in set " + ("A" if a.empty else "B"))
    rng = np.random.default_rng(0)
    print(f"A: {sorted(a.level.unique())}\nB: {sorted(b.level.unique())}")
    print("| estimator | noise | episodes A / B | SPL A | SPL B | B − A SPL [95 %] | success A | success B |")
    print("|---|---|---|---|---|---|---|---|")
    ests = [e for e in ("ours", "no-map", "dynamics", "gt") if e in set(a.estimator) & set(b.estimator)]
    for est in ests:
        for noise in NOISES:
            sa = a[(a.estimator == est) & (a.noise == noise)]
            sb = b[(b.estimator == est) & (b.noise == noise)]
            if sa.empty or sb.empty:
                continue
            d = stratified_means(sb, rng, 4000) - stratified_means(sa, rng, 4000)
            lo, hi = np.percentile(d, [2.5, 97.5])
            print(f"| {est} | {noise} | {len(sa)} / {len(sb)} | {sa.spl_term.mean():.3f} | "
                  f"{sb.spl_term.mean():.3f} | {sb.spl_term.mean() - sa.spl_term.mean():+.3f} "
                  f"[{lo:+.3f}, {hi:+.3f}] | {sa.success.mean():.3f} | {sb.success.mean():.3f} |")
    both = pd.concat([a, b])
    per = both.pivot_table(index="level", columns=["estimator", "noise"], values="spl_term", aggfunc="mean")
    cols = [(e, n) for e in ests for n in NOISES if (e, n) in per.columns]
    print("\n| level | " + " | ".join(f"{e} {n}" for e, n in cols) + " |")
    print("|---|" + "---|" * len(cols))
    for lv, row in per.iterrows():
        print(f"| {lv} | " + " | ".join(f"{row[c]:.3f}" for c in cols) + " |")
    if args.difficulty is None:
        return
    with open(args.difficulty) as f:
        diff = json.load(f)
    rows = diff if isinstance(diff, list) else diff.get("levels", diff)
    dd = pd.DataFrame(rows).set_index("level")
    levels = [lv for lv in per.index if lv in dd.index]
    print(f"\nSpearman rho over {len(levels)} levels (p in brackets):")
    print("| SPL of | " + " | ".join(MEASURES[m] for m in MEASURES if m in dd.columns) + " |")
    print("|---|" + "---|" * sum(m in dd.columns for m in MEASURES))
    for c in cols:
        cells = []
        for m in MEASURES:
            if m not in dd.columns:
                continue
            r = stats.spearmanr(per.loc[levels, c], dd.loc[levels, m])
            cells.append(f"{r.statistic:+.2f} ({r.pvalue:.3f})")
        print(f"| {c[0]} {c[1]} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
