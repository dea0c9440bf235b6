"""Issue 37 §4 probe: ``ours`` on a map fitted from the engine's views, replayed on the engine's
frames with its depth buffer and with exact depth (the first TRAJ trajectories of the tracking
study's recording, STEPS steps, half camera).

``python docs/data/vizdoom/probe_fitted_map.py MAP.npz [TRAJ] [STEPS]``, MAP the fit-map artifact
of ``navbench all --profile vizdoom-quick`` (``<cache>/fit-map/<key>/map.npz``). Prints the ATE (m)
and rotation RMSE (deg) per trajectory.
"""

from __future__ import annotations

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


def main(argv: list[str]) -> None:
    vmap = load_world_model(argv[0])
    n = int(argv[1]) if len(argv) > 1 else 3
    steps = int(argv[2]) if len(argv) > 2 else 30
    level = load_level(ROOT / "levels" / "house-1.json")
    trajs = record_trajectories(level, n, steps, noise="tracking", seed=0)
    for name, options in (("vizdoom buffer", {}), ("vizdoom exact depth", {"depth": "exact"})):
        cfg = TrackingStudyConfig(trajectories=n, steps=steps, estimators=("ours",), sim="vizdoom",
                                  estimator_options={}, trajectory_limits={})
        with PoseRenderer("vizdoom", level, camera_by_name("half"), CAMERA_HEIGHT, **options) as cam:
            e = _replay(level, vmap, cfg, trajs, None, None, cam)["estimators"]["ours"]
        print(name, "ATE", np.round(e["loc_rmse_m"], 4), "rot", np.round(e["rot_rmse_deg"], 3), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
