"""The acceptance test of a benchmark version change (issue 36 §3; ``docs/changelog.md``).

The same grid (profile ``acceptance``) is run under the old and the new version, one database
each. The new version is **accepted** when both hold:

1. **No cell gets worse.** For every estimator and noise level, the paired SPL difference
   ``new - old`` (episodes paired on level, noise, task and seed, pooled over levels) has
   ``|mean| <= tolerance`` (0.01), or its 95 % interval lies above 0 (the new version better).
2. **The paper's claim holds under both.** At every noise level and under each version,
   ``ours - ablation`` SPL is > 0 with its 95 % interval excluding 0, for each ablation
   (``no-map`` and ``dynamics``: every other estimator of the grid but the oracle ``gt``).

Both are computed by :func:`navbench.results.compare.compare` (the same pairing, scoring preset
and intervals as ``navbench compare``); nothing here is a new statistic.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from navbench.errors import ConfigError

if TYPE_CHECKING:  # pragma: no cover
    import pandas

#: How far a version change may move a cell's mean SPL without its interval showing it better.
TOLERANCE = 0.01
#: The estimator the paper's claim is about, and estimators never taken as its ablations.
CLAIM_BASE = "ours"
NOT_ABLATIONS = ("gt",)

#: Columns of :attr:`Acceptance.cells` and :attr:`Acceptance.claim`.
CELL_COLUMNS = ["estimator", "noise", "pairs", "spl_old", "spl_new", "spl_diff", "spl_diff_ci_low",
                "spl_diff_ci_high", "success_old", "success_new", "success_diff", "success_diff_ci_low",
                "success_diff_ci_high", "verdict"]
CLAIM_COLUMNS = ["version", "ablation", "noise", "pairs", "spl_diff", "spl_diff_ci_low", "spl_diff_ci_high",
                 "holds"]


@dataclass
class Acceptance:
    """What :func:`acceptance` returns: one row per (estimator, noise) of ``new - old``
    (``cells``), one per (version, ablation, noise) of ``ours - ablation`` (``claim``), the
    verdict and, when it is no, every reason (``failures``)."""

    old: str
    new: str
    cells: "pandas.DataFrame"
    claim: "pandas.DataFrame"
    accepted: bool
    failures: list[str]
    preset: str
    interval: str
    tolerance: float = TOLERANCE
    warnings: list[str] = field(default_factory=list)


def cell_verdict(diff: float, low: float, tolerance: float = TOLERANCE) -> str:
    """``"within"`` (|diff| <= tolerance), ``"better"`` (interval above 0) or ``"worse"``
    (neither: the rule fails). A cell within the tolerance is called ``within`` even when its
    interval is also above 0."""
    if abs(diff) <= tolerance + 1e-12:
        return "within"
    if low > 0:
        return "better"
    return "worse"


def acceptance(old_db: str, new_db: str, *, tolerance: float = TOLERANCE, ablations=None,
               level: list[str] | None = None, method: str = "bca", n_boot: int | None = None,
               seed: int = 0) -> Acceptance:
    """The acceptance test of ``new_db``'s version against ``old_db``'s (module docstring).

    ``ablations``: the estimators ``ours`` must beat (default: every estimator both databases
    hold but ``ours`` and ``gt``). Each database is read at its newest version; both at the same
    version is a :class:`ConfigError` (there is no change to accept)."""
    import pandas as pd

    from navbench.results.compare import compare

    if not tolerance >= 0:
        raise ConfigError(f"--tolerance must be >= 0, not {tolerance}")
    versions = compare(db=old_db, b_db=new_db, level=level, method=method, n_boot=n_boot, seed=seed)
    old, new = _version(versions.side_a), _version(versions.side_b)
    if old == new:
        raise ConfigError(f"both databases hold {old}: the acceptance test compares two benchmark versions "
                          "(run the grid under each, one database each)")
    pooled = versions.table[versions.table["level"] == "all"]
    cells = pd.DataFrame({
        "estimator": pooled["estimator_a"], "noise": pooled["noise"], "pairs": pooled["pairs"],
        "spl_old": pooled["spl_a"], "spl_new": pooled["spl_b"], "spl_diff": pooled["spl_diff"],
        "spl_diff_ci_low": pooled["spl_diff_ci_low"], "spl_diff_ci_high": pooled["spl_diff_ci_high"],
        "success_old": pooled["success_a"], "success_new": pooled["success_b"],
        "success_diff": pooled["success_diff"], "success_diff_ci_low": pooled["success_diff_ci_low"],
        "success_diff_ci_high": pooled["success_diff_ci_high"],
    }).reset_index(drop=True)
    cells["verdict"] = [cell_verdict(d, lo, tolerance) for d, lo in zip(cells["spl_diff"], cells["spl_diff_ci_low"])]
    failures = [f"{r.estimator} at {r.noise} noise: SPL {new} - {old} {r.spl_diff:+.3f} "
                f"[{r.spl_diff_ci_low:+.3f}, {r.spl_diff_ci_high:+.3f}] is neither within ±{tolerance:g} "
                f"nor better" for r in cells.itertuples() if r.verdict == "worse"]

    held = set(cells["estimator"])
    if CLAIM_BASE not in held:
        raise ConfigError(f"the databases share no {CLAIM_BASE!r} episodes: the paper's claim cannot be checked "
                          f"(they share: {', '.join(sorted(held))})")
    if ablations is None:
        ablations = sorted(held - {CLAIM_BASE, *NOT_ABLATIONS})
    if not ablations:
        raise ConfigError(f"no ablation to check the claim against: the databases hold only {', '.join(sorted(held))}")
    claim_rows = []
    warnings = [w for w in versions.warnings if "comparison across benchmark versions" not in w]
    for version, db in ((old, old_db), (new, new_db)):
        c = compare(db=db, pairs=[(a, CLAIM_BASE) for a in ablations], level=level, method=method,
                    n_boot=n_boot, seed=seed)
        warnings += [f"{version}: {w}" for w in c.warnings]
        for r in c.table[c.table["level"] == "all"].itertuples():
            holds = bool(r.spl_diff > 0 and r.spl_diff_ci_low > 0)
            claim_rows.append([version, r.estimator_a, r.noise, r.pairs, r.spl_diff, r.spl_diff_ci_low,
                               r.spl_diff_ci_high, holds])
            if not holds:
                failures.append(f"the claim fails under {version} at {r.noise} noise: {CLAIM_BASE} - "
                                f"{r.estimator_a} SPL {r.spl_diff:+.3f} [{r.spl_diff_ci_low:+.3f}, "
                                f"{r.spl_diff_ci_high:+.3f}] does not exclude 0 from above")
    claim = pd.DataFrame(claim_rows, columns=CLAIM_COLUMNS)
    return Acceptance(old=old, new=new, cells=cells[CELL_COLUMNS], claim=claim, accepted=not failures,
                      failures=failures, preset=versions.preset, interval=versions.interval,
                      tolerance=tolerance, warnings=warnings)


def _version(side: str) -> str:
    """The version a side's description ends with (``compare``'s ``"..., navbench-2"``)."""
    return side.rsplit(", ", 1)[-1] if ", " in side else side


def markdown(result: Acceptance) -> str:
    """The two tables and the verdict as the changelog prints them."""
    from navbench.results.compare import fmt_diff

    lines = [f"**{result.new} against {result.old}: {'accepted' if result.accepted else 'not accepted'}** "
             f"(tolerance ±{result.tolerance:g} SPL; preset {result.preset}; intervals: {result.interval})", "",
             f"| estimator | noise | pairs | SPL {result.old} | SPL {result.new} | SPL difference [95 %] | "
             f"success difference [95 %] | verdict |", "|---|---|---|---|---|---|---|---|"]
    for r in result.cells.itertuples():
        lines.append(f"| `{r.estimator}` | {r.noise} | {r.pairs} | {r.spl_old:.3f} | {r.spl_new:.3f} | "
                     f"{fmt_diff(r.spl_diff, r.spl_diff_ci_low, r.spl_diff_ci_high)} | "
                     f"{fmt_diff(r.success_diff, r.success_diff_ci_low, r.success_diff_ci_high)} | {r.verdict} |")
    lines += ["", f"| version | `{CLAIM_BASE}` − | noise | pairs | SPL difference [95 %] | claim |",
              "|---|---|---|---|---|---|"]
    for r in result.claim.itertuples():
        lines.append(f"| {r.version} | `{r.ablation}` | {r.noise} | {r.pairs} | "
                     f"{fmt_diff(r.spl_diff, r.spl_diff_ci_low, r.spl_diff_ci_high)} | "
                     f"{'holds' if r.holds else 'fails'} |")
    if result.failures:
        lines += ["", "Why not:", ""] + [f"- {f}" for f in result.failures]
    return "\n".join(lines) + "\n"
