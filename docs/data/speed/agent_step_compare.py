"""Compare the per-step cost of two navbench checkouts under pool-worker conditions (issue 17).

    python docs/data/speed/agent_step_compare.py OLD_ROOT NEW_ROOT [--camera paper] [--repeats 3] [--tasks 3]

Each repeat runs, for each checkout in turn (alternating which goes first, so both see the same
machine load; the simulator step, whose code is the same in both, shows the noise floor),
a fresh process with one numba thread (as a pool worker) that runs the same seeded episodes
(house-1 on its voxelized true geometry, mid noise, ``--estimators``) and prints the summed
timing components. Prints the median over repeats of the agent step (render + estimate + plan +
control per step), the simulator step, the episode wall time, the process CPU time per step
(simulator included: the steadiest figure on a busy machine) and the new/old ratios, and
whether both checkouts produced the same trajectories (a hash of poses and controls).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
from scripts._env import pythonpath_first  # noqa: E402

CHILD = r"""
import hashlib, json, sys, time
import numpy as np
from navbench.levelio import resolve_level
from navbench.worldmodel.grid import grid_for_level, voxelize_level
from navbench.bench.timers import bench_tasks
from navbench.geometry import CAMERAS, CAMERA_HEIGHT
from navbench.nav.episode import run_episode
from navbench.sim.world import Simulator
from navbench.track.registry import make_estimator, uses_frames
camera, ntasks, ests = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(",")
level = resolve_level("house-1")
vmap = voxelize_level(level, grid_for_level(level))
occ, xs, ys = vmap.occupancy_slice("band")
tasks = bench_tasks(level, vmap, ntasks + 1, 1)
intr = CAMERAS[camera]
def episodes(ts):
    sums, steps, h = {}, 0, hashlib.sha256()
    t0, c0 = time.perf_counter(), time.process_time()
    for name in ests:
        for i, t in enumerate(ts):
            sim = Simulator(level, noise="mid", seed=i, intrinsics=intr if uses_frames(name) else None,
                            camera_height=CAMERA_HEIGHT)
            est = make_estimator(name, vmap=vmap, intrinsics=intr, camera_height=CAMERA_HEIGHT, seed=i)
            rec = run_episode(level, occ, xs, ys, t, est, sim)
            steps += rec.steps
            for k, v in rec.timings_ms.items():
                sums[k] = sums.get(k, 0.0) + float(np.sum(v))
            for a in (rec.true_poses, rec.est_poses, rec.controls):
                h.update(np.ascontiguousarray(a).tobytes())
    return sums, steps, time.perf_counter() - t0, time.process_time() - c0, h.hexdigest()
episodes(tasks[-1:])  # warm-up (compilation)
sums, steps, wall, cpu, digest = episodes(tasks[:ntasks])
print(json.dumps({"sums_ms": sums, "steps": steps, "wall_s": wall, "cpu_s": cpu, "digest": digest}))
"""


def run(root: str, camera: str, tasks: int, ests: str) -> dict:
    env = {**os.environ, "PYTHONPATH": pythonpath_first(root), "NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
           "NUMBA_CACHE_DIR": os.path.join(root, ".numba_cache")}
    res = subprocess.run([sys.executable, "-c", CHILD, camera, str(tasks), ests], cwd=root, env=env,
                         capture_output=True, text=True)
    if res.returncode != 0:
        last = (res.stderr.strip().splitlines() or ["no output"])[-1]
        raise SystemExit(f"error: the episodes failed in {root}: {last}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--camera", default="paper", choices=("half", "paper"))
    ap.add_argument("--repeats", type=int, default=3, choices=range(1, 101), metavar="1..100")
    ap.add_argument("--tasks", type=int, default=3, choices=range(1, 33), metavar="1..32")
    ap.add_argument("--estimators", default="ours")
    a = ap.parse_args()
    for which in ("old", "new"):
        if not os.path.isfile(os.path.join(getattr(a, which), "navbench", "__init__.py")):
            print(f"error: {which}: {getattr(a, which)} is not a navbench checkout (no navbench/__init__.py)",
                  file=sys.stderr)
            return 2
    got: dict[str, list[dict]] = {"old": [], "new": []}
    for rep in range(a.repeats):  # old first, then new first: a load that drifts cancels out
        for which in (("old", "new") if rep % 2 == 0 else ("new", "old")):
            got[which].append(run(getattr(a, which), a.camera, a.tasks, a.estimators))
    load = os.getloadavg()[0]

    def med(which: str, f) -> float:
        return statistics.median(f(r) for r in got[which])

    def agent(r):
        return sum(v for k, v in r["sums_ms"].items() if k != "sim") / r["steps"]

    rows = {"agent step ms": agent, "sim step ms": lambda r: r["sums_ms"]["sim"] / r["steps"],
            "episodes wall s": lambda r: r["wall_s"],
            # CPU seconds of the process per step (simulator included; its code is the same in
            # both): far less sensitive to other processes than the wall-clock rows
            "cpu ms per step": lambda r: r.get("cpu_s", float("nan")) * 1e3 / r["steps"]}
    print(f"{a.estimators}, {a.camera} camera, {a.tasks} tasks, {a.repeats} repeats, one numba thread, "
          f"load {load:.2f}")
    for label, f in rows.items():
        o, n = med("old", f), med("new", f)
        print(f"{label:<16} old {o:8.2f}  new {n:8.2f}  new/old {n / o:.3f}")
    same = {r["digest"] for r in got["old"]} == {r["digest"] for r in got["new"]}
    print(f"steps old {got['old'][0]['steps']} new {got['new'][0]['steps']}; identical trajectories: {same}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
