"""Tracking a recorded RGB-D sequence driven by odometry (``navbench track-sequence``).

The estimator starts at the known first pose with the first frame, then takes one
:class:`~navbench.track.odometry.OdometryIncrement` and the next frame per step, exactly as the
navigation loop feeds it a control and a frame. Pure: arrays in, arrays out.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from navbench.geometry import Frame
from navbench.track.odometry import OdometryIncrement
from navbench.track.registry import checked_pose


@dataclass
class SequenceTrack:
    """The estimate of :func:`track_frames`: ``est_poses (N, 3)`` (the given first pose first),
    per-update wall times ``step_ms (N-1,)`` (the whole ``update``: reference render and
    optimisation) and the estimator's own ``render_ms`` / ``estimate_ms (N-1,)``."""

    est_poses: np.ndarray
    step_ms: np.ndarray
    render_ms: np.ndarray
    estimate_ms: np.ndarray


def frame_at(views, n: int) -> Frame:
    """Frame ``n`` of :class:`~navbench.worldmodel.views.Views` as the estimators see it (colour
    in [0, 1] float32, z-depth float32 with +inf where invalid)."""
    valid = np.asarray(views.valid[n], dtype=bool)
    depth = np.where(valid, np.asarray(views.depth[n], dtype=np.float32), np.float32(np.inf))
    return Frame(np.asarray(views.rgb[n], dtype=np.float32) / np.float32(255.0),
                 depth.astype(np.float32), valid)


def track_frames(estimator, views, start_pose, increments) -> SequenceTrack:
    """Run ``estimator`` over the ``N`` frames of ``views`` from ``start_pose (3,)`` with the
    odometry ``increments (N-1, 3)`` between consecutive frames."""
    inc = np.asarray(increments, dtype=np.float64).reshape(-1, 3)
    n = len(views)
    if len(inc) != n - 1:
        raise ValueError(f"{len(inc)} odometry increments for {n} frames (need {n - 1})")
    est = np.empty((n, 3))
    est[0] = np.asarray(start_pose, dtype=np.float64).reshape(3)
    step, render, estimate = (np.empty(n - 1) for _ in range(3))
    estimator.reset(est[0].copy(), frame_at(views, 0))
    for t in range(n - 1):
        frame = frame_at(views, t + 1)
        t0 = time.perf_counter()
        est[t + 1] = checked_pose(estimator, estimator.update(
            OdometryIncrement(*(float(v) for v in inc[t])), frame), t + 1)
        step[t] = (time.perf_counter() - t0) * 1e3
        render[t] = estimator.last_timing.get("render", 0.0)
        estimate[t] = estimator.last_timing.get("estimate", 0.0)
    return SequenceTrack(est, step, render, estimate)


#: Walks :func:`render_walk` draws: the planner's shortest paths between sampled tasks, or the
#: tracking study's random walk.
WALKS = ("planner", "random")


