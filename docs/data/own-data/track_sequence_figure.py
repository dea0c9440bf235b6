"""Issue 13's tracking figure: a sequence rendered by navbench, exported as TUM RGB-D, then
imported, fitted and tracked (a) through the CLI alone and (b) through the Python API; prints
both paths' `ours` ATE (and the odometry's own), which must agree within 1e-6 m, and checks
`ours` ATE <= 1 cm with `gt+mid` odometry.

    python docs/data/own-data/track_sequence_figure.py                      # house-1, 300 paper frames
    python docs/data/own-data/track_sequence_figure.py --frames 60 --steps 300   # a quick check

Steps (every file under --work, default results/figures/track-sequence/):
1. render: the first trajectory of navbench.track.study.record_trajectories on the level (seed
   --walk-seed, tracking-study noise), rendered by the ray-cast camera at every true pose and
   exported with navbench.worldmodel.tum.export_views (kept if already there);
2. CLI path: `navbench fit-map --views DIR --steps N --json` (issue 13's level-free fit), then
   `navbench track-sequence DIR --map KEY --odometry gt+mid --json --no-store`;
3. API path: import_views -> fit_views (the level-free fit with the CLI's default held-out split
   and the FitConfig the CLI's profile resolves: --profile with --steps) -> save and load the map
   (as the fit-map stage stores it: colour as float16; the unsaved float32 colours move the ATE
   by ~1e-6 m) -> navbench.pipeline.tracking.track_sequence.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
from scripts._env import pythonpath_first  # noqa: E402


def cli(*args, cwd: Path) -> tuple[int, str, str]:
    env = {**os.environ, "PYTHONPATH": pythonpath_first(Path(__file__).resolve().parents[3])}
    p = subprocess.run([sys.executable, "-m", "navbench.cli.main", *map(str, args)], cwd=cwd,
                       capture_output=True, text=True, env=env)
    return p.returncode, p.stdout, p.stderr


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--level", default="house-1")
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--camera", default="paper")
    ap.add_argument("--walk-seed", type=int, default=0)
    ap.add_argument("--steps", type=int, default=2000, help="fit steps (the quick profile's)")
    ap.add_argument("--profile", default="quick", help="profile whose fit settings both paths use")
    ap.add_argument("--odometry", default="gt+mid")
    ap.add_argument("--seed", type=int, default=0, help="odometry noise seed")
    ap.add_argument("--work", default="results/figures/track-sequence")
    args = ap.parse_args()

    from navbench.geometry import camera_by_name
    from navbench.levelio import load_level
    from navbench.pipeline.profiles import load_profile
    from navbench.pipeline.stages.maps import FitMapConfig
    from navbench.pipeline.tracking import track_sequence
    from navbench.track.sequence import render_walk
    from navbench.worldmodel.fitviews import fit_views
    from navbench.worldmodel.tum import export_views, import_views

    root = Path.cwd()
    work = Path(args.work).resolve()
    seq = work / f"{args.level}-{args.frames}-{args.camera}-walk{args.walk_seed}"
    t0 = time.perf_counter()
    if not (seq / "groundtruth.txt").is_file():
        level = load_level(root / "levels" / f"{args.level}.json")
        export_views(render_walk(level, args.frames, camera_by_name(args.camera), args.walk_seed), seq)
        print(f"rendered and exported {args.frames} frames -> {seq} ({time.perf_counter() - t0:.1f} s)")

    # API path
    prof = load_profile(args.profile)
    fit_cfg = FitMapConfig(args.steps, prof.fit_seed, dict(prof.fit)).fit_config()
    t0 = time.perf_counter()
    views = import_views(seq)
    vmap, metrics = fit_views(views, fit_cfg)
    api_map = work / f"{seq.name}-api-map.npz"
    vmap.save(api_map)
    fit_s = time.perf_counter() - t0
    from navbench.worldmodel.base import load_world_model

    vmap = load_world_model(api_map)  # the map as fit-map stores it (colour as float16)
    api = track_sequence(seq, vmap, estimator="ours", odometry=args.odometry, seed=args.seed)
    print(f"API: import + fit {fit_s:.1f} s ({fit_cfg.steps} steps on {len(views)} views), map "
          f"{vmap.content_hash()[:12]}; ours ATE {api.ate_m:.6f} m, RPE "
          f"{api.rpe_m:.5f} m / {api.rpe_deg:.3f} deg per frame, odometry alone {api.odometry_ate_m:.4f} m, "
          f"{api.ms_per_frame:.1f} ms per frame")

    # CLI path
    code, out, err = cli("fit-map", "--views", seq, "--steps", args.steps, "--profile", args.profile,
                         "--json", cwd=root)
    if code != 0:
        print(f"CLI fit-map --views failed: {err.strip()}")
        return 1
    fit = json.loads(out)
    map_ref = fit["map_key"]
    print(f"CLI fit-map --views: map {map_ref[:12]}, depth MAE {fit['depth_mae_m']:.6f} m, RGB L1 "
          f"{fit['rgb_l1']:.6f} (API: {metrics['depth_mae_m']:.6f} m, {metrics['rgb_l1']:.6f})")
    code, out, err = cli("track-sequence", seq, "--map", map_ref, "--odometry", args.odometry,
                         "--seed", args.seed, "--json", "--no-store",
                         "--out", work / f"{seq.name}-ours.txt", cwd=root)
    if code != 0:
        print(f"CLI track-sequence failed: {err.strip()}")
        return 1
    got = json.loads(out)
    print(f"CLI: ours ATE {got['ate_m']:.6f} m, RPE {got['rpe_m']:.5f} m / {got['rpe_deg']:.3f} deg "
          f"per frame, {got['ms_per_frame']:.1f} ms per frame; estimate {got['out']}")
    diff = abs(got["ate_m"] - api.ate_m)
    qdiff = max(abs(fit["depth_mae_m"] - metrics["depth_mae_m"]), abs(fit["rgb_l1"] - metrics["rgb_l1"]))
    ok_same, ok_cm = diff <= 1e-6 and qdiff <= 1e-6, api.ate_m <= 0.01
    print(f"|CLI - API| map quality = {qdiff:.2e}, ATE = {diff:.2e} m ({'<=' if ok_same else '>'} "
          f"1e-6); ours ATE "
          f"{api.ate_m * 100:.3f} cm ({'<=' if ok_cm else '>'} 1 cm with {args.odometry})")
    return 0 if ok_same and ok_cm else 1


if __name__ == "__main__":
    sys.exit(main())
