"""Speed benchmark of every per-step component (issue #7), the library behind ``navbench bench``.

Each ``time_*`` function measures one thing and returns a list of wall-clock **milliseconds**,
one per timed repeat: ``warmup`` untimed calls first (numba compilation, torch start-up, caches),
then ``repeats`` timed calls with :func:`time.perf_counter`, stopping early once ``budget_s``
seconds are spent and at least ``min(3, repeats)`` repeats are in. Inputs (poses, pixels,
trajectories, tasks) are drawn from explicit seeds, so two runs time the same work.

:func:`run_bench` runs all of them on one level (house-1) and one map -- the newest fitted map
of that level in the stage cache (``results/cache/fit-map``) if there is one, else the level's
true geometry voxelized on the paper's 200 x 200 x 20 grid -- and returns one JSON-ready dict:
medians under flat keys (``render_ms_paper`` ...), the full statistics per metric, the paper's
figures, the issue's targets with pass/fail, the host and the library versions. A key whose
measurement is impossible here (no CUDA device, an estimator that does not exist yet) holds
``None`` and ``notes[key]`` says why.

The paper's figures (section 5, fig. 4c) were taken on an NVIDIA Quadro RTX 8000 GPU with 8
Intel Xeon Gold 6252 cores; everything here runs on the CPU unless stated, so compare with care.
"""

from __future__ import annotations

import math
import os
import platform
import socket
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, NamedTuple

import numpy as np

from navbench.errors import ConfigError
from navbench.geometry import AGENT_RADIUS, CAMERA_HEIGHT, CAMERAS, Intrinsics

#: The paper's per-step figures (section 5, fig. 4c; Quadro RTX 8000 GPU), in our units.
PAPER_FIGURES: dict[str, float] = {
    "voxel_render_ms": 50.0,  # one image rendered from the voxel map
    "nerf_render_ms": 2720.0,  # one image rendered from a NeRF map (not part of navbench)
    "emission_track_ms": 250.0,  # one emission-based tracking step
    "ours_track_ms": 60.0,  # one prediction-to-observation tracking step
    "control_step_ms": 62.0,  # ours + control, one full time step
    "control_step_hz": 16.1,
}
PAPER_HARDWARE = "NVIDIA Quadro RTX 8000 GPU + 8 Intel Xeon Gold 6252 cores (2.1 GHz)"

#: The paper's Monte-Carlo batch of the map fit: 25 images x 200 pixels (appendix A).
FIT_BATCH = (25, 200)
#: Pixels per step of the paper's trackers (appendix C).
TRACK_PIXELS = 1000
#: The paper's fit length, for the extrapolated fit time.
FIT_STEPS = 10_000
#: The paper's ray sampling for fitting (appendix A): n = 200 samples, n * Delta = 20 m.
RAY_SAMPLES = 200
RAY_STEP = 20.0 / RAY_SAMPLES
#: Adam steps of one emission update (paper) and of the quick benchmark's shortened update.
EMISSION_STEPS = 100
QUICK_EMISSION_STEPS = 10


class Stats(NamedTuple):
    """Summary of a timing list: count, median, quartiles (numpy's linear interpolation), range."""

    n: int
    median: float
    q1: float
    q3: float
    min: float
    max: float

    @property
    def iqr(self) -> float:
        return self.q3 - self.q1


def stats(values) -> Stats:
    """:class:`Stats` of ``values``; all-NaN fields when there are none."""
    a = np.asarray(list(values), dtype=np.float64)
    if a.size == 0:
        nan = math.nan
        return Stats(0, nan, nan, nan, nan, nan)
    q1, med, q3 = np.percentile(a, [25, 50, 75])
    return Stats(int(a.size), float(med), float(q1), float(q3), float(a.min()), float(a.max()))


@dataclass(frozen=True)
class Target:
    """A speed target of issue #7: ``key`` compared with ``threshold`` by ``op`` (``<=``/``>=``)."""

    key: str
    op: str
    threshold: float
    label: str

    def check(self, value: float | None) -> bool | None:
        if value is None or not math.isfinite(value):
            return None
        return value <= self.threshold if self.op == "<=" else value >= self.threshold


TARGETS: tuple[Target, ...] = (
    Target("render_ms_paper", "<=", 10.0, "map render, paper camera <= 10 ms"),
    Target("track_ms_ours_paper", "<=", 30.0, "ours tracking step, paper camera <= 30 ms"),
    Target("control_step_hz_paper", ">=", 20.0, "full control step, paper camera >= 20 Hz"),
    Target("control_step_hz_half", ">=", 50.0, "full control step, half camera >= 50 Hz"),
    Target("emission_ours_ratio_half", ">=", 4.0,
           "emission / ours step time, equal pixel budget >= 4"),
    Target("fit_10k_steps_s", "<=", 180.0,
           "fit-map 10 000 steps <= 3 min (extrapolated from one step)"),
)


# ---------------------------------------------------------------------------------- helpers

def timed_loop(call: Callable[[int], float], repeats: int, warmup: int = 1,
               budget_s: float | None = None) -> list[float]:
    """Run ``call(k)`` ``warmup`` times untimed, then up to ``repeats`` times; ``call`` returns
    the milliseconds of the part it times (its set-up stays outside). Stops early once
    ``budget_s`` seconds have passed and ``min(3, repeats)`` repeats are done."""
    for k in range(warmup):
        call(k)
    out: list[float] = []
    t_start = time.perf_counter()
    for k in range(repeats):
        out.append(float(call(warmup + k)))
        if budget_s is not None and len(out) >= min(3, repeats) and \
                time.perf_counter() - t_start > budget_s:
            break
    return out


