"""``ours-every-k``: navbench's ``ours`` tracker (eq. 7) on every k-th step, the noise-free
dynamics in between. An example of an estimator plugin (see this package's README)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from navbench.errors import ConfigError
from navbench.geometry import CAMERA_HEIGHT
from navbench.track.odometry import predict_pose  # a control, or an odometry increment
from navbench.track.registry import make_estimator


@dataclass(frozen=True)
class Options:
    """Options of ``ours-every-k`` (a profile's ``[navigation.options.ours-every-k]``)."""

    k: int = 2   # track with eq. 7 on every k-th step (1: every step, as ``ours``)

    def __post_init__(self):
        # a NavbenchError: the CLI prints it as one line naming the option
        if not isinstance(self.k, int) or isinstance(self.k, bool) or self.k < 1:
            raise ConfigError(f"k must be an integer >= 1, got {self.k!r}")


class OursEveryK:
    """Eq. 7 against the map's rendering on every ``k``-th step; path integration otherwise."""

    name = "ours-every-k"   # the entry point's name
    uses_frames = True      # it reads camera images (on the tracked steps)
    uses_map = True         # and renders the world model
    options = Options       # its keyword options, checked before anything runs

    def __init__(self, vmap=None, intrinsics=None, camera_height: float = CAMERA_HEIGHT,
                 renderer=None, seed: int = 0, **options):
        self.opts = Options(**options)
        # reuse navbench's own tracker (built the way the pipeline builds any estimator)
        self._ours = make_estimator("ours", vmap=vmap, intrinsics=intrinsics,
                                    camera_height=camera_height, renderer=renderer, seed=seed)
        self.intrinsics = intrinsics
        self.pose = None
        self.last_timing: dict[str, float] = {}
        self._t = 0

    def reset(self, pose0, frame0) -> None:
        self._ours.reset(pose0, frame0)
        self.pose = np.asarray(pose0, dtype=np.float64).copy()
        self._t = 0
        self.last_timing = {}

    def update(self, control, frame, true_pose=None) -> np.ndarray:
        self._t += 1
        if self._t % self.opts.k == 0:
            self._ours.pose = self.pose.copy()  # eq. 7 starts from our current estimate
            self.pose = self._ours.update(control, frame)
            self.last_timing = dict(self._ours.last_timing)
        else:
            t0 = time.perf_counter()
            self.pose = np.asarray(predict_pose(self.pose, control), dtype=np.float64)
            self.last_timing = {"render": 0.0, "estimate": (time.perf_counter() - t0) * 1e3}
        return self.pose.copy()
