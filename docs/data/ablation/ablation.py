"""Where the gap comes from (issue 16, section 2): the paper's conditions on and off.

    .venv/bin/python docs/data/ablation/ablation.py --profile six --tasks 100 \\
        --condition pose_quantisation=round --condition direction_limit=true \\
        --condition collision_check=endpoint --all-on --db sqlite:///results/ablation.db

Runs the profile's grid (levels x noise x estimators x tasks) once with every condition at its
default (the *baseline*), once per ``--condition NAME=VALUE`` with that one condition changed, and
with ``--all-on`` once with all of them together; every run goes through the pipeline
(:func:`navbench.pipeline.run.run_profile`, ``until="navigation"``), so episodes are cached,
stored in ``--db`` and a rerun resumes. Then prints, per setting and noise level, pooled over the
levels: each estimator's SPL with a level-stratified bootstrap interval and success rate with a
Clopper-Pearson interval, the paired differences ``ours - no-map`` and ``ours - dynamics``
(same level, task and seed), and each estimator's SPL change against the baseline (paired).
Every setting sees the same tasks and the same simulator noise seeds.

The interval functions below are deliberately simple and local (issue 16 section 3 belongs to
another branch): replace ``success_ci``, ``mean_ci`` and ``paired_ci`` by the score module's
functions once they exist. Writes only the database and the pipeline cache; prints a table
(``--csv FILE`` also writes the rows).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

N_BOOT = 2000
LEVEL = 0.95


# ------------------------------------------- intervals (navbench.nav.metrics, as score's)

def success_ci(successes: int, n: int, level: float = LEVEL) -> tuple[float, float]:
    """Clopper-Pearson (exact binomial) interval of a success rate."""
    from navbench.nav.metrics import clopper_pearson

    return clopper_pearson(successes, n, level)


def mean_ci(values, strata, n_boot: int = N_BOOT, seed: int = 0, level: float = LEVEL) -> tuple[float, float]:
    """Bootstrap interval (BCa) of the mean of ``values``, resampling within each stratum (level)
    so every resample keeps each level's episode count: ``score``'s own interval."""
    from navbench.nav.metrics import stratified_bootstrap_ci

    v = np.asarray(values, dtype=np.float64)
    s = np.asarray(strata)
    return stratified_bootstrap_ci([v[s == k] for k in np.unique(s)], level, n_boot, seed)


def paired_ci(a, b, strata, n_boot: int = N_BOOT, seed: int = 0) -> tuple[float, float, float]:
    """``(mean(a - b), low, high)`` for paired values, stratified bootstrap of the differences."""
    d = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
    return (float(d.mean()) if d.size else float("nan"), *mean_ci(d, strata, n_boot, seed))


# ------------------------------------------------------------------------------- the runs

def settings_of(args) -> list[tuple[str, dict]]:
    """``[(label, {condition: value})]``: the baseline, one per condition, and all together."""
    from navbench.sim.conditions import parse_condition_args

    base = parse_condition_args(args.base, "--base")
    out = [("baseline" if not base else "base:" + ",".join(f"{k}={v}" for k, v in base.items()), dict(base))]
    chosen: dict[str, str] = {}
    for item in args.condition:  # one setting per item: a name may come with several values
        (name, value), = parse_condition_args([item], "--condition").items()
        if getattr(args, "only_all", False):  # --only-all: the baseline and all together, not one at a time
            chosen[name] = value
            continue
        if (f"{name}={value}", {**base, name: value}) not in out:
            out.append((f"{name}={value}", {**base, name: value}))
        chosen[name] = value
    if (args.all_on or getattr(args, "only_all", False)) and len(args.condition) > 1:  # a name given twice: its last value
        out.append(("all", {**base, **chosen}))
    return out


def run_setting(prof, conditions: dict, db, args):
    """Run (or resume) the grid of ``prof`` under ``conditions``; its episodes frame."""
    from navbench.pipeline.profiles import override
    from navbench.pipeline.run import run_profile
    from navbench.results.score import select_episodes
    from navbench.sim.conditions import conditions_to_episode

    p = override(prof, episode={**prof.episode, **conditions_to_episode(conditions)})
    res = run_profile(p, db=db, workers=args.workers, until="navigation",
                      command="docs/data/ablation/ablation.py " + " ".join(sys.argv[1:]), ref_name="ablation")
    keys = {c.key for c in res.navigation.cells}
    # the cells first, then score's once-per-(setup, task, seed) rule: filtering after it would
    # drop the tasks another run's cells (a smaller task set of the same tasks) stored first
    return select_episodes(db, level=list(p.levels), cell_keys=keys)


def rows_of(label: str, frame, base_frame, estimators) -> list[dict]:
    """Table rows of one setting: per noise (low, mid, high), pooled over levels."""
    from navbench.sim.dynamics import NOISE_LEVELS

    out = []
    idx = ["level", "task_id", "seed"]
    order = {n: i for i, n in enumerate(NOISE_LEVELS)}
    for noise, g in sorted(frame.groupby("noise", sort=False), key=lambda t: order.get(t[0], len(order))):
        row = {"setting": label, "noise": noise}
        by_est = {e: g[g["estimator"] == e].set_index(idx).sort_index() for e in estimators}
        for e, f in by_est.items():
            lv = f.index.get_level_values("level")
            row[f"{e}_spl"] = float(f["spl_term"].mean()) if len(f) else float("nan")
            row[f"{e}_spl_ci"] = mean_ci(f["spl_term"], lv)
            row[f"{e}_sr"] = float(f["success"].mean()) if len(f) else float("nan")
            row[f"{e}_sr_ci"] = success_ci(int(f["success"].sum()), len(f))
            row[f"{e}_n"] = len(f)
            if base_frame is not None:
                b = base_frame[(base_frame["noise"] == noise) & (base_frame["estimator"] == e)].set_index(idx)
                common = f.index.intersection(b.index)
                row[f"{e}_vs_base"] = paired_ci(f.loc[common, "spl_term"], b.loc[common, "spl_term"],
                                                common.get_level_values("level"))
        for other in [e for e in estimators if e != "ours"]:
            if "ours" in by_est:
                o, x = by_est["ours"], by_est[other]
                common = o.index.intersection(x.index)
                row[f"ours-{other}"] = paired_ci(o.loc[common, "spl_term"], x.loc[common, "spl_term"],
                                                 common.get_level_values("level"))
        out.append(row)
    return out


def fmt(v, ci) -> str:
    return f"{v:.3f} [{ci[0]:.2f},{ci[1]:.2f}]"


def print_table(rows, estimators) -> None:
    heads = ["setting", "noise"] + [f"{e} SPL" for e in estimators] + [f"{e} SR" for e in estimators]
    heads += [f"ours-{e}" for e in estimators if e != "ours" and "ours" in estimators]
    heads += [f"d {e} vs base" for e in estimators]
    lines = [heads]
    for r in rows:
        cells = [r["setting"], r["noise"]]
        cells += [fmt(r[f"{e}_spl"], r[f"{e}_spl_ci"]) for e in estimators]
        cells += [fmt(r[f"{e}_sr"], r[f"{e}_sr_ci"]) for e in estimators]
        cells += [fmt(r[k][0], r[k][1:]) for k in (f"ours-{e}" for e in estimators if e != "ours") if k in r]
        cells += [fmt(r[f"{e}_vs_base"][0], r[f"{e}_vs_base"][1:]) if f"{e}_vs_base" in r else "-"
                  for e in estimators]
        lines.append(cells)
    widths = [max(len(str(line[i])) for line in lines) for i in range(len(heads))]
    for line in lines:
        print("  ".join(str(c).ljust(w) for c, w in zip(line, widths)))
    n = {e: rows[0][f"{e}_n"] for e in estimators} if rows else {}
    print(f"episodes per cell (first row): {n}; SPL: mean with a level-stratified BCa bootstrap "
          f"({N_BOOT}) 95 % interval; SR: success rate, Clopper-Pearson 95 %; differences paired on "
          "(level, task, seed)")


def per_level_rows(label: str, frame, estimators) -> list[dict]:
    """Per (noise, level): each estimator's SPL (for the difficulty comparison)."""
    from navbench.sim.dynamics import NOISE_LEVELS

    order = {n: i for i, n in enumerate(NOISE_LEVELS)}
    out = []
    groups = frame.groupby(["noise", "level"], sort=True)
    for (noise, level), g in sorted(groups, key=lambda t: (order.get(t[0][0], len(order)), t[0][1])):
        row = {"setting": label, "noise": noise, "level": level}
        for e in estimators:
            f = g[g["estimator"] == e]
            row[e] = float(f["spl_term"].mean()) if len(f) else float("nan")
        out.append(row)
    return out


