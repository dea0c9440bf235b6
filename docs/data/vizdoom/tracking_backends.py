"""Issue 37 §4, first step: is frame-to-frame tracking (``no-map``) harder on the engine's frames?

The same recorded trajectories of one house (the tracking study's: tracking noise, random
waypoints, ``record_trajectories``) are replayed on the pymunk simulator's exact frames and on
ViZDoom's frames (:func:`navbench.track.study.run_tracking_study` with ``sim``), and the
estimators' location RMSE (ATE) is compared trajectory by trajectory (paired). ``dynamics``
(dead reckoning) and ``gt`` are the controls: neither reads a frame, so their only difference
is the engine's pose quantisation. ``ours`` tracks on the level's true voxelised geometry
(the map's upper bound; the pymunk backend's exact renderer of that map is the same on both).
A third replay, ``vizdoom-exact``, takes the engine's RGB with the exact depth of the level's
geometry from the engine's pose (``DoomSimulator(depth="exact")``): what the engine's 8-bit
depth buffer (7.1 cm steps) costs, apart from its images.

``python docs/data/vizdoom/tracking_backends.py [LEVEL] [TRAJECTORIES] [STEPS] [CAMERA ...]``
(default house-1 30 100 half paper); prints one table per camera and writes each camera's
figures to ``docs/data/vizdoom/tracking_backends[-<LEVEL>]-<CAMERA>.json`` (no level part for
house-1) as soon as they are measured.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from navbench.geometry import camera_by_name  # noqa: E402
from navbench.levelio import load_level  # noqa: E402
from navbench.sim.backends import PoseRenderer  # noqa: E402
from navbench.track.study import TrackingStudyConfig, _replay, record_trajectories  # noqa: E402
from navbench.worldmodel.grid import voxelize_level  # noqa: E402

ESTIMATORS = ("no-map", "ours", "dynamics", "gt")
#: The replays: name -> (simulator, the engine simulator's options).
REPLAYS = {"pymunk": ("pymunk", {}), "vizdoom": ("vizdoom", {}), "vizdoom-exact": ("vizdoom", {"depth": "exact"})}


def paired(a: np.ndarray, b: np.ndarray, reps: int = 10000, seed: int = 0) -> tuple[float, float, float]:
    """Median of ``b - a`` and its 95 % bootstrap interval (paired by trajectory)."""
    d = np.asarray(b) - np.asarray(a)
    rng = np.random.default_rng(seed)
    boots = np.median(d[rng.integers(0, len(d), (reps, len(d)))], axis=1)
    return float(np.median(d)), float(np.percentile(boots, 2.5)), float(np.percentile(boots, 97.5))


def main(argv: list[str]) -> None:
    level_name = argv[0] if argv else "house-1"
    n = int(argv[1]) if len(argv) > 1 else 30
    steps = int(argv[2]) if len(argv) > 2 else 100
    cameras = argv[3:] or ["half", "paper"]
    level = load_level(ROOT / "levels" / f"{level_name}.json")
    vmap = voxelize_level(level)
    trajs = record_trajectories(level, n, steps, noise="tracking", seed=0)
    out = {"level": level_name, "trajectories": n, "steps": steps, "estimators": list(ESTIMATORS), "cameras": {}}
    for camera in cameras:
        res = {}
        for name, (sim, options) in REPLAYS.items():
            cfg = TrackingStudyConfig(trajectories=n, steps=steps, estimators=ESTIMATORS, camera=camera,
                                      sim=sim, estimator_options={}, trajectory_limits={})
            t0 = time.perf_counter()
            with PoseRenderer(sim, level, camera_by_name(camera), cfg.camera_height, **options) as cam:
                res[name] = _replay(level, vmap, cfg, trajs, None, None, cam)
            res[name]["seconds"] = time.perf_counter() - t0
            print(f"{camera} {name}: {res[name]['seconds']:.0f} s", flush=True)
        rows = {}
        print(f"\n{level_name}, {n} trajectories x {steps} steps, camera {camera}; ATE (m) medians, "
              f"paired differences (replay - pymunk) with 95 % bootstrap intervals; rotation RMSE medians (deg)")
        for est in ESTIMATORS:
            a = res["pymunk"]["estimators"][est]["loc_rmse_m"]
            ra = res["pymunk"]["estimators"][est]["rot_rmse_deg"]
            rows[est] = {"pymunk": {"ate_median": float(np.median(a)), "ate_mean": float(np.mean(a)),
                                    "below_0_1m": float(np.mean(a < 0.1)), "rot_median": float(np.median(ra))}}
            line = f"{est:9} pymunk {np.median(a):.4f} (<0.1 m {100 * np.mean(a < 0.1):.0f} %, rot {np.median(ra):.3f})"
            for name in list(REPLAYS)[1:]:
                b = res[name]["estimators"][est]["loc_rmse_m"]
                rb = res[name]["estimators"][est]["rot_rmse_deg"]
                med, lo, hi = paired(a, b)
                rows[est][name] = {"ate_median": float(np.median(b)), "ate_mean": float(np.mean(b)),
                                   "below_0_1m": float(np.mean(b < 0.1)), "rot_median": float(np.median(rb)),
                                   "paired_median_diff": med, "ci95": [lo, hi], "worse": int(np.sum(b > a)),
                                   "n": int(len(a))}
                line += (f" | {name} {np.median(b):.4f} ({med:+.4f} [{lo:+.4f}, {hi:+.4f}], worse "
                         f"{int(np.sum(b > a))}/{len(a)}, <0.1 m {100 * np.mean(b < 0.1):.0f} %, rot {np.median(rb):.3f})")
            print(line)
        out["cameras"][camera] = {"seconds": {s: res[s]["seconds"] for s in res}, "estimators": rows}
        stem = "tracking_backends" + ("" if level_name == "house-1" else f"-{level_name}")
        path = Path(__file__).with_name(f"{stem}-{camera}.json")
        path.write_text(json.dumps({**out, "cameras": {camera: out["cameras"][camera]}}, indent=1) + "\n")
        print(f"wrote {path.relative_to(ROOT)}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
