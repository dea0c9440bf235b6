"""Why did a localisation query fail? (issue 14, section 1: search failure or inherent ambiguity)

    PYTHONPATH=. .venv/bin/python docs/data/localisation/localize_diagnose.py tune-house --map true --queries 100
    ... --map fit --profile quick --queries 100 [--changes OC1] [--sampling trajectory]
        [-o KEY=VALUE ...] [--show 20]

Runs ``localize-eval``'s queries (same draw: ``--seed``, ``--changes``) through the localiser and,
for every query whose best hypothesis is more than 0.5 m from the true pose, compares the chosen
hypothesis's score with the score of the *true* pose: the query frame verified at the true pose
as is, and after the same refinement a candidate gets, started at the true pose. Classes:

* ``ambiguity``: the chosen pose scores at least as well as the true pose (within :data:`TIE`) (verified and refined
  from there): the view cannot be told apart against this map by the localiser's score;
* ``search: no candidate``: the true pose would win, but no coarse candidate lay within 0.5 m and
  30 degrees of it (the coarse ranking missed it);
* ``search: not refined``: such a candidate existed but refinement stopped before it;
* ``search: screened out``: it was not aligned, its score at the coarse pose being too low
  (``screen_margin``);
* ``search: refinement lost``: it was refined but converged elsewhere (or verified worse).

Prints the counts, and per failure (up to ``--show``) the true and chosen pose, their scores, the
coarse rank of the first candidate near the truth and the distance of the true pose to the
nearest solid. Tune on ``tune-house`` (``navbench make-level tune-house --seed 1234``) only:
never on the reported levels. Writes nothing but the cache (bank, map) it needs.
"""

from __future__ import annotations

import argparse
import math
from collections import Counter

import numpy as np

#: Scores within this of each other are a tie (an ambiguity, not a search failure).
TIE = 0.005


def study_localizer(args):
    """``(localizer, level, queries)`` of ``localize-eval``'s study for the parsed ``args``
    (``level``, ``map``, ``profile``, ``queries``, ``seed``, ``changes``, ``camera``,
    ``sampling``, ``option``): the cached map and bank, exactly the stage's queries."""
    from navbench.cli.commands.localize_eval import _localizer_config
    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.pipeline.profiles import load_profile
    from navbench.pipeline.run import stage_context
    from navbench.pipeline.stages import study_level, study_map
    from navbench.pipeline.stages.level import load_level_ref
    from navbench.pipeline.stages.localize import LocalizeEvalConfig, load_localizer, study_queries

    cfg = LocalizeEvalConfig(queries=args.queries, seed=args.seed, camera=args.camera,
                             changes=args.changes, localizer=_localizer_config(args.option),
                             sampling=args.sampling).resolved()
    prof = load_profile(args.profile) if args.map == "fit" else None
    ctx = stage_context()
    level_ref = study_level(ctx, args.level, prof)
    vmap = study_map(ctx, args.map, level_ref, prof)
    intr = camera_by_name(cfg.camera)
    loc, _ = load_localizer(ctx, vmap, intr, CAMERA_HEIGHT, cfg.localizer, level=level_ref)
    base = load_level_ref(level_ref)
    return loc, base, study_queries(base, cfg, intr)


