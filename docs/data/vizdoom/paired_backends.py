"""Issue 37 §4: vizdoom − pymunk SPL and success per estimator on the same (task, seed), from one
results database holding a `vizdoom-quick` run and a `quick` run (benchmark versions
navbench-1+vizdoom and navbench-1). Mean difference, 95 % bootstrap interval over the pairs.

``python docs/data/vizdoom/paired_backends.py results.db``
"""

from __future__ import annotations

import sqlite3
import sys

import numpy as np


def main(path: str) -> None:
    con = sqlite3.connect(path)
    pairs: dict = {}
    for est, noise, task, seed, version, spl, success in con.execute(
            "select estimator, noise, task_id, seed, benchmark_version, spl_term, success from episodes"):
        pairs.setdefault((est, noise), {}).setdefault((task, seed), {})[version or "navbench-1"] = (spl, success)
    rng = np.random.default_rng(0)
    for (est, noise), by_task in pairs.items():
        d = np.array([[p["navbench-1+vizdoom"][0] - p["navbench-1"][0], p["navbench-1+vizdoom"][1] - p["navbench-1"][1]]
                      for p in by_task.values() if len(p) == 2], float)
        boot = d[rng.integers(0, len(d), (10000, len(d)))].mean(axis=1)
        lo, hi = np.percentile(boot, [2.5, 97.5], axis=0)
        print(f"{est:9} {noise:5} pairs {len(d):3}  SPL {d[:, 0].mean():+.3f} [{lo[0]:+.3f}, {hi[0]:+.3f}]  "
              f"success {d[:, 1].mean():+.3f} [{lo[1]:+.3f}, {hi[1]:+.3f}]")


if __name__ == "__main__":
    main(sys.argv[1])
