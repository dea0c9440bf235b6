"""Odometry as the trackers' prediction: relative planar pose increments, and their noise.

The estimators of :mod:`navbench.track` predict the next pose from the previous estimate and
what drove the agent. In navigation that is a control ``u_t`` through the noise-free dynamics
(:func:`navbench.sim.dynamics.predict`); on a recorded sequence (``navbench track-sequence``)
it is an odometry reading: the relative motion between frames ``t-1`` and ``t`` measured in the
body frame of frame ``t-1``, as RNR-Map's camera-tracking experiment gives its trackers
(seed 003, C.1: "a stream of image observations and noisy odometry sensor readings").
:func:`predict_pose` is the one prediction every estimator calls: it composes an
:class:`OdometryIncrement` and hands anything else to the dynamics unchanged, so the
navigation and track-eval paths compute exactly what they did before.

Planar poses are ``(x, y, theta)`` world metres / radians; an increment ``(dx, dy, dtheta)`` is
``pose_{t-1}^-1 * pose_t`` in SE(2): ``(dx, dy)`` metres in the frame of pose ``t-1`` (x along
its heading), ``dtheta`` radians (wrapped to ``[-pi, pi)``).

Simulated odometry (:func:`noisy_increments`) applies the paper's dynamics noise (section 5,
:data:`navbench.sim.dynamics.NOISE_LEVELS`) to each true increment written in polar form
``(s, o, dtheta)`` (step length, direction of the step relative to the heading, turn)::

    dtheta' = sign(dtheta) * max(0, |dtheta| + eps_alpha)      (only if dtheta != 0)
    o'      = o + eps_alpha,   s' = max(0, s + eps_s)          (only if s > 0)

with ``eps_alpha ~ N(0, sigma_alpha)``, ``eps_s ~ N(0, sigma_s)``: the same expressions as
:func:`navbench.sim.dynamics.apply_dynamics` with the measured increment in place of the
commanded control, two normals drawn per frame whatever the motion (a seeded stream stays
aligned).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navbench.geometry import wrap_angle
from navbench.sim.dynamics import draw_noise, predict


@dataclass(frozen=True)
class OdometryIncrement:
    """One odometry reading: the motion from frame ``t-1`` to ``t`` in the body frame of ``t-1``."""

    dx: float  # metres, along the previous heading
    dy: float  # metres, to the left of the previous heading
    dtheta: float  # radians, counter-clockwise

    def as_array(self) -> np.ndarray:
        """``(3,)`` float64 ``(dx, dy, dtheta)``."""
        return np.array([self.dx, self.dy, self.dtheta], dtype=np.float64)


def compose(pose, increment) -> np.ndarray:
    """``pose * increment`` in SE(2): pose ``(3,)`` and increment ``(3,)`` -> pose ``(3,)``."""
    x, y, a = (float(v) for v in pose)
    dx, dy, da = (float(v) for v in increment)
    c, s = math.cos(a), math.sin(a)
    return np.array([x + c * dx - s * dy, y + s * dx + c * dy, float(wrap_angle(a + da))])


def relative_increments(poses) -> np.ndarray:
    """The increments ``pose_{t-1}^-1 * pose_t`` of a trajectory ``(T + 1, 3)`` -> ``(T, 3)``;
    :func:`integrate` from ``poses[0]`` gives the poses back."""
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    d = np.diff(p[:, :2], axis=0)
    c, s = np.cos(p[:-1, 2]), np.sin(p[:-1, 2])
    out = np.empty((len(p) - 1, 3))
    out[:, 0] = c * d[:, 0] + s * d[:, 1]
    out[:, 1] = -s * d[:, 0] + c * d[:, 1]
    out[:, 2] = wrap_angle(np.diff(p[:, 2]))
    return out


def integrate(pose0, increments) -> np.ndarray:
    """Dead reckoning: ``pose0 (3,)`` composed with each increment ``(T, 3)`` -> ``(T + 1, 3)``."""
    out = [np.asarray(pose0, dtype=np.float64).reshape(3).copy()]
    for inc in np.asarray(increments, dtype=np.float64).reshape(-1, 3):
        out.append(compose(out[-1], inc))
    return np.array(out)


def noisy_increments(increments, sigmas: tuple[float, float], rng: np.random.Generator) -> np.ndarray:
    """Simulated odometry: the true ``increments (T, 3)`` with the dynamics noise of the module
    docstring, ``sigmas = (sigma_alpha [rad], sigma_s [m])`` per frame, drawn from ``rng``."""
    out = []
    for dx, dy, da in np.asarray(increments, dtype=np.float64).reshape(-1, 3):
        ea, es = draw_noise(rng, sigmas)
        if da != 0.0:
            da = math.copysign(max(0.0, abs(da) + ea), da)
        step = math.hypot(dx, dy)
        if step > 0.0:
            o = math.atan2(dy, dx) + ea
            step = max(0.0, step + es)
            dx, dy = step * math.cos(o), step * math.sin(o)
        out.append((dx, dy, float(wrap_angle(da))))
    return np.array(out, dtype=np.float64).reshape(-1, 3)


def predict_pose(pose, u) -> np.ndarray:
    """The estimators' prediction of the next pose ``(3,)``: ``pose`` composed with ``u`` when
    ``u`` is an :class:`OdometryIncrement`, else the noise-free dynamics ``predict(pose, u)``."""
    if isinstance(u, OdometryIncrement):
        return compose(pose, (u.dx, u.dy, u.dtheta))
    return predict(pose, u)
