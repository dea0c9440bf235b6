"""Tracking and mapping together (issue 15 section 3): a map-based tracker on the map it builds.

:class:`OnlineMapping` wraps a map-based estimator (``ours``) whose map is a
:class:`~navbench.worldmodel.fusion.FusedMap` that starts empty (no prior map):

* ``reset(pose0, frame0)``: the map is cleared and the first frame fused at the known start
  pose ``pose0``, then the tracker is reset;
* ``update(control, frame)``: the tracker aligns ``frame`` against the map built so far (eq. 7
  against the map rendered at its previous estimate ``z*_{t-1}``, through
  :class:`~navbench.worldmodel.fusion_render.FusedRenderer`), then ``frame`` is fused at the new
  estimate ``z*_t``. The estimate never sees the true pose.

The fusion time of each step is reported as ``last_timing["fuse"]`` and counted in
``"estimate"`` (so a study's step time is render + track + fuse). Estimators that ignore the
``renderer`` they are given (:data:`RENDERER_IGNORED`: ``emission``, which differentiates the
map's tensors built once) cannot follow a map that changes, and are refused.

Arrays in, arrays out; no files, printing or database.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from navbench.errors import ConfigError
from navbench.geometry import CAMERA_HEIGHT, Frame, Intrinsics
from navbench.track.registry import checked_pose
from navbench.worldmodel.fusion import FusedMap
from navbench.worldmodel.fusion_render import FusedRenderer

#: Map-based estimators that do not render through the ``renderer`` argument.
RENDERER_IGNORED = ("emission",)


def check_online(name: str) -> None:
    """Raise :class:`ConfigError` when estimator ``name`` cannot track on an online map."""
    if name in RENDERER_IGNORED:
        raise ConfigError(f"--map online: estimator {name!r} cannot track against a map that is "
                          f"built while it tracks (it ignores the renderer it is given); "
                          f"drop it from --estimators (e.g. --estimators ours,no-map,dynamics,gt)")


class OnlineMapping:
    """Tracking and mapping: ``estimator`` tracks against ``fused``, which it extends (see the
    module docstring). ``estimator`` must have been built with ``renderer`` rendering
    ``fused`` (:func:`online_estimator` does both)."""

    uses_frames = True
    uses_map = True

    def __init__(self, estimator, fused: FusedMap, intrinsics: Intrinsics,
                 camera_height: float = CAMERA_HEIGHT):
        self.estimator = estimator
        self.name = estimator.name
        self.options = getattr(estimator, "options", None)
        self.fused = fused
        self.intrinsics = intrinsics
        self.camera_height = float(camera_height)
        self.last_timing: dict[str, float] = {}
        self.steps = 0  # updates since reset (named when the estimator returns no pose)

    @property
    def pose(self):
        return self.estimator.pose

    @property
    def last_health(self):
        return getattr(self.estimator, "last_health", None)

    def reset(self, pose0, frame0: Frame) -> None:
        self.fused.clear()
        self.fused.fuse(frame0, np.asarray(pose0, np.float64), self.intrinsics, self.camera_height)
        self.estimator.reset(pose0, frame0)
        self.last_timing = {}
        self.steps = 0

    def update(self, control: Any, frame: Frame, true_pose=None) -> np.ndarray:
        self.steps += 1
        est = checked_pose(self.estimator, self.estimator.update(control, frame, None), self.steps)
        t0 = time.perf_counter()
        self.fused.fuse(frame, est, self.intrinsics, self.camera_height)
        ms = (time.perf_counter() - t0) * 1e3
        timing = dict(self.estimator.last_timing)
        timing["fuse"] = ms
        timing["estimate"] = timing.get("estimate", 0.0) + ms
        self.last_timing = timing
        return est.copy()


def online_estimator(name: str, fused: FusedMap, intrinsics: Intrinsics,
                     camera_height: float = CAMERA_HEIGHT, seed: int = 0, **options) -> OnlineMapping:
    """Estimator ``name`` (a registered map-based one) tracking and mapping on a fresh copy of
    ``fused``'s grid and fusion settings; ``options`` are the estimator's own."""
    from navbench.track.registry import make_estimator

    check_online(name)
    own = fused.fresh()
    render = FusedRenderer(own, intrinsics, camera_height).render
    est = make_estimator(name, vmap=own.vmap, intrinsics=intrinsics, camera_height=camera_height,
                         renderer=render, seed=seed, **options)
    return OnlineMapping(est, own, intrinsics, camera_height)
