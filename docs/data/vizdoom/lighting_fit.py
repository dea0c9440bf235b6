"""Issue 37: does Doom's distance lighting make ``ours`` fail on engine-fitted maps? Collect the
views of house-1 on the engine with sector light LIGHT, fit a map (STEPS Adam steps, the quick
profile's fit otherwise), evaluate it on 200 held-out views, and replay ``ours`` on it over the
first TRAJ trajectories of the tracking study's recording (STEPS_T steps, half camera), with the
frames of the same lighting, with the depth buffer and with exact depth.

``python docs/data/vizdoom/lighting_fit.py LIGHT STEPS OUT_DIR [TRAJ] [STEPS_T] [OURS_JSON] [VIEW_DEPTH]``:
writes ``OUT_DIR/map-<LIGHT>-<STEPS>[-<VIEW_DEPTH>].npz`` (or loads it when it is there) and
prints the map's metrics and the probe's ATE / rotation RMSE per trajectory; ``OURS_JSON``:
options of ``ours`` (``'{"photo_weight": 0}'``: the depth term alone); ``VIEW_DEPTH``: the
depth of the views the map is fitted on, ``buffer`` (default, the engine's) or ``exact``.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from navbench.geometry import CAMERA_HEIGHT, camera_by_name  # noqa: E402
from navbench.levelio import load_level  # noqa: E402
from navbench.sim.backends import PoseRenderer  # noqa: E402
from navbench.track.study import TrackingStudyConfig, _replay, record_trajectories  # noqa: E402
from navbench.worldmodel.base import load_world_model  # noqa: E402
from navbench.worldmodel.fit import FitConfig, evaluate_map, fit_map  # noqa: E402
from navbench.worldmodel.views import collect_views  # noqa: E402


def engine_views(level, count, seed, **options):
    shown = []
    cam_i = camera_by_name("half")
    with PoseRenderer("vizdoom", level, cam_i, CAMERA_HEIGHT, **options) as cam:
        def render(pose):
            frame = cam.render(pose)
            shown.append(cam.shown)
            return frame

        views = collect_views(level, count, cam_i, seed, renderer=render)
        return dataclasses.replace(views, poses=np.array(shown), intrinsics=cam.intrinsics)


def probe(level, vmap, n, steps, ours=None, **options):
    trajs = record_trajectories(level, n, steps, noise="tracking", seed=0)
    out = {}
    for name, extra in (("buffer", {}), ("exact", {"depth": "exact"})):
        cfg = TrackingStudyConfig(trajectories=n, steps=steps, estimators=("ours",), sim="vizdoom",
                                  estimator_options={"ours": dict(ours or {})}, trajectory_limits={})
        with PoseRenderer("vizdoom", level, camera_by_name("half"), CAMERA_HEIGHT, **options, **extra) as cam:
            e = _replay(level, vmap, cfg, trajs, None, None, cam)["estimators"]["ours"]
        out[name] = {"ate_m": np.round(e["loc_rmse_m"], 4).tolist(), "rot_deg": np.round(e["rot_rmse_deg"], 3).tolist()}
        print(name, "ATE", out[name]["ate_m"], "rot", out[name]["rot_deg"], flush=True)
    return out


def main(argv):
    light, steps, out_dir = int(argv[0]), int(argv[1]), Path(argv[2])
    n = int(argv[3]) if len(argv) > 3 else 3
    steps_t = int(argv[4]) if len(argv) > 4 else 30
    out_dir.mkdir(parents=True, exist_ok=True)
    level = load_level(ROOT / "levels" / "house-1.json")
    view_depth = argv[6] if len(argv) > 6 else "buffer"
    path = out_dir / f"map-{light}-{steps}{'' if view_depth == 'buffer' else '-' + view_depth}.npz"
    opts = {"light_level": light}
    vopts = {**opts, **({"depth": "exact"} if view_depth == "exact" else {})}
    if path.exists():
        vmap = load_world_model(path)
        print("map", path, "(loaded)")
    else:
        t0 = time.time()
        train = engine_views(level, 2000, 0, **vopts)
        held = engine_views(level, 200, 1, **vopts)
        print(f"views {time.time() - t0:.1f} s", flush=True)
        every = max(1, steps // 10)
        t1 = time.time()

        def progress(step, total, loss):
            if step % every == 0:
                print(f"  fit {step}/{total} loss {loss:.4f} {time.time() - t1:.0f} s", flush=True)

        vmap, metrics = fit_map(train, FitConfig(steps=steps, seed=0), progress=progress)
        q = evaluate_map(vmap, level, held)
        vmap.save(path)
        keep = {k: (round(float(v), 4) if isinstance(v, (int, float)) else v) for k, v in {**metrics, **q}.items()
                if k in ("fit_time_s", "ms_per_step", "final_loss", "depth_mae_m", "rgb_l1", "slice_precision",
                         "slice_recall")}
        print("metrics", json.dumps(keep), flush=True)
    ours = json.loads(argv[5]) if len(argv) > 5 else {}
    print("ours options", ours, flush=True)
    probe(level, vmap, n, steps_t, ours, **opts)


if __name__ == "__main__":
    main(sys.argv[1:])
