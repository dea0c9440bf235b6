"""Issue 37 §4: where a ViZDoom episode's time goes (house-1, the half and the paper camera).

Two parts, both timed with ``time.perf_counter`` around the real calls (the engine's
``vizdoom.DoomGame`` is subclassed and the backend's functions wrapped here; nothing in
navbench is changed to time it):

1. **The engine** per camera, before and now: the level -> WAD conversion (``level_to_map``),
   the engine's start (``DoomSimulator(...)`` to its first frame: the WAD conversion or a hit
   of :func:`navbench.sim.doom.wad.cached_level_map`, ``init`` of a new engine process or
   ``new_episode`` in a reused one, the 12 warm-up tics, the rest), the first
   ``reset(pose)``, ``close``; and per ``step``: the warp command, the settle tics
   (``advance_action``), the state read (``get_state``: the engine's screen and depth buffers
   into numpy), RGB to float, the depth buffer to metres (``buffer_to_metres``) and the rest
   (navbench's noisy dynamics, swept collision, bookkeeping). Medians over repeats; cameras
   and before/now interleaved.
2. **Episodes** as a pipeline worker runs them (:func:`navbench.pipeline.worker.run_episode_chunk`:
   a simulator per episode, an estimator, :func:`navbench.nav.episode.run_episode`, close,
   score) with ``no-map`` and ``dynamics`` at mid noise on a few tasks, planned on the level's
   true occupancy (the pipeline plans on a fitted map's; planning is a small share either
   way). Per episode: engine start (of it the WAD), close, reset (first frame + estimator
   reset), the episode's own step timings (sim, render, estimate, plan, control), the
   estimator's construction, scoring, and other (the rest of the episode's wall time); and
   inside sim, per step, the engine's parts. Before (a conversion and an engine process per
   episode) and now (inside the worker's chunk block, after the chunk's first episode),
   interleaved task by task: the ratio of per-episode times, and of engine starts.

Pool workers run compiled kernels on one thread (``NUMBA_NUM_THREADS=1``); so does this script.
``nice -n 5 python docs/data/vizdoom/episode_time.py [REPEATS] [TASKS] > docs/data/vizdoom/episode_time.txt``
(default 9 and 9). The load average (``uptime``) is printed at the start and the end.
"""

from __future__ import annotations

import contextlib
import os
import statistics
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

# as the pipeline's pool workers (navbench.pipeline.executor): compiled kernels on one thread
os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import vizdoom  # noqa: E402

import navbench.sim.doom.engine as engine_mod  # noqa: E402
import navbench.sim.doom.simulator as sim_mod  # noqa: E402
import navbench.sim.doom.wad as wad_mod  # noqa: E402
from navbench.geometry import CAMERA_HEIGHT, camera_by_name  # noqa: E402
from navbench.level import occupancy_raster  # noqa: E402
from navbench.levelio import load_level  # noqa: E402
from navbench.nav.episode import EpisodeConfig, run_episode  # noqa: E402
from navbench.nav.metrics import FinalGeodesic, score_episode  # noqa: E402
from navbench.plan.tasks import sample_tasks  # noqa: E402
from navbench.sim.backends import close_simulator, make_simulator, sim_intrinsics  # noqa: E402
from navbench.sim.dynamics import Control  # noqa: E402
from navbench.sim.world import sample_free_points  # noqa: E402
from navbench.track.registry import make_estimator, uses_frames  # noqa: E402

CAMERAS = ("half", "paper")
ACC: dict[str, list[float]] = defaultdict(list)  # name -> seconds, one entry per call
pc = time.perf_counter


def _timed(name, fn):
    def wrapper(*a, **k):
        t = pc()
        try:
            return fn(*a, **k)
        finally:
            ACC[name].append(pc() - t)
    return wrapper


class TimedGame(vizdoom.DoomGame):
    """``vizdoom.DoomGame`` with its calls timed into :data:`ACC`."""

    def init(self):
        t = pc()
        out = super().init()
        ACC["engine init"].append(pc() - t)
        return out

    def send_game_command(self, cmd):
        t = pc()
        super().send_game_command(cmd)
        ACC["warp command"].append(pc() - t)

    def set_action(self, action):
        t = pc()
        super().set_action(action)
        ACC["set action"].append(pc() - t)

    def advance_action(self, tics=1, update_state=True):
        t = pc()
        super().advance_action(tics, update_state)
        ACC["tics"].append(pc() - t)

    def get_state(self):
        t = pc()
        out = super().get_state()
        ACC["get_state"].append(pc() - t)
        return out

    def new_episode(self, *a):
        t = pc()
        super().new_episode(*a)
        ACC["engine new_episode"].append(pc() - t)

    def close(self):
        t = pc()
        super().close()
        ACC["engine close"].append(pc() - t)


