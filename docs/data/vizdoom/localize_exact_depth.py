"""Issue 37 §3, a diagnostic of ``localize-eval --sim vizdoom``: the same 50 queries on the
vizdoom-quick map with the engine's images and (a) its 8-bit depth buffer (the study's frames:
must give the stored study's estimates), (b) the exact depth of the geometry from the engine's
pose (``DoomSimulator(depth="exact")``: the engine's RGB without its buffer). Per query: the
location error in both, and the share of the frame's pixels the buffer leaves invalid (beyond
its 4.5 m reach at 160 x 120, or on a discontinuity). Nothing is cached (the localiser's bank
is the study's, read from the cache).

``python docs/data/vizdoom/localize_exact_depth.py CACHE VIZDOOM_MAP [QUERIES]``
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


def main(cache: str, map_path: str, queries: int = 50) -> None:
    import navbench.sim.backends as backends
    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.stages.context import StageContext
    from navbench.pipeline.stages.level import LevelConfig, load_level_ref, make_level_stage
    from navbench.pipeline.stages.localize import LocalizeEvalConfig, load_localizer, study_queries
    from navbench.pipeline.stages.track_eval import study_map

    ctx = StageContext(ArtifactStore(Path(cache)))
    level = make_level_stage(ctx, LevelConfig("house-1"))
    vmap = study_map(ctx, map_path, level)
    cfg = LocalizeEvalConfig(queries=queries, sim="vizdoom").resolved()
    intr = camera_by_name(cfg.camera)
    loc, _ = load_localizer(ctx, vmap, backends.sim_intrinsics("vizdoom", intr), CAMERA_HEIGHT, cfg.localizer,
                            level=level)
    base = backends.PoseRenderer
    out = {}
    for mode in ("buffer", "exact"):
        class Renderer(base):
            def __init__(self, sim, lv, intrinsics, height, **options):
                super().__init__(sim, lv, intrinsics, height, depth=mode, **options)

        backends.PoseRenderer = Renderer
        try:
            rows = []
            for pose, frame, _ in study_queries(load_level_ref(level), cfg, intr):
                h = loc.localize(frame)[0]
                err = float(np.hypot(*(np.asarray(h.pose[:2]) - pose[:2])))
                rows.append((err, 1.0 - float(np.mean(frame.valid))))
            out[mode] = np.array(rows)
        finally:
            backends.PoseRenderer = base
    buf, exact = out["buffer"], out["exact"]
    for name, r in out.items():
        e = r[:, 0]
        print(f"{name:6} depth: recall 25 / 50 / 100 cm {100 * np.mean(e <= 0.25):.0f} / "
              f"{100 * np.mean(e <= 0.5):.0f} / {100 * np.mean(e <= 1.0):.0f} %, median error {100 * np.median(e):.1f} cm")
    ok_b, ok_e = buf[:, 0] <= 0.5, exact[:, 0] <= 0.5
    print(f"found (50 cm) with the buffer only {int(np.sum(ok_b & ~ok_e))}, with exact depth only "
          f"{int(np.sum(~ok_b & ok_e))}, both {int(np.sum(ok_b & ok_e))}, neither {int(np.sum(~ok_b & ~ok_e))}")
    inv = buf[:, 1]
    print(f"invalid pixels of the buffer's frame, median: found {100 * np.median(inv[ok_b]):.1f} %, "
          f"missed {100 * np.median(inv[~ok_b]):.1f} %")
    print("per query (error buffer m, error exact m, invalid share):")
    for i, (b, x) in enumerate(zip(buf, exact)):
        print(f"  {i:2d} {b[0]:7.3f} {x[0]:7.3f} {b[1]:.3f}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], *(int(a) for a in sys.argv[3:4]))
