"""Query time of two localiser settings, measured in alternation (issue 14, section 5's 20 ms).

    PYTHONPATH=. .venv/bin/python docs/data/localisation/localize_speed.py tune-house --map fit --queries 60 \
        --a geo_threshold=5.0 --a front_weight=1.0 --a beyond_weight=1.0 --a screen_margin=0.0

Setting A is the default :class:`~navbench.localize.LocalizerConfig` with the ``--a KEY=VALUE``
changes, setting B the default with the ``--b`` changes (both share one bank: only refinement
and verification settings may differ). Every query is localised by A and by B in turn, in an
order that alternates, so that machine load hits both alike; prints per setting the median and
p90 of the query's wall and process-CPU time, the median of each ``last_timing`` phase, recall
within 50 cm, and the B / A ratio of the CPU medians. Also times the coarse correlation's two
paths on the same queries: the full cost table and its row minima (``Correlator.costs``) and
the fused float32 row minima (``Correlator.best``). Writes nothing but the cache it needs. Run
it on an otherwise idle machine for absolute figures; under load compare ratios only.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("level")
    ap.add_argument("--map", default="fit")
    ap.add_argument("--profile", default=None)
    ap.add_argument("--queries", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sampling", default="uniform")
    ap.add_argument("--a", action="append", default=[], help="KEY=VALUE of setting A")
    ap.add_argument("--b", action="append", default=[], help="KEY=VALUE of setting B")
    args = ap.parse_args()

    from navbench.cli.commands.localize_eval import _localizer_config
    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.localize import Localizer
    from navbench.pipeline.profiles import load_profile
    from navbench.pipeline.run import stage_context
    from navbench.pipeline.stages import study_level, study_map
    from navbench.pipeline.stages.level import load_level_ref
    from navbench.pipeline.stages.localize import bank_config, draw_queries, load_localizer

    cfgs = {"A": _localizer_config(args.a), "B": _localizer_config(args.b)}
    if bank_config(cfgs["A"], 0.0) != bank_config(cfgs["B"], 0.0):
        raise SystemExit("A and B must share the bank: change only refinement/verification fields")
    prof = load_profile(args.profile) if args.map == "fit" else None
    ctx = stage_context()
    level_ref = study_level(ctx, args.level, prof)
    vmap = study_map(ctx, args.map, level_ref, prof)
    intr = camera_by_name("half")
    loc_a, _ = load_localizer(ctx, vmap, intr, CAMERA_HEIGHT, cfgs["A"], level=level_ref)
    locs = {"A": loc_a, "B": Localizer(loc_a.world_model, intr, CAMERA_HEIGHT, cfgs["B"], loc_a.bank)}
    queries = list(draw_queries(load_level_ref(level_ref), args.queries, args.seed, 0.1, intr,
                                sampling=args.sampling))
    for loc in locs.values():  # compile and warm up
        loc.localize(queries[0][1])
    rec = {k: {"wall": [], "cpu": [], "ok": [], "phases": {}} for k in locs}
    corr = {"costs": [], "best": []}
    for n, (pose, frame, _) in enumerate(queries):
        for name in (("A", "B") if n % 2 == 0 else ("B", "A")):
            loc = locs[name]
            h = loc.localize(frame)[0]
            r = rec[name]
            r["wall"].append(loc.last_timing["total"])
            r["cpu"].append(loc.last_timing["cpu"])
            r["ok"].append(float(np.hypot(*(h.pose[:2] - pose[:2]))) <= 0.5)
            for k, v in loc.last_timing.items():
                r["phases"].setdefault(k, []).append(v)
        Q = loc_a.query_signature(frame)
        for name in (("costs", "best") if n % 2 == 0 else ("best", "costs")):
            c0 = time.process_time()
            if name == "costs":
                D = loc_a._corr.costs(Q)
                np.argmin(D, axis=1), D.min(axis=1)
            else:
                loc_a._corr.best(Q)
            corr[name].append(1e3 * (time.process_time() - c0))
    for name, r in rec.items():
        print(f"{name} ({', '.join((args.a if name == 'A' else args.b)) or 'defaults'}): "
              f"wall median {np.median(r['wall']):.1f} ms (p90 {np.percentile(r['wall'], 90):.1f}), "
              f"CPU median {np.median(r['cpu']):.1f} ms (p90 {np.percentile(r['cpu'], 90):.1f}), "
              f"recall 50 cm {100 * np.mean(r['ok']):.1f} %; phases (median ms) "
              + ", ".join(f"{k} {np.median(v):.1f}" for k, v in r["phases"].items()))
    print(f"B / A CPU median: {np.median(rec['B']['cpu']) / np.median(rec['A']['cpu']):.2f}")
    print(f"correlation CPU median: cost table + minima {np.median(corr['costs']):.1f} ms, "
          f"fused minima {np.median(corr['best']):.1f} ms")


if __name__ == "__main__":
    main()