def print_per_level(rows, estimators, difficulty) -> None:
    """Per-level SPL beside the level's difficulty measures (navbench.plan.difficulty)."""
    print("\nper level: SPL, and the level's difficulty (geo/eucl: mean shortest / straight task "
          "distance; door: median narrowest width across the shortest paths, m)")
    print("  ".join(["setting".ljust(24), "noise", "level".ljust(8)] + [e.rjust(8) for e in estimators]
                    + ["geo/eucl", "door"]))
    for r in rows:
        d = difficulty.get(r["level"], {})
        print("  ".join([r["setting"].ljust(24), r["noise"].ljust(5), r["level"].ljust(8)]
                        + [f"{r[e]:8.3f}" for e in estimators]
                        + [f"{d.get('geodesic_ratio', float('nan')):8.3f}",
                           f"{d.get('narrowest_passage_median', float('nan')):5.2f}"]))


def main(argv=None) -> int:
    from navbench.errors import NavbenchError

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--profile", default="six", help="profile name or .toml (default six)")
    ap.add_argument("--levels", help="comma-separated levels (default: the profile's)")
    ap.add_argument("--noise", help="comma-separated noise levels (default: the profile's)")
    ap.add_argument("--estimators", default="ours,no-map,dynamics")
    ap.add_argument("--tasks", type=int, help="tasks per level (default: the profile's)")
    ap.add_argument("--map", dest="map_source", help="fit, true or a map file (default: the profile's)")
    ap.add_argument("--condition", action="append", default=[], metavar="NAME=VALUE",
                    help="a condition to switch on against the baseline (repeatable; a name may "
                    "come with several values, each its own setting)")
    ap.add_argument("--base", action="append", default=[], metavar="NAME=VALUE",
                    help="a condition of the baseline itself (repeatable; default: every default)")
    ap.add_argument("--all-on", action="store_true", help="also run all --condition values together "
                    "(the last value of a name given twice)")
    ap.add_argument("--only-all", action="store_true", help="run only the baseline and all --condition "
                    "values together (implies --all-on; the one-at-a-time settings are left out)")
    ap.add_argument("--workers", type=int, default=0, help="worker processes (0 = CPU count)")
    ap.add_argument("--db", default="sqlite:///results/ablation.db", help="results database URL")
    ap.add_argument("--csv", help="also write the rows to this CSV file")
    ap.add_argument("--per-level", action="store_true",
                    help="also print each level's SPL beside its difficulty measures")
    args = ap.parse_args(argv)
    try:
        return _run(args)
    except NavbenchError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


