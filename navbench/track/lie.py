"""Small Lie-group helpers for the trackers: SE(3) exponential/logarithm and planar projection.

Conventions
    A twist ``xi = (rho, phi)`` is a ``(6,)`` float64 vector, translation ``rho`` (metres) first,
    rotation ``phi`` (axis-angle, radians) second. ``se3_exp(xi)`` is the 4x4 rigid transform
    ``exp(xi^)``; a *right* perturbation of a pose ``T`` is ``T @ se3_exp(delta)``, i.e. ``delta``
    is expressed in the frame that ``T`` maps from (for a camera pose ``T_wc``: the camera frame).

Planar poses ``(x, y, theta)`` and camera poses follow :mod:`navbench.geometry`; the camera of a
planar pose is :func:`navbench.geometry.camera_pose`. :func:`planar_from_camera` projects an
arbitrary camera pose back onto the planar manifold (position ``x, y`` of the optical centre and
the yaw of the optical axis), which is how se(3) estimates become planar agent poses.
"""

from __future__ import annotations

import math

import numpy as np

from navbench.geometry import wrap_angle


def hat(w: np.ndarray) -> np.ndarray:
    """Skew-symmetric matrix ``[w]x`` (3x3) of a ``(3,)`` vector, so ``hat(w) @ p = w x p``."""
    x, y, z = (float(v) for v in w)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def so3_exp(phi: np.ndarray) -> np.ndarray:
    """Rodrigues: axis-angle ``(3,)`` (rad) -> rotation matrix (3x3)."""
    phi = np.asarray(phi, dtype=np.float64)
    th = float(np.linalg.norm(phi))
    K = hat(phi)
    if th < 1e-8:
        return np.eye(3) + K + 0.5 * K @ K
    return np.eye(3) + (math.sin(th) / th) * K + ((1.0 - math.cos(th)) / th**2) * K @ K


def so3_log(R: np.ndarray) -> np.ndarray:
    """Rotation matrix (3x3) -> axis-angle ``(3,)`` with angle in ``[0, pi]``."""
    c = min(1.0, max(-1.0, (float(np.trace(R)) - 1.0) / 2.0))
    th = math.acos(c)
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if th < 1e-8:
        return 0.5 * v
    if math.pi - th < 1e-6:  # near pi: axis from the symmetric part
        M = (R + np.eye(3)) / 2.0
        k = int(np.argmax(np.diag(M)))
        axis = M[:, k] / math.sqrt(max(M[k, k], 1e-300))
        return th * axis / np.linalg.norm(axis)
    return th / (2.0 * math.sin(th)) * v


def _left_jacobian_so3(phi: np.ndarray) -> np.ndarray:
    th = float(np.linalg.norm(phi))
    K = hat(phi)
    if th < 1e-8:
        return np.eye(3) + 0.5 * K + K @ K / 6.0
    return (np.eye(3) + ((1.0 - math.cos(th)) / th**2) * K
            + ((th - math.sin(th)) / th**3) * K @ K)


def se3_exp(xi: np.ndarray) -> np.ndarray:
    """Twist ``(6,)`` = ``(rho, phi)`` -> 4x4 rigid transform."""
    xi = np.asarray(xi, dtype=np.float64)
    T = np.eye(4)
    T[:3, :3] = so3_exp(xi[3:])
    T[:3, 3] = _left_jacobian_so3(xi[3:]) @ xi[:3]
    return T


def se3_log(T: np.ndarray) -> np.ndarray:
    """4x4 rigid transform -> twist ``(6,)`` = ``(rho, phi)`` (inverse of :func:`se3_exp`)."""
    phi = so3_log(T[:3, :3])
    rho = np.linalg.solve(_left_jacobian_so3(phi), T[:3, 3])
    return np.concatenate([rho, phi])


def se3_inverse(T: np.ndarray) -> np.ndarray:
    """Inverse of a 4x4 rigid transform."""
    Ti = np.eye(4)
    Ti[:3, :3] = T[:3, :3].T
    Ti[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return Ti


def planar_from_camera(T_wc: np.ndarray) -> np.ndarray:
    """Project a camera pose ``T_wc`` (4x4) to the planar pose ``(x, y, theta)`` of its agent.

    ``x, y`` are the optical centre's world coordinates, ``theta`` the yaw of the optical axis
    (the camera's ``z`` column) projected onto the floor plane. Exact inverse of
    :func:`navbench.geometry.camera_pose` on poses that are planar.
    """
    fwd = T_wc[:3, 2]
    return np.array([T_wc[0, 3], T_wc[1, 3], float(wrap_angle(math.atan2(fwd[1], fwd[0])))])


def se2_compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Planar pose composition ``a (+) b``: ``b`` is expressed in the frame of ``a``."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1],
                     float(wrap_angle(a[2] + b[2]))])


def se2_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Relative planar pose ``a^-1 (+) b`` (``b`` seen from ``a``); ``se2_compose(a, .)`` inverts it."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return np.array([c * dx + s * dy, -s * dx + c * dy, float(wrap_angle(b[2] - a[2]))])


def pose_error(est: np.ndarray, true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-pose errors of planar trajectories ``(N, 3)``: location (m, ``(N,)``), |heading| (rad)."""
    est = np.atleast_2d(np.asarray(est, dtype=np.float64))
    true = np.atleast_2d(np.asarray(true, dtype=np.float64))
    loc = np.linalg.norm(est[:, :2] - true[:, :2], axis=1)
    rot = np.abs(wrap_angle(est[:, 2] - true[:, 2]))
    return loc, rot