def planner_walk(level, frames: int, seed: int = 0, noise: str = "none") -> np.ndarray:
    """``(frames, 3)`` true poses (world metres, radians) of one continuous walk: the simulator
    driven by the path controller along the shortest collision-free paths (agent radius) from
    the first sampled task's start to its target, then on to the next task's target, and so on
    (tasks of :func:`navbench.plan.tasks.sample_tasks` with ``seed``, more drawn when the walk
    outlasts them). ``noise``: the simulator's actuation noise (``none``: the path exactly);
    a step that collides re-plans from where the robot is. Deterministic for a given ``seed``."""
    from navbench.nav.controller import control_towards
    from navbench.geometry import AGENT_RADIUS
    from navbench.plan.shortest import graph_for_level, shortest_path
    from navbench.plan.tasks import sample_tasks
    from navbench.sim.world import Simulator

    if frames < 2:
        raise ValueError(f"a sequence needs at least 2 frames, got {frames}")
    graph = graph_for_level(level, 1.1 * AGENT_RADIUS)  # a margin: paths graze corners
    batch = max(4, frames // 40)
    tasks, drawn = list(sample_tasks(level, count=batch, seed=seed)), 1
    sim = Simulator(level, noise=noise, seed=int(seed), intrinsics=None)
    sim.reset(np.asarray(tasks[0].start, dtype=np.float64))
    poses = [sim.pose.copy()]
    task, path, wp, idle = 0, None, 1, 0
    while len(poses) < frames:
        if path is None or wp >= len(path):
            if path is not None:
                task += 1
            if task >= len(tasks):  # the walk outlasts the tasks: draw the next batch
                tasks += sample_tasks(level, count=batch, seed=int(seed) + 7919 * drawn)
                drawn += 1
            _, path = shortest_path(graph, sim.pose[:2], np.asarray(tasks[task].target, dtype=np.float64)[:2])
            path, wp = np.asarray(path, dtype=np.float64).reshape(-1, 2), 1
            continue
        if np.hypot(*(path[wp] - sim.pose[:2])) < 1e-3:
            wp += 1
            continue
        res = sim.step(control_towards(sim.pose, path[wp]))
        if res.collided:  # re-plan from here (the pose the simulator kept)
            sim.reset(poses[-1])
            path, wp, task = None, 1, task - 1
            idle += 1
            if idle > 50:
                raise ValueError(f"{level.name}: the walk is stuck at {poses[-1][:2]}")
            continue
        idle = 0
        poses.append(sim.pose.copy())
    return np.array(poses[:frames])


def render_poses(level, poses, intrinsics, camera_height: float | None = None, seed: int = 0,
                 meta: dict | None = None, sim: str = "pymunk"):
    """The exact ray-cast views of ``level`` at the planar ``poses (N, 3)`` in order, as
    :class:`~navbench.worldmodel.views.Views` (export with :func:`navbench.worldmodel.tum.export_views`).
    ``sim="vizdoom"``: the engine's frames, each labelled with the pose the engine shows, and
    the engine's projection as the views' intrinsics (:class:`navbench.sim.backends.PoseRenderer`)."""
    from navbench.geometry import CAMERA_HEIGHT
    from navbench.sim.backends import PoseRenderer
    from navbench.worldmodel.views import Views, check_views_memory

    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    frames = len(poses)
    check_views_memory(frames, intrinsics, "render a sequence")
    cam_h = CAMERA_HEIGHT if camera_height is None else float(camera_height)
    H, W = intrinsics.shape
    rgb = np.empty((frames, H, W, 3), np.uint8)
    depth = np.empty((frames, H, W), np.float32)
    valid = np.empty((frames, H, W), bool)
    shown = poses.copy()
    with PoseRenderer(sim, level, intrinsics, cam_h) as camera:
        for n, pose in enumerate(poses):
            fr = camera.render(pose)
            shown[n] = camera.shown
            rgb[n] = np.clip(np.rint(fr.rgb * 255.0), 0, 255).astype(np.uint8)
            depth[n] = fr.depth
            valid[n] = fr.valid
        intrinsics = camera.intrinsics
    box = ((0.0, 0.0, 0.0), (float(level.width), float(level.depth), float(level.height)))
    meta = dict(meta or {}, **({} if sim == "pymunk" else {"sim": sim}))
    return Views(shown, intrinsics, cam_h, rgb, depth, valid, level.name, int(seed), box, meta)


def render_walk(level, frames: int, intrinsics, seed: int = 0, camera_height: float | None = None,
                noise: str = "tracking", walk: str = "random", sim: str = "pymunk"):
    """A sequence rendered by navbench, as :class:`~navbench.worldmodel.views.Views` (``frames``
    views in walk order; export it with :func:`navbench.worldmodel.tum.export_views` for a TUM
    sequence), rendered exactly by the ray-cast camera at every true pose of the walk:

    * ``walk="random"``: the first trajectory of :func:`navbench.track.study.record_trajectories`
      (``frames - 1`` controls with the simulator's ``noise`` from ``seed``);
    * ``walk="planner"``: :func:`planner_walk` (the shortest paths between sampled tasks, driven
      by the simulator with ``noise``).

    ``sim``: the frames' simulator (:func:`render_poses`; the walk itself is navbench's).
    """
    from navbench.track.study import record_trajectories

    if frames < 2:
        raise ValueError(f"a sequence needs at least 2 frames, got {frames}")
    if walk not in WALKS:
        raise ValueError(f"walk: expected one of {WALKS}, got {walk!r}")
    from navbench.worldmodel.views import check_views_memory

    check_views_memory(frames, intrinsics, "render a sequence")  # before the walk is driven
    if walk == "random":
        poses = record_trajectories(level, 1, frames - 1, noise=noise, seed=seed)[0].true_poses
    else:
        poses = planner_walk(level, frames, seed, noise)
    meta = {"walk_seed": int(seed), "noise": noise, **({} if walk == "random" else {"walk": walk})}
    return render_poses(level, poses, intrinsics, camera_height, seed, meta, sim)