def _ms(fn: Callable[[], Any]) -> float:
    t0 = time.perf_counter()
    fn()
    return 1000.0 * (time.perf_counter() - t0)


def _torch_sync(device: str) -> None:
    if device.startswith("cuda"):
        import torch

        torch.cuda.synchronize()


# ---------------------------------------------------------------------------------- the map

def bench_map(level, level_file: Path | None, cache_root: str | Path = "results/cache"):
    """``(vmap, description)``: the newest verified fit-map artifact of ``level`` in the cache
    (matched by the sha256 of ``level_file``), else :func:`voxelize_level` on the paper grid."""
    import hashlib

    from navbench.worldmodel.grid import grid_for_level, load_map, voxelize_level

    root = Path(cache_root)
    spec = grid_for_level(level)
    if level_file is not None and root.is_dir():
        from navbench.errors import ArtifactError
        from navbench.pipeline.cache import ArtifactStore

        level_key = hashlib.sha256(Path(level_file).read_bytes()).hexdigest()
        store = ArtifactStore(root)
        for stage in ("fit-map", "true-map"):
            for info in reversed(store.ls(stage)):
                if info.inputs.get("level") != level_key:
                    continue
                try:
                    store.verify(stage, info.key)
                    vmap = load_map(info.path / "map.npz")
                except ArtifactError:
                    continue
                if stage == "true-map" and vmap.spec != spec:
                    continue
                what = "fitted map" if stage == "fit-map" else "true geometry voxelized (cached)"
                return vmap, f"{what} {stage}/{info.key[:12]} from {root} ({_shape(vmap)})"
    vmap = voxelize_level(level, spec)
    return vmap, f"true geometry voxelized (voxelize_level, {_shape(vmap)}; no fitted map in {root})"


def _shape(vmap) -> str:
    return " x ".join(str(n) for n in vmap.spec.shape)


# ---------------------------------------------------------------------------------- simulator

def time_sim_frame(level, intrinsics: Intrinsics, repeats: int, warmup: int = 2, seed: int = 0) -> list[float]:
    """One RGB-D frame of the simulator's ray-cast camera (see :mod:`navbench.sim.bench`)."""
    from navbench.sim.bench import time_render

    return time_render(level, intrinsics, repeats=repeats, warmup=warmup, seed=seed)


def time_sim_step(level, repeats: int, warmup: int = 10, seed: int = 0) -> list[float]:
    """One dynamics + collision step of the simulator, no rendering."""
    from navbench.sim.bench import time_step

    return time_step(level, repeats=repeats, warmup=warmup, noise="mid", seed=seed)


# ---------------------------------------------------------------------------------- world model

def time_map_render(level, vmap, intrinsics: Intrinsics, repeats: int, warmup: int = 2, seed: int = 0,
                    budget_s: float | None = None) -> list[float]:
    """One fast (numba) render of ``vmap`` from free-space poses, with a kept
    :class:`~navbench.worldmodel.fastrender.FastRenderer` (as the trackers use it)."""
    from navbench.sim.bench import bench_poses
    from navbench.worldmodel.fastrender import FastRenderer

    fr = FastRenderer(vmap, intrinsics, CAMERA_HEIGHT)
    poses = bench_poses(level, warmup + repeats, seed)
    return timed_loop(lambda k: _ms(lambda: fr.render(poses[k])), repeats, warmup, budget_s)


def _fit_tensors(vmap, device: str):
    import torch

    occ = torch.tensor(vmap.occ, dtype=torch.float32, device=device, requires_grad=True)
    col = torch.tensor(vmap.col, dtype=torch.float32, device=device, requires_grad=True)
    return occ, col


def _bench_rays(level, count: int, pixels: int, seed: int, intrinsics: Intrinsics):
    """``(origins, dirs)`` (R, 3) float32 world rays: ``count`` free-space poses x ``pixels``
    uniform pixels of ``intrinsics``."""
    from navbench.geometry import camera_rotation, pixel_rays
    from navbench.sim.bench import bench_poses

    poses = bench_poses(level, count, seed)
    rng = np.random.default_rng(seed)
    cam = pixel_rays(intrinsics).reshape(-1, 3)
    pix = rng.integers(0, len(cam), size=(count, pixels))
    R = np.stack([camera_rotation(t) for t in poses[:, 2]])
    dirs = np.einsum("bij,bpj->bpi", R, cam[pix]).reshape(-1, 3)
    origins = np.repeat(np.column_stack([poses[:, :2], np.full(count, CAMERA_HEIGHT)]), pixels, axis=0)
    return origins.astype(np.float32), dirs.astype(np.float32)


