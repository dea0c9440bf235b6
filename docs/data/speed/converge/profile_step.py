"""cProfile of ours / no-map episodes (one numba thread): top functions by internal time."""
import cProfile, pstats, sys, json
import numpy as np
from navbench.levelio import resolve_level
from navbench.worldmodel.base import load_world_model
from navbench.bench.timers import bench_tasks
from navbench.geometry import CAMERAS
from navbench.nav.episode import run_episode
from navbench.sim.world import Simulator
from navbench.track.registry import make_estimator, uses_frames
name, mappath, cam, ntasks, opts = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), json.loads(sys.argv[5])
level = resolve_level("tune-house")
vmap = load_world_model(mappath)
occ, xs, ys = vmap.occupancy_slice("band")
tasks = bench_tasks(level, vmap, ntasks + 1, 1)
intr = CAMERAS[cam]
def run(ts):
    steps = 0
    for i, t in enumerate(ts):
        sim = Simulator(level, noise="mid", seed=i, intrinsics=intr)
        est = make_estimator(name, vmap=vmap, intrinsics=intr, seed=i, **opts)
        rec = run_episode(level, occ, xs, ys, t, est, sim)
        steps += rec.steps
    return steps
run(tasks[-1:])
pr = cProfile.Profile(); pr.enable(); steps = run(tasks[:-1]); pr.disable()
print("steps", steps)
st = pstats.Stats(pr); st.sort_stats("tottime").print_stats(22)
