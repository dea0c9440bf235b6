"""Unknown-house image-goal navigation on the TRUE sensing model (issue 15 section 3, a stepping
stone): SR / SPL under the ``nrns`` preset for the first tasks of a level's committed task set.

    .venv/bin/python docs/data/image-goals/imagenav_unknown.py house-1 --tasks 5 --difficulty any

The goal image of task ``k`` is the TRUE camera's RGB-D frame at the task's target with a heading
drawn from ``numpy.random.default_rng(seed * 100003 + k)``. ``--difficulty`` keeps the tasks whose
exact geodesic length (the task's ``optimal_length``) is in NRNS's band (easy 1.5-3 m, medium
3-5 m, hard 5-10 m). ``--ablation``: ``full`` (exploration and goal scores), ``no-goal``
(exploration without goal scoring), ``no-explore`` (goal scoring without exploration),
``gt-stopper`` (the full model stopped by an oracle once within 1 m of the goal), ``voronoi``
(the full model exploring places on a Voronoi graph of the seen free space). Writes
nothing; prints one line per episode and the totals. See :mod:`navbench.nav.imagenav`.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from navbench.geometry import HALF_CAMERA
from navbench.levelio import resolve_level
from navbench.nav.imagenav import run_unknown_image_episode, score_image_episode
from navbench.pipeline.stages.online import ABLATIONS, loop_config
from navbench.plan.tasks import find_task_file, load_tasks
from navbench.sim.camera import RaycastCamera
from navbench.worldmodel.grid import voxelize_level

BANDS = {"easy": (1.5, 3.0), "medium": (3.0, 5.0), "hard": (5.0, 10.0), "any": (0.0, math.inf)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("level")
    ap.add_argument("--tasks", type=int, default=5)
    ap.add_argument("--difficulty", choices=sorted(BANDS), default="any")
    ap.add_argument("--ablation", choices=ABLATIONS, default="full")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-steps", type=int, default=500)
    ap.add_argument("--log", action="store_true", help="print every goal match of every episode")
    ap.add_argument("--ids", default="", help="comma-separated task ids to run instead (diagnosis)")
    args = ap.parse_args()
    level = resolve_level(args.level)
    lo, hi = BANDS[args.difficulty]
    tasks = [t for t in load_tasks(find_task_file(level.name, 200)) if lo <= t.optimal_length < hi][: args.tasks]
    if args.ids:
        ids = {int(v) for v in args.ids.split(",")}
        tasks = [t for t in load_tasks(find_task_file(level.name, 200)) if t.id in ids]
    cfg = loop_config({"max_steps": args.max_steps}, args.ablation)  # the pipeline's loop settings
    full = voxelize_level(level)
    cam = RaycastCamera(level, HALF_CAMERA)
    succ, spls = [], []
    t0 = time.process_time()
    for t in tasks:
        rng = np.random.default_rng(args.seed * 100003 + t.id)
        goal = cam.render(np.array([t.target[0], t.target[1], rng.uniform(-math.pi, math.pi)]))
        oracle = np.asarray(t.target) if args.ablation == "gt-stopper" else None
        ep = run_unknown_image_episode(level, np.asarray(t.start), goal, cfg, HALF_CAMERA, full, oracle)
        ok, spl, final = score_image_episode(ep, t.target, t.optimal_length, cfg.success_radius)
        if args.log:
            print("   ", ep.match_log)
        succ.append(ok)
        spls.append(spl)
        print(f"task {t.id:3d}  l={t.optimal_length:5.2f} m  {ep.end_reason:10s} steps={len(ep.true_poses) - 1:3d} "
              f"matches={ep.matches:2d} seen={ep.seen_share:.2f} final={final:5.2f} m  success={int(ok)} spl={spl:.3f}",
              flush=True)
    n = max(len(tasks), 1)
    print(f"{level.name} {args.difficulty} {args.ablation}: {len(tasks)} episodes  SR {np.sum(succ) / n:.3f}  "
          f"SPL {np.sum(spls) / n:.3f}  (nrns preset; CPU {time.process_time() - t0:.0f} s)")


if __name__ == "__main__":
    main()
