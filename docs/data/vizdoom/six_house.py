"""Issue 37 §4: the six-house grid on both backends, paired (vizdoom - pymunk) per estimator and
noise, pooled over the houses both databases hold, and the paper's claim under each backend.

``python docs/data/vizdoom/six_house.py PYMUNK_DB VIZDOOM_DB`` (sqlite URLs or paths). The
pairing and intervals are ``navbench compare``'s (through :func:`navbench.results.acceptance.acceptance`,
whose cells are exactly "new - old" per estimator and noise; its accept/reject verdict is about
benchmark versions and is not printed here). The paper's Fig. 5a SPL is printed beside them."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from navbench.results.acceptance import acceptance  # noqa: E402
from navbench.results.compare import fmt_diff  # noqa: E402

PAPER = {("ours", "low"): 0.92, ("ours", "mid"): 0.79, ("ours", "high"): 0.46,
         ("no-map", "low"): 0.61, ("no-map", "mid"): 0.51, ("no-map", "high"): 0.37,
         ("dynamics", "low"): 0.61, ("dynamics", "mid"): 0.52, ("dynamics", "high"): 0.33}


def url(x: str) -> str:
    return x if "://" in x else f"sqlite:///{Path(x).resolve()}"


def main(argv: list[str]) -> None:
    r = acceptance(url(argv[0]), url(argv[1]))
    print(f"{r.new} - {r.old}, paired on level, noise, task and seed; {r.interval}")
    print()
    print("| estimator | noise | pairs | SPL pymunk | SPL vizdoom | paper | SPL vizdoom − pymunk [95 %] | success vizdoom − pymunk [95 %] |")
    print("|---|---|---|---|---|---|---|---|")
    for c in r.cells.itertuples():
        print(f"| `{c.estimator}` | {c.noise} | {c.pairs} | {c.spl_old:.3f} | {c.spl_new:.3f} | "
              f"{PAPER.get((c.estimator, c.noise), float('nan')):.2f} | "
              f"{fmt_diff(c.spl_diff, c.spl_diff_ci_low, c.spl_diff_ci_high)} | "
              f"{fmt_diff(c.success_diff, c.success_diff_ci_low, c.success_diff_ci_high)} |")
    print()
    print("| backend | `ours` − | noise | pairs | SPL difference [95 %] | paper |")
    print("|---|---|---|---|---|---|")
    for c in r.claim.itertuples():
        paper = PAPER[("ours", c.noise)] - PAPER[(c.ablation, c.noise)]
        print(f"| {c.version} | `{c.ablation}` | {c.noise} | {c.pairs} | "
              f"{fmt_diff(c.spl_diff, c.spl_diff_ci_low, c.spl_diff_ci_high)} | {paper:+.2f} |")
    for w in r.warnings:
        print(f"warning: {w}")


if __name__ == "__main__":
    main(sys.argv[1:])
