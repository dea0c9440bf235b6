"""The pose-estimator interface every tracker implements.

An estimator is stateful over one episode: ``reset`` with the known start pose and the first
observation, then ``update`` once per executed control with the new observation. Poses are planar
``(x, y, theta)`` world-frame arrays of shape ``(3,)`` (see :mod:`navbench.geometry`).
``true_pose`` is passed to every ``update`` but only the ``gt`` estimator may read it.
After each ``update``, ``last_timing`` holds that step's component times in milliseconds
(for example ``{"render": 3.1, "estimate": 9.4}``).
"""

from __future__ import annotations

import math
import numbers
from typing import Any, Protocol, runtime_checkable

import numpy as np

from navbench.geometry import Frame


@runtime_checkable
class Estimator(Protocol):
    """What the pipeline calls. The capabilities are class attributes that the registry reads
    before any episode runs (:mod:`navbench.track.registry`); the constructor takes the keyword
    arguments ``vmap``, ``intrinsics``, ``camera_height``, ``renderer``, ``seed`` and the options."""

    name: str
    uses_frames: bool                 # reads camera images (False: the simulator renders none)
    uses_map: bool                    # needs the world model (vmap)
    options: type | None              # frozen dataclass of its keyword options, or None
    last_timing: dict[str, float]

    def reset(self, pose0: np.ndarray, frame0: Frame) -> None:
        """Start an episode at the known pose ``pose0`` with its observation ``frame0``."""

    def update(self, control: Any, frame: Frame, true_pose: np.ndarray | None = None) -> np.ndarray:
        """Return the new planar pose estimate ``(3,)`` after ``control`` was executed."""


def observed_pixels(estimator: Any) -> np.ndarray | None:
    """The flat pixel indices (``row * width + column``) the estimator reads from the frames
    given to ``update``, or None when it may read any pixel (the default).

    An estimator may declare them with an optional method ``observed_pixels()`` (the same array
    for the whole episode, read-only); the episode loop then has the simulator cast only those
    pixels and marks the others unseen (NaN colour and depth, ``valid`` False), which gives the
    same estimates for a fraction of the camera's cost. The first frame (``reset``) is always
    whole.
    """
    method = getattr(estimator, "observed_pixels", None)
    return method() if callable(method) else None


def check_update(estimator: Any, frame: Frame) -> None:
    """The checks every camera estimator's ``update`` starts with: ``reset`` came first, and
    ``frame`` has the size of the estimator's ``intrinsics``; raises :class:`TrackingError`."""
    from navbench.errors import TrackingError

    if estimator.pose is None:
        raise TrackingError(f"estimator {estimator.name!r}: update() before reset()")
    if frame.depth.shape != estimator.intrinsics.shape:
        raise TrackingError(f"estimator {estimator.name!r}: observation is {frame.depth.shape}, "
                            f"intrinsics say {estimator.intrinsics.shape}")


def config_from_options(base: Any, options: dict[str, Any], what: str) -> Any:
    """``base`` (a frozen dataclass config) with keyword ``options`` applied; sequence values of
    tuple fields become float tuples; unknown names raise :class:`TrackingError` naming ``what``."""
    from dataclasses import fields, replace

    from navbench.errors import TrackingError

    names = {f.name for f in fields(base)}
    unknown = sorted(set(options) - names)
    if unknown:
        raise TrackingError(f"unknown {what} option(s) {unknown}; known: {sorted(names)}")
    conv = {}
    for k, v in options.items():
        if isinstance(getattr(base, k), tuple):
            # a string is iterable too: '[nan,1,1]' (not JSON, so kept as text) is no list
            ok = isinstance(v, (list, tuple, np.ndarray)) and all(
                isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x) for x in v)
            if not ok:
                raise TrackingError(f"{what} option {k}: expected a list of finite numbers, got {repr(v)[:80]}")
            v = tuple(float(x) for x in v)
        conv[k] = v
    return replace(base, **conv)
