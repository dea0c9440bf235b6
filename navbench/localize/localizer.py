"""The localiser: panoramic signature bank, circular correlation, eq.-7 refinement.

Build (once per map and camera, :meth:`Localizer.build`)
    1. a lattice of planar positions every ``lattice_step`` metres in the map's free space (the
       world model's body-band occupancy slice, ``clearance`` metres from any occupied cell);
    2. at each lattice point a 360-degree *panorama signature*: ``bins`` uniform heading bins,
       and per bin the inverse horizontal range and the grey level at ``rows`` elevations
       (thin renders through the world model's renderer, four 90-degree quadrants resampled
       to the bins). Headings are not stored separately: a query's field of view is a window
       of the panorama.

Query (:meth:`Localizer.localize`)
    1. the query frame's signature over its field of view (the same elevations and bins);
    2. the squared distance to every lattice point's panorama at every circular shift by FFT
       (:func:`navbench.localize.signature.circular_costs`): best shift = heading;
    3. the ``refine_k`` best (position, heading) candidates after non-maximum suppression are
       refined by the ``ours`` alignment (planar Gauss-Newton of eq. 7 against the map's render
       at the candidate, ``refine_rounds`` re-renders) and verified by their depth residual
       (``confidence`` = fraction of the query's valid pixels whose depth the map predicts
       within tolerance at the refined pose).

Hypotheses come back best first by ``score``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from navbench.errors import NavbenchError
from navbench.geometry import Frame, Intrinsics


class LocalizationError(NavbenchError):
    """A localiser input a user can get wrong (an empty map, a frame of the wrong size)."""


@dataclass(frozen=True)
class LocalizerConfig:
    """Every setting of the localiser; its hash (with the map's and the camera's) keys the bank."""

    lattice_step: float = 0.25     # m between lattice points
    clearance: float = 0.1         # m from any occupied cell (the agent radius)
    bins: int = 720                # heading bins of a panorama (0.5 deg)
    rows: int = 4                  # signature elevations y_c = row_top + j * row_step
    row_top: float = -0.3
    row_step: float = 0.15
    grey_weight: float = 0.5       # weight of the grey channel against inverse range (1/m)
    refine_k: int = 3              # candidates refined by eq. 7
    nms_radius: float = 0.5        # m: candidates closer than this (and nms_deg) are one
    nms_deg: float = 30.0
    refine_rounds: int = 2         # render + Gauss-Newton rounds per candidate
    gn_pixels: int = 1500
    inlier_abs: float = 0.05       # m: depth agreement tolerance abs + rel * depth
    inlier_rel: float = 0.03


@dataclass(frozen=True)
class Hypothesis:
    """A pose the frame may have been taken from: ``pose`` (x, y, theta) in m, rad; ``score``
    (higher is better, the ranking key); ``confidence`` in [0, 1] from the depth residual."""

    pose: np.ndarray
    score: float
    confidence: float


class Bank(NamedTuple):
    """The cached part of a localiser: lattice ``points (N, 2)`` (m) and their panorama
    signatures ``pano (N, C, bins)`` float32."""

    points: np.ndarray
    pano: np.ndarray


class Localizer:
    """See the module docstring. ``last_timing``: the last query's component times (ms)."""

    def __init__(self, world_model, intrinsics: Intrinsics, camera_height: float,
                 config: LocalizerConfig, bank: Bank):
        self.world_model = world_model
        self.intrinsics = intrinsics
        self.camera_height = camera_height
        self.config = config
        self.bank = bank
        self.last_timing: dict[str, float] = {}

    @classmethod
    def build(cls, world_model, intrinsics: Intrinsics, camera_height: float,
              config: LocalizerConfig = LocalizerConfig()) -> "Localizer":
        """Render the signature bank of ``world_model`` (any :class:`~navbench.worldmodel.base.WorldModel`)
        for a camera ``intrinsics`` at ``camera_height``; :class:`LocalizationError` for a map
        with no free lattice point."""
        raise NotImplementedError

    def localize(self, frame: Frame, k: int | None = None) -> list[Hypothesis]:
        """The ``k`` (default ``config.refine_k``) best poses for ``frame`` (an RGB-D
        :class:`~navbench.geometry.Frame` of this localiser's intrinsics), best first."""
        raise NotImplementedError
