"""How precise is the robust search's place in changed rooms? (issue 14, OC4 diagnosis)

    PYTHONPATH=. .venv/bin/python docs/data/localisation/robust_region_rank.py tune-house --map fit --profile quick \\
        --changes OC4 --queries 100

For each ``localize-eval`` query (same draw: ``--seed``, ``--changes``) it runs the robust search
(:meth:`navbench.localize.Localizer.robust_costs`, the localiser's settings) over every
lattice point and prints where the lattice point nearest the true pose ranks among the points
within ``--radius`` m of the truth (0: it is its neighbourhood's best, the candidate the
non-maximum suppression keeps), the heading error at its best shift, and its rank over the whole
lattice; then the shares of queries at rank 0, <= 2 and <= 4. Tune on ``tune-house`` only.
Writes nothing but the cache (bank, map) it needs.
"""

from __future__ import annotations

import argparse
import math

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("level")
    ap.add_argument("--map", default="fit")
    ap.add_argument("--profile", default="quick")
    ap.add_argument("--queries", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--changes", default="OC4")
    ap.add_argument("--radius", type=float, default=0.5)
    ap.add_argument("--option", "-o", action="append", default=[])
    args = ap.parse_args()

    from localize_diagnose import study_localizer  # this script's folder (on sys.path)

    from navbench.geometry import wrap_angle

    args.camera, args.sampling = "half", "uniform"
    loc, _, queries = study_localizer(args)
    c, points = loc.config, loc.bank.points
    ranks = []
    for n, (true, frame, _) in enumerate(queries):
        shift, cost = loc.robust_costs(loc.query_signature(frame))
        d = np.hypot(points[:, 0] - true[0], points[:, 1] - true[1])
        tp = int(np.argmin(d))
        region = np.flatnonzero(d < args.radius)
        order = region[np.argsort(cost[region], kind="stable")]
        rank = int(np.flatnonzero(order == tp)[0])
        ranks.append(rank)
        head = abs(math.degrees(float(wrap_angle(shift[tp] * 2 * math.pi / c.bins - true[2]))))
        print(f"q{n:<4d} nearest lattice point {100 * d[tp]:.0f} cm from the truth: rank {rank} of "
              f"{len(region)} within {args.radius} m (their best {100 * d[order[0]]:.0f} cm from it), "
              f"heading error {head:.1f} deg, rank {int((cost < cost[tp]).sum())} of {len(points)} overall")
    r = np.array(ranks)
    print(f"{args.level}, map {args.map}, {len(r)} queries, changes {args.changes}: nearest point best of "
          f"its neighbourhood {np.mean(r == 0):.0%}, among its 3 best {np.mean(r <= 2):.0%}, 5 best {np.mean(r <= 4):.0%}")


if __name__ == "__main__":
    main()
