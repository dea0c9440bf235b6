"""Image-goal localisation with other localiser settings, goal by goal (issue 15 §6: the known
map's failures; a measurement script, writes nothing).

    .venv/bin/python docs/data/image-goals/goal_search_ab.py LEVEL MAP --tasks 100 \\
        '{"default": {}, "exhaustive": {"accept": 2.0, "max_candidates": 64}}'

``MAP``: a world-model file or ``true`` (the level voxelised). The goals are those of the
known-map path (``navbench.nav.imagegoal.render_goal`` at heading ``goal_heading(0, id)``, the
``half`` camera) for ``--tasks`` tasks per NRNS difficulty (``sample_tasks_by_difficulty``, seed
0, the pipeline's banded sampling). Each variant is a JSON object of
:class:`navbench.localize.LocalizerConfig` overrides on top of the image-goal stage's own
(``k = 2``); its goals are classified by the stage's rules (``classify``). Prints per variant:
goals wrong (best place more than 0.5 m from the target), ambiguous, failed, and the median and
90th-percentile query time.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def main(argv=None) -> int:
    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.levelio import resolve_level
    from navbench.localize import Localizer
    from navbench.nav.imagegoal import classify, render_goal
    from navbench.pipeline.stages.goals import ImageGoalConfig
    from navbench.plan.tasks import sample_tasks_by_difficulty
    from navbench.worldmodel.base import load_world_model
    from navbench.worldmodel.grid import voxelize_level

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("level")
    ap.add_argument("map")
    ap.add_argument("variants")
    ap.add_argument("--tasks", type=int, default=100)
    args = ap.parse_args(argv)
    level = resolve_level(args.level)
    vmap = voxelize_level(level) if args.map == "true" else load_world_model(args.map)
    intr = camera_by_name("half")
    goal_cfg = ImageGoalConfig()
    tasks = sample_tasks_by_difficulty(level, args.tasks, 0, ("easy", "medium", "hard"))
    frames = [render_goal(level, t, intr, goal_cfg.seed) for t in tasks]
    base = goal_cfg.localizer_config()
    for name, over in json.loads(args.variants).items():
        loc = Localizer.build(vmap, intr, CAMERA_HEIGHT, dataclasses.replace(base, **over))
        wrong, amb, failed, ms, bad_ids = 0, 0, 0, [], []
        for t, f in zip(tasks, frames):
            t0 = time.perf_counter()
            g = classify(loc.localize(f, k=2), t.target, goal_cfg.rules())
            ms.append((time.perf_counter() - t0) * 1e3)
            w = not (g.error_m <= 0.5)
            wrong += w
            amb += g.status == "ambiguous"
            failed += g.status == "failed"
            if w:
                bad_ids.append(t.id)
        n = len(tasks)
        print(f"{args.level} {name:12s} goals {n}  wrong {wrong} ({wrong / n:.1%})  ambiguous {amb}  "
              f"failed {failed}  query ms median {np.median(ms):.0f} p90 {np.percentile(ms, 90):.0f}  "
              f"wrong ids {bad_ids}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