class _Vzd:
    """The ``vizdoom`` module with :class:`TimedGame` as its ``DoomGame``."""

    DoomGame = TimedGame

    def __getattr__(self, name):
        return getattr(vizdoom, name)


engine_mod._vizdoom = lambda: _Vzd()
sim_mod.buffer_to_metres = _timed("depth to metres", sim_mod.buffer_to_metres)
_CONVERT = _timed("wad conversion", wad_mod.level_to_map)
wad_mod.level_to_map = _CONVERT  # what cached_level_map calls on a miss
CACHED = wad_mod.cached_level_map


def set_cache(on: bool) -> None:
    """The backend as it is (on: the converted-map cache; engines reused inside
    ``reuse_engines``, as the worker runs a chunk) or as it was before both (off: a conversion
    and an engine process per simulator, stopped on close)."""
    engine_mod.cached_level_map = CACHED if on else (lambda level, light: _CONVERT(level, light))


def reuse(on: bool):
    """The worker's chunk block (on) or nothing (off)."""
    return engine_mod.reuse_engines() if on else contextlib.nullcontext()


_observe = sim_mod.DoomSimulator.observe


def observe(self, pixels=None):
    t = pc()
    out = _observe(self, pixels)
    ACC["observe"].append(pc() - t)
    return out


sim_mod.DoomSimulator.observe = observe


def take(names=None) -> dict[str, float]:
    """The seconds accumulated per name since the last take (and clear)."""
    out = {k: sum(v) for k, v in ACC.items() if names is None or k in names}
    ACC.clear()
    return out


def med(xs):
    return statistics.median(xs) if xs else float("nan")


def load() -> str:
    return "load average %.2f %.2f %.2f" % os.getloadavg()


# ----------------------------------------------------------------------------- 1. the engine

START_PARTS = ("wad conversion", "engine init", "engine new_episode", "tics", "get_state")


def engine_part(level, repeats: int, steps: int = 100) -> None:
    rng = np.random.default_rng(0)
    pts = sample_free_points(level, rng, 200, 0.25)
    poses = [np.array([p[0], p[1], rng.uniform(-np.pi, np.pi)]) for p in pts]
    conv = []
    rows = {(c, on): defaultdict(list) for c in CAMERAS for on in (False, True)}
    for r in range(repeats):
        t = pc()
        _CONVERT(level, wad_mod.LIGHT_LEVEL)
        conv.append(pc() - t)
        for cam in (CAMERAS if r % 2 == 0 else CAMERAS[::-1]):
            for on in ((False, True) if r % 2 == 0 else (True, False)):
                row = rows[(cam, on)]
                set_cache(on)
                block = reuse(on)
                block.__enter__()
                if on:  # an earlier episode's engine on this camera, closed (not timed)
                    sim_mod.DoomSimulator(level, noise="mid", seed=r, intrinsics=camera_by_name(cam)).close()
                take()
                t = pc()
                sim = sim_mod.DoomSimulator(level, noise="mid", seed=r, intrinsics=camera_by_name(cam))
                row["start"].append(pc() - t)
                got = take()
                for k in START_PARTS:
                    row["start: " + k].append(got.get(k, 0.0))
                row["start: rest (collision world, WAD file)"].append(
                    row["start"][-1] - sum(got.get(k, 0.0) for k in START_PARTS))
                t = pc()
                sim.reset(poses[r])
                row["first reset"].append(pc() - t)
                take()
                per = defaultdict(float)
                for k in range(steps):
                    c = Control(rng.uniform(-0.2, 0.2), 0.0, rng.uniform(0.0, 0.16))
                    t = pc()
                    res = sim.step(c)
                    per["total"] += pc() - t
                    for name, v in take().items():
                        per[name] += v
                    if res.collided:  # start again elsewhere (not counted)
                        sim.reset(poses[(r * steps + k) % len(poses)])
                        take()
                per["rgb to float"] = per["observe"] - per["depth to metres"]
                per["rest (dynamics, collision, set_pose's own)"] = per["total"] - sum(
                    per[k] for k in ("warp command", "set action", "tics", "get_state", "observe"))
                for name, v in per.items():
                    row["step: " + name].append(v / steps)
                t = pc()
                sim.close()
                row["close"].append(pc() - t)
                t = pc()
                block.__exit__(None, None, None)
                row["end of the chunk's block"].append(pc() - t)
                take()
    set_cache(True)
    print(f"== 1. the engine on {level.name}: median of {repeats} (cameras and modes interleaved), "
          f"{steps} steps each")
    print(f"level -> WAD conversion (level_to_map): {med(conv) * 1e3:.1f} ms (min {min(conv) * 1e3:.1f})")
    print("before: a conversion and an engine process per simulator, stopped on close; now: the map "
          "cached, inside the worker's chunk block a closed engine reused (new_episode) and the one "
          "left running stopped at the block's end")
    for cam in CAMERAS:
        print(f"-- {cam} camera ({camera_by_name(cam).width}x{camera_by_name(cam).height})"
              f"{'':14s} before       now   (ms)")
        b, n = rows[(cam, False)], rows[(cam, True)]
        for k in ("start", *("start: " + p for p in START_PARTS), "start: rest (collision world, WAD file)",
                  "first reset", "close", "end of the chunk's block"):
            print(f"  {k:44s} {med(b[k]) * 1e3:8.2f} {med(n[k]) * 1e3:8.2f}")
        print(f"  {'start before / now (median of per-repeat ratios)':44s} "
              f"{med([x / y for x, y in zip(b['start'], n['start'])]):8.1f}x")
        print("  per step (mean over the steps, median over repeats):")
        for k in ("total", "warp command", "set action", "tics", "get_state", "observe", "rgb to float",
                  "depth to metres", "rest (dynamics, collision, set_pose's own)"):
            print(f"  {'step: ' + k:44s} {med(b['step: ' + k]) * 1e3:8.3f} {med(n['step: ' + k]) * 1e3:8.3f}")


