"""Replay the health test's alarms of stored no-kidnap tracking studies at another threshold.

    .venv/bin/python docs/data/localisation/false_alarm_replay.py b16fa98b 178c3b1e --threshold auto

Each argument is the key (prefix) of a ``track-eval`` artifact whose ``ours`` ran with the health
test on and no kidnapping (``-o ours.health=true``: the test only reads, so its stored inlier
fractions give the alarms of any threshold exactly, without rerunning). ``--threshold``: a number,
or ``auto`` (the study map's calibrated threshold, :mod:`navbench.pipeline.stages.health`,
computed and cached in ``--cache``). Prints per study and pooled: the false alarms per step
(alarms at a pose within 0.25 m and 10 deg, as ``track-eval``), split into those at an estimate
within 5 cm and 2 deg and the rest, and into the steps while the robot moves and the steps after
a collision froze it (appendix D; ``track-eval --collisions``). Writes nothing but the cache.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("studies", nargs="+", help="track-eval artifact keys (prefixes)")
    ap.add_argument("--threshold", default="auto", help="a number within [0, 1], or auto")
    ap.add_argument("--cache", default="results/cache")
    args = ap.parse_args()
    if args.threshold != "auto":
        try:
            fixed = float(args.threshold)
        except ValueError:
            fixed = -1.0
        if not 0 <= fixed <= 1:
            sys.exit(f"error: --threshold: a number within [0, 1] or auto, got {args.threshold!r}")
    from navbench.errors import NavbenchError

    try:
        run(args)
    except NavbenchError as e:
        sys.exit(f"error: {e}")


def run(args) -> None:
    import json

    from navbench.geometry import wrap_angle
    from navbench.pipeline.artifacts import MAP_FILE, STUDY_FILE, load_study
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.stages.context import StageContext
    from navbench.pipeline.stages.health import (HealthCalibrationConfig, calibration_views,
                                                 health_calibration_stage, tracker_options)
    from navbench.worldmodel.base import load_world_model

    store = ArtifactStore(args.cache)
    ctx = StageContext(store)
    tot = np.zeros(6)
    for prefix in args.studies:
        stage, key = store.find(prefix, "track-eval")
        d = store.load(stage, key)
        man = json.loads((d / "manifest.json").read_text())
        res = load_study(d / STUDY_FILE)
        e = res["estimators"].get("ours")
        if e is None or "inliers" not in e or res["trajectories"].get("kidnapped") is not None:
            sys.exit(f"error: study {key[:12]}: no ours with the health test, or kidnapping")
        map_key = man["inputs"]["map"]
        if args.threshold == "auto":
            mstage, mkey = store.find(map_key, ("fit-map", "true-map"))
            path = store.load(mstage, mkey) / MAP_FILE
            views = calibration_views(ctx, "fit", mkey, None)
            opts = res["config"].get("estimator_options", {}).get("ours", {})
            th = health_calibration_stage(ctx, views, mkey, lambda: load_world_model(path),
                                          HealthCalibrationConfig({}, tracker_options(opts))
                                          ).meta["threshold"]
        else:
            th = float(args.threshold)
        tp = res["trajectories"]["true_poses"]
        est, inl = e["est_poses"][:, 1:], e["inliers"]
        tr = tp[e["trajectory"], 1:]
        loc = np.hypot(est[..., 0] - tr[..., 0], est[..., 1] - tr[..., 1])
        rot = np.degrees(np.abs(wrap_angle(est[..., 2] - tr[..., 2])))
        on = (loc < 0.25) & (rot < 10.0)
        tight = (loc < 0.05) & (rot < 2.0)
        frozen = _frozen(tp, res["trajectories"]["collided"])[e["trajectory"]]
        fa = on & (inl < th)
        n, nm = inl.size, int(np.sum(~frozen))
        row = [n, fa.sum(), np.sum(fa & tight), nm, np.sum(fa & ~frozen), np.sum(frozen)]
        tot += row
        print(f"{res['level']} ({key[:12]}): threshold {th:.3f}; false alarms {_pct(fa.sum(), n)} "
              f"per step (within 5 cm, 2 deg: {_pct(row[2], n)}); while moving {_pct(row[4], nm)}"
              f" of {nm} steps; {int(row[5])} steps frozen after a collision", flush=True)
    print(f"pooled: false alarms {_pct(tot[1], tot[0])} per step (within 5 cm, 2 deg: "
          f"{_pct(tot[2], tot[0])}); while moving {_pct(tot[4], tot[3])} ({int(tot[4])} in "
          f"{int(tot[3])}); {int(tot[5])} of {int(tot[0])} steps frozen after a collision")


def _frozen(true_poses: np.ndarray, collided: np.ndarray) -> np.ndarray:
    """``(N, T)`` bool: step ``t`` of a collided trajectory lies after its last movement."""
    d = np.diff(true_poses, axis=1)
    moved = (np.hypot(d[..., 0], d[..., 1]) > 0) | (d[..., 2] != 0)
    out = np.zeros(moved.shape, bool)
    for n in np.flatnonzero(np.asarray(collided, bool)):
        last = np.flatnonzero(moved[n])
        out[n, (last[-1] + 1 if len(last) else 0):] = True
    return out


def _pct(a, b) -> str:
    return f"{a / b:.2%}" if b else "-"


if __name__ == "__main__":
    main()
