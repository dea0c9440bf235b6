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
        est[t + 1] = estimator.update(OdometryIncrement(*(float(v) for v in inc[t])), frame)
        step[t] = (time.perf_counter() - t0) * 1e3
        render[t] = estimator.last_timing.get("render", 0.0)
        estimate[t] = estimator.last_timing.get("estimate", 0.0)
    return SequenceTrack(est, step, render, estimate)


def render_walk(level, frames: int, intrinsics, seed: int = 0, camera_height: float | None = None,
                noise: str = "tracking"):
    """A sequence rendered by navbench: the first trajectory of
    :func:`navbench.track.study.record_trajectories` (``frames - 1`` controls with the
    tracking-study noise from ``seed``) rendered exactly by the ray-cast camera at every true
    pose, as :class:`~navbench.worldmodel.views.Views` (``frames`` views in trajectory order;
    export it with :func:`navbench.worldmodel.tum.export_views` for a TUM sequence)."""
    from navbench.geometry import CAMERA_HEIGHT
    from navbench.sim.camera import RaycastCamera
    from navbench.track.study import record_trajectories
    from navbench.worldmodel.views import Views, check_views_memory

    if frames < 2:
        raise ValueError(f"a sequence needs at least 2 frames, got {frames}")
    check_views_memory(frames, intrinsics, "render a sequence")
    cam_h = CAMERA_HEIGHT if camera_height is None else float(camera_height)
    traj = record_trajectories(level, 1, frames - 1, noise=noise, seed=seed)[0]
    camera = RaycastCamera(level, intrinsics, cam_h)
    H, W = intrinsics.shape
    rgb = np.empty((frames, H, W, 3), np.uint8)
    depth = np.empty((frames, H, W), np.float32)
    valid = np.empty((frames, H, W), bool)
    for n, pose in enumerate(traj.true_poses):
        fr = camera.render(pose)
        rgb[n] = np.clip(np.rint(fr.rgb * 255.0), 0, 255).astype(np.uint8)
        depth[n] = fr.depth
        valid[n] = fr.valid
    box = ((0.0, 0.0, 0.0), (float(level.width), float(level.depth), float(level.height)))
    return Views(traj.true_poses.copy(), intrinsics, cam_h, rgb, depth, valid, level.name, int(seed),
                 box, {"walk_seed": int(seed), "noise": noise})
