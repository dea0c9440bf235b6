"""The timers of ``navbench bench``: each ``time_*`` function measures one thing.

Each returns a list of wall-clock **milliseconds**, one per timed repeat: ``warmup`` untimed
calls first (numba compilation, torch start-up, caches), then ``repeats`` timed calls with
:func:`time.perf_counter`, stopping early once ``budget_s`` seconds are spent and at least
``min(3, repeats)`` repeats are in (see :func:`~navbench.bench.core.timed_loop`). Inputs (poses,
pixels, trajectories, tasks) are drawn from explicit seeds, so two runs time the same work.
:func:`time_navigation` is the exception: it returns a :class:`Throughput`. The measurement
table (:mod:`navbench.bench.table`) says which of them run, with which inputs and repeats.
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from navbench.bench.core import RAY_SAMPLES, RAY_STEP, _ms, _torch_sync, timed_loop
from navbench.errors import ConfigError
from navbench.geometry import AGENT_RADIUS, CAMERA_HEIGHT, Intrinsics


# ---------------------------------------------------------------------------------- the map

def bench_map(level, level_file: Path | None, cache_root: str | Path = "results/cache",
              map_path: str | Path | None = None):
    """``(vmap, description)``: the voxel map file ``map_path`` when given; else the newest
    verified fit-map artifact of ``level`` in the cache (matched by the sha256 of
    ``level_file``), else :func:`voxelize_level` on the paper grid."""
    import hashlib

    from navbench.worldmodel.grid import VoxelMap, grid_for_level, voxelize_level

    if map_path is not None:
        from navbench.errors import ConfigError
        from navbench.worldmodel.base import load_world_model

        vmap = load_world_model(map_path)  # a bad file: one ArtifactError line naming it
        if not isinstance(vmap, VoxelMap):
            raise ConfigError(f"bench --map {map_path}: the bench times navbench's voxel map; this file "
                              f"holds a {type(vmap).__name__}")
        digest = hashlib.sha256(Path(map_path).read_bytes()).hexdigest()
        return vmap, f"map file {map_path} ({digest[:12]}, {_shape(vmap)})"
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
                    vmap = VoxelMap.load(info.path / "map.npz")
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

def time_sim_frame(level, intrinsics: Intrinsics, repeats: int, warmup: int = 2, seed: int = 0,
                   pixels_of: str | None = None) -> list[float]:
    """One RGB-D frame of the simulator's ray-cast camera (see :mod:`navbench.sim.bench`);
    ``pixels_of="ours"``: only the pixels ``ours`` reads (its Gauss-Newton sample), the frame
    the simulator gives it in an episode."""
    from navbench.sim.bench import time_render

    pixels = None
    if pixels_of == "ours":
        from navbench.track.ours import gn_pixels
        from navbench.track.trackconfig import TrackerConfig

        pixels = gn_pixels(intrinsics.height, intrinsics.width, TrackerConfig().gn_pixels)
    elif pixels_of is not None:
        raise ValueError(f"pixels_of: 'ours' or None, got {pixels_of!r}")
    return time_render(level, intrinsics, repeats=repeats, warmup=warmup, seed=seed, pixels=pixels)


def time_sim_frame_textures(level, intrinsics: Intrinsics, repeats: int, seed: int = 0,
                            modes=("procedural", "table", "polynomial")) -> dict[str, list[float]]:
    """Milliseconds per full frame of each camera texture mode, interleaved on the same poses
    (:func:`navbench.sim.bench.time_render_modes`)."""
    from navbench.sim.bench import time_render_modes

    return time_render_modes(level, intrinsics, modes, repeats=repeats, seed=seed)


def time_sim_step(level, repeats: int, warmup: int = 10, seed: int = 0) -> list[float]:
    """One dynamics + collision step of the simulator, no rendering."""
    from navbench.sim.bench import time_step

    return time_step(level, repeats=repeats, warmup=warmup, noise="mid", seed=seed)


# ---------------------------------------------------------------------------------- world model

def time_map_render(level, vmap, intrinsics: Intrinsics, repeats: int, warmup: int = 2, seed: int = 0,
                    budget_s: float | None = None) -> list[float]:
    """One fast (numba) render of ``vmap`` from free-space poses, with a kept
    :class:`~navbench.worldmodel.fastrender.FastRenderer` (``vmap.renderer``, as the trackers use it)."""
    from navbench.sim.bench import bench_poses

    fr = vmap.renderer(intrinsics, CAMERA_HEIGHT)
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

    occ2d, xs, ys = vmap.occupancy_slice("band")
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

    occ2d, xs, ys = vmap.occupancy_slice("band")
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
    from navbench.track.registry import make_estimator

    if len(walk.controls) < warmup + repeats:
        raise ConfigError(f"the walk has {len(walk.controls)} steps, {warmup + repeats} needed")
    est = make_estimator(estimator, vmap=vmap, intrinsics=intrinsics, camera_height=CAMERA_HEIGHT,
                         seed=seed, **(options or {}))
    est.reset(walk.pose0.copy(), walk.frame0)

    def call(k: int) -> float:
        return _ms(lambda: est.update(walk.controls[k], walk.frames[k], true_pose=walk.poses[k]))

    return timed_loop(call, repeats, warmup, budget_s)


def time_fusion(walk: Walk, level, intrinsics: Intrinsics, repeats: int = 10, warmup: int = 2,
                budget_s: float | None = None) -> list[float]:
    """One online-mapping step (issue 15): ``fuse_frame`` of the walk's next frame at its true
    pose into a map on the level's default grid (:mod:`navbench.worldmodel.fusion`), the walk's
    start frame fused first, the first ``warmup`` steps untimed."""
    from navbench.worldmodel.fusion import FusedMap
    from navbench.worldmodel.grid import grid_for_level

    if len(walk.frames) < warmup + repeats:
        raise ConfigError(f"the walk has {len(walk.frames)} steps, {warmup + repeats} needed")
    fused = FusedMap.empty(grid_for_level(level))
    fused.fuse(walk.frame0, walk.pose0, intrinsics, CAMERA_HEIGHT)
    return timed_loop(lambda k: _ms(lambda: fused.fuse(walk.frames[k], walk.poses[k], intrinsics,
                                                       CAMERA_HEIGHT)), repeats, warmup, budget_s)


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
                      estimator: str = "ours", noise: str = "mid", budget_s: float | None = None,
                      exclude: tuple[str, ...] = (), options: dict | None = None,
                      texture: str = "procedural") -> list[float]:
    """One full time step of :func:`navbench.nav.episode.run_episode` with ``estimator`` (its
    default options, as navigation runs it): controller, simulator step with its RGB-D
    observation, tracking with the map render, and A* when (re)planning -- the per-step sum of
    the episode's recorded component timings. Episodes over seeded tasks run until ``repeats``
    steps are in (or ``budget_s`` is spent); one short episode of ``warmup`` steps runs first.
    ``exclude``: timing components left out of the sum (``("sim",)``: the agent's own step);
    ``options``: the estimator's keyword options (default: none); ``texture``: the simulator
    camera's texture mode (:mod:`navbench.sim.texels`)."""
    from dataclasses import replace

    from navbench.nav.episode import EpisodeConfig, run_episode
    from navbench.plan.astar import make_planner_map
    from navbench.sim.world import Simulator
    from navbench.track.registry import make_estimator, uses_frames

    occ2d, xs, ys = vmap.occupancy_slice("band")
    pm = make_planner_map(occ2d, xs, ys)
    tasks = bench_tasks(level, vmap, 64, seed)

    # as the pipeline's workers: no camera for an estimator that reads no frame
    cam = intrinsics if uses_frames(estimator) else None

    def episode(task, max_steps: int, ep_seed: int) -> np.ndarray:
        sim = Simulator(level, noise=noise, seed=ep_seed, intrinsics=cam, camera_height=CAMERA_HEIGHT,
                        texture=texture)
        est = make_estimator(estimator, vmap=vmap, intrinsics=intrinsics, camera_height=CAMERA_HEIGHT,
                             seed=ep_seed, **(options or {}))
        cfg = replace(EpisodeConfig(), max_steps=max_steps, texture=texture)
        rec = run_episode(level, occ2d, xs, ys, task, est, sim, config=cfg, planner_map=pm)
        t = rec.timings_ms
        parts = [np.asarray(t[k], dtype=np.float64) for k in t if k not in exclude]
        return np.sum(parts, axis=0) if rec.steps else np.zeros(0)

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
                    camera: str = "half", noise: str = "mid", seed: int = 0,
                    estimator_options: dict | None = None, episode: dict | None = None) -> Throughput:
    """Episodes per wall-clock time through the pipeline's run-navigation stage
    (:func:`navbench.pipeline.stages.run_navigation_stage`) with a local process pool, in a
    throw-away cache and SQLite database: ``tasks`` x ``estimators`` episodes at ``noise``
    (``estimator_options``: estimator name -> its options, as a profile's; ``episode``: the
    episode settings, as a profile's ``[navigation.episode]``).
    A warm-up pass (one 2-step episode per worker, same pool) runs first and is not timed."""
    import hashlib

    from navbench.pipeline.cache import ArtifactStore
    from navbench.results.db import ResultsDB
    from navbench.pipeline.executor import make_executor
    from navbench.pipeline.stages import (
        LevelInputs,
        NavigationConfig,
        Ref,
        StageContext,
        run_navigation_stage,
    )
    from navbench.plan.tasks import save_tasks

    def sha(p: Path) -> str:
        return hashlib.sha256(Path(p).read_bytes()).hexdigest()

    with tempfile.TemporaryDirectory(prefix="navbench-bench-") as tmp:
        d = Path(tmp)
        map_path = vmap.save(d / "map.npz")
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
            cfg = NavigationConfig(estimators=tuple(estimators), noise=(noise,), seeds=1, camera=camera,
                                   estimator_options=dict(estimator_options or {}), episode=dict(episode or {}))
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
