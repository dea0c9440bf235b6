"""Issue 14's figures for long trajectories and the kidnapped robot, pooled over levels.

    .venv/bin/python docs/data/localisation/kidnap_figures.py --levels house-1,house-2 --trajectories 2 --steps 300 \\
        --kidnap-every 50 --map true --relocalizer grid

For every level it runs two ``navbench track-eval`` studies (cached stages; rows stored in
``--db``), then pools their per-trajectory rows from the database:

1. **long trajectories, no kidnapping**: estimators ``ours`` (health test on: it only reads, the
   estimates are those of plain ``ours``) and ``dynamics``, body-frame odometry. Prints the ATE
   (translation RMSE without alignment) median / mean of ``ours``, the raw-odometry ATE of the
   same trajectories, ``ours``'s median step time, its alarms per step and its **false alarms
   per step** (alarms raised at a pose within 0.25 m and 10 deg of the truth: on these
   trajectories the others flag real one-step tracking failures) and the fraction of
   trajectories with a false alarm.
2. **kidnapping every N steps**: ``ours`` with ``recover=true`` and the relocaliser
   ``--relocalizer``. Prints the detection rate and the rate recovered within 5 steps
   (location < 0.25 m and heading < 10 deg).

``--health-threshold auto`` gives both studies ``-o ours.health_min_inliers=auto`` (the
threshold calibrated per map on its own views, printed per level); ``--keep K`` gives
``-o ours.relocalize_keep=K`` (runner-up hypotheses tracked for K steps after a
relocalisation); ``--plain-recover`` runs study 1 with ``recover=true`` (the tracker as it
would be deployed: an alarm relocalises; its ATE then is that of ``ours`` with recovery).
``--collisions stop`` records the trajectories without appendix D's freeze after a collision
(``track-eval --collisions``). Options at their defaults are not passed, so the studies stored
before them keep their keys.

Writes nothing but the studies' cache and rows; prints one table.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

import numpy as np


def track_eval(level: str, args, extra: list[str]) -> dict:
    cmd = [sys.executable, "-m", "navbench.cli.main", "track-eval", level, "--steps", str(args.steps),
           "--trajectories", str(args.trajectories), "--noise", args.noise, "--camera", args.camera,
           "--map", args.map.format(level=level), "--db", args.db, "--json", *extra]
    if args.profile:
        cmd += ["--profile", args.profile]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)}\n{p.stderr}")
    return json.loads(p.stdout)


def rows(db, study_key: str, estimator: str):
    f = db.tracking_frame(study_key=study_key)
    return f[f.estimator == estimator]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default="house-1,house-2,house-3,house-4,house-5,house-6")
    ap.add_argument("--trajectories", type=int, default=10)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--kidnap-every", type=int, default=50)
    ap.add_argument("--noise", default="mid")
    ap.add_argument("--camera", default="half")
    ap.add_argument("--map", default="fit", help="fit, true or a map file; {level} is replaced")
    ap.add_argument("--profile", default=None, help="profile of --map fit (e.g. paper)")
    ap.add_argument("--relocalizer", default="localize", help="localize or grid")
    ap.add_argument("--health-threshold", default="0.5",
                    help="ours's health_min_inliers: a number, or auto (calibrated per map)")
    ap.add_argument("--keep", type=int, default=0,
                    help="ours's relocalize_keep: steps runner-up hypotheses are tracked (0: off)")
    ap.add_argument("--plain-recover", action="store_true",
                    help="without kidnapping too, run ours with recover=true (as deployed) "
                    "instead of the read-only health test")
    ap.add_argument("--collisions", default="freeze", help="freeze or stop: track-eval --collisions")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--db", default="sqlite:///results/navbench.db")
    args = ap.parse_args()
    if args.health_threshold != "auto":
        try:
            ok = 0 <= float(args.health_threshold) <= 1
        except ValueError:
            ok = False
        if not ok:
            ap.error(f"--health-threshold: a number within [0, 1] or auto, got {args.health_threshold!r}")
    if args.keep < 0:
        ap.error(f"--keep: a step count >= 0, got {args.keep}")
    # options at their defaults are not passed: the studies keep the keys they were stored under
    health = [] if args.health_threshold == "0.5" else ["-o", f"ours.health_min_inliers={args.health_threshold}"]
    keep = [] if args.keep == 0 else ["-o", f"ours.relocalize_keep={args.keep}"]
    if args.collisions != "freeze":
        keep_col = ["--collisions", args.collisions]
    else:
        keep_col = []
    from navbench.results.db import ResultsDB

    db = ResultsDB(args.db)
    plain, kid = [], []
    for level in args.levels.split(","):
        seed = ["--seed", str(args.seed), *keep_col]
        plain_opts = (["-o", "ours.recover=true", "-o", f"ours.relocalizer_name={args.relocalizer}",
                       *keep] if args.plain_recover else ["-o", "ours.health=true"])
        a = track_eval(level, args, ["--estimators", "ours,dynamics", "--odometry", "body",
                                     *plain_opts, *health, *seed])
        b = track_eval(level, args, ["--estimators", "ours", "--kidnap-every", str(args.kidnap_every),
                                     "-o", "ours.recover=true", "-o",
                                     f"ours.relocalizer_name={args.relocalizer}", *health, *keep, *seed])
        plain.append(rows(db, a["meta"]["study_key"], "ours"))
        kid.append(rows(db, b["meta"]["study_key"], "ours"))
        th = {**a["meta"].get("health_thresholds", {}), **b["meta"].get("health_thresholds", {})}
        print(f"{level}: " + (f"threshold {th['ours']:.3f}, " if "ours" in th else "")
              + f"ATE median {a['ours']['loc_rmse_m_median']:.4f} m, raw odometry "
              f"{a['meta']['raw_odometry']['ate_m_median']:.3f} m, false alarms/step "
              f"{a['ours']['false_alarms_per_step']:.3%}, recovered<=5 {b['ours']['recovered_frac']:.1%}",
              flush=True)
    import pandas as pd

    p, k = pd.concat(plain), pd.concat(kid)
    steps = p.steps.sum()
    print(f"\n{len(args.levels.split(','))} levels, {args.trajectories} x {args.steps} steps each, "
          f"noise {args.noise}, camera {args.camera}, map {args.map}, kidnap every {args.kidnap_every}, "
          f"health_min_inliers {args.health_threshold}, relocalize_keep {args.keep}"
          + (", no-kidnap study with recovery on" if args.plain_recover else ""))
    print(f"ours ATE median {np.median(p.loc_rmse_m):.4f} m (mean {p.loc_rmse_m.mean():.4f}, "
          f"p90 {np.percentile(p.loc_rmse_m, 90):.4f}) over {len(p)} trajectories")
    print(f"raw odometry ATE median {np.median(p.raw_odom_ate_m):.4f} m (mean {p.raw_odom_ate_m.mean():.4f})")
    print(f"ours step median {np.median(p.step_ms_median):.1f} ms (render {np.median(p.render_ms):.1f}, "
          f"estimate {np.median(p.estimate_ms):.1f})")
    print(f"alarms without kidnapping: {int(p.alarms.sum())} in {int(steps)} steps = "
          f"{p.alarms.sum() / steps:.3%} per step; false alarms (at a pose within 0.25 m and 10 deg): "
          f"{int(p.false_alarms.sum())} = {p.false_alarms.sum() / steps:.3%} per step, "
          f"{np.mean(p.false_alarms > 0):.1%} of trajectories with one")
    n = k.kidnaps.sum()
    print(f"kidnaps {int(n)}: detected {k.kidnaps_detected.sum() / n:.1%}, recovered within 5 steps "
          f"{k.kidnaps_recovered.sum() / n:.1%}")


if __name__ == "__main__":
    main()
