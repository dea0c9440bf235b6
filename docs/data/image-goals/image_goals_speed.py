"""Wall time of the image-goals stage in one process and over a local pool (alternating).

    PYTHONPATH=. .venv/bin/python docs/data/image-goals/image_goals_speed.py --profile imagenav-quick --level house-1 \
        --workers 2 --repeats 2

Recomputes the stage's artifact (force) for the profile's task set of one level on its map,
serially (``ctx.workers = 1``) and pooled (``ctx.workers = N``), alternating, and prints each
wall time, the medians, their ratio and whether the goals agree (the timing field aside). The
map and the localiser's bank come from the cache (built first if missing, outside the timing).
"""

from __future__ import annotations

import argparse
import statistics
import time


def main() -> None:
    from navbench.pipeline.profiles import load_profile
    from navbench.pipeline.run import stage_context
    from navbench.pipeline.stages import build_level_inputs
    from navbench.pipeline.stages.goals import ImageGoalConfig, load_goals
    from navbench.pipeline.stages.inputs import with_image_goals

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profile", default="imagenav-quick")
    ap.add_argument("--level", default="house-1")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    prof = load_profile(args.profile)
    cfg = ImageGoalConfig(camera=prof.camera, localizer=dict(prof.goal_localizer))
    li = build_level_inputs(stage_context(), prof, args.level)
    reference = load_goals(with_image_goals(stage_context(), li, cfg).goals.path)  # builds the bank if missing

    def strip(goals):
        return {k: {f: v for f, v in g.items() if f != "ms"} for k, g in goals.items()}

    walls: dict[int, list[float]] = {1: [], args.workers: []}
    same = True
    for _ in range(args.repeats):
        for w in (1, args.workers):
            ctx = stage_context(force={"image-goals"})
            ctx.workers = w
            t0 = time.perf_counter()
            ref = with_image_goals(ctx, li, cfg).goals
            walls[w].append(time.perf_counter() - t0)
            same &= strip(load_goals(ref.path)) == strip(reference)
            print(f"workers {w}: {walls[w][-1]:.1f} s ({len(reference)} goals)", flush=True)
    one, many = statistics.median(walls[1]), statistics.median(walls[args.workers])
    print(f"median: 1 worker {one:.1f} s, {args.workers} workers {many:.1f} s, ratio {one / many:.2f}x; "
          f"goals equal to the cached ones: {same}")


if __name__ == "__main__":
    main()
