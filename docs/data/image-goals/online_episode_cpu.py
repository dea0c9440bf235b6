"""CPU of unknown-house episodes as the at-size run plays them (fused mapping, ``ours`` tracking).

    NUMBA_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python docs/data/image-goals/online_episode_cpu.py house-2 --tasks 0,1,2 --repeats 2

Runs the tasks ``--tasks`` (ids of the level's committed 200-task file) through
:func:`navbench.pipeline.stages.online.run_online_episode` with the loop's pipeline settings, mid
noise, simulator seed = task id, goal seed 0 (not the pipeline's seeds: a fixed workload for
comparing code versions, not a result), ``--repeats`` times; prints each episode's steps, end
reason and final true pose (to compare code versions for identical behaviour) and the process
CPU of each repeat and their median. ``--profile FILE`` writes a cProfile of one pass instead.
Run it with ``NUMBA_NUM_THREADS=1`` (what a pool worker runs) at two revisions to compare them
(for example from a ``git worktree`` of the older one); under load compare ratios only.
"""

from __future__ import annotations

import argparse
import sys
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("level")
    ap.add_argument("--tasks", default="0,1,2", help="comma-separated task ids")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--profile", default=None, help="write a cProfile of one pass here")
    args = ap.parse_args()
    try:
        ids = [int(v) for v in args.tasks.split(",")]
    except ValueError:
        ap.error(f"--tasks: comma-separated integers, got {args.tasks!r}")
    if args.repeats < 1:
        ap.error("--repeats must be >= 1")

    import numpy as np

    from navbench.errors import NavbenchError
    from navbench.geometry import CAMERA_HEIGHT, HALF_CAMERA
    from navbench.levelio import resolve_level
    from navbench.pipeline.stages.online import loop_config, online_config, run_online_episode
    from navbench.plan.tasks import find_task_file, load_tasks
    from navbench.sim.world import Simulator
    from navbench.worldmodel.grid import voxelize_level

    try:
        level = resolve_level(args.level)
        tasks = {t.id: t for t in load_tasks(find_task_file(level.name, 200))}
    except NavbenchError as e:
        sys.exit(f"error: {e}")
    missing = [i for i in ids if i not in tasks]
    if missing:
        sys.exit(f"error: {level.name}'s task file has no task {missing[0]} (ids 0..{len(tasks) - 1})")
    full = voxelize_level(level)
    cfg, loop = online_config("online-fused"), loop_config({})

    def one_pass():
        out = []
        for i in ids:
            sim = Simulator(level, noise="mid", seed=i, intrinsics=HALF_CAMERA, camera_height=CAMERA_HEIGHT)
            r = run_online_episode(level, full, tasks[i], sim, HALF_CAMERA, cfg, loop, 0, "mid", 0, "ours", 0, {})
            out.append((i, len(r.true_poses) - 1, r.end_reason, np.round(r.true_poses[-1], 4).tolist()))
        return out

    if args.profile:
        import cProfile

        cProfile.runctx("one_pass()", globals(), {"one_pass": one_pass}, args.profile)
        print(f"profile written to {args.profile}")
        return
    one_pass()  # compile and warm up outside the timing
    cpu = []
    for _ in range(args.repeats):
        c0 = time.process_time()
        eps = one_pass()
        cpu.append(time.process_time() - c0)
    for i, steps, end, pose in eps:
        print(f"task {i:3d}  steps {steps:3d}  {end:12s} final true pose {pose}")
    print(f"CPU per pass: {', '.join(f'{c:.2f}' for c in cpu)} s; median {float(np.median(cpu)):.2f} s")


if __name__ == "__main__":
    main()
