"""The camera's texture modes (issue 36, "textures as tables"): frame time and episode step,
procedural against texel tables (and the polynomial sine), interleaved in one process.

    python docs/data/speed/texture_modes.py [--level house-1] [--repeats 9] [--tasks 6]
        [--estimators ours,no-map] [--json OUT]

1. Texel tables of the level: build time (after compilation), texel size, memory, bound; and
   the accuracy of whole paper frames at 8 free-space poses, each mode against procedural
   (mean and max absolute colour difference; depth and validity compared bit for bit).
2. Full frames at the paper (320x240) and half (160x120) cameras: each repeat renders the same
   10 free-space poses with every mode in turn (order alternating), each mode's mean per frame;
   medians over repeats and the median of the per-repeat ratios procedural / mode.
3. Whole episode steps (``ours`` and ``no-map``, paper camera, house-1 on its voxelized true
   geometry, mid noise): the same seeded tasks run with each mode in turn, the per-step
   components of :func:`navbench.nav.episode.run_episode` summed; medians of ``sim`` (dynamics +
   collision + the frame: the 3000 pixels ``ours`` reads, ``no-map``'s whole frame) and of the
   whole step, and the simulator's share.
   Also a simulator step with the whole paper frame (what a full-frame estimator pays).

``uptime``'s load is printed before and after (two shared cores: compare ratios, not times).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))

MODES = ("procedural", "table", "polynomial")


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def accuracy(level, count: int = 8) -> dict:
    from navbench.geometry import PAPER_CAMERA
    from navbench.sim.bench import bench_poses
    from navbench.sim.camera import RaycastCamera

    cams = {m: RaycastCamera(level, PAPER_CAMERA, texture=m) for m in MODES}
    diffs = {m: [] for m in MODES[1:]}
    same_depth = True
    for pose in bench_poses(level, count, 7):
        f = {m: c.render(pose) for m, c in cams.items()}
        for m in MODES[1:]:
            diffs[m].append(np.abs(f[m].rgb.astype(np.float64) - f["procedural"].rgb))
            same_depth &= bool(np.array_equal(f[m].depth, f["procedural"].depth)
                               and np.array_equal(f[m].valid, f["procedural"].valid))
    out = {m: {"mean": float(np.mean(d)), "max": float(np.max(d)),
               "share_over_half_8bit": float(np.mean(np.concatenate([x.ravel() for x in d]) > 0.5 / 255))}
           for m, d in diffs.items()}
    out["depth_identical"] = same_depth
    return out


def frames(level, repeats: int) -> dict:
    from navbench.geometry import CAMERAS
    from navbench.sim.bench import time_render_modes

    out = {}
    for cam in ("paper", "half"):
        t = time_render_modes(level, CAMERAS[cam], MODES, repeats=repeats, frames=10)
        a = {m: np.asarray(v) for m, v in t.items()}
        out[cam] = {"median_ms": {m: float(np.median(v)) for m, v in a.items()},
                    "ratio": {m: float(np.median(a["procedural"] / a[m])) for m in MODES[1:]},
                    "times_ms": {m: v.tolist() for m, v in a.items()}}
    return out


def sim_full_frame_step(level, repeats: int) -> dict:
    """Simulator.step with the whole paper frame, interleaved per mode (mean of 20 steps each)."""
    from navbench.geometry import PAPER_CAMERA
    from navbench.sim.bench import bench_poses
    from navbench.sim.dynamics import Control
    from navbench.sim.world import Simulator

    sims = {m: Simulator(level, "mid", 0, PAPER_CAMERA, texture=m) for m in MODES}
    starts = bench_poses(level, repeats + 1, 3)
    out = {m: [] for m in MODES}
    for r in range(repeats + 1):
        for m in (MODES if r % 2 == 0 else MODES[::-1]):
            sim = sims[m]
            sim.reset(starts[r], seed=r)
            t0 = time.perf_counter()
            for _ in range(20):
                sim.step(Control(0.02, float(sim.pose[2]), 0.0))  # turning on the spot: no collision
            if r:  # the first round warms up
                out[m].append(1000.0 * (time.perf_counter() - t0) / 20)
    a = {m: np.asarray(v) for m, v in out.items()}
    return {"median_ms": {m: float(np.median(v)) for m, v in a.items()},
            "ratio": {m: float(np.median(a["procedural"] / a[m])) for m in MODES[1:]}}


def episodes(level, ntasks: int, estimator: str) -> dict:
    from dataclasses import replace

    from navbench.bench.timers import bench_tasks
    from navbench.geometry import CAMERA_HEIGHT, PAPER_CAMERA
    from navbench.nav.episode import EpisodeConfig, run_episode
    from navbench.plan.astar import make_planner_map
    from navbench.sim.world import Simulator
    from navbench.track.registry import make_estimator
    from navbench.worldmodel.grid import grid_for_level, voxelize_level

    vmap = voxelize_level(level, grid_for_level(level))
    occ2d, xs, ys = vmap.occupancy_slice("band")
    pm = make_planner_map(occ2d, xs, ys)
    tasks = bench_tasks(level, vmap, ntasks + 1, 0)
    steps = {m: {"sim": [], "total": []} for m in MODES}
    for i, task in enumerate(tasks):
        for m in (MODES if i % 2 == 0 else MODES[::-1]):
            sim = Simulator(level, noise="mid", seed=i, intrinsics=PAPER_CAMERA, camera_height=CAMERA_HEIGHT,
                            texture=m)
            est = make_estimator(estimator, vmap=vmap, intrinsics=PAPER_CAMERA, camera_height=CAMERA_HEIGHT, seed=i)
            cfg = replace(EpisodeConfig(), max_steps=60 if i else 5, texture=m)
            rec = run_episode(level, occ2d, xs, ys, task, est, sim, config=cfg, planner_map=pm)
            if i == 0:
                continue  # warm-up
            t = rec.timings_ms
            steps[m]["sim"].extend(np.asarray(t["sim"]).tolist())
            steps[m]["total"].extend(np.sum([np.asarray(v) for v in t.values()], axis=0).tolist())
    out = {}
    for m, d in steps.items():
        sim_ms, tot = float(np.median(d["sim"])), float(np.median(d["total"]))
        out[m] = {"steps": len(d["sim"]), "sim_ms": sim_ms, "step_ms": tot, "sim_share": sim_ms / tot}
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--level", default="house-1")
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--tasks", type=int, default=6)
    ap.add_argument("--estimators", default="ours,no-map")
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = ap.parse_args(argv)
    from navbench.levelio import resolve_level
    from navbench.sim.texels import build_texel_tables, texel_tables

    level = resolve_level(args.level)
    res = {"level": args.level, "load_start": load(), "numba_threads": None}
    import numba

    res["numba_threads"] = numba.get_num_threads()
    texel_tables(level)  # compile
    t0 = time.perf_counter()
    tb = build_texel_tables(level)
    res["tables"] = {"build_s": time.perf_counter() - t0, "h_m": tb.h, "mib": tb.nbytes / 2**20,
                     "surfaces": int(len(tb.texture)), "colour_bound": tb.bound}
    print(f"load at start (1, 5, 15 min): {res['load_start']}")
    print(f"tables of {args.level}: {len(tb.texture)} surfaces, texel {tb.h:g} m, "
          f"{tb.nbytes / 2**20:.1f} MiB, built in {res['tables']['build_s']:.2f} s, colour bound {tb.bound:.2e}")
    res["accuracy"] = acc = accuracy(level)
    for m in MODES[1:]:
        a = acc[m]
        print(f"accuracy, 8 paper frames, {m} - procedural: mean {a['mean']:.2e}, max {a['max']:.2e} in colour "
              f"({100 * a['share_over_half_8bit']:.3f} % of values off by more than half an 8-bit level)")
    print(f"depth and validity identical in every mode: {acc['depth_identical']}")
    res["frames"] = frames(level, args.repeats)
    for cam, d in res["frames"].items():
        med, rat = d["median_ms"], d["ratio"]
        print(f"frame {cam}: " + ", ".join(f"{m} {med[m]:.2f} ms" for m in MODES)
              + f"; procedural/table {rat['table']:.2f}x, procedural/polynomial {rat['polynomial']:.2f}x"
              + f" (medians of {args.repeats} interleaved repeats of 10 poses)")
    res["sim_step_full_frame"] = d = sim_full_frame_step(level, args.repeats)
    print("simulator step with the whole paper frame: " + ", ".join(f"{m} {d['median_ms'][m]:.2f} ms" for m in MODES)
          + f"; procedural/table {d['ratio']['table']:.2f}x")
    for name in args.estimators.split(",") if args.tasks else ():
        res[f"episode_steps_{name}"] = ep = episodes(level, args.tasks, name)
        for m, e in ep.items():
            print(f"episode step ({name}, paper, {e['steps']} steps): {m}: sim {e['sim_ms']:.2f} ms of "
                  f"{e['step_ms']:.2f} ms ({100 * e['sim_share']:.0f} %)")
        print(f"  {name}: whole step procedural / table "
              f"{ep['procedural']['step_ms'] / ep['table']['step_ms']:.2f}x")
    res["load_end"] = load()
    print(f"load at end: {res['load_end']}")
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
