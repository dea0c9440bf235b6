"""Plain timing functions for the simulator (``navbench bench`` calls them and prints).

Each returns a list of wall-clock times in **milliseconds**, one per repeat, measured with
``time.perf_counter`` after ``warmup`` untimed calls (which also trigger numba compilation).
Poses are drawn in free space with an explicit seed, so two runs time the same views.
"""

from __future__ import annotations

import math
import time

import numpy as np

from navbench.geometry import AGENT_LENGTH, CAMERA_HEIGHT, Intrinsics
from navbench.level import Level


def bench_poses(level: Level, count: int, seed: int = 0) -> np.ndarray:
    """``(count, 3)`` poses uniform in free space (clearance 1.2 L), random headings."""
    from navbench.sim.world import sample_free_points

    rng = np.random.default_rng(seed)
    xy = sample_free_points(level, rng, count, 1.2 * AGENT_LENGTH)
    return np.column_stack([xy, rng.uniform(-math.pi, math.pi, count)])


def time_render(level: Level, intrinsics: Intrinsics, repeats: int = 50, warmup: int = 3, seed: int = 0,
                parallel: bool | None = None, camera_height: float = CAMERA_HEIGHT,
                pixels=None) -> list[float]:
    """Milliseconds per :meth:`RaycastCamera.render` call, over ``repeats`` free-space poses
    (``pixels``: only those, as for an estimator that declares the pixels it reads)."""
    from navbench.sim.camera import RaycastCamera

    cam = RaycastCamera(level, intrinsics, camera_height, parallel=parallel)
    poses = bench_poses(level, max(repeats, 1), seed)
    for k in range(warmup):
        cam.render(poses[k % len(poses)], pixels)
    out = []
    for k in range(repeats):
        t0 = time.perf_counter()
        cam.render(poses[k], pixels)
        out.append(1000.0 * (time.perf_counter() - t0))
    return out


def time_render_modes(level: Level, intrinsics: Intrinsics, modes=("procedural", "table"),
                      repeats: int = 7, frames: int = 10, warmup: int = 2, seed: int = 0,
                      parallel: bool | None = None, camera_height: float = CAMERA_HEIGHT,
                      pixels=None) -> dict[str, list[float]]:
    """Milliseconds per frame of each texture mode (:mod:`navbench.sim.texels`), interleaved:
    each of ``repeats`` rounds renders the same ``frames`` free-space poses with every mode in
    turn and records each mode's mean over them, so that a load spike hits all modes alike.
    The tables are built (and every kernel compiled) before timing."""
    from navbench.sim.camera import RaycastCamera

    cams = {m: RaycastCamera(level, intrinsics, camera_height, parallel=parallel, texture=m) for m in modes}
    poses = bench_poses(level, max(frames, 1), seed)
    for cam in cams.values():
        for k in range(warmup):
            cam.render(poses[k % len(poses)], pixels)
    out: dict[str, list[float]] = {m: [] for m in modes}
    for r in range(repeats):
        order = list(modes) if r % 2 == 0 else list(modes)[::-1]
        for m in order:
            cam = cams[m]
            t0 = time.perf_counter()
            for pose in poses:
                cam.render(pose, pixels)
            out[m].append(1000.0 * (time.perf_counter() - t0) / len(poses))
    return out


def time_step(level: Level, repeats: int = 1000, warmup: int = 10, noise="low", seed: int = 0) -> list[float]:
    """Milliseconds per :meth:`Simulator.step` (dynamics + collision, no rendering).

    Random controls within the limits, mostly forward; the agent restarts at a fresh free pose
    after a collision (restarts are not timed).
    """
    from navbench.sim.dynamics import MAX_STEP, MAX_TURN, Control
    from navbench.sim.world import Simulator

    sim = Simulator(level, noise=noise, seed=seed, intrinsics=None)
    rng = np.random.default_rng(seed)
    starts = bench_poses(level, 64, seed + 1)
    n = 0
    sim.reset(starts[0])
    out = []
    for k in range(warmup + repeats):
        if sim.collided:
            n += 1
            sim.reset(starts[n % len(starts)])
        u = Control(rng.uniform(-MAX_TURN, MAX_TURN), float(sim.pose[2]) + rng.uniform(-0.05, 0.05),
                    rng.uniform(0.5, 1.0) * MAX_STEP)
        t0 = time.perf_counter()
        sim.step(u)
        dt = 1000.0 * (time.perf_counter() - t0)
        if k >= warmup:
            out.append(dt)
    return out


def summarise(times_ms: list[float]) -> dict[str, float]:
    """``{"n", "median", "p10", "p90", "min"}`` of a timing list (milliseconds)."""
    a = np.asarray(times_ms, dtype=np.float64)
    if a.size == 0:
        return {"n": 0, "median": math.nan, "p10": math.nan, "p90": math.nan, "min": math.nan}
    return {"n": int(a.size), "median": float(np.median(a)), "p10": float(np.percentile(a, 10)),
            "p90": float(np.percentile(a, 90)), "min": float(a.min())}
