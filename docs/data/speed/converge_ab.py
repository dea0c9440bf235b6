"""Tracking that stops when it has converged (issue 36): diagnostics and an in-process A/B.

    python docs/data/speed/converge_ab.py diag LEVEL MAP --tasks 10 --noise mid,high --camera half
    python docs/data/speed/converge_ab.py speed LEVEL MAP --tasks 3 --repeats 5 --camera paper \
        --variants '{"off": {}, "on": {"gn_geo_tol": [1e-4, 1e-4]}}' [--estimators ours,no-map] \
        [--base '{"ours": {"reference_scale": 0.5}}']

``MAP``: a world-model file, or ``voxel`` (the level's true geometry voxelised). Tasks are
sampled with seed 123 (not a pipeline task set); every (task, noise) episode runs with the
simulator seed ``1000 + task id`` for every variant, so the variants see the same noise.

``diag``: runs ``ours`` and ``no-map`` with their default options (the heading search scored
through a gate of 1e-12, which searches whenever the prediction can be scored: the same
estimates as no gate) and prints, per estimator, the distribution of the Gauss-Newton
iterations, and of the prediction's score (``yaw_score``) against the prediction's true
heading error and the offset the heading search chose: what a gate on the score would skip.

``speed``: one process (one numba thread, as a pool worker), the variants interleaved in
alternating order over ``--repeats`` passes of the same episodes; prints per estimator and
variant the median over passes of the agent's step (render + estimate + plan + control per
step, ms), the process CPU per step (the simulator's step included) and the variant/first
ratios of both, whether the trajectories equal the first variant's, and the load.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time

import numpy as np


def _setup(level_name: str, map_path: str):
    from navbench.levelio import resolve_level
    from navbench.worldmodel.base import load_world_model

    level = resolve_level(level_name)
    if map_path == "voxel":
        from navbench.worldmodel.grid import grid_for_level, voxelize_level

        vmap = voxelize_level(level, grid_for_level(level))
    else:
        vmap = load_world_model(map_path)
    return level, vmap


def _episode(level, vmap, occ, task, name, opts, noise, intr, hook=None):
    from navbench.nav.episode import run_episode
    from navbench.sim.world import Simulator
    from navbench.track.registry import make_estimator, uses_frames

    seed = 1000 + task.id
    sim = Simulator(level, noise=noise, seed=seed, intrinsics=intr if uses_frames(name) else None)
    est = make_estimator(name, vmap=vmap, intrinsics=intr, seed=seed, **opts)
    if hook is not None:
        hook(est)
    occ2d, xs, ys = occ
    return run_episode(level, occ2d, xs, ys, task, est, sim)


def diag(args) -> int:
    from navbench.geometry import CAMERAS, wrap_angle
    from navbench.plan.tasks import sample_tasks
    from navbench.track.odometry import predict_pose

    level, vmap = _setup(args.level, args.map)
    occ = vmap.occupancy_slice("band")
    tasks = sample_tasks(level, args.tasks, 123)
    intr = CAMERAS[args.camera]
    for name in args.estimators.split(","):
        rows = []  # (gn_iters, yaw_score, |pred heading error| deg, |offset| deg)
        steps = []  # per update: the Gauss-Newton steps (largest translation m, rotation rad)

        def hook(est, rows=rows):
            update = est.update

            def wrapped(control, frame, true_pose=None):
                pred = predict_pose(est.pose, control)
                out = update(control, frame, true_pose=true_pose)
                i = est.last_info
                err = abs(math.degrees(wrap_angle(float(pred[2]) - float(true_pose[2]))))
                rows.append((i.get("gn_iters", -1), i.get("yaw_score", math.nan), err,
                             abs(i.get("yaw_offset_deg", 0.0))))
                steps.append(i.get("gn_steps", []))
                return out

            est.update = wrapped

        for noise in args.noise.split(","):
            for t in tasks:
                _episode(level, vmap, occ, t, name, {"yaw_search_gate": 1e-12}, noise, intr, hook)
        r = np.array(rows, float)
        it, score, err, off = r.T
        print(f"== {name}: {len(r)} steps; GN iterations: mean {it.mean():.2f}, "
              f"counts {dict(zip(*np.unique(it, return_counts=True)))}")
        print(f"   prediction heading error: median {np.median(err):.2f} deg, p90 {np.percentile(err, 90):.2f}, "
              f"max {err.max():.2f}; search offset != 0: {np.mean(off > 1e-9):.3f}, >= 4 deg: {np.mean(off >= 4 - 1e-9):.3f}")
        ok = np.isfinite(score)
        print(f"   score: unscored {np.mean(~ok):.3f}; quantiles 10/25/50/75/90: "
              + " ".join(f"{np.percentile(score[ok], q):.4f}" for q in (10, 25, 50, 75, 90)))
        full = np.array([st for st in steps if len(st) == 10])  # (n, 10, 2)
        for k in range(full.shape[1]):
            print(f"   GN iteration {k + 1}: step median {np.median(full[:, k, 0]) * 1e3:.4f} mm "
                  f"{math.degrees(np.median(full[:, k, 1])):.5f} deg, p90 {np.percentile(full[:, k, 0], 90) * 1e3:.4f} mm "
                  f"{math.degrees(np.percentile(full[:, k, 1], 90)):.5f} deg")
        for tol in args.tols:
            for lo, hi, what in ((0, 5, "point-to-plane"), (5, 10, "full")):
                ph = full[:, lo:hi]
                below = (ph[..., 0] < tol) & (ph[..., 1] < tol)
                first = np.where(below.any(axis=1), below.argmax(axis=1), hi - lo - 1)
                saved = (hi - lo - 1 - first).mean()
                rest = np.array([ph[n, first[n] + 1:].sum(axis=0) for n in range(len(ph))])
                print(f"   tol {tol:g} ({what} phase): saves {saved:.2f} of {hi - lo} iterations; "
                      f"the skipped steps sum to (p50/p99/max) {np.median(rest[:, 0]) * 1e3:.3f}/"
                      f"{np.percentile(rest[:, 0], 99) * 1e3:.3f}/{rest[:, 0].max() * 1e3:.3f} mm, "
                      f"{math.degrees(np.median(rest[:, 1])):.4f}/{math.degrees(np.percentile(rest[:, 1], 99)):.4f}/"
                      f"{math.degrees(rest[:, 1].max()):.4f} deg")
        for gate in args.gates:
            skip = ok & (score <= gate)
            print(f"   gate {gate:.3f}: skips {skip.mean():.3f} of the searches; among skipped: "
                  f"pred error > 4 deg {np.sum(skip & (err > 4))}, > 2 deg {np.sum(skip & (err > 2))}, "
                  f"search moved >= 4 deg {np.sum(skip & (off >= 4 - 1e-9))}, >= 2 deg {np.sum(skip & (off >= 2 - 1e-9))}; "
                  f"not skipped with error > 4 deg: {np.sum(~skip & (err > 4))}")
    print("load", os.getloadavg())
    return 0


def speed(args) -> int:
    import hashlib

    from navbench.geometry import CAMERAS
    from navbench.plan.tasks import sample_tasks

    level, vmap = _setup(args.level, args.map)
    occ = vmap.occupancy_slice("band")
    tasks = sample_tasks(level, args.tasks + 1, 123)
    intr = CAMERAS[args.camera]
    variants = json.loads(args.variants)
    base = json.loads(args.base) if args.base else {}
    names = args.estimators.split(",")
    noises = args.noise.split(",")

    def one(name, opts, ts):
        agent = steps = 0.0
        h = hashlib.sha256()
        c0 = time.process_time()
        for noise in noises:
            for t in ts:
                rec = _episode(level, vmap, occ, t, name, opts, noise, intr)
                tm = rec.timings_ms
                agent += sum(float(np.sum(tm[k])) for k in tm if k != "sim")
                steps += rec.steps
                for a in (rec.true_poses, rec.est_poses, rec.controls):
                    h.update(np.ascontiguousarray(a).tobytes())
        return agent / steps, (time.process_time() - c0) * 1e3 / steps, h.hexdigest(), int(steps)

    for name in names:  # warm-up: compile and load every kernel
        for v in variants.values():
            one(name, {**base.get(name, {}), **v}, tasks[-1:])
    res = {(n, v): [] for n in names for v in variants}
    for r in range(args.repeats):
        order = list(variants) if r % 2 == 0 else list(variants)[::-1]
        for name in names:
            for v in order:
                res[(name, v)].append(one(name, {**base.get(name, {}), **variants[v]}, tasks[:-1]))
        print(f"pass {r + 1}/{args.repeats} done, load {os.getloadavg()[0]:.2f}", file=sys.stderr, flush=True)
    first = list(variants)[0]
    for name in names:
        a0 = statistics.median(x[0] for x in res[(name, first)])
        c0 = statistics.median(x[1] for x in res[(name, first)])
        for v in variants:
            xs = res[(name, v)]
            a = statistics.median(x[0] for x in xs)
            c = statistics.median(x[1] for x in xs)
            same = xs[0][2] == res[(name, first)][0][2]
            print(f"{name:7s} {v:10s} agent step {a:6.2f} ms ({a / a0:.3f})  CPU/step incl. sim "
                  f"{c:6.2f} ms ({c / c0:.3f})  steps {xs[0][3]}  same trajectories as {first}: {same}")
    print("load", os.getloadavg())
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("diag", "speed"))
    ap.add_argument("level")
    ap.add_argument("map")
    ap.add_argument("--tasks", type=int, default=10)
    ap.add_argument("--noise", default="mid,high")
    ap.add_argument("--camera", default="half")
    ap.add_argument("--estimators", default="ours,no-map")
    ap.add_argument("--gates", type=float, nargs="*", default=[0.02, 0.05, 0.1, 0.15, 0.2, 0.3])
    ap.add_argument("--tols", type=float, nargs="*", default=[1e-5, 3e-5, 1e-4, 3e-4, 1e-3])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--variants", default='{"off": {}}')
    ap.add_argument("--base", default="")
    args = ap.parse_args()
    return diag(args) if args.mode == "diag" else speed(args)


if __name__ == "__main__":
    sys.exit(main())
