"""navbench-2 against navbench-1 in one process (issue 36): the agent step of ours and no-map at
the paper camera (ours reference_scale 0.5), interleaved, and whole episodes through the
pipeline's run-navigation stage with N workers. Usage: python v2ab.py MAP LEVEL_FILE [N] [STEPS] [TASKS]"""
import json
import sys
import time
from pathlib import Path

import numpy as np

from navbench.bench import timers
from navbench.bench.table import REF05, version_levers
from navbench.geometry import CAMERAS
from navbench.levelio import resolve_level
from navbench.worldmodel.grid import load_map

def main():
    map_path, level_file = sys.argv[1], Path(sys.argv[2])
    workers = int(sys.argv[3]) if len(sys.argv) > 3 else 2
    steps = int(sys.argv[4]) if len(sys.argv) > 4 else 200
    tasks_n = int(sys.argv[5]) if len(sys.argv) > 5 else 16
    rounds = int(sys.argv[6]) if len(sys.argv) > 6 else 2
    level = resolve_level(str(level_file))
    vmap = load_map(map_path)
    opts2, ep2 = version_levers("navbench-2")
    tex2 = ep2.get("texture", "procedural")
    out = {"workers": workers, "steps": steps, "tasks": tasks_n, "levers": {"options": opts2, "episode": ep2}}
    step = {}
    for r in range(rounds):
        for est in ("ours", "no-map"):
            base = dict(REF05) if est == "ours" else {}
            for v, opts, tex in (("navbench-1", base, "procedural"), ("navbench-2", {**base, **opts2.get(est, {})}, tex2)):
                for what, ex in (("agent", ("sim",)), ("control", ())):
                    t = timers.time_control_step(level, vmap, CAMERAS["paper"], steps, estimator=est, exclude=ex,
                                                 options=opts, texture=tex, seed=r)
                    step.setdefault(f"{what}_{est}_{v}", []).append(float(np.median(t)))
                    print(f"round {r} {what} {est} {v}: {np.median(t):.2f} ms (n {len(t)})", flush=True)
    out["step_ms_median_of_rounds"] = {k: float(np.median(v)) for k, v in step.items()}
    tasks = timers.bench_tasks(level, vmap, tasks_n, 1)
    e2e = {}
    for r in range(rounds):
        for v in (("navbench-1", "navbench-2") if r % 2 == 0 else ("navbench-2", "navbench-1")):
            if v == "navbench-1":
                options, episode = {"ours": REF05}, {}
            else:
                options = {**opts2, "ours": {**REF05, **opts2.get("ours", {})}}
                episode = ep2
            tp = timers.time_navigation(level_file, vmap, tasks, ("ours", "no-map", "dynamics"), workers,
                                        camera="paper", noise="mid", seed=0, estimator_options=options,
                                        episode=episode)
            epm = 60.0 * tp.episodes / tp.seconds
            e2e.setdefault(v, []).append(epm)
            print(f"round {r} e2e {v}: {tp.episodes} episodes, {tp.steps} steps in {tp.seconds:.1f} s: "
                  f"{epm:.1f} episodes/min ({tp.workers} workers)", flush=True)
    out["e2e_episodes_per_min"] = e2e
    out["e2e_ratio_v2_over_v1_median"] = float(np.median(e2e["navbench-2"]) / np.median(e2e["navbench-1"]))
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
