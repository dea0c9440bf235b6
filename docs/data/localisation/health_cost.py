"""What the tracking-health test costs ``ours`` in normal tracking (issue 14, section 3).

    .venv/bin/python docs/data/localisation/health_cost.py house-1 --map MAP.npz --trajectories 2 --steps 200

Replays the same recorded trajectories (``--noise``, body-frame odometry, no kidnapping) through
plain ``ours`` and ``ours`` with ``health=true``, step by step in alternation (so that machine
load hits both alike), and prints each one's median per-step time (render + estimate), the
ratio, the largest difference of their estimates (the test only reads: 0), the alarms raised
(there is no kidnapping) and the quantiles of the inlier fraction in this normal tracking: the
data the alarm threshold ``health_min_inliers`` was calibrated on (house-1, ``--seed 99``, a
seed no reported figure uses). Writes nothing.
"""

from __future__ import annotations

import argparse

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("level")
    ap.add_argument("--map", required=True, help="a map file (map.npz format)")
    ap.add_argument("--trajectories", type=int, default=2)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--noise", default="mid")
    ap.add_argument("--camera", default="half")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.levelio import resolve_level
    from navbench.sim.camera import RaycastCamera
    from navbench.track.kidnap import body_control
    from navbench.track.registry import make_estimator
    from navbench.track.study import record_trajectories
    from navbench.worldmodel.base import load_world_model

    level = resolve_level(args.level)
    vmap = load_world_model(args.map)
    intr = camera_by_name(args.camera)
    cam = RaycastCamera(level, intr, CAMERA_HEIGHT)
    ests = {"plain": make_estimator("ours", vmap=vmap, intrinsics=intr),
            "health": make_estimator("ours", vmap=vmap, intrinsics=intr, health=True)}
    ms = {k: [] for k in ests}
    diff, alarms, steps, inliers = 0.0, 0, 0, []
    for tr in record_trajectories(level, args.trajectories, args.steps, args.noise, args.seed):
        frame0 = cam.render(tr.start)
        for e in ests.values():
            e.reset(tr.start, frame0)
        for t in range(len(tr.controls)):
            frame = cam.render(tr.true_poses[t + 1])
            out = {}
            for k, e in ests.items():
                u = body_control(tr.controls[t], tr.true_poses[t, 2], e.pose[2])
                out[k] = e.update(u, frame)
                ms[k].append(e.last_timing["render"] + e.last_timing["estimate"])
            diff = max(diff, float(np.abs(out["plain"] - out["health"]).max()))
            alarms += int(ests["health"].last_health["alarm"])
            inliers.append(ests["health"].last_health["inliers"])
            steps += 1
    a, b = np.median(ms["plain"]), np.median(ms["health"])
    print(f"{args.level}: {args.trajectories} x {args.steps} steps, noise {args.noise}, camera {args.camera}")
    print(f"step median: plain {a:.2f} ms, health {b:.2f} ms, ratio {b / a:.3f}")
    print(f"largest estimate difference {diff:.3g}; alarms {alarms} in {steps} steps")
    q = np.nanpercentile(inliers, [0, 0.5, 1, 5, 50])
    print("inlier fraction quantiles 0 / 0.5 / 1 / 5 / 50 %: " + " / ".join(f"{v:.3f}" for v in q))


if __name__ == "__main__":
    main()
