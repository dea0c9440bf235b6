"""Issue 37: the heading search's score per candidate heading, split into its photometric and
point-to-plane parts, on a map fitted from the engine's views.

For P random free poses of house-1 (seed 0; the engine's frame with exact depth, sector light
192), the reference is the map rendered at the engine's pose and the search is asked to find
that pose's heading (the prediction is the pose itself): the score of the candidates
``k * 2 deg`` (``|k| <= 12``) is computed on the search's default pixels (the first 400 of the
tracker's 3000, sorted: the image's top rows), on 400 spread over the image
(``yaw_search_spread``) and on all 3000. Prints, per subset, how often the best candidate is not the
true heading (|offset| >= 2 deg) and how large the score's differences are next to its spread.

``python docs/data/vizdoom/search_curve.py MAP.npz|true [P]``
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from navbench.geometry import CAMERA_HEIGHT, camera_by_name, camera_pose  # noqa: E402
from navbench.levelio import load_level  # noqa: E402
from navbench.sim.backends import PoseRenderer  # noqa: E402
from navbench.sim.world import sample_free_points  # noqa: E402
from navbench.track.eq7 import accumulate_values, linearization, make_config, prepare_reference, sample_observation  # noqa: E402
from navbench.track.heading import _initial_state, search_positions, yaw_search  # noqa: E402
from navbench.track.lie import se3_inverse  # noqa: E402
from navbench.track.ours import default_renderer, gn_pixels  # noqa: E402
from navbench.worldmodel.base import load_world_model  # noqa: E402
from navbench.worldmodel.grid import grid_for_level, voxelize_level  # noqa: E402


def main(argv):
    level = load_level(ROOT / "levels" / "house-1.json")
    vmap = voxelize_level(level, grid_for_level(level)) if argv[0] == "true" else load_world_model(argv[0])
    n = int(argv[1]) if len(argv) > 1 else 40
    rng = np.random.default_rng(0)
    poses = [np.array([*p, rng.uniform(-math.pi, math.pi)]) for p in sample_free_points(level, rng, n, 0.3)]
    cfg = make_config({})
    offsets = np.arange(-12, 13) * 2.0
    with PoseRenderer("vizdoom", level, camera_by_name("half"), CAMERA_HEIGHT, depth="exact") as cam:
        K = cam.intrinsics
        render = default_renderer(vmap, K, CAMERA_HEIGHT)
        idx = gn_pixels(K.height, K.width, cfg.gn_pixels, 0)
        spread = dataclasses.replace(cfg, yaw_search_spread=True)
        subsets = {"first 400 (default: the top rows)": idx[search_positions(len(idx), cfg)],
                   "400 spread (yaw_search_spread)": idx[search_positions(len(idx), spread)],
                   "all 3000": idx}
        stats = {k: [] for k in subsets}
        for p in poses:
            frame = cam.render(p)
            p0 = cam.shown.copy()
            ref = prepare_reference(render(p0), K, camera_pose(p0, CAMERA_HEIGHT))
            Ti = se3_inverse(ref.T_wc)
            lins = []
            for o in offsets:
                c = p0.copy()
                c[2] += math.radians(o)
                lins.append(linearization(cfg.param, _initial_state(cfg.param, c, CAMERA_HEIGHT), ref.T_wc,
                                          CAMERA_HEIGHT, Ti))
            for label, sub in subsets.items():
                npx = len(sub)
                obs = sample_observation(frame, ref.observed, sub)
                # the search's score: the kept data term per kept photometric pixel (both parts
                # divided by the full term's photometric count, as the search divides)
                v_all, cnt = accumulate_values(ref, obs, lins, cfg)
                kept = cnt[:, 0]
                parts = []
                for w in ((cfg.photo_weight, 0.0), (0.0, cfg.geo_weight)):
                    v, _ = accumulate_values(ref, obs, lins, dataclasses.replace(cfg, photo_weight=w[0], geo_weight=w[1]))
                    parts.append(v / np.maximum(kept, 1))
                score = v_all / np.maximum(kept, 1)
                score[kept < 0.3 * npx] = np.inf
                best = offsets[int(np.argmin(score))]
                if label.startswith("first") or label.startswith("400 spread"):  # the tracker's own search agrees
                    c3 = cfg if label.startswith("first") else spread
                    got = math.degrees(yaw_search(ref, frame, p0, c3, idx)[2] - p0[2])
                    assert abs(got - best) < 1e-6 or not np.isfinite(score).any(), (got, best)
                stats[label].append((best, parts[0], parts[1]))
    for label, rows in stats.items():
        best = np.array([r[0] for r in rows])
        photo = np.array([r[1] for r in rows])
        geo = np.array([r[2] for r in rows])
        # how much a 4 deg error raises each part, against the photometric part's wiggle between
        # neighbouring candidates (a second difference: its noise)
        c = len(offsets) // 2
        rise_p = np.median((photo[:, c - 2] + photo[:, c + 2]) / 2 - photo[:, c])
        rise_g = np.median((geo[:, c - 2] + geo[:, c + 2]) / 2 - geo[:, c])
        wiggle = np.median(np.abs(photo[:, 2:] - 2 * photo[:, 1:-1] + photo[:, :-2]))
        print(f"{argv[0] if argv[0] == 'true' else Path(argv[0]).name}, {label}: best candidate off the true heading "
              f"(>= 2 deg) {np.mean(np.abs(best) >= 2):.2f} of {len(best)} poses, >= 10 deg {np.mean(np.abs(best) >= 10):.2f}; "
              f"score rise at +-4 deg: photometric {rise_p:.4f}, point-to-plane {rise_g:.4f}; "
              f"photometric wiggle between neighbours {wiggle:.4f}; photometric score at the truth {np.median(photo[:, c]):.3f}",
              flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
