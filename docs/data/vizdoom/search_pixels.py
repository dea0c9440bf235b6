"""Issue 37: the heading search of ``ours`` / ``no-map`` on the engine's frames, scored on its
default 400 pixels or on more (``yaw_search_pixels``), or switched off (``yaw_search_deg = 0``).

Replays the first TRAJ trajectories of the tracking study's recording of house-1 (tracking noise,
seed 0, STEPS steps, half camera) on the engine's frames (sector light 192, the default), with
its depth buffer and with exact depth, and prints per variant the rotation RMSE and ATE per
trajectory and their medians.

``python docs/data/vizdoom/search_pixels.py MAP.npz [TRAJ] [STEPS] [VARIANTS_JSON]`` (MAP: a map
fitted on the engine's views, ``lighting_fit.py 192 2000 DIR`` writes one; VARIANTS_JSON: a list
of ``[estimator, options]``, default :data:`VARIANTS`; a fifth argument ``pymunk`` replays on the
pymunk simulator instead, MAP ``true`` the level's true geometry).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from navbench.geometry import CAMERA_HEIGHT, camera_by_name  # noqa: E402
from navbench.levelio import load_level  # noqa: E402
from navbench.sim.backends import PoseRenderer  # noqa: E402
from navbench.track.study import TrackingStudyConfig, _replay, record_trajectories  # noqa: E402
from navbench.worldmodel.base import load_world_model  # noqa: E402

VARIANTS = (
    ("ours", {}), ("ours", {"yaw_search_pixels": 3000}), ("ours", {"yaw_search_deg": 0}),
    ("no-map", {}), ("no-map", {"yaw_search_pixels": 3000}), ("no-map", {"yaw_search_deg": 0}),
    ("ours", {"yaw_search_spread": True}), ("no-map", {"yaw_search_spread": True}),
)


def main(argv):
    sim = argv[4] if len(argv) > 4 else "vizdoom"
    level = load_level(ROOT / "levels" / "house-1.json")
    if argv[0] == "true":
        from navbench.worldmodel.grid import grid_for_level, voxelize_level

        vmap = voxelize_level(level, grid_for_level(level))
    else:
        vmap = load_world_model(argv[0])
    n = int(argv[1]) if len(argv) > 1 else 10
    steps = int(argv[2]) if len(argv) > 2 else 30
    variants = json.loads(argv[3]) if len(argv) > 3 else VARIANTS
    trajs = record_trajectories(level, n, steps, noise="tracking", seed=0)
    for depth in ("buffer", "exact") if sim == "vizdoom" else ("exact",):
        extra = {"depth": "exact"} if depth == "exact" and sim == "vizdoom" else {}
        with PoseRenderer(sim, level, camera_by_name("half"), CAMERA_HEIGHT, **extra) as cam:
            for name, opts in variants:
                cfg = TrackingStudyConfig(trajectories=n, steps=steps, estimators=(name,), sim=sim,
                                          estimator_options={name: opts}, trajectory_limits={})
                e = _replay(level, vmap, cfg, trajs, None, None, cam)["estimators"][name]
                rot, ate = np.asarray(e["rot_rmse_deg"]), np.asarray(e["loc_rmse_m"])
                print(f"{depth:6s} {name:6s} {json.dumps(opts):28s} rot median {np.median(rot):7.3f} deg "
                      f"(< 2 deg: {np.mean(rot < 2):.2f}) ATE median {np.median(ate):.4f} m  "
                      f"rot {np.round(rot, 2).tolist()}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