# ----------------------------------------------------------------------------- 2. episodes

SIM_PARTS = ("warp command", "tics", "get_state", "depth to metres")
EP_KEYS = ("start", "start: wad", "close", "reset", "sim", "render", "estimate", "plan", "control",
           "estimator build", "score", "other", "total")


def episode(level, occ, xs, ys, task, est_name, cam, seed, geodesic):
    """One episode as the worker runs it; its components in seconds."""
    cfg = EpisodeConfig()
    frames = uses_frames(est_name)
    take()
    t0 = pc()
    sim = make_simulator("vizdoom", level, noise="mid", seed=seed,
                         intrinsics=camera_by_name(cam) if frames else None, camera_height=CAMERA_HEIGHT,
                         enforce_direction_limit=cfg.body_fixed_drive, pose_quantisation=cfg.pose_quantisation,
                         collision_check=cfg.collision_check)
    t1 = pc()
    wad = take().get("wad conversion", 0.0)
    intr = sim_intrinsics("vizdoom", camera_by_name(cam))
    est = make_estimator(est_name, vmap=None, intrinsics=intr, camera_height=CAMERA_HEIGHT, renderer=None,
                         seed=seed)
    t2 = pc()
    resets = []
    sim.reset = _reset_timer(sim.reset, resets)
    est.reset = _reset_timer(est.reset, resets)
    take()
    try:
        rec = run_episode(level, occ, xs, ys, task, est, sim, config=cfg)
    finally:
        inner = take()
        t3 = pc()
        close_simulator(sim)
        t4 = pc()
    score_episode(rec, geodesic=geodesic)
    t5 = pc()
    out = {"start": t1 - t0, "start: wad": wad, "estimator build": t2 - t1, "reset": sum(resets),
           "close": t4 - t3, "score": t5 - t4, "total": t5 - t0}
    for k, v in rec.timings_ms.items():
        out[k] = float(np.sum(v)) / 1e3
    out["other"] = out["total"] - sum(out[k] for k in EP_KEYS if k not in ("other", "total", "start: wad"))
    out["steps"] = rec.steps
    # inside sim (the engine's share of the episode's steps and its reset; per step below)
    for k in SIM_PARTS:
        out["sim: " + k] = inner.get(k, 0.0)
    out["sim: rgb to float, pixel mask"] = inner.get("observe", 0.0) - inner.get("depth to metres", 0.0)
    out["sim: rest (dynamics, collision)"] = out["sim"] + out["reset"] - sum(
        inner.get(k, 0.0) for k in ("warp command", "set action", "tics", "get_state", "observe"))
    return out


def _reset_timer(fn, into):
    def wrapper(*a, **k):
        t = pc()
        try:
            return fn(*a, **k)
        finally:
            into.append(pc() - t)
    return wrapper


