"""Benchmark versions side by side in one process (issue 36): the agent and control step of ours
and no-map at the paper camera (ours at the paper profile's reference_scale 0.5), and whole
episodes through the pipeline's run-navigation stage, every version in turn, the order rotating
by round. The same timers as ``navbench bench``'s rows (``navbench.bench.timers``), for any
number of versions (the bench's side-by-side rows measure one).

    PYTHONPATH=. python docs/data/speed/versions_ab.py MAP LEVEL_FILE \\
        [--versions navbench-1,navbench-4,navbench-5] [--workers 2] [--steps 200] [--tasks 6] [--rounds 3]

Prints one line per measurement and a JSON summary: per version the median over rounds of each
round's median step, episodes a minute per round and their median, and each version's ratio of
medians over the first version's. Writes nothing.
"""
from __future__ import annotations

import argparse
import json
import os

import numpy as np

from navbench.bench import timers
from navbench.bench.table import paper_levers
from navbench.benchmark import check_version
from navbench.geometry import CAMERAS
from navbench.levelio import resolve_level
from navbench.worldmodel.grid import load_map


def rotated(items: list, r: int) -> list:
    return items[r % len(items):] + items[:r % len(items)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("map"), ap.add_argument("level_file")
    ap.add_argument("--versions", default="navbench-1,navbench-4,navbench-5")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--tasks", type=int, default=6)
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args()
    versions = [check_version(v.strip()) for v in a.versions.split(",")]
    level, vmap = resolve_level(a.level_file), load_map(a.map)
    out = {"versions": versions, "workers": a.workers, "steps": a.steps, "tasks": a.tasks, "rounds": a.rounds,
           "load_start": os.getloadavg()[0], "levers": {v: paper_levers(v) for v in versions}}
    step: dict[str, list[float]] = {}
    for r in range(a.rounds):
        for est in ("ours", "no-map"):
            for v in rotated(versions, r):
                options, episode = paper_levers(v)
                for what, ex in (("agent", ("sim",)), ("control", ())):
                    t = timers.time_control_step(level, vmap, CAMERAS["paper"], a.steps, estimator=est, exclude=ex,
                                                 options=options.get(est, {}),
                                                 texture=episode.get("texture", "procedural"), seed=r)
                    step.setdefault(f"{what}_{est}|{v}", []).append(float(np.median(t)))
                    print(f"round {r} {what} step {est} {v}: {np.median(t):.2f} ms (n {len(t)})", flush=True)
    tasks = timers.bench_tasks(level, vmap, a.tasks, 1)
    e2e: dict[str, list[float]] = {}
    for r in range(a.rounds):
        for v in rotated(versions, r):
            options, episode = paper_levers(v)
            tp = timers.time_navigation(a.level_file, vmap, tasks, ("ours", "no-map", "dynamics"), a.workers,
                                        camera="paper", noise="mid", seed=0, estimator_options=options,
                                        episode=episode)
            epm = 60.0 * tp.episodes / tp.seconds
            e2e.setdefault(v, []).append(epm)
            print(f"round {r} e2e {v}: {tp.episodes} episodes, {tp.steps} steps in {tp.seconds:.1f} s: "
                  f"{epm:.1f} episodes/min ({tp.workers} workers), load {os.getloadavg()[0]:.2f}", flush=True)
    first = versions[0]
    out["step_ms_median_of_rounds"] = {k: float(np.median(v)) for k, v in step.items()}
    out["e2e_episodes_per_min"] = e2e
    out["e2e_median"] = {v: float(np.median(x)) for v, x in e2e.items()}
    out["e2e_ratio_over_first"] = {v: out["e2e_median"][v] / out["e2e_median"][first] for v in versions}
    out["e2e_ratio_by_round"] = {v: [x / y for x, y in zip(e2e[v], e2e[first])] for v in versions}
    out["load_end"] = os.getloadavg()[0]
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