def difficulty_of(prof) -> dict:
    """``{level: summary}`` of :func:`navbench.plan.difficulty.level_difficulty` on the levels'
    committed task files (the first ``prof.tasks`` tasks)."""
    from navbench.errors import NavbenchError
    from navbench.levelio import resolve_level
    from navbench.plan.difficulty import level_difficulty
    from navbench.plan.tasks import find_task_file, load_tasks

    out = {}
    for name in prof.levels:
        try:
            level = resolve_level(name)
            out[name] = level_difficulty(level, load_tasks(find_task_file(name))[:prof.tasks]).summary()
        except NavbenchError:
            continue  # a generated level without a committed task file: no measures
    return out


def _run(args) -> int:
    from navbench.pipeline.profiles import load_profile, override
    from navbench.pipeline.run import open_db

    def lst(s):
        return None if s is None else [t.strip() for t in s.split(",") if t.strip()]

    prof = override(load_profile(args.profile), levels=lst(args.levels), noise=lst(args.noise),
                    estimators=lst(args.estimators), tasks=args.tasks, map_source=args.map_source)
    settings = settings_of(args)
    estimators = list(prof.estimators)
    rows, level_rows = [], []
    with open_db(args.db) as db:
        base = None
        for label, conditions in settings:
            frame = run_setting(prof, conditions, db, args)
            rows += rows_of(label, frame, base, estimators)
            level_rows += per_level_rows(label, frame, estimators)
            if base is None:
                base = frame
    print(f"profile {prof.name}: levels {','.join(prof.levels)}; noise {','.join(prof.noise)}; "
          f"{prof.tasks} tasks x {prof.seeds} seeds; map {prof.map_source}; db {args.db}")
    print_table(rows, estimators)
    if args.per_level:
        print_per_level(level_rows, estimators, difficulty_of(prof))
    if args.csv:
        import pandas as pd

        pd.DataFrame(rows).to_csv(args.csv, index=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