def episode_part(level, n_tasks: int) -> None:
    occ, xs, ys = occupancy_raster(level, 0.05, 0.05, 1.0)
    tasks = sample_tasks(level, n_tasks, seed=7)
    geodesic = FinalGeodesic(level)
    cases = [("no-map", "half"), ("no-map", "paper"), ("dynamics", "half")]
    got = {(e, c, on): [] for e, c in cases for on in (True, False)}
    set_cache(True)
    # a worker's first episode converts the map, starts an engine and compiles (numba) or
    # loads compiled code: one of each case first, reported apart
    for e, c in cases:
        first = episode(level, occ, xs, ys, tasks[0], e, c, 999, geodesic)
        print(f"first episode in the process, {e} {c}: {first['total']:.2f} s ({first['steps']} steps; "
              f"start {first['start']:.3f} s of it the WAD {first['start: wad']:.3f} s; "
              f"estimate {first['estimate']:.2f} s, plan {first['plan']:.2f} s, other {first['other']:.3f} s)")
    take()
    for i, task in enumerate(tasks):
        for e, c in cases:
            for on in ((True, False) if i % 2 == 0 else (False, True)):
                set_cache(on)
                with reuse(on):
                    if on:  # the chunk's previous episode on this engine (not timed)
                        episode(level, occ, xs, ys, tasks[(i + 1) % len(tasks)], e, c, 2000 + i, geodesic)
                    got[(e, c, on)].append(episode(level, occ, xs, ys, task, e, c, 1000 + i, geodesic))
    set_cache(True)
    print(f"== 2. episodes on {level.name} (mid noise, {n_tasks} tasks, seeds 1000..; the worker's loop: "
          "a simulator per episode)")
    print("seconds per episode, median over tasks; share of the episode's total; as the backend is now "
          "(the map cached; not the chunk's first episode: the engine reused)")
    for e, c in cases:
        eps = got[(e, c, True)]
        steps = med([x["steps"] for x in eps])
        tot = med([x["total"] for x in eps])
        frames = "camera " + c if uses_frames(e) else "no frames (engine 160x120, pose only)"
        print(f"-- {e}, {frames}: {steps:.0f} steps, {tot:.2f} s per episode")
        for k in EP_KEYS:
            v = med([x[k] for x in eps])
            share = med([x[k] / x["total"] for x in eps])
            per_step = f"{med([x[k] / max(1, x['steps']) for x in eps]) * 1e3:7.2f} ms/step" \
                if k in ("sim", "render", "estimate", "plan", "control") else ""
            print(f"  {k:16s} {v:7.3f} s {share * 100:5.1f} %  {per_step}")
        print("  inside sim + reset, per step:",
              ", ".join(f"{k} {med([x['sim: ' + k] / max(1, x['steps']) for x in eps]) * 1e3:.3f} ms"
                        for k in (*SIM_PARTS, "rgb to float, pixel mask", "rest (dynamics, collision)")))
    print("before / now (before: a conversion and an engine process per episode; now: not a chunk's "
          "first episode; episodes interleaved, same task and seed; median of per-task ratios):")
    for e, c in cases:
        on, off = got[(e, c, True)], got[(e, c, False)]
        r_total = med([b["total"] / a["total"] for a, b in zip(on, off)])
        r_start = med([b["start"] / a["start"] for a, b in zip(on, off)])
        d = med([b["total"] - a["total"] for a, b in zip(on, off)])
        same = all(a["steps"] == b["steps"] for a, b in zip(on, off))
        print(f"  {e:9s} {c:6s} episode {r_total:.2f}x ({med([b['total'] for b in off]):.3f} s before, "
              f"{med([a['total'] for a in on]):.3f} s now; before - now {d * 1e3:+.0f} ms), "
              f"engine start {r_start:.1f}x ({med([b['start'] for b in off]) * 1e3:.0f} ms before, "
              f"{med([a['start'] for a in on]) * 1e3:.1f} ms now); same step counts: {same}")


def main(argv):
    repeats = int(argv[0]) if argv else 9
    n_tasks = int(argv[1]) if len(argv) > 1 else 9
    print(time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()), "vizdoom", vizdoom.__version__)
    print("start:", load())
    level = load_level(ROOT / "levels" / "house-1.json")
    engine_part(level, repeats)
    print("after part 1:", load())
    episode_part(level, n_tasks)
    print("end:", load())


if __name__ == "__main__":
    main(sys.argv[1:])
