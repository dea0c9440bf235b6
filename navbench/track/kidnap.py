"""Long trajectories and the kidnapped robot (issue 14, sections 3 and 4; RNR-Map seed 003, C.1).

**ATE.** The absolute trajectory error of TUM RGB-D / evo, *translation RMSE without alignment*,
is ``sqrt(mean_t |l_t - lhat_t|^2)`` over the ``T + 1`` poses of a trajectory (start included):
exactly :func:`navbench.nav.metrics.location_rmse`, the ``loc_rmse_m`` every tracking row already
holds. No alignment is needed because every estimator starts from the known start pose, in the
map's frame.

**Odometry.** A recorded control is ``(turn, direction, speed)`` with ``direction`` an *absolute*
world angle, set by the recording controller from the *true* heading (the tracking study's
controller steers with the true pose). Replayed as is (``odometry="world"``, the study's
historical mode) it hands the estimators the true heading for every translation. What a robot's
odometry measures is the motion in its own frame: the turn, the step length and the step's
direction relative to the heading, ``offset = direction - theta_true`` (within 5 deg, 0 for the
study's controller). ``odometry="body"`` gives each estimator the control re-expressed at its
own previous heading, :func:`body_control` (as in navigation episodes, where the controller
steers with the estimate). With kidnapping only ``body`` is meaningful: a world direction would
leak the new true heading.

**Raw odometry** (RNR-Map Table 1a's "raw noise": the trajectory of the noisy odometry readings
not adjusted by any tracker) is the dead reckoning of the body-frame controls from the known
start, :func:`dead_reckoning`; the noise of the dynamics (``eps_alpha``, ``eps_s``) is what the
readings miss. It equals the ``dynamics`` estimator replayed with ``odometry="body"``; the
``dynamics`` estimator replayed with ``odometry="world"`` is *not* raw odometry (its
translations follow the true heading).

**Kidnapping.** Every ``every`` steps the recording teleports the true pose to a uniform free
pose (clearance as the waypoints, uniform heading) from its own seeded stream; the estimators
are not told. A kidnap at pose index ``k`` means observation ``k`` is the first seen from the
new pose. :func:`recovery` scores one trajectory: a kidnap is *detected* when the estimator's
health alarm fires at a step in ``[k, next kidnap)``, and *recovered after s steps* when
``s >= 0`` is the first offset with location error < ``loc_tol`` (0.25 m) and heading error
< ``rot_tol_deg`` (10 deg) at index ``k + s`` (before the next kidnap; else never).

Pure functions: arrays in, arrays out.
"""

from __future__ import annotations

import math

import numpy as np

from navbench.geometry import wrap_angle
from navbench.sim.dynamics import Control, predict

#: Odometry modes of the tracking study (see the module doc).
ODOMETRY_MODES = ("world", "body")
#: Salt of the kidnap stream: ``np.random.default_rng([seed, i, KIDNAP_SALT])``.
KIDNAP_SALT = 0x4B1D


def body_control(control, true_heading: float, est_heading: float) -> Control:
    """``control (turn, direction, speed)`` recorded at true heading ``true_heading``, as the
    robot's odometry gives it to an estimator at heading ``est_heading`` (rad)."""
    turn, direction, speed = (float(v) for v in control)
    offset = float(wrap_angle(direction - true_heading))
    return Control(turn, float(wrap_angle(est_heading + offset)), speed)


def dead_reckoning(start, controls, true_poses) -> np.ndarray:
    """Raw odometry ``(T + 1, 3)``: the body-frame controls integrated by the noise-free
    dynamics from ``start`` (``controls (T, 3)``, ``true_poses (T + 1, 3)`` for the offsets)."""
    pose = np.asarray(start, dtype=np.float64).copy()
    out = [pose]
    for t, u in enumerate(np.asarray(controls, dtype=np.float64)):
        pose = predict(pose, body_control(u, float(true_poses[t][2]), float(pose[2])))
        out.append(pose)
    return np.array(out)


def kidnap_indices(steps: int, every: int) -> np.ndarray:
    """Pose indices ``k`` of the kidnaps of a ``steps``-control trajectory: ``every, 2 every, ...``
    while ``k + 5 <= steps`` (five steps are left to recover from the last one); none when
    ``every`` is 0."""
    if every <= 0:
        return np.zeros(0, dtype=np.int64)
    return np.arange(every, steps - 4, every, dtype=np.int64)


def pose_errors(true_poses, est_poses) -> tuple[np.ndarray, np.ndarray]:
    """Per pose: location error (m) and absolute wrapped heading error (deg)."""
    t = np.asarray(true_poses, dtype=np.float64)
    e = np.asarray(est_poses, dtype=np.float64)
    loc = np.hypot(*(e[:, :2] - t[:, :2]).T)
    rot = np.degrees(np.abs(wrap_angle(e[:, 2] - t[:, 2])))
    return loc, rot


def recovery(true_poses, est_poses, kidnapped, alarms, loc_tol: float = 0.25,
             rot_tol_deg: float = 10.0) -> dict[str, np.ndarray]:
    """Score the kidnaps of one trajectory (see the module doc).

    ``kidnapped (T + 1,)`` bool marks the kidnap indices; ``alarms (T,)`` bool: alarm raised by
    the update that produced pose ``t + 1`` (``None``: the estimator has no health test).
    Returns ``{"index": (K,), "detected": (K,) bool, "steps": (K,) int, -1 when never}``.
    """
    loc, rot = pose_errors(true_poses, est_poses)
    ok = (loc < loc_tol) & (rot < rot_tol_deg)
    ks = np.flatnonzero(np.asarray(kidnapped, bool))
    ends = np.append(ks[1:], len(ok))
    detected = np.zeros(len(ks), bool)
    steps = np.full(len(ks), -1, np.int64)
    for j, (k, end) in enumerate(zip(ks, ends)):
        if alarms is not None:
            detected[j] = bool(np.any(np.asarray(alarms, bool)[k - 1: end - 1]))
        hit = np.flatnonzero(ok[k:end])
        if len(hit):
            steps[j] = int(hit[0])
    return {"index": ks, "detected": detected, "steps": steps}


def recovered_within(steps: np.ndarray, within: int = 5) -> np.ndarray:
    """Whether each kidnap recovered after at most ``within`` steps (``steps`` from :func:`recovery`)."""
    s = np.asarray(steps)
    return (s >= 0) & (s <= within)


def median_or_nan(values) -> float:
    """The median of ``values``, or ``nan`` when there are none."""
    v = np.asarray(values, dtype=np.float64)
    return float(np.median(v)) if v.size else math.nan