def add_study_arguments(ap: argparse.ArgumentParser, queries: int = 100) -> None:
    """The arguments :func:`study_localizer` reads but ``option``: the level, its map and the
    query draw of ``localize-eval``."""
    ap.add_argument("level")
    ap.add_argument("--map", default="true")
    ap.add_argument("--profile", default=None)
    ap.add_argument("--queries", type=int, default=queries)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--changes", default=None)
    ap.add_argument("--camera", default="half")
    ap.add_argument("--sampling", default="uniform", help="uniform or trajectory")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_study_arguments(ap)
    ap.add_argument("--option", "-o", action="append", default=[])
    ap.add_argument("--show", type=int, default=20)
    args = ap.parse_args()

    from navbench.geometry import CAMERA_HEIGHT, wrap_angle
    from navbench.level import distance_to_solids

    loc, base, queries = study_localizer(args)
    intr = loc.intrinsics

    def near(pose, true):
        return (math.hypot(*(pose[:2] - true[:2])) <= 0.5
                and abs(math.degrees(float(wrap_angle(pose[2] - true[2])))) <= 30)

    full = loc.world_model.renderer(intr, CAMERA_HEIGHT)
    lc = loc.config

    def full_score(frame, pose):
        """The change-tolerant score on every pixel of the full-size frame (not the sample)."""
        from navbench.localize.localizer import one_sided_confidence

        pred = full.render(np.asarray(pose, np.float64))
        dc = np.abs(frame.rgb - pred.rgb).mean(axis=-1).ravel()
        _, rob, ok = one_sided_confidence(frame.depth.ravel(), frame.valid.ravel(), pred.depth.ravel(),
                                          pred.valid.ravel(), dc, lc.inlier_abs, lc.inlier_rel,
                                          lc.inlier_colour, lc.front_weight, lc.beyond_weight)
        return rob - (float(dc[ok].mean()) if ok.any() else 0.0)

    counts: Counter = Counter()
    wall = {"found": [], "failed": []}
    view = {"found": [], "failed": []}
    rows, ms, nref, heading_ok = [], [], [], []
    for n, (true, frame, diff) in enumerate(queries):
        h = loc.localize(frame)[0]
        ms.append(loc.last_timing["cpu"])
        nref.append(len(loc.last_refined))
        heading_ok.append(abs(math.degrees(float(wrap_angle(h.pose[2] - true[2])))) <= 10)
        err = math.hypot(*(h.pose[:2] - true[:2]))
        wall["found" if err <= 0.5 else "failed"].append(float(distance_to_solids(base, true[None, :2])[0]))
        view["found" if err <= 0.5 else "failed"].append(float(np.median(frame.depth[frame.valid])))
        if err <= 0.5:
            counts["found"] += 1
            continue
        at_true = loc.verify_at(frame, true)
        from_true = loc.refine(frame, true)
        best_true = max(at_true.score, from_true.score if near(from_true.pose, true) else -np.inf)
        rank = next((i for i, c in enumerate(loc.last_candidates) if near(c, true)), None)
        if h.score >= best_true - TIE:
            cls = "ambiguity"
        elif rank is None:
            cls = "search: no candidate"
        elif rank >= len(loc.last_refined):
            cls = "search: not refined"
        elif np.array_equal(loc.last_refined[rank].pose, loc.last_candidates[rank]):
            cls = "search: screened out"
        else:
            cls = "search: refinement lost"
        counts[cls] += 1
        full_gap = full_score(frame, from_true.pose if near(from_true.pose, true) else true) \
            - full_score(frame, h.pose)
        rows.append((n, cls, true, h, at_true, from_true, rank, len(loc.last_refined),
                     float(distance_to_solids(base, true[None, :2])[0]), diff, full_gap))

    total = sum(counts.values())
    print(f"{args.level}, map {args.map}, {total} queries, changes {args.changes}: "
          f"recall 50 cm {100 * counts['found'] / total:.1f} %, median query {np.median(ms):.1f} ms CPU (p90 {np.percentile(ms, 90):.1f}), "
          f"refined per query median {np.median(nref):.0f} (mean {np.mean(nref):.2f}, max {max(nref)}), "
          f"heading within 10 deg {100 * np.mean(heading_ok):.1f} %")
    for k, v in counts.most_common():
        print(f"  {k:26s} {v:4d}")
    edges = (0.0, 0.2, 0.4, 0.8, np.inf)
    ok_w, bad_w = np.array(wall["found"]), np.array(wall["failed"])
    print("  failure rate by the true pose's distance to the nearest solid: " + ", ".join(
        f"[{a:.1f}, {b:.1f}) m {int(((bad_w >= a) & (bad_w < b)).sum())}/"
        f"{int(((bad_w >= a) & (bad_w < b)).sum() + ((ok_w >= a) & (ok_w < b)).sum())}"
        for a, b in zip(edges[:-1], edges[1:])))
    ok_v, bad_v = np.array(view["found"]), np.array(view["failed"])
    print("  failure rate by the query's median depth: " + ", ".join(
        f"[{a:.1f}, {b:.1f}) m {int(((bad_v >= a) & (bad_v < b)).sum())}/"
        f"{int(((bad_v >= a) & (bad_v < b)).sum() + ((ok_v >= a) & (ok_v < b)).sum())}"
        for a, b in zip((0.0, 0.5, 1.0, 2.0), (0.5, 1.0, 2.0, np.inf))))
    print(f"  failures the true pose wins on every pixel of the full frame: "
          f"{sum(r[-1] > 0 for r in rows)} of {len(rows)}")
    amb = [r for r in rows if r[1] == "ambiguity"]
    if amb:  # does the wrong place explain more of the view than the true one (inlier share)?
        print(f"  ambiguities whose chosen pose has more inliers than the true pose: "
              f"{sum(r[3].confidence > r[4].confidence for r in amb)} of {len(amb)} "
              f"(true pose's inlier share median {np.median([r[4].confidence for r in amb]):.2f}, "
              f"chosen's {np.median([r[3].confidence for r in amb]):.2f})")
    for n, cls, true, h, at_true, from_true, rank, nr, clear, diff, gap in rows[: args.show]:
        print(f"q{n:<4d} {cls:24s} true ({true[0]:6.2f},{true[1]:6.2f},{math.degrees(true[2]):7.1f}) "
              f"chosen ({h.pose[0]:6.2f},{h.pose[1]:6.2f},{math.degrees(h.pose[2]):7.1f}) "
              f"score chosen {h.score:.3f} (conf {h.confidence:.2f}) | true as-is {at_true.score:.3f} "
              f"(conf {at_true.confidence:.2f}) "
              f"refined {from_true.score:.3f} (moved {100 * math.hypot(*(from_true.pose[:2] - true[:2])):.1f} cm) "
              f"| near-true rank {rank} of {nr} refined | wall {clear:.2f} m | diff {100 * diff:.0f} % "
              f"| full-frame true - chosen {gap:+.3f}")


if __name__ == "__main__":
    main()
