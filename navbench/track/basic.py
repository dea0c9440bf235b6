"""Two reference estimators: ``gt`` (the true pose) and ``dynamics`` (path integration).

``gt`` returns the simulator's true pose (the upper bound of navigation with perfect tracking);
``dynamics`` is the paper's "dynamics" ablation: the noise-free dynamics
:func:`navbench.sim.dynamics.predict` applied to the previous estimate, from the known start.
Both ignore the observations. Poses are ``(3,)`` ``(x, y, theta)`` world metres / radians.
"""

from __future__ import annotations

import time

import numpy as np

from navbench.errors import TrackingError
from navbench.geometry import CAMERA_HEIGHT, Frame
from navbench.track.odometry import predict_pose


class _Basic:
    """Shared constructor: accepts and ignores the uniform estimator keyword arguments.
    Neither reads frames or the map, and neither takes options (registry capabilities)."""

    name = "basic"
    uses_frames = False
    uses_map = False
    options = None

    def __init__(self, vmap=None, intrinsics=None, camera_height: float = CAMERA_HEIGHT,
                 renderer=None, seed: int = 0, **options):
        self.pose = None
        self.last_timing: dict[str, float] = {}

    def reset(self, pose0, frame0: Frame | None = None) -> None:
        """Start at the known pose ``pose0 (3,)``."""
        self.pose = np.asarray(pose0, dtype=np.float64).reshape(3).copy()
        self.last_timing = {}

    def _check(self):
        if self.pose is None:
            raise TrackingError(f"estimator {self.name!r}: update() before reset()")


class GroundTruthEstimator(_Basic):
    """Returns the true pose passed to :meth:`update`."""

    name = "gt"

    def update(self, control, frame: Frame | None = None, true_pose=None) -> np.ndarray:
        self._check()
        if true_pose is None:
            raise TrackingError("the 'gt' estimator needs true_pose in update()")
        t0 = time.perf_counter()
        self.pose = np.asarray(true_pose, dtype=np.float64).reshape(3).copy()
        self.last_timing = {"render": 0.0, "estimate": (time.perf_counter() - t0) * 1e3}
        return self.pose.copy()


class DynamicsEstimator(_Basic):
    """Path integration: ``pose <- predict(pose, control)`` (noise-free dynamics), or the
    odometry increment composed (:func:`navbench.track.odometry.predict_pose`)."""

    name = "dynamics"

    def update(self, control, frame: Frame | None = None, true_pose=None) -> np.ndarray:
        self._check()
        t0 = time.perf_counter()
        self.pose = predict_pose(self.pose, control)
        self.last_timing = {"render": 0.0, "estimate": (time.perf_counter() - t0) * 1e3}
        return self.pose.copy()
