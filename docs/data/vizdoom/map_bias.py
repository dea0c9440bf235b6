"""Issue 37: one tracking step of ``ours`` from a known pose, on a map fitted from the engine's
views and on the level's true geometry: the error a map makes the tracker commit per step.

For P random free poses of house-1 (seed 0): the estimator is reset at the pose ``p`` the engine
shows, and updated once with a zero control and the engine's frame at ``p`` turned by DELTA deg
(unknown to the control, so the prior is centred on ``p``); the printed error is the estimate
minus the engine's pose of that frame. With a consistent map the error is near 0 and does not
depend on the sign of DELTA.

``python docs/data/vizdoom/map_bias.py LIGHT DEPTH MAP.npz|true [P] [DELTA] [OURS_JSON]``: LIGHT the
sector light of the frames, DEPTH ``buffer`` or ``exact`` (the frames' depth).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from navbench.geometry import CAMERA_HEIGHT, camera_by_name  # noqa: E402
from navbench.levelio import load_level  # noqa: E402
from navbench.sim.backends import PoseRenderer  # noqa: E402
from navbench.sim.dynamics import Control  # noqa: E402
from navbench.sim.world import sample_free_points  # noqa: E402
from navbench.track.registry import make_estimator  # noqa: E402
from navbench.worldmodel.base import load_world_model  # noqa: E402
from navbench.worldmodel.grid import grid_for_level, voxelize_level  # noqa: E402


def main(argv):
    light, depth, mp = int(argv[0]), argv[1], argv[2]
    n = int(argv[3]) if len(argv) > 3 else 60
    delta = math.radians(float(argv[4]) if len(argv) > 4 else 2.0)
    ours = json.loads(argv[5]) if len(argv) > 5 else {}
    level = load_level(ROOT / "levels" / "house-1.json")
    vmap = voxelize_level(level, grid_for_level(level)) if mp == "true" else load_world_model(mp)
    rng = np.random.default_rng(0)
    poses = [np.array([*p, rng.uniform(-math.pi, math.pi)]) for p in sample_free_points(level, rng, n, 0.3)]
    opts = {"light_level": light, **({"depth": "exact"} if depth == "exact" else {})}
    errs = []
    with PoseRenderer("vizdoom", level, camera_by_name("half"), CAMERA_HEIGHT, **opts) as cam:
        est = make_estimator("ours", vmap=vmap, intrinsics=cam.intrinsics, camera_height=CAMERA_HEIGHT,
                             renderer=None, seed=0, **ours)
        for p in poses:
            for sign in (1, -1):
                f0 = cam.render(p)
                p0 = cam.shown.copy()
                f1 = cam.render(p0 + [0, 0, sign * delta])
                p1 = cam.shown.copy()
                est.reset(p0, f0)
                e = est.update(Control(0.0, 0.0, 0.0), f1)
                d = e - p1
                errs.append([d[0], d[1], (d[2] + math.pi) % (2 * math.pi) - math.pi])
    errs = np.array(errs)
    yaw = np.degrees(errs[:, 2])
    xy = np.hypot(errs[:, 0], errs[:, 1])
    print(f"{mp if mp == 'true' else Path(mp).name} light {light} {depth} delta {math.degrees(delta):g} deg "
          f"ours {ours}: |yaw error| median {np.median(np.abs(yaw)):.3f} deg, 90% {np.percentile(np.abs(yaw), 90):.3f}, "
          f"share > 1 deg {np.mean(np.abs(yaw) > 1):.3f}; xy error median {np.median(xy) * 100:.2f} cm, "
          f"90% {np.percentile(xy, 90) * 100:.2f} cm ({len(errs)} steps)", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
