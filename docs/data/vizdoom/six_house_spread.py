"""Issue 37 §4: the six-house grid with the heading search spread over the image, on both
backends, against the same grid with the default trackers (``six_house.py``'s databases).

``python docs/data/vizdoom/six_house_spread.py PYMUNK_DB VIZDOOM_DB PYMUNK_SPREAD_DB VIZDOOM_SPREAD_DB``
(sqlite URLs or paths). The spread databases come from the same commands as the default ones plus
``--set navigation.options.ours.yaw_search_spread=true --set navigation.options.no-map.yaw_search_spread=true``
(the same cache, so the same views, maps, tasks and seeds). Printed, as Markdown tables:

1. SPL per estimator and noise on each backend, default and spread, beside the paper's Fig. 5a;
2. spread − default per backend (``dynamics`` reads no frame: its difference must be exactly 0);
3. vizdoom − pymunk with the spread search (the engine's effect once the search's flaw is gone);
4. the paper's claim (``ours`` − each ablation) per backend with the spread search.

Every difference is :func:`navbench.results.compare.compare`'s (episodes paired on level, noise,
task and seed, pooled over the levels; 95 % BCa bootstrap intervals stratified by level)."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from navbench.results.compare import compare, fmt_diff  # noqa: E402

PAPER = {("ours", "low"): 0.92, ("ours", "mid"): 0.79, ("ours", "high"): 0.46,
         ("no-map", "low"): 0.61, ("no-map", "mid"): 0.51, ("no-map", "high"): 0.37,
         ("dynamics", "low"): 0.61, ("dynamics", "mid"): 0.52, ("dynamics", "high"): 0.33}
NOISE = ("low", "mid", "high")
ESTIMATORS = ("ours", "no-map", "dynamics")


def url(x: str) -> str:
    return x if "://" in x else f"sqlite:///{Path(x).resolve()}"


def pooled(c) -> dict:
    """(estimator_a, estimator_b, noise) -> the row pooled over levels."""
    t = c.table[c.table["level"] == "all"]
    return {(r.estimator_a, r.estimator_b, r.noise): r for r in t.itertuples()}


def diff_table(title: str, a_db: str, b_db: str, a_name: str, b_name: str) -> dict:
    c = compare(db=a_db, b_db=b_db)
    rows = pooled(c)
    print(f"### {title}")
    print()
    print(f"| estimator | noise | pairs | SPL {a_name} | SPL {b_name} | SPL {b_name} − {a_name} [95 %] | "
          f"success {b_name} − {a_name} [95 %] |")
    print("|---|---|---|---|---|---|---|")
    for e in ESTIMATORS:
        for n in NOISE:
            r = rows.get((e, e, n))
            if r is None:
                continue
            print(f"| `{e}` | {n} | {r.pairs} | {r.spl_a:.3f} | {r.spl_b:.3f} | "
                  f"{fmt_diff(r.spl_diff, r.spl_diff_ci_low, r.spl_diff_ci_high)} | "
                  f"{fmt_diff(r.success_diff, r.success_diff_ci_low, r.success_diff_ci_high)} |")
    for w in c.warnings:
        if "comparison across benchmark versions" not in w:
            print(f"\nwarning: {w}")
    print()
    return rows


def main(argv: list[str]) -> int:
    if len(argv) != 4:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    pym, viz, pym_s, viz_s = map(url, argv)
    spl = {}
    for backend, default, spread in (("pymunk", pym, pym_s), ("vizdoom", viz, viz_s)):
        rows = diff_table(f"{backend}: spread search − default search", default, spread, "default", "spread")
        for (e, _, n), r in rows.items():
            spl[(backend, "default", e, n)] = r.spl_a
            spl[(backend, "spread", e, n)] = r.spl_b
        dyn = [r.spl_diff for (e, _, n), r in rows.items() if e == "dynamics"]
        print(f"`dynamics` reads no frame: spread − default is exactly 0 in every cell: "
              f"{all(d == 0 for d in dyn)} ({len(dyn)} cells)\n")
    print("### SPL low / mid / high")
    print()
    print("| estimator | pymunk, default | pymunk, spread | ViZDoom, default | ViZDoom, spread | paper |")
    print("|---|---|---|---|---|---|")
    for e in ESTIMATORS:
        cells = [" / ".join(f"{spl.get((b, s, e, n), float('nan')):.2f}" for n in NOISE)
                 for b in ("pymunk", "vizdoom") for s in ("default", "spread")]
        print(f"| `{e}` | {' | '.join(cells)} | {' / '.join(f'{PAPER[(e, n)]:.2f}' for n in NOISE)} |")
    print()
    diff_table("spread search: vizdoom − pymunk", pym_s, viz_s, "pymunk", "vizdoom")
    print("### The paper's claim with the spread search: `ours` − ablation")
    print()
    print("| backend | `ours` − | noise | pairs | SPL difference [95 %] | holds | paper |")
    print("|---|---|---|---|---|---|---|")
    for backend, db in (("pymunk", pym_s), ("vizdoom", viz_s)):
        c = compare(db=db, pairs=[("no-map", "ours"), ("dynamics", "ours")])
        for (a, _, n), r in sorted(pooled(c).items(), key=lambda kv: (kv[0][0], NOISE.index(kv[0][2]))):
            holds = r.spl_diff > 0 and r.spl_diff_ci_low > 0
            print(f"| {backend} | `{a}` | {n} | {r.pairs} | "
                  f"{fmt_diff(r.spl_diff, r.spl_diff_ci_low, r.spl_diff_ci_high)} | {'yes' if holds else 'no'} | "
                  f"{PAPER[('ours', n)] - PAPER[(a, n)]:+.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
