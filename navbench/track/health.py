"""The tracking-health test of the prediction-to-observation trackers (issue 14, "kidnapped robot").

After eq. 7 is minimised, the tracker asks whether its estimate still explains the observation:
the **inlier fraction** is the share of the observed pixels (a fixed sample) whose back-projected
point ``p``, moved into the reference camera (``q = T_ref^-1 T_wc(z_t) p``), lands on a reference
pixel whose z-depth agrees with ``q_z`` to within ``tol * q_z`` and whose colour agrees with the
observed one to within ``photo_tol`` (L1 over RGB), both at the projective association of eq. 7::

    inliers = #{k : |D_ref[pi(q_k)] - q_kz| <= tol q_kz  and  |I_ref[pi(q_k)] - I_k|_1 <= photo_tol}
              / #{k : pi(q_k) inside, D_ref valid}

Depth alone cannot tell apart two places whose geometry is alike (the corners of two rooms of
the same shape); their textures differ.

Only points between the heights ``band = (z_low, z_high)`` above the floor count: the floor and
the ceiling are horizontal planes that agree with *any* planar pose at the camera height (a point
on the floor stays on the floor), so they carry no evidence for or against ``(x, y, theta)``.
Projections that leave the reference image are not evidence either; with fewer than
``min_pixels`` evidence pixels the fraction is ``nan`` (no decision: healthy).

The tracker raises an alarm when the fraction falls below ``health_min_inliers``
(:class:`navbench.track.eq7.TrackerConfig`); the threshold was calibrated on normal tracking of
``house-1`` only (see README, "Localisation and the kidnapped robot"). Pure numpy: arrays in, a float out.
"""

from __future__ import annotations

import math

import numpy as np

from navbench.geometry import CAMERA_HEIGHT, Frame, camera_pose
from navbench.track.eq7 import Reference, sample_observation
from navbench.track.lie import se3_inverse


def inlier_fraction(ref: Reference, frame: Frame, pose, idx: np.ndarray, tol: float = 0.05,
                    band: tuple[float, float] = (0.05, 1.1), camera_height: float = CAMERA_HEIGHT,
                    min_pixels: int = 20, photo_tol: float = 0.3) -> float:
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
    agree = (np.abs(ref.depth[vi, ui] - z) <= tol * z) \
        & (np.abs(ref.rgb[vi, ui] - obs.rgb[use]).sum(axis=1) <= photo_tol)
    return float(np.sum(agree & seen)) / n
