"""Accuracy and cost of ``ours`` options at the paper camera (issue 17, part 2).

    python docs/data/speed/tracker_options_ab.py LEVEL MAP TASKS NOISES VARIANTS
    NUMBA_NUM_THREADS=1 python docs/data/speed/tracker_options_ab.py house-1 results/cache/fit-map/<key>/map.npz \
        6 mid,high '{"base": {}, "ref0.5": {"reference_scale": 0.5}}'

``MAP``: a world-model file, or ``voxel`` (the level's true geometry voxelised). ``TASKS`` tasks
are sampled with seed 123 (not a pipeline task set); every (task, noise) episode runs with the
simulator seed ``1000 + task id`` for every variant, so the variants see the same noise. Prints,
per variant (a JSON object: name -> ours' keyword options): success rate, mean SPL term,
location RMSE (median and mean over episodes), heading RMSE median, steps, and the process CPU
time per step (simulator included; the first variant also pays loading the compiled kernels)
and the recorded render + estimate wall time per step. Writes nothing.
"""

import json
import os
import sys
import time

import numpy as np


def main() -> int:
    if len(sys.argv) != 6:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    from navbench.geometry import CAMERAS
    from navbench.levelio import resolve_level
    from navbench.nav.episode import run_episode
    from navbench.nav.metrics import score_episode
    from navbench.plan.tasks import sample_tasks
    from navbench.sim.world import Simulator
    from navbench.track.registry import make_estimator
    from navbench.worldmodel.base import load_world_model

    level_name, map_path, ntasks, noises = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4].split(",")
    variants = json.loads(sys.argv[5])
    level = resolve_level(level_name)
    if map_path == "voxel":
        from navbench.worldmodel.grid import grid_for_level, voxelize_level

        vmap = voxelize_level(level, grid_for_level(level))
    else:
        vmap = load_world_model(map_path)
    occ, xs, ys = vmap.occupancy_slice("band")
    tasks = sample_tasks(level, ntasks, 123)
    intr = CAMERAS["paper"]
    for name, opts in variants.items():
        rows = []
        for noise in noises:
            for t in tasks:
                seed = 1000 + t.id
                sim = Simulator(level, noise=noise, seed=seed, intrinsics=intr)
                est = make_estimator("ours", vmap=vmap, intrinsics=intr, seed=seed, **opts)
                c0 = time.process_time()
                rec = run_episode(level, occ, xs, ys, t, est, sim)
                cpu = time.process_time() - c0
                sc = score_episode(rec)
                tm = rec.timings_ms
                rows.append((sc.success, sc.spl_term, sc.loc_rmse_m, sc.rot_rmse_deg, rec.steps, cpu,
                             float(np.sum(tm["render"]) + np.sum(tm["estimate"]))))
        r = np.array(rows, float)
        steps = r[:, 4].sum()
        print(f"{name:10s} n={len(r)} success {r[:, 0].mean():.3f} SPL {r[:, 1].mean():.3f} "
              f"locRMSE median {np.median(r[:, 2]) * 1e3:.1f} mm mean {r[:, 2].mean() * 1e3:.1f} mm "
              f"rot median {np.median(r[:, 3]):.2f} deg  steps {int(steps)}  "
              f"cpu/step {r[:, 5].sum() / steps * 1e3:.2f} ms  render+estimate/step {r[:, 6].sum() / steps:.2f} ms",
              flush=True)
    print("load", os.getloadavg())
    return 0


if __name__ == "__main__":
    sys.exit(main())
