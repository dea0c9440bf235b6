"""Issue 36: the heading-search fix alone (navbench-1 with ``yaw_search_spread = true`` on
``ours`` and ``no-map``) judged by the acceptance rule of a version change against navbench-1.

    python docs/data/versions/heading-fix-2026-11-27/verdict.py ACCEPTANCE_1_DB FIX_DB

``ACCEPTANCE_1_DB``: the navbench-1 acceptance grid (``docs/data/versions/acceptance-2026-11-27/
acceptance-1.db.gz``, gunzipped); ``FIX_DB``: the same grid's ``ours`` and ``no-map`` run with the
fix (``navbench all --profile acceptance --benchmark-version navbench-1 --set
navigation.estimators=ours,no-map --set navigation.options.ours.yaw_search_spread=true --set
navigation.options.no-map.yaw_search_spread=true``) on the same cached maps. ``dynamics`` reads no
frame, so the fix cannot touch it: its rows are navbench-1's, and the claim's ``ours − dynamics``
pairs the fix's ``ours`` with navbench-1's ``dynamics`` on the same level, noise, task and seed.

Both databases hold navbench-1 rows, so ``navbench compare --acceptance`` (which compares two
versions) refuses them; this script applies the same rule
(:func:`navbench.results.acceptance.cell_verdict`, the paired differences of
:func:`navbench.results.compare.compare`) and prints the verdict and every reason."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[4]
sys.path.insert(0, str(ROOT))

from navbench.results.acceptance import TOLERANCE, cell_verdict  # noqa: E402
from navbench.results.compare import compare, fmt_diff  # noqa: E402

NOISE = ("low", "mid", "high")


def url(x: str) -> str:
    return x if "://" in x else f"sqlite:///{Path(x).resolve()}"


def pooled(c) -> dict:
    t = c.table[c.table["level"] == "all"]
    return {(r.estimator_a, r.estimator_b, r.noise): r for r in t.itertuples()}


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    old, fix = map(url, argv)
    failures = []
    print("### The fix − navbench-1, per estimator and noise (the rule: |mean SPL difference| <= "
          f"{TOLERANCE} or the interval above 0)")
    print()
    print("| estimator | noise | pairs | SPL navbench-1 | SPL fix | SPL fix − navbench-1 [95 %] | "
          "success fix − navbench-1 [95 %] | verdict |")
    print("|---|---|---|---|---|---|---|---|")
    cells = pooled(compare(db=old, b_db=fix))
    for e in ("ours", "no-map"):
        for n in NOISE:
            r = cells[(e, e, n)]
            v = cell_verdict(r.spl_diff, r.spl_diff_ci_low)
            if v == "worse":
                failures.append(f"{e} at {n} noise: SPL {r.spl_diff:+.3f} [{r.spl_diff_ci_low:+.3f}, "
                                f"{r.spl_diff_ci_high:+.3f}]")
            print(f"| `{e}` | {n} | {r.pairs} | {r.spl_a:.3f} | {r.spl_b:.3f} | "
                  f"{fmt_diff(r.spl_diff, r.spl_diff_ci_low, r.spl_diff_ci_high)} | "
                  f"{fmt_diff(r.success_diff, r.success_diff_ci_low, r.success_diff_ci_high)} | {v} |")
    print("| `dynamics` | all | – | – | – | +0 by construction (reads no frame) | | within |")
    print()
    print("### The paper's claim, `ours` − ablation, under each")
    print()
    print("| under | `ours` − | noise | pairs | SPL difference [95 %] | holds |")
    print("|---|---|---|---|---|---|")
    sides = [("navbench-1", compare(db=old, pairs=[("no-map", "ours"), ("dynamics", "ours")])),
             ("the fix", compare(db=fix, pairs=[("no-map", "ours")])),
             ("the fix", compare(db=old, b_db=fix, pairs=[("dynamics", "ours")]))]
    for name, c in sides:
        for (a, _, n), r in sorted(pooled(c).items(), key=lambda kv: (kv[0][0], NOISE.index(kv[0][2]))):
            holds = bool(r.spl_diff > 0 and r.spl_diff_ci_low > 0)
            if not holds:
                failures.append(f"the claim under {name} at {n} noise: ours - {a} {r.spl_diff:+.3f} "
                                f"[{r.spl_diff_ci_low:+.3f}, {r.spl_diff_ci_high:+.3f}]")
            print(f"| {name} | `{a}` | {n} | {r.pairs} | "
                  f"{fmt_diff(r.spl_diff, r.spl_diff_ci_low, r.spl_diff_ci_high)} | {'yes' if holds else 'no'} |")
    print()
    print(f"**Verdict: {'accepted' if not failures else 'not accepted'}**")
    for f in failures:
        print(f"- {f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
