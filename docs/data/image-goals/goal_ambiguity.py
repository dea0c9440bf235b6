"""How many image goals are ambiguous in the level itself, not only in the fitted map (issue 15 §6).

    .venv/bin/python docs/data/image-goals/goal_ambiguity.py --profile imagenav [--levels house-1,house-2] \\
        [--db sqlite:///results/imagenav100.db]

For every task of the profile's task sets, the image-goals stage (``navbench.pipeline.stages.goals``,
the known-map path's own) localises the goal image twice: in the map the profile's agent plans
on (its ``map``, the fitted one for ``imagenav``) and in the level's voxelised true geometry
(``--map true``: no fitting error, so what is left is the view itself). A goal is *wrong* when its
best place is more than 0.5 m from the true target, and *ambiguous* as the stage classifies it (a
second verified place at least 1 m away scores within 0.02). Both stages are cached artifacts;
a goal wrong or ambiguous on the true map is one no map can settle from the picture alone.
Prints per level: goals, wrong / ambiguous on each map, the goals wrong on both, and with
``--db`` the image-goal episodes that failed (success under the ``paper`` preset) split by
whether their goal was wrong or ambiguous on the true map. Writes nothing but the cache.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

WRONG_M = 0.5  # a found goal farther than this from the target is at the wrong place


def goals_of(ctx, prof, map_source: str, name: str):
    """``{task id: goal record}`` of level ``name`` localised in ``map_source``'s map."""
    from navbench.pipeline.profiles import override
    from navbench.pipeline.stages.goals import ImageGoalConfig, load_goals
    from navbench.pipeline.stages.inputs import build_level_inputs, with_image_goals

    p = override(prof, map_source=map_source)
    li = with_image_goals(ctx, build_level_inputs(ctx, p, name), ImageGoalConfig(camera=p.camera))
    return load_goals(li.goals.path), li


def bad(goal: dict) -> tuple[bool, bool]:
    """``(wrong, ambiguous)`` of one goal record."""
    err = goal.get("error_m")
    return (err is None or err > WRONG_M), goal.get("status") == "ambiguous"


def main(argv=None) -> int:
    from navbench.errors import NavbenchError

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--profile", default="imagenav")
    ap.add_argument("--levels", help="comma-separated levels (default: the profile's)")
    ap.add_argument("--db", help="a results database with the profile's image-goal episodes")
    args = ap.parse_args(argv)
    try:
        return _run(args)
    except NavbenchError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


def _run(args) -> int:
    from navbench.pipeline.profiles import load_profile, override
    from navbench.pipeline.run import stage_context

    prof = load_profile(args.profile)
    if args.levels:
        prof = override(prof, levels=[s.strip() for s in args.levels.split(",") if s.strip()])
    ctx = stage_context()
    episodes = _episodes(args.db) if args.db else None
    failed = None
    if episodes is not None:
        f = episodes[(episodes["goal"] == "image") & (~episodes["success"].astype(bool))]
        failed = {(str(r.level), int(r.task_id)) for r in f.itertuples()}
    inherent: set[tuple[str, int]] = set()  # goals wrong or ambiguous on the true map
    print("level     goals  wrong(map) amb(map)  wrong(true) amb(true)  wrong both   "
          "failed episodes: goal wrong/amb on the true map, other")
    tot = [0] * 8
    for name in prof.levels:
        on_map, li = goals_of(ctx, prof, prof.map_source, name)
        on_true, _ = goals_of(ctx, prof, "true", name)
        row = [len(on_map), 0, 0, 0, 0, 0, 0, 0]
        for tid, g in on_map.items():
            w, a = bad(g)
            wt, at = bad(on_true[tid])
            row[1] += w
            row[2] += a
            row[3] += wt
            row[4] += at
            row[5] += w and wt
            if wt or at:
                inherent.add((name, tid))
            if failed is not None and (name, tid) in failed:
                row[6 if (wt or at) else 7] += 1
        tot = [x + y for x, y in zip(tot, row)]
        _print(name, row, failed is not None)
    _print("all", tot, failed is not None)
    if episodes is not None:
        _print_gap(episodes, inherent)
    return 0


def _print_gap(episodes, inherent: set) -> None:
    """SPL of image and point goals over the same tasks: all, and without the tasks whose goal
    is wrong or ambiguous on the true map (a diagnosis of the gap, not a score)."""
    keys = list(zip(episodes["level"].astype(str), episodes["task_id"].astype(int)))
    clear = episodes[[k not in inherent for k in keys]]
    for label, f in (("all tasks", episodes), ("goals unambiguous on the true map", clear)):
        spl = {g: f.loc[f["goal"] == g, "spl_term"].astype(float) for g in ("point", "image")}
        sr = {g: f.loc[f["goal"] == g, "success"].astype(float).mean() for g in ("point", "image")}
        print(f"{label}: episodes point {len(spl['point'])} image {len(spl['image'])}; SPL point "
              f"{spl['point'].mean():.3f} image {spl['image'].mean():.3f} (gap "
              f"{spl['point'].mean() - spl['image'].mean():.3f}); success point {sr['point']:.3f} "
              f"image {sr['image']:.3f}")


def _print(name, row, with_episodes: bool) -> None:
    n = max(row[0], 1)
    cells = [f"{name:8s}", f"{row[0]:5d}"] + [f"{row[i]:4d} {100 * row[i] / n:4.1f}%" for i in range(1, 6)]
    if with_episodes:
        cells.append(f"{row[6]:4d} / {row[7]:4d}")
    print("  ".join(cells))


def _episodes(url: str):
    """The episodes of ``url`` (``score``'s selection) with ``goal`` filled (``point`` where
    the row says nothing); success and SPL as stored (the ``paper`` preset)."""
    from navbench.pipeline.run import open_db
    from navbench.results.score import select_episodes

    with open_db(url) as db:
        f = select_episodes(db)
    f["goal"] = f["goal"].where(f["goal"].notna(), "point")
    return f


if __name__ == "__main__":
    sys.exit(main())
