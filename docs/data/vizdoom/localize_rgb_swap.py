"""Issue 37 §3, a diagnostic of ``localize-eval --sim vizdoom`` on the true map: which part of the
engine's frame breaks the localiser there, its depth or its colours?

The first ``QUERIES`` queries of the study (seed 0, uniform) on house-1's true geometry, the
localiser's signature without its grey channel (``grey_weight = 0``: the coarse search reads
depth only), three frames at the pose the engine shows, all with the engine's projection
(fx 80, fy 94):

* ``raycast``: navbench's ray-cast RGB-D (navbench's textures, which the true map carries);
* ``engine``: the engine's RGB with the exact depth of the geometry (``depth="exact"``, so
  the depth is the ray caster's, bit for bit);
* ``engine depth + raycast RGB``: the engine frame's depth and valid mask, navbench's RGB.

Nothing is cached but the localiser's bank (built in CACHE if missing).

``python docs/data/vizdoom/localize_rgb_swap.py CACHE [QUERIES]``
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np


def main(cache: str, queries: int = 20) -> None:
    from navbench.geometry import CAMERA_HEIGHT, HALF_CAMERA, Frame
    from navbench.localize import LocalizerConfig
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.stages.context import StageContext
    from navbench.pipeline.stages.level import LevelConfig, load_level_ref, make_level_stage
    from navbench.pipeline.stages.localize import draw_queries, load_localizer
    from navbench.pipeline.stages.track_eval import study_map
    from navbench.sim.backends import PoseRenderer
    from navbench.sim.camera import RaycastCamera

    ctx = StageContext(ArtifactStore(Path(cache)))
    level = make_level_stage(ctx, LevelConfig("house-1"))
    lv = load_level_ref(level)
    vmap = study_map(ctx, "true", level)
    model = vmap.load()
    cfg = dataclasses.replace(LocalizerConfig(), grey_weight=0.0)
    poses = [p for p, _, _ in draw_queries(lv, queries, 0, 0.1, HALF_CAMERA)]
    with PoseRenderer("vizdoom", lv, HALF_CAMERA, CAMERA_HEIGHT, depth="exact") as engine:
        intr = engine.intrinsics
        ray = RaycastCamera(lv, intr, CAMERA_HEIGHT)
        loc, _ = load_localizer(ctx, vmap, intr, CAMERA_HEIGHT, cfg, model, level)
        rows = {"raycast": [], "engine": [], "engine depth + raycast RGB": []}
        for p in poses:
            f = engine.render(p)
            shown = engine.shown
            g = ray.render(shown)
            assert np.array_equal(f.valid, g.valid) and np.array_equal(f.depth[f.valid], g.depth[g.valid])
            for name, frame in (("raycast", g), ("engine", f), ("engine depth + raycast RGB", Frame(g.rgb, f.depth, f.valid))):
                h = loc.localize(frame)[0]
                rows[name].append((float(np.hypot(*(np.asarray(h.pose[:2]) - shown[:2]))), float(h.confidence)))
    for name, r in rows.items():
        r = np.array(r)
        print(f"{name:28} found within 50 cm {int(np.sum(r[:, 0] <= 0.5)):2d} / {len(r)}, median error "
              f"{100 * np.median(r[:, 0]):7.1f} cm, confidence median {np.median(r[:, 1]):.3f}")


if __name__ == "__main__":
    main(sys.argv[1], *(int(a) for a in sys.argv[2:3]))
