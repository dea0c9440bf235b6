"""Replay the localiser's stop rule (issue 14, ``close_margin``) on recorded searches.

    PYTHONPATH=. .venv/bin/python docs/data/localisation/localize_stop_replay.py tune-house --map true --queries 1000
    ... --map fit --profile quick | --changes OC1 --queries 300

Runs ``localize-eval``'s queries (the same draw as ``docs/data/localisation/localize_diagnose.py``) with every
fast-path candidate refined up to ``close_max`` once one verifies (``close_margin`` huge), and
records per query each candidate's coarse cost and its verified hypothesis (score, confidence,
within 0.5 m of the truth). The order in which candidates are refined does not depend on where
the search stops, so any stop rule can be applied afterwards: the answer is the best score among
the candidates refined before it stops. Prints recall within 50 cm and refined candidates per
query for no extension, the ratio rule (next cost <= (1 + m) x best) and the difference rule
(next cost - best <= d, the default since 2026-11-26). Queries that needed the robust search
keep their recorded answer under every rule (the rule does not extend robust candidates).
Tune on ``tune-house`` only. Writes nothing but the cache it needs.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[3]))


def replay(recs, close, close_max: int, accept: float, min_candidates: int) -> tuple[float, float]:
    """``(recall, refined per query)`` of the stop rule ``close(costs, i)`` (refine candidate ``i``?)."""
    ok, nref = 0, []
    for costs, refined, robust in recs:
        stop = len(refined)
        if not robust:
            for i in range(1, len(refined) + 1):
                if i >= min_candidates and any(h[1] >= accept for h in refined[:i]):
                    if not (i < close_max and i < len(costs) and close(costs, i)):
                        stop = i
                        break
        ok += max(refined[:stop], key=lambda h: h[0])[2]
        nref.append(stop)
    return ok / len(recs), float(np.mean(nref))


def main() -> None:
    from localize_diagnose import add_study_arguments, study_localizer

    from navbench.localize import Localizer

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_study_arguments(ap, queries=300)
    ap.add_argument("--close-max", type=int, default=6)
    args = ap.parse_args()
    args.option = ["close_margin=1e9", f"close_max={args.close_max}"]
    loc, _, queries = study_localizer(args)
    cfg = loc.config
    seen: list = []
    coarse = Localizer.coarse_candidates

    def recording(self, Q, count, costs=None):
        out = coarse(self, Q, count, costs)
        seen.append(list(costs or []))
        return out

    Localizer.coarse_candidates = recording
    recs = []
    for true, frame, _ in queries:
        seen.clear()
        loc.localize(frame)
        refined = [(float(h.score), float(h.confidence), math.hypot(*(h.pose[:2] - true[:2])) <= 0.5)
                   for h in loc.last_refined]
        recs.append((seen[0], refined, loc.last_timing["robust"] > 0))
    Localizer.coarse_candidates = coarse
    print(f"{args.level}, map {args.map}, {len(recs)} queries, changes {args.changes}: recall within 50 cm / "
          f"refined candidates per query (mean)")
    rules = [("off (close_margin = 0)", lambda c, i: False)]
    rules += [(f"ratio {m}", lambda c, i, m=m: c[i] <= (1 + m) * c[0]) for m in (0.25, 0.5, 1.0)]
    rules += [(f"difference {d}", lambda c, i, d=d: c[i] - c[0] <= d) for d in (0.5, 1.0, 2.0, 3.0, 5.0)]
    for name, rule in rules:
        r, n = replay(recs, rule, args.close_max, cfg.accept, cfg.min_candidates)
        print(f"  {name:24s} {100 * r:5.1f} %  {n:.2f}")


if __name__ == "__main__":
    main()