def time_diff_render(level, vmap, rays: int, repeats: int, warmup: int = 2, seed: int = 0,
                     device: str = "cpu", budget_s: float | None = None) -> list[float]:
    """One forward pass of the differentiable eq. 1-2 renderer over ``rays`` rays (the map
    tensors require grad, so the autograd graph is built), with the fit's sampling
    (``Delta = 0.1 m``, ``n = 200``). Rays: ``rays // 200`` free-space poses x 200 pixels of
    the paper camera (or one pose x ``rays`` pixels when ``rays < 200``).

    ``device`` as :class:`~navbench.worldmodel.fit.FitConfig`'s: ``"cpu"``:
    :func:`~navbench.worldmodel.diffrender.render_rays` (numba crossing search + autograd at the
    bracket); ``"cuda[:N]"`` (or ``"torch-cpu"``):
    :func:`~navbench.worldmodel.diffrender.render_rays_torch` (every sample searched on the
    device, autograd at the bracket), the renderer of the fit's device path.
    """
    import torch

    from navbench.geometry import PAPER_CAMERA
    from navbench.worldmodel.diffrender import render_rays, render_rays_torch

    per = min(200, rays)
    o_np, d_np = _bench_rays(level, max(1, rays // per), per, seed, PAPER_CAMERA)
    dev = "cpu" if device == "torch-cpu" else device
    fn = render_rays if device == "cpu" else render_rays_torch
    occ, col = _fit_tensors(vmap, dev)
    o = torch.from_numpy(o_np).to(dev)
    d = torch.from_numpy(d_np).to(dev)

    def call(_k: int) -> float:
        _torch_sync(dev)
        t0 = time.perf_counter()
        out = fn(occ, col, vmap.spec, vmap.tau, o, d, RAY_STEP, RAY_SAMPLES)
        out.depth.sum().item()  # touch the result (waits for the device)
        _torch_sync(dev)
        return 1000.0 * (time.perf_counter() - t0)

    return timed_loop(call, repeats, warmup, budget_s)


def time_fit_step(level, repeats: int, warmup: int = 1, seed: int = 0, views_count: int = 50,
                  chunk: int = 10, device: str = "cpu") -> list[float]:
    """One step of the map fit, timed inside :func:`navbench.worldmodel.fit.fit_map` itself:
    a fit with the default :class:`~navbench.worldmodel.fit.FitConfig` on ``device`` (25 x 200
    pixel batches, render, eq. 2-3 NLL and the free-space term, backward, lazy Adam) runs
    ``chunk * (warmup + repeats)`` steps on ``views_count`` seeded half-camera views of
    ``level``; its progress callback (every ``chunk`` steps) gives one time per ``chunk``
    steps, reported per step. The device path reads each step's loss back, so a step has
    finished on the GPU when it is counted. The first ``warmup`` chunks (compilation, start-up)
    are dropped. These are the first steps of a fit from the paper's initialisation."""
    from navbench.geometry import HALF_CAMERA
    from navbench.worldmodel.fit import FitConfig, fit_map
    from navbench.worldmodel.views import collect_views

    views = collect_views(level, views_count, HALF_CAMERA, seed)
    stamps: list[tuple[int, float]] = []
    cfg = FitConfig(steps=chunk * (warmup + repeats), seed=seed, device=device)

    def progress(step: int, _total: int, _loss: float) -> None:
        stamps.append((step, time.perf_counter()))

    t0 = time.perf_counter()
    fit_map(views, cfg, progress=progress)
    out = []
    prev_step, prev_t = 0, t0
    for k, (st, t) in enumerate(stamps):
        if k >= warmup and st > prev_step:
            out.append(1000.0 * (t - prev_t) / (st - prev_step))
        prev_step, prev_t = st, t
    return out


# ---------------------------------------------------------------------------------- planning

def far_pair(level, vmap, seed: int = 0, candidates: int = 48) -> tuple[np.ndarray, np.ndarray]:
    """The farthest-apart pair among ``candidates`` free points (seeded) that A* connects on the
    map's band slice without the straight-line shortcut: ``(start_xy, goal_xy)``."""
    from navbench.plan.astar import make_planner_map, plan_on_map, straight_line_free
    from navbench.sim.bench import bench_poses
    from navbench.worldmodel.grid import occupancy_slice

    occ2d, xs, ys = occupancy_slice(vmap, "band")
    pm = make_planner_map(occ2d, xs, ys)
    pts = bench_poses(level, candidates, seed)[:, :2]
    d = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
    order = np.dstack(np.unravel_index(np.argsort(-d, axis=None), d.shape))[0]
    for i, j in order[: 2 * candidates]:
        if i < j and not straight_line_free(pm, pts[i], pts[j]) and plan_on_map(pm, pts[i], pts[j]).ok:
            return pts[i], pts[j]
    raise ConfigError(f"no far start/goal pair that A* connects on level {level.name!r}")


def time_plan(level, vmap, repeats: int, warmup: int = 1, seed: int = 0,
              budget_s: float | None = None) -> list[float]:
    """One A* plan across the level (the :func:`far_pair`) on the map's band slice, with the
    per-map distance transform precomputed (as the episode loop does)."""
    from navbench.plan.astar import make_planner_map, plan_on_map
    from navbench.worldmodel.grid import occupancy_slice

    occ2d, xs, ys = occupancy_slice(vmap, "band")
    pm = make_planner_map(occ2d, xs, ys)
    a, b = far_pair(level, vmap, seed)
    return timed_loop(lambda k: _ms(lambda: plan_on_map(pm, a, b)), repeats, warmup, budget_s)


# ---------------------------------------------------------------------------------- tracking

class Walk(NamedTuple):
    """A recorded camera trajectory: start pose and frame, then per step the applied control,
    the observation and the true pose."""

    pose0: np.ndarray
    frame0: Any
    controls: list
    frames: list
    poses: list


def record_walk(level, intrinsics: Intrinsics, steps: int, seed: int = 0, noise: str = "tracking") -> Walk:
    """Drive the simulator ``steps`` controls from a seeded free pose: forward (0.8 of the
    maximum step, a little turn) while a swept disc of twice the agent's radius is free three
    steps ahead, else turn in place; a random 20 % of the steps turn anyway."""
    from navbench.sim.bench import bench_poses
    from navbench.sim.dynamics import MAX_STEP, MAX_TURN, Control
    from navbench.sim.world import CollisionWorld, Simulator

    sim = Simulator(level, noise=noise, seed=seed, intrinsics=intrinsics, camera_height=CAMERA_HEIGHT)
    rng = np.random.default_rng(seed)
    wide = CollisionWorld(level, radius=2 * AGENT_RADIUS)
    pose0 = bench_poses(level, 1, seed + 7)[0]
    frame0 = sim.reset(pose0)
    pose0 = sim.pose.copy()
    controls, frames, poses = [], [], []
    turn_dir = 1.0
    for _ in range(steps):
        th = float(sim.pose[2])
        ahead = sim.pose[:2] + 3 * MAX_STEP * np.array([math.cos(th), math.sin(th)])
        _, blocked = wide.sweep(sim.pose[:2], ahead)
        if blocked or rng.random() < 0.2:
            if rng.random() < 0.1:
                turn_dir = -turn_dir
            u = Control(turn_dir * 0.8 * MAX_TURN, th, 0.0)
        else:
            u = Control(float(rng.uniform(-0.2, 0.2)) * MAX_TURN, th, 0.8 * MAX_STEP)
        res = sim.step(u)
        controls.append(sim.last_control)
        frames.append(res.frame)
        poses.append(res.pose.copy())
    return Walk(pose0, frame0, controls, frames, poses)


def time_tracking(walk: Walk, vmap, intrinsics: Intrinsics, estimator: str, options: dict | None = None,
                  repeats: int = 10, warmup: int = 2, seed: int = 0,
                  budget_s: float | None = None) -> list[float]:
    """One ``estimator.update`` (the reference render included) along ``walk``: the estimator is
    reset at the walk's known start, the first ``warmup`` steps are tracked untimed."""
    from navbench.track.base import make_estimator

    if len(walk.controls) < warmup + repeats:
        raise ConfigError(f"the walk has {len(walk.controls)} steps, {warmup + repeats} needed")
    est = make_estimator(estimator, vmap=vmap, intrinsics=intrinsics, camera_height=CAMERA_HEIGHT,
                         seed=seed, **(options or {}))
    est.reset(walk.pose0.copy(), walk.frame0)

    def call(k: int) -> float:
        return _ms(lambda: est.update(walk.controls[k], walk.frames[k], true_pose=walk.poses[k]))

    return timed_loop(call, repeats, warmup, budget_s)


# ---------------------------------------------------------------------------------- control step

def bench_tasks(level, vmap, count: int, seed: int = 0) -> list:
    """``count`` tasks between seeded free points at least 2 m apart (``optimal_length`` is the
    straight-line distance: these tasks are for timing, not scoring)."""
    from navbench.plan.tasks import Task
    from navbench.sim.bench import bench_poses

    pts = bench_poses(level, 8 * count + 16, seed)
    tasks = []
    for k in range(0, len(pts) - 1, 2):
        a, b = pts[k], pts[k + 1]
        dist = float(np.hypot(*(b[:2] - a[:2])))
        if dist >= 2.0:
            tasks.append(Task(len(tasks), (float(a[0]), float(a[1]), float(a[2])),
                              (float(b[0]), float(b[1])), dist))
        if len(tasks) == count:
            break
    return tasks


def time_control_step(level, vmap, intrinsics: Intrinsics, repeats: int, warmup: int = 3, seed: int = 0,
                      estimator: str = "ours", noise: str = "mid", budget_s: float | None = None) -> list[float]:
    """One full time step of :func:`navbench.nav.episode.run_episode` with ``estimator`` (its
    default options, as navigation runs it): controller, simulator step with its RGB-D
    observation, tracking with the map render, and A* when (re)planning -- the per-step sum of
    the episode's recorded component timings. Episodes over seeded tasks run until ``repeats``
    steps are in (or ``budget_s`` is spent); one short episode of ``warmup`` steps runs first."""
    from dataclasses import replace

    from navbench.nav.episode import EpisodeConfig, run_episode
    from navbench.plan.astar import make_planner_map
    from navbench.sim.world import Simulator
    from navbench.track.base import make_estimator
    from navbench.worldmodel.grid import occupancy_slice

    occ2d, xs, ys = occupancy_slice(vmap, "band")
    pm = make_planner_map(occ2d, xs, ys)
    tasks = bench_tasks(level, vmap, 64, seed)

    def episode(task, max_steps: int, ep_seed: int) -> np.ndarray:
        sim = Simulator(level, noise=noise, seed=ep_seed, intrinsics=intrinsics, camera_height=CAMERA_HEIGHT)
        est = make_estimator(estimator, vmap=vmap, intrinsics=intrinsics, camera_height=CAMERA_HEIGHT,
                             seed=ep_seed)
        cfg = replace(EpisodeConfig(), max_steps=max_steps)
        rec = run_episode(level, occ2d, xs, ys, task, est, sim, config=cfg, planner_map=pm)
        t = rec.timings_ms
        return np.sum([np.asarray(t[k], dtype=np.float64) for k in t], axis=0) if rec.steps else np.zeros(0)

    episode(tasks[-1], max(1, warmup), seed + 10_000)
    out: list[float] = []
    t_start = time.perf_counter()
    for i, task in enumerate(tasks[:-1]):
        out.extend(episode(task, repeats - len(out), seed + i).tolist())
        if len(out) >= repeats or (budget_s is not None and len(out) >= min(3, repeats)
                                   and time.perf_counter() - t_start > budget_s):
            break
    return out[:repeats]


# ---------------------------------------------------------------------------------- end to end

class Throughput(NamedTuple):
    """Episodes and steps run in ``seconds`` of wall-clock time by ``workers`` processes."""

    episodes: int
    steps: int
    seconds: float
    workers: int


def time_navigation(level_file: Path, vmap, tasks: list, estimators: tuple[str, ...], workers: int,
                    camera: str = "half", noise: str = "mid", seed: int = 0) -> Throughput:
    """Episodes per wall-clock time through the pipeline's run-navigation stage
    (:func:`navbench.pipeline.stages.run_navigation_stage`) with a local process pool, in a
    throw-away cache and SQLite database: ``tasks`` x ``estimators`` episodes at ``noise``.
    A warm-up pass (one 2-step episode per worker, same pool) runs first and is not timed."""
    import hashlib

    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.db import ResultsDB
    from navbench.pipeline.executor import make_executor
    from navbench.pipeline.stages import (
        LevelInputs,
        NavigationConfig,
        Ref,
        StageContext,
        run_navigation_stage,
    )
    from navbench.plan.tasks import save_tasks
    from navbench.worldmodel.grid import save_map

    def sha(p: Path) -> str:
        return hashlib.sha256(Path(p).read_bytes()).hexdigest()

    with tempfile.TemporaryDirectory(prefix="navbench-bench-") as tmp:
        d = Path(tmp)
        map_path = save_map(vmap, d / "map.npz")
        task_path = save_tasks(d / "tasks.json", vmap.meta.get("level", "bench"), tasks, seed=seed)
        warm_path = save_tasks(d / "warm.json", vmap.meta.get("level", "bench"), tasks[:max(1, workers)], seed=seed)
        lref = Ref("make-level", sha(level_file), Path(level_file), True, "bench")
        mref = Ref("fit-map", sha(map_path), map_path, True, "bench")
        inputs = [LevelInputs(lref, mref, Ref("sample-tasks", sha(task_path), task_path, True, "bench"))]
        warm = [LevelInputs(lref, mref, Ref("sample-tasks", sha(warm_path), warm_path, True, "bench"))]
        db = ResultsDB(f"sqlite:///{d / 'bench.db'}")
        try:
            run_id = db.start_run(profile="bench", command="bench e2e", config={}, config_hash="")
            ctx = StageContext(store=ArtifactStore(d / "cache"), db=db)
            cfg = NavigationConfig(estimators=tuple(estimators), noise=(noise,), seeds=1, camera=camera)
            warm_cfg = NavigationConfig(estimators=(estimators[0],), noise=(noise,), seeds=1, camera=camera,
                                        episode={"max_steps": 2})
            with make_executor("local", workers) as ex:
                run_navigation_stage(ctx, run_id, warm, warm_cfg, executor=ex, chunk_size=1)
                t0 = time.perf_counter()
                summary = run_navigation_stage(ctx, run_id, inputs, cfg, executor=ex, chunk_size=1)
                seconds = time.perf_counter() - t0
            frame = db.episodes_frame(run_ids=[run_id])
            keys = {c.key for c in summary.cells}
            steps = int(frame.loc[frame["cell_key"].isin(keys), "steps"].sum()) if len(frame) else 0
            return Throughput(int(summary.ran), steps, seconds, int(getattr(ex, "workers", workers)))
        finally:
            db.close()


# ---------------------------------------------------------------------------------- the whole run

@dataclass(frozen=True)
class BenchConfig:
    """What :func:`run_bench` measures and how long it may take.

    ``repeats``: timed repeats per measurement (``None``: 5 with ``quick``, 20 otherwise);
    ``budget_s``: seconds after which a measurement stops repeating (once it has 3 repeats);
    ``workers``: local processes of the end-to-end measurement (0: the CPU count);
    ``e2e_tasks``: navigation tasks of the end-to-end measurement (``None``: 2 quick, 6 default),
    run with ``e2e_estimators`` (``None``: ``ours`` quick, ``ours, no-map, dynamics`` default).
    """

    level: str = "house-1"
    quick: bool = False
    repeats: int | None = None
    seed: int = 0
    budget_s: float | None = None
    workers: int = 0
    e2e_tasks: int | None = None
    e2e_estimators: tuple[str, ...] | None = None
    cache_root: str = "results/cache"
    root: str = "."  # project root: levels are read from ROOT/levels/NAME.json
    cuda: bool | None = None  # None: whenever torch sees a CUDA device

    def __post_init__(self):
        if self.repeats is not None and self.repeats < 1:
            raise ConfigError(f"repeats must be >= 1, got {self.repeats}")
        if self.workers < 0:
            raise ConfigError(f"workers must be >= 0, got {self.workers}")
        if self.e2e_tasks is not None and self.e2e_tasks < 0:
            raise ConfigError(f"e2e tasks must be >= 0, got {self.e2e_tasks}")

    @property
    def n(self) -> int:
        return self.repeats if self.repeats is not None else (5 if self.quick else 20)

    @property
    def budget(self) -> float:
        return self.budget_s if self.budget_s is not None else (2.0 if self.quick else 12.0)


@dataclass
class Metric:
    """One row of the benchmark: ``key``, what it is, its unit, its timing statistics (or a
    derived ``value``), the device, the paper's figure to compare with and a note."""

    key: str
    group: str
    label: str
    unit: str
    value: float | None
    stats: Stats | None = None
    device: str = "cpu"
    paper: float | None = None
    note: str = ""


# The ordered list of flat keys run_bench always returns (None where n/a).
CAMERA_NAMES = ("half", "paper")
TRACKERS = (  # (key part, estimator name, options, label)
    ("ours", "ours", {}, "ours, default"),
    ("ours_adam", "ours", {"optimizer": "adam"}, "ours, Adam 100x1000 px"),
    ("ours_gauss_newton", "ours", {"optimizer": "gauss-newton"}, "ours, Gauss-Newton"),
    ("no_map", "no-map", {}, "no-map, default"),
    ("emission", "emission", {}, "emission, Adam 100x1000 px"),
)


def metric_keys() -> list[str]:
    """Every flat key of :func:`run_bench`'s result that holds a measurement."""
    keys = ["sim_frame_ms_half", "sim_frame_ms_paper", "sim_step_ms", "render_ms_half", "render_ms_paper",
            "diffrender_ms_5000", "diffrender_ms_1000", "fit_step_ms", "fit_10k_steps_s",
            "diffrender_ms_5000_cuda", "fit_step_ms_cuda", "fit_10k_steps_s_cuda", "plan_ms"]
    keys += [f"track_ms_{t[0]}_{c}" for c in CAMERA_NAMES for t in TRACKERS]
    keys += ["emission_ours_ratio_half", "emission_ours_ratio_paper"]
    keys += [f"control_step_{u}_{c}" for c in CAMERA_NAMES for u in ("ms", "hz")]
    keys += ["e2e_episodes_per_min", "e2e_steps_per_s"]
    return keys


def host_info() -> dict[str, Any]:
    """Host name, CPU model and cores, load average, library versions and thread counts."""
    import numba
    import torch

    from navbench import __version__
    from navbench.pipeline.db import cpu_description

    cuda = torch.cuda.is_available()
    load = os.getloadavg() if hasattr(os, "getloadavg") else (math.nan,) * 3
    return {
        "host": socket.gethostname(),
        "cpu": cpu_description(),
        "cpu_count": os.cpu_count(),
        "platform": platform.platform(),
        "python_version": platform.python_version(),
        "navbench_version": __version__,
        "torch_version": torch.__version__,
        "numba_version": numba.__version__,
        "numpy_version": np.__version__,
        "torch_threads": torch.get_num_threads(),
        "numba_threads": numba.get_num_threads(),
        "cuda_device": torch.cuda.get_device_name(0) if cuda else None,
        "device": "cpu + cuda:0" if cuda else "cpu",
        "load_avg_1m_start": float(load[0]),
    }


def run_bench(quick: bool = False, repeats: int | None = None, config: BenchConfig | None = None,
              progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run every measurement (see the module docstring) and return the JSON-ready result.

    ``quick``/``repeats`` fill a default :class:`BenchConfig` when ``config`` is None.
    ``progress(label)`` is called before each measurement. Result keys: every
    :func:`metric_keys` entry (a positive float, or None with ``notes[key]``), ``stats``
    (per key: n, median, q1, q3, min, max), ``units``, ``devices``, ``paper`` (the paper's
    figures), ``paper_hardware``, ``targets``, ``map``, ``config``, ``wall_s``, ``notes`` and
    :func:`host_info`.
    """
    import dataclasses

    import torch

    from navbench.level import level_path, resolve_level
    from navbench.track.base import estimator_names

    cfg = config if config is not None else BenchConfig(quick=quick, repeats=repeats)
    sections: dict[str, float] = {}
    last = [None, time.perf_counter()]

    def say(label: str) -> None:
        now = time.perf_counter()
        if last[0] is not None:
            sections[last[0]] = round(now - last[1], 3)
        last[0], last[1] = label, now
        if progress is not None:
            progress(label)

    n, budget, seed = cfg.n, cfg.budget, cfg.seed
    t_start = time.perf_counter()
    info = host_info()
    level = resolve_level(cfg.level, cfg.root)
    level_file = Path(cfg.level) if Path(cfg.level).suffix == ".json" else level_path(cfg.level, cfg.root)
    level_file = level_file if level_file.is_file() else None
    say("map")
    vmap, map_desc = bench_map(level, level_file, cfg.cache_root)
    from navbench.worldmodel.fastrender import map_step

    step = map_step(vmap, None)
    metrics: dict[str, Metric] = {}

    def add(m: Metric) -> None:
        metrics[m.key] = m

    def timed(key, group, label, times, unit="ms", paper=None, device="cpu", note=""):
        s = stats(times)
        if not s.n:
            note = "nothing was timed (no repeat completed)" + (f"; {note}" if note else "")
        add(Metric(key, group, label, unit, s.median if s.n else None, s, device, paper, note))

    def na(key, group, label, note, unit="ms", paper=None, device="cpu"):
        add(Metric(key, group, label, unit, None, None, device, paper, note))

    # simulator
    for cam in CAMERA_NAMES:
        say(f"simulator frame ({cam})")
        timed(f"sim_frame_ms_{cam}", "simulator", f"sim RGB-D frame, {cam}",
              time_sim_frame(level, CAMERAS[cam], n, seed=seed))
    say("simulator step")
    timed("sim_step_ms", "simulator", "sim dynamics + collision step",
          time_sim_step(level, 50 * n, seed=seed))

    # world model
    for cam in CAMERA_NAMES:
        say(f"map render ({cam})")
        timed(f"render_ms_{cam}", "world model", f"map render (numba), {cam}",
              time_map_render(level, vmap, CAMERAS[cam], n, seed=seed, budget_s=budget),
              paper=PAPER_FIGURES["voxel_render_ms"] if cam == "paper" else None,
              note=f"ray samples every {step:.4g} m (the map's Delta), {int(round(20.0 / step))} per ray")
    for rays in (5000, 1000):
        say(f"differentiable render ({rays} rays)")
        timed(f"diffrender_ms_{rays}", "world model",
              f"diff. render fwd, {rays} rays" + (" (25x200)" if rays == 5000 else ""),
              time_diff_render(level, vmap, rays, n, seed=seed, budget_s=budget),
              note="render_rays (numba crossing search + autograd at the bracket), Delta 0.1 m, "
                   "n 200, paper-camera pixels")
    say("fit-map step")
    from navbench.worldmodel.fit import FitConfig

    fit_chunks = min(n, 3) if cfg.quick else n
    fit_note = (f"fit_map itself on the CPU path (optimizer {FitConfig().optimizer!r}, default "
                "FitConfig): mean step time of each block of 10 steps after a 10-step warm-up, "
                "the first steps of a fit from the paper's initialisation")
    timed("fit_step_ms", "world model", "fit-map step (25x200 px, fwd+bwd+Adam)",
          time_fit_step(level, fit_chunks, seed=seed, device="cpu"), note=fit_note)

    def fit_10k(suffix: str, device: str) -> None:
        med = metrics["fit_step_ms" + suffix].value
        add(Metric("fit_10k_steps_s" + suffix, "world model",
                   "fit-map 10 000 steps" + (" [CUDA]" if suffix else ""), "s",
                   None if med is None else med * FIT_STEPS / 1000.0, device=device,
                   note="EXTRAPOLATED: 10 000 x the median fit-map step time"))

    fit_10k("", "cpu")
    use_cuda = torch.cuda.is_available() if cfg.cuda is None else (cfg.cuda and torch.cuda.is_available())
    cuda_rows = (("diffrender_ms_5000_cuda", "diff. render fwd, 5000 rays [CUDA]",
                  "render_rays_torch (crossing search over every sample on the GPU, autograd at "
                  "the bracket) on cuda:0, the fit's device path",
                  lambda: time_diff_render(level, vmap, 5000, n, seed=seed, device="cuda", budget_s=budget)),
                 ("fit_step_ms_cuda", "fit-map step, 25x200 px [CUDA]",
                  "fit_map itself with device='cuda' (render_rays_torch, free-space term, masked "
                  "lazy Adam on cuda:0); blocks of 10 steps as the CPU row",
                  lambda: time_fit_step(level, fit_chunks, seed=seed, device="cuda")))
    for key, label, what, fn in cuda_rows:
        if not use_cuda:
            na(key, "world model", label, "no CUDA device" if cfg.cuda is None or cfg.cuda else "CUDA disabled",
               device="cuda:0")
        else:
            say(label)
            try:
                timed(key, "world model", label, fn(), device="cuda:0", note=what)
            except RuntimeError as e:  # report a failing device path as n/a and go on
                na(key, "world model", label, f"CUDA run failed: {str(e).splitlines()[0][:160]}",
                   device="cuda:0")
    fit_10k("_cuda", "cuda:0")

    # planning
    say("A* plan")
    timed("plan_ms", "planning", f"A* plan across {level.name}",
          time_plan(level, vmap, n, seed=seed, budget_s=budget),
          note="the farthest seeded free-point pair that needs A* (no straight-line shortcut), "
               "band slice of the map, distance transform precomputed")

    # tracking
    available = set(estimator_names())
    track_warmup = 2
    for cam in CAMERA_NAMES:
        say(f"record a walk ({cam})")
        walk = record_walk(level, CAMERAS[cam], track_warmup + n, seed=seed)
        for part, name, options, label in TRACKERS:
            key = f"track_ms_{part}_{cam}"
            paper = PAPER_FIGURES["ours_track_ms"] if part == "ours" else \
                PAPER_FIGURES["emission_track_ms"] if part == "emission" else None
            if part == "ours" and name in available:
                from navbench.track.ours import TrackerConfig

                label = f"{label} = {TrackerConfig().optimizer}"
            full = f"track {label}, {cam}"
            if name not in available:
                na(key, "tracking", full, f"estimator {name!r} not available yet", paper=paper)
                continue
            say(f"tracking {part} ({cam})")
            scale, note = 1.0, "estimator.update incl. the reference render, tracking-noise walk"
            if name == "emission" and cfg.quick:
                # quick: 10 of the paper's 100 Adam steps (each step renders and back-propagates
                # the same 1000 pixels; an update has no other work), scaled to 100
                options = {**options, "steps": QUICK_EMISSION_STEPS}
                scale = EMISSION_STEPS / QUICK_EMISSION_STEPS
                note = (f"quick: measured with {QUICK_EMISSION_STEPS} Adam steps x 1000 px, "
                        f"scaled x{scale:g} to the paper's {EMISSION_STEPS}")
            times = time_tracking(walk, vmap, CAMERAS[cam], name, options, n,
                                  1 if name == "emission" else track_warmup, seed, budget)
            timed(key, "tracking", full, [scale * t for t in times], paper=paper, note=note)
        e, o = metrics[f"track_ms_emission_{cam}"].value, metrics[f"track_ms_ours_adam_{cam}"].value
        add(Metric(f"emission_ours_ratio_{cam}", "tracking", f"emission / ours-Adam step, {cam}", "x",
                   None if e is None or o is None else e / o,
                   paper=PAPER_FIGURES["emission_track_ms"] / PAPER_FIGURES["ours_track_ms"],
                   note="equal pixel budget: both Adam, 100 steps x 1000 pixels"
                   if e is not None and o is not None else "needs both the emission and the ours-Adam step"))

    # the full control step
    for cam in CAMERA_NAMES:
        ms_key, hz_key = f"control_step_ms_{cam}", f"control_step_hz_{cam}"
        ms_label, hz_label = f"control step (ours), {cam}", f"control step rate (ours), {cam}"
        if "ours" not in available:
            na(ms_key, "control", ms_label, "estimator 'ours' not available")
            na(hz_key, "control", hz_label, "estimator 'ours' not available", unit="Hz")
            continue
        say(f"control step ({cam})")
        times = time_control_step(level, vmap, CAMERAS[cam], max(n, 10), seed=seed, budget_s=budget)
        timed(ms_key, "control", ms_label, times, paper=PAPER_FIGURES["control_step_ms"],
              note="run_episode per-step sum: controller + simulator step with its RGB-D frame + "
                   "tracking with the map render + A* when (re)planning; mid noise")
        s = metrics[ms_key].stats
        hz = Stats(s.n, 1000.0 / s.median, 1000.0 / s.q3, 1000.0 / s.q1, 1000.0 / s.max, 1000.0 / s.min) \
            if s.n else None
        add(Metric(hz_key, "control", hz_label, "Hz", hz.median if hz else None, hz,
                   paper=PAPER_FIGURES["control_step_hz"], note="1000 / step time (quartiles likewise)"))

    # end to end
    e2e_tasks = cfg.e2e_tasks if cfg.e2e_tasks is not None else (2 if cfg.quick else 6)
    e2e_est = cfg.e2e_estimators or (("ours",) if cfg.quick else ("ours", "no-map", "dynamics"))
    e2e_est = tuple(e for e in e2e_est if e in available)
    if e2e_tasks == 0 or not e2e_est or level_file is None:
        why = "disabled (0 tasks)" if e2e_tasks == 0 else "no estimator available" if not e2e_est \
            else "the level is not a committed level file"
        na("e2e_episodes_per_min", "end to end", "episodes per minute", why, unit="episodes/min")
        na("e2e_steps_per_s", "end to end", "episode steps per second", why, unit="steps/s")
    else:
        from navbench.pipeline.executor import default_workers

        workers = cfg.workers or default_workers()
        say(f"end to end ({e2e_tasks} tasks x {len(e2e_est)} estimators, {workers} workers)")
        tp = time_navigation(Path(level_file), vmap, bench_tasks(level, vmap, e2e_tasks, seed + 1),
                             e2e_est, workers, camera="half", noise="mid", seed=seed)
        desc = (f"run-navigation stage: {tp.episodes} episodes ({e2e_tasks} tasks x "
                f"{', '.join(e2e_est)}), {tp.steps} steps, mid noise, half camera, {tp.workers} local "
                f"workers, {tp.seconds:.1f} s after a warm-up pass")
        add(Metric("e2e_episodes_per_min", "end to end", f"episodes per minute ({tp.workers} workers)",
                   "episodes/min", 60.0 * tp.episodes / tp.seconds if tp.episodes else None, note=desc))
        add(Metric("e2e_steps_per_s", "end to end", f"episode steps per second ({tp.workers} workers)",
                   "steps/s", tp.steps / tp.seconds if tp.steps else None, note=desc))

    say("done")
    load = os.getloadavg() if hasattr(os, "getloadavg") else (math.nan,)
    context = {**info, "map": map_desc, "render_step_m": step, "level": cfg.level, "quick": cfg.quick,
               "repeats": n, "config": {**dataclasses.asdict(cfg), "repeats": n, "budget_s": budget},
               "load_avg_1m_end": float(load[0]), "wall_s": time.perf_counter() - t_start,
               "section_s": sections}
    return assemble_result(metrics, context)


def assemble_result(metrics: dict[str, Metric], context: dict[str, Any]) -> dict[str, Any]:
    """The JSON-ready result of :func:`run_bench` from its :class:`Metric` rows (one per
    :func:`metric_keys` entry) and ``context`` (host information, map, config, ...)."""
    missing = [k for k in metric_keys() if k not in metrics]
    if missing:
        raise ValueError(f"bench result lacks {missing}")  # a bug in the caller, not a user error
    out: dict[str, Any] = {k: metrics[k].value for k in metric_keys()}
    out.update(context)
    out["stats"] = {k: m.stats._asdict() | {"iqr": m.stats.iqr} for k, m in metrics.items()
                    if m.stats is not None and m.stats.n}
    out["units"] = {k: m.unit for k, m in metrics.items()}
    out["labels"] = {k: m.label for k, m in metrics.items()}
    out["groups"] = {k: m.group for k, m in metrics.items()}
    out["devices"] = {k: m.device for k, m in metrics.items()}
    out["paper_vs"] = {k: m.paper for k, m in metrics.items() if m.paper is not None}
    out["notes"] = {k: m.note for k, m in metrics.items() if m.note}
    out["paper"] = dict(PAPER_FIGURES)
    out["paper_hardware"] = PAPER_HARDWARE
    out["targets"] = [{"key": t.key, "label": t.label, "op": t.op, "threshold": t.threshold,
                       "value": out[t.key], "passed": t.check(out[t.key])} for t in TARGETS]
    return out


def bench_rows(result: dict[str, Any]) -> list[dict]:
    """Rows for :meth:`navbench.pipeline.db.ResultsDB.add_bench_rows`: one per measured key
    (the median, or the derived value), with its unit and device; n/a keys are left out."""
    rows = []
    for key in metric_keys():
        value = result.get(key)
        if value is None:
            continue
        rows.append({"metric": key.removesuffix("_cuda"), "value": float(value),
                     "unit": result["units"][key], "device": result["devices"][key],
                     "host": result.get("host"), "cpu": result.get("cpu"),
                     "navbench_version": result.get("navbench_version")})
    return rows
