"""Exact invariants of the Lie-group helpers."""

from __future__ import annotations

import math

import numpy as np

from navbench.geometry import camera_pose
from navbench.track.lie import (
    hat,
    planar_from_camera,
    pose_error,
    se2_between,
    se2_compose,
    se3_exp,
    se3_inverse,
    se3_log,
    so3_exp,
)


def test_se3_exp_log_roundtrip():
    rng = np.random.default_rng(0)
    for scale in (1e-9, 1e-3, 0.5, 2.0):
        xi = rng.normal(size=6) * scale
        T = se3_exp(xi)
        assert np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)
        assert np.allclose(se3_log(T), xi, atol=1e-10)


def test_so3_exp_matches_hat_for_small_angles_and_rotates_about_axis():
    R = so3_exp(np.array([0.0, 0.0, math.pi / 2]))
    assert np.allclose(R @ [1.0, 0, 0], [0, 1.0, 0], atol=1e-12)
    w = np.array([1e-9, -2e-9, 3e-9])
    assert np.allclose(so3_exp(w), np.eye(3) + hat(w), atol=1e-17)


def test_se3_inverse():
    T = se3_exp(np.array([0.3, -0.2, 1.0, 0.4, -0.1, 0.7]))
    assert np.allclose(se3_inverse(T) @ T, np.eye(4), atol=1e-12)


def test_planar_from_camera_inverts_camera_pose():
    for pose in ([1.0, 2.0, 0.3], [-3.0, 0.5, 3.0], [0.0, 0.0, -2.5]):
        assert np.allclose(planar_from_camera(camera_pose(pose, 0.5)), pose, atol=1e-12)


def test_se2_between_and_compose_are_inverse():
    a = np.array([1.0, 2.0, 0.7])
    b = np.array([-0.5, 3.0, -2.9])
    rel = se2_between(a, b)
    assert np.allclose(se2_compose(a, rel), b, atol=1e-12)
    loc, rot = pose_error(a[None], b[None])
    assert math.isclose(loc[0], math.hypot(1.5, 1.0))
    assert math.isclose(rot[0], abs((b[2] - a[2] + math.pi) % (2 * math.pi) - math.pi))
