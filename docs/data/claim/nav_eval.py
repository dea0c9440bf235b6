"""Quick navigation numbers (issue #4 section 4): success and SPL per (estimator, noise).

    .venv/bin/python docs/data/claim/nav_eval.py house-1 --estimators gt,dynamics --noise low,mid,high --tasks 200

The map the agent plans on is the TRUE occupancy raster (0.057 m cells, every solid) with
``--map true`` (the default), the occupancy band of the true geometry voxelised on the world
model's grid (``--map voxel``, :func:`navbench.worldmodel.grid.voxelize_level`), or the
occupancy band of a fitted world-model map file (``--map FILE``, see
:func:`navbench.worldmodel.grid.occupancy_slice`). The simulator runs without
a camera (``intrinsics=None``) unless an estimator needs images (``--camera half|paper``).
Episode ``k`` of a task set uses the simulator seed ``--seed * 100003 + task.id``, the same for
every estimator. Writes nothing; prints a table.
"""

from __future__ import annotations

import argparse
import time
from collections import Counter

import numpy as np

from navbench.level import occupancy_raster
from navbench.levelio import resolve_level
from navbench.nav.episode import EpisodeConfig, run_episode
from navbench.nav.metrics import score_episode, spl
from navbench.plan.astar import make_planner_map
from navbench.plan.tasks import find_task_file, load_tasks, sample_tasks
from navbench.sim.world import Simulator
from navbench.track.registry import make_estimator

TRUE_MAP_CELL = 0.057  # m, the 200-cell grid's cell on an 11.4 m level


def planning_map(level, spec: str):
    """``(occ2d, xs, ys, description)`` for ``--map true`` or a map file."""
    if spec == "true":
        occ, xs, ys = occupancy_raster(level, TRUE_MAP_CELL, z_low=0.05)
        return occ, xs, ys, f"TRUE occupancy raster ({TRUE_MAP_CELL} m cells)"
    from navbench.worldmodel.grid import load_map, occupancy_slice, voxelize_level

    if spec == "voxel":
        occ, xs, ys = occupancy_slice(voxelize_level(level), mode="band")
        return occ, xs, ys, "TRUE geometry voxelised on the 200 x 200 x 20 grid (occupancy band)"
    vmap = load_map(spec)
    occ, xs, ys = occupancy_slice(vmap, mode="band")
    return occ, xs, ys, f"world-model map {spec} (occupancy band)"


def run_suite(level, occ, xs, ys, tasks, estimator: str, noise: str, seed: int = 0,
              config: EpisodeConfig = EpisodeConfig(), intrinsics=None, vmap=None):
    """Episode records of every task for one (estimator, noise) pair."""
    pm = make_planner_map(occ, xs, ys, config.planner)
    records = []
    for t in tasks:
        sim = Simulator(level, noise=noise, seed=seed * 100003 + t.id, intrinsics=intrinsics)
        est = make_estimator(estimator, vmap=vmap, intrinsics=intrinsics, seed=seed)
        records.append(run_episode(level, occ, xs, ys, t, est, sim, config, planner_map=pm))
    return records


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("level")
    ap.add_argument("--estimators", default="gt,dynamics")
    ap.add_argument("--noise", default="low,mid,high")
    ap.add_argument("--tasks", type=int, default=200, help="use the first N tasks of the task file")
    ap.add_argument("--map", default="true", help="'true', 'voxel' or a map file")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--task-file", default=None, help="default: the committed tasks/<level>-200-*.json")
    args = ap.parse_args(argv)

    level = resolve_level(args.level)
    try:
        tasks = load_tasks(args.task_file or find_task_file(level.name, 200))
        source = "task file"
    except Exception:  # no committed task file yet: sample the same way
        tasks = sample_tasks(level, 200, 0)
        source = "sampled (seed 0)"
    tasks = tasks[: args.tasks]
    occ, xs, ys, desc = planning_map(level, args.map)
    print(f"level {level.name}: {len(tasks)} tasks ({source}); planning map: {desc}")
    print(f"{'estimator':<10} {'noise':<6} {'success':>8} {'SPL':>6} {'steps':>6} {'collided':>8} "
          f"{'plan ms':>8} {'s/ep':>6}  end reasons")
    for est in [e.strip() for e in args.estimators.split(",") if e.strip()]:
        for noise in [n.strip() for n in args.noise.split(",") if n.strip()]:
            t0 = time.perf_counter()
            recs = run_suite(level, occ, xs, ys, tasks, est, noise, args.seed)
            dt = (time.perf_counter() - t0) / max(1, len(recs))
            scores = [score_episode(r) for r in recs]
            succ = np.mean([s.success for s in scores])
            steps = np.mean([s.steps for s in scores])
            coll = np.mean([s.collided for s in scores])
            plan_ms = np.median([r.plan_ms for r in recs])
            reasons = dict(Counter(s.end_reason for s in scores))
            print(f"{est:<10} {noise:<6} {succ:8.3f} {spl(scores):6.3f} {steps:6.1f} {coll:8.3f} "
                  f"{plan_ms:8.2f} {dt:6.2f}  {reasons}", flush=True)


if __name__ == "__main__":
    main()
