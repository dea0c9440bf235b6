"""A/B of the lazy reference render of `ours` in one process (issue 17): the summed timing
components of 2 house-1 episodes at the paper camera (voxelized true geometry, mid noise),
alternating LAZY_REFERENCE False/True, 3 repeats, medians (milliseconds). Run with one numba
thread as a pool worker: NUMBA_NUM_THREADS=1 python docs/data/speed/lazy_reference_ab.py"""
import numpy as np
from navbench.levelio import resolve_level
from navbench.worldmodel.grid import grid_for_level, voxelize_level
from navbench.bench.timers import bench_tasks
from navbench.geometry import CAMERAS
from navbench.nav.episode import run_episode
from navbench.sim.world import Simulator
from navbench.track.registry import make_estimator
import navbench.track.ours as ours
level = resolve_level("house-1"); vmap = voxelize_level(level, grid_for_level(level))
occ, xs, ys = vmap.occupancy_slice("band"); tasks = bench_tasks(level, vmap, 3, 1)
intr = CAMERAS["paper"]
res = {True: [], False: []}
for rep in range(3):
    for lazy in (False, True):
        ours.LAZY_REFERENCE = lazy
        tot = {}
        for i, t in enumerate(tasks[:2]):
            sim = Simulator(level, noise="mid", seed=i, intrinsics=intr)
            est = make_estimator("ours", vmap=vmap, intrinsics=intr, seed=i)
            rec = run_episode(level, occ, xs, ys, t, est, sim)
            for k, v in rec.timings_ms.items(): tot[k] = tot.get(k, 0) + float(np.sum(v))
        res[lazy].append(tot)
for lazy in (False, True):
    print("lazy", lazy, {k: round(float(np.median([r[k] for r in res[lazy]])), 1) for k in res[lazy][0]})
