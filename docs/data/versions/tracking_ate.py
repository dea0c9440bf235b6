"""The tracking study's ATE under two benchmark versions, paired trajectory by trajectory
(issue 36 §3: "the tracking study's ATE" of a version change's acceptance test).

    PYTHONPATH=. .venv/bin/python docs/data/versions/tracking_ate.py \\
        [--level house-1] [--trajectories 30] [--steps 100] [--profile quick] \\
        [--old navbench-1] [--new navbench-2] [--boot 10000]

Runs ``navbench track-eval LEVEL --map fit --profile PROFILE --estimators ours,no-map,dynamics
--trajectories N --steps T --benchmark-version V --json --no-store`` once per version (the study
and its map are cached stages: a rerun only reads them), loads both studies from the cache and
pairs them by trajectory: the recorded trajectories do not depend on the version (the
recording renders no frame), which the script checks (bit-identical true poses, controls and
noise). Under the new version the map is fitted on its own views (``views.texture``) and the
frames and trackers take its settings (``navigation.episode.texture``,
``navigation.options.<estimator>``).

Per estimator it prints the ATE (translation RMSE without alignment, m) median and mean under
each version, and NEW - OLD of the median and of the mean, each with a 95 % percentile
bootstrap interval over the paired trajectories (``--boot`` resamples of the trajectory indices,
both versions resampled together; seed 0). Nothing was tuned on it. No step times: the two
studies run one after the other, so their times are no speed comparison (``navbench bench``
measures the versions side by side). Writes nothing but the studies' cache; prints one table.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

import numpy as np

ESTIMATORS = ("ours", "no-map", "dynamics")


def run_study(args, version: str) -> dict:
    """``track-eval --json`` under ``version``: its meta (the study's key among it)."""
    cmd = [sys.executable, "-c", "from navbench.cli.main import main; main()", "track-eval", args.level, "--map", "fit",
           "--profile", args.profile, "--estimators", ",".join(ESTIMATORS),
           "--trajectories", str(args.trajectories), "--steps", str(args.steps),
           "--benchmark-version", version, "--json", "--no-store"]
    print("$", " ".join(["navbench", *cmd[3:]]), flush=True)
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=os.environ)
    return json.loads(out.stdout)["meta"]


def load(key: str) -> dict:
    from navbench.pipeline.artifacts import STUDY_FILE, load_study
    from navbench.pipeline.cache import ArtifactStore

    return load_study(ArtifactStore().load("track-eval", key) / STUDY_FILE)


def paired_ate(old: dict, new: dict, name: str) -> tuple[np.ndarray, np.ndarray]:
    """The two versions' ATE of estimator ``name``, ordered by trajectory (seed 0)."""
    out = []
    for res in (old, new):
        r = res["estimators"][name]
        keep = r["seed"] == 0
        order = np.argsort(r["trajectory"][keep])
        out.append(np.asarray(r["loc_rmse_m"][keep][order], dtype=float))
    if len(out[0]) != len(out[1]):
        raise SystemExit(f"{name}: {len(out[0])} vs {len(out[1])} trajectories: not paired")
    return out[0], out[1]


def boot(a: np.ndarray, b: np.ndarray, n: int, seed: int = 0) -> dict:
    """NEW - OLD of the median and the mean, each with its 95 % percentile bootstrap interval
    (trajectory indices resampled, the pair kept together)."""
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, len(a), size=(n, len(a)))
    dmed = np.median(b[idx], axis=1) - np.median(a[idx], axis=1)
    dmean = np.mean(b[idx] - a[idx], axis=1)
    return {"median_diff": float(np.median(b) - np.median(a)),
            "median_ci": tuple(float(v) for v in np.percentile(dmed, [2.5, 97.5])),
            "mean_diff": float(np.mean(b - a)),
            "mean_ci": tuple(float(v) for v in np.percentile(dmean, [2.5, 97.5]))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--level", default="house-1")
    ap.add_argument("--profile", default="quick")
    ap.add_argument("--trajectories", type=int, default=30)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--old", default="navbench-1")
    ap.add_argument("--new", default="navbench-2")
    ap.add_argument("--boot", type=int, default=10000)
    args = ap.parse_args()
    metas = {v: run_study(args, v) for v in (args.old, args.new)}
    for v, m in metas.items():
        print(f"{v}: study {m['study_key'][:12]}, map {m['map_key'][:12]}, {m['version_line']}, "
              f"{'cached' if m['cached'] else 'computed'} ({m['wall_s']:.0f} s)")
    old, new = load(metas[args.old]["study_key"]), load(metas[args.new]["study_key"])
    for k in ("true_poses", "controls", "noise"):
        if not np.array_equal(old["trajectories"][k], new["trajectories"][k]):
            raise SystemExit(f"the two studies' recorded {k} differ: not paired")
    print(f"\n{args.level}, profile {args.profile} (--map fit), {args.trajectories} trajectories x "
          f"{args.steps} steps, noise tracking, camera half; ATE = location RMSE (m); "
          f"diff = {args.new} - {args.old}, 95 % percentile bootstrap over the paired "
          f"trajectories ({args.boot} resamples, seed 0)\n")
    head = (f"{'estimator':<10} {'n':>3} {'median ' + args.old:>18} {'median ' + args.new:>18} "
            f"{'median diff [95 % CI]':>32} {'mean ' + args.old:>16} {'mean ' + args.new:>16} "
            f"{'mean diff [95 % CI]':>32}")
    print(head)
    print("-" * len(head))
    for name in ESTIMATORS:
        a, b = paired_ate(old, new, name)
        s = boot(a, b, args.boot)
        print(f"{name:<10} {len(a):>3} {np.median(a):>18.5f} {np.median(b):>18.5f} "
              f"{s['median_diff']:>+10.5f} [{s['median_ci'][0]:+.5f}, {s['median_ci'][1]:+.5f}] "
              f"{np.mean(a):>16.5f} {np.mean(b):>16.5f} "
              f"{s['mean_diff']:>+10.5f} [{s['mean_ci'][0]:+.5f}, {s['mean_ci'][1]:+.5f}]")


if __name__ == "__main__":
    main()
