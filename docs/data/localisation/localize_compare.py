"""Localiser query time and answers of two checkouts of navbench, run alternately (issue 14's 20 ms).

    git worktree add /tmp/navbench-before <rev>
    NUMBA_NUM_THREADS=1 python docs/data/localisation/localize_compare.py /tmp/navbench-before . \\
        --levels house-1,house-2,house-3,house-4,house-5,house-6 --queries 200

For each level, each checkout localises the same uniform queries (seed 0) on the level's fitted
map of ``--profile`` (default ``examples/paper-half.toml``) in its own process, A then B; prints
both medians and p90s of the wall time per query and whether the hypotheses (pose, score,
confidence of each) are identical. Writes nothing but the caches it needs (shared: run it in a
project whose maps and banks are cached, as the README's loop leaves them).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
from scripts._env import pythonpath_first  # noqa: E402

CHILD = r"""
import json, os, sys, time
root, level, n, profile = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
# the project's folder (cwd, first on sys.path for -c) must not shadow the checkout under test
sys.path = [p for p in sys.path if p not in ("", os.getcwd())]
import numpy as np
import navbench
assert navbench.__file__.startswith(root), (navbench.__file__, root)
from navbench.cli.commands.localize_eval import _localizer_config
from navbench.geometry import CAMERA_HEIGHT, camera_by_name
from navbench.pipeline.profiles import load_profile
from navbench.pipeline.run import stage_context
from navbench.pipeline.stages import study_level, study_map
from navbench.pipeline.stages.level import load_level_ref
from navbench.pipeline.stages.localize import draw_queries, load_localizer
ctx = stage_context()
level_ref = study_level(ctx, level, load_profile(profile))
vmap = study_map(ctx, "fit", level_ref, load_profile(profile))
intr = camera_by_name("half")
loc, _ = load_localizer(ctx, vmap, intr, CAMERA_HEIGHT, _localizer_config([]), level=level_ref)
qs = list(draw_queries(load_level_ref(level_ref), n, 0, 0.1, intr, sampling="uniform"))
for q in qs[:3]:
    loc.localize(q[1])  # compile and warm up
res, walls = [], []
for q in qs:
    t = time.perf_counter()
    hyps = loc.localize(q[1])
    walls.append(time.perf_counter() - t)
    res.append([[float(v) for v in h.pose] + [float(h.score), float(h.confidence)] for h in hyps])
print(json.dumps({"res": res, "walls": walls}))
"""


def run(root: Path, level: str, queries: int, profile: str) -> dict:
    env = {**os.environ, "PYTHONPATH": pythonpath_first(root)}
    p = subprocess.run([sys.executable, "-c", CHILD, str(root), level, str(queries), profile],
                       env=env, capture_output=True, text=True)
    if p.returncode:
        raise SystemExit(f"{root} on {level} failed:\n{p.stderr[-2000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def main() -> None:
    import numpy as np

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a", type=Path, help="checkout A (e.g. the code before a change)")
    ap.add_argument("b", type=Path, help="checkout B")
    ap.add_argument("--levels", default="house-1")
    ap.add_argument("--queries", type=int, default=200)
    ap.add_argument("--profile", default="examples/paper-half.toml")
    args = ap.parse_args()
    profile = str(Path(args.profile).resolve())
    for level in [s for s in args.levels.split(",") if s]:
        out = {k: run(root.resolve(), level, args.queries, profile) for k, root in (("A", args.a), ("B", args.b))}
        ms = {k: (1e3 * np.median(v["walls"]), 1e3 * np.percentile(v["walls"], 90)) for k, v in out.items()}
        print(f"{level}: A {ms['A'][0]:.1f} / {ms['A'][1]:.1f} ms, B {ms['B'][0]:.1f} / {ms['B'][1]:.1f} ms "
              f"(median / p90), hypotheses identical: {out['A']['res'] == out['B']['res']}")


if __name__ == "__main__":
    main()
