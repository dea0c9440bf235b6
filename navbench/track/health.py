"""The tracking-health test of the prediction-to-observation trackers (issue 14, "kidnapped robot").

After eq. 7 is minimised, the tracker asks whether its estimate still explains the observation:
the **inlier fraction** is the share of the observed pixels (a fixed sample) whose back-projected
point ``p``, moved into the reference camera (``q = T_ref^-1 T_wc(z_t) p``), lands on a reference
pixel whose z-depth agrees with ``q_z`` to within ``tol * q_z`` and whose colour agrees with the
observed one to within ``photo_tol`` (L1 over RGB), both at the projective association of eq. 7::

    inliers = #{k : |D_ref[pi(q_k)] - q_kz| <= tol q_kz + tol_abs  and  |I_ref[pi(q_k)] - I_k|_1 <= photo_tol}
              / #{k : pi(q_k) inside, D_ref valid}

``tol_abs`` (option ``health_tol_abs``, 2 cm; 0 before 2026-11-26) is the fitted map's own
depth error: without it a robot held against furniture (surfaces 0.1-0.3 m away, 5 % of which
is 5-15 mm) failed the test at a correct pose (house-5: 16.9 % of all steps were such false
alarms; with it 0.08 %, the estimates unchanged).
Depth alone cannot tell apart two places whose geometry is alike (the corners of two rooms of
the same shape); their textures differ.

Only points between the heights ``band = (z_low, z_high)`` above the floor count: the floor and
the ceiling are horizontal planes that agree with *any* planar pose at the camera height (a point
on the floor stays on the floor), so they carry no evidence for or against ``(x, y, theta)``.
Projections that leave the reference image are not evidence either; with fewer than
``min_pixels`` evidence pixels the fraction is ``nan`` (no decision: healthy).

The tracker raises an alarm when the fraction falls below ``health_min_inliers``
(:class:`navbench.track.eq7.TrackerConfig`): the fixed 0.5 was calibrated on normal tracking of
``house-1`` only (see docs/notebook/tracking.md); ``"auto"`` sets it per map
from the map's own views (:class:`HealthCalibration`, :func:`view_inlier_fractions`,
:func:`calibrated_threshold`; the cached stage: :mod:`navbench.pipeline.stages.health`).
Math layer: arrays in, arrays out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from navbench.errors import TrackingError
from navbench.geometry import CAMERA_HEIGHT, Frame, Intrinsics, camera_pose
from navbench.track.eq7 import Reference, sample_observation
from navbench.track.lie import se3_inverse


def inlier_fraction(ref: Reference, frame: Frame, pose, idx: np.ndarray, tol: float = 0.05,
                    band: tuple[float, float] = (0.05, 1.1), camera_height: float = CAMERA_HEIGHT,
                    min_pixels: int = 20, photo_tol: float = 0.3, tol_abs: float = 0.0) -> float:
    """The health statistic of the module doc for planar ``pose`` (x, y, theta) and the observed
    pixels with flat indices ``idx``; ``nan`` when fewer than ``min_pixels`` pixels are evidence."""
    obs = sample_observation(frame, ref.intr, idx)
    T_wc = camera_pose(np.asarray(pose, dtype=np.float64), camera_height)
    height = T_wc[2, 3] + obs.points @ T_wc[2, :3]  # world z of the observed points
    use = obs.ok & (height >= band[0]) & (height <= band[1])
    Trel = se3_inverse(ref.T_wc) @ T_wc
    q = obs.points[use] @ Trel[:3, :3].T + Trel[:3, 3]
    intr = ref.intr
    H, W = intr.shape
    z = q[:, 2]
    front = z > 1e-6
    zs = np.where(front, z, 1.0)
    u = np.floor(intr.fx * q[:, 0] / zs + intr.cx + 0.5)
    v = np.floor(intr.fy * q[:, 1] / zs + intr.cy + 0.5)
    inside = front & (u >= 0) & (u <= W - 1) & (v >= 0) & (v <= H - 1)
    ui = np.where(inside, u, 0).astype(np.int64)
    vi = np.where(inside, v, 0).astype(np.int64)
    seen = inside & ref.valid[vi, ui]
    n = int(seen.sum())
    if n < min_pixels:
        return math.nan
    agree = (np.abs(ref.depth[vi, ui] - z) <= tol * z + tol_abs) \
        & (np.abs(ref.rgb[vi, ui] - obs.rgb[use]).sum(axis=1) <= photo_tol)
    return float(np.sum(agree & seen)) / n


# ------------------------------------------------------------------------------ calibration

@dataclass(frozen=True)
class HealthCalibration:
    """How ``health_min_inliers = "auto"`` is set per map (:func:`calibrated_threshold`).

    The threshold must sit below the inlier fractions the tracker sees at a *correct* pose on
    this map (a false alarm otherwise) and above those of a lost track (a kidnap: 0.00-0.1,
    the module doc). The first depend on the map (how well its fitted depth and colour agree
    with real frames) and not on any trajectory, so they are measured on the map's own
    pose-labelled views (held-out views where the map has them), each through **one tracking
    step** as the tracker takes it: the previous estimate is the view's pose moved by a control's
    noise (Gaussian, ``perturb = (sigma_xy [m], sigma_theta [rad])``, the default prior's), the
    map renders the reference there, the tracker's alignment (eq. 7) estimates the view's pose
    from it, and the test scores the view at that estimate. A random pose error alone would be
    pessimistic: the alignment leaves the error along directions the image cannot see.

    The threshold is ``factor`` times the ``quantile`` of these fractions, clamped to
    ``clamp``: a share of the low tail rather than the tail minus a constant, so that a map whose
    agreement is low everywhere gets a proportionally lower threshold, while a lost track (near
    0 on any map) still falls below it. ``factor`` and ``quantile`` were chosen on house-1's two
    fitted maps only (docs/notebook/tracking.md, "A threshold per map").
    """

    views: int = 200  # views scored (a seeded subset when the map has more)
    perturb: tuple[float, float] = (0.05, math.radians(3.0))
    quantile: float = 0.1
    factor: float = 0.6
    clamp: tuple[float, float] = (0.15, 0.5)
    seed: int = 0

    def __post_init__(self):
        if int(self.views) < 1 or not 0 < self.quantile < 1 or not self.factor > 0 \
                or not 0 <= self.clamp[0] <= self.clamp[1] <= 1 or min(self.perturb) < 0:
            raise TrackingError(f"bad health calibration {self}: views >= 1, 0 < quantile < 1, "
                                f"factor > 0, 0 <= clamp[0] <= clamp[1] <= 1, perturb >= 0")


def view_inlier_fractions(render: Callable[[np.ndarray], Frame], frames: Sequence[Frame],
                          poses: np.ndarray, intr: Intrinsics, idx: np.ndarray,
                          cal: HealthCalibration = HealthCalibration(),
                          camera_height: float = CAMERA_HEIGHT, align: Callable | None = None,
                          tracker=None, **test) -> np.ndarray:
    """The health statistic of each view ``frames[i]`` (true planar pose ``poses[i]``) after one
    tracking step (:class:`HealthCalibration`) against ``render(pose) -> Frame`` (the map):
    ``align(ref, frame, pred, tracker, seed, camera_height) -> pose`` is the tracker's alignment
    with its config ``tracker`` (:func:`navbench.track.ours.align`; ``None``: the test is taken
    at the perturbed pose itself); ``test``: :func:`inlier_fraction`'s tolerances.
    ``(N,)``, ``nan`` where a view has too few evidence pixels."""
    from navbench.track.eq7 import prepare_reference

    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    rng = np.random.default_rng([int(cal.seed), 0xCA11B])
    sigma = np.array([cal.perturb[0], cal.perturb[0], cal.perturb[1]])
    out = np.full(len(poses), np.nan)
    for i, (frame, pose) in enumerate(zip(frames, poses)):
        prev = pose + rng.normal(0.0, 1.0, 3) * sigma
        ref = prepare_reference(render(prev), intr, camera_pose(prev, camera_height))
        est = prev if align is None else align(ref, frame, prev, tracker, 0, camera_height)
        out[i] = inlier_fraction(ref, frame, est, idx, camera_height=camera_height, **test)
    return out


def calibrated_threshold(fractions, cal: HealthCalibration = HealthCalibration()) -> float:
    """``clamp(factor * quantile(fractions))`` over the finite fractions (``clamp[1]`` when none
    is finite: no evidence, the fixed default's ceiling)."""
    f = np.asarray(fractions, dtype=np.float64)
    f = f[np.isfinite(f)]
    if not f.size:
        return float(cal.clamp[1])
    return float(np.clip(cal.factor * np.quantile(f, cal.quantile), *cal.clamp))
