"""Exact invariants of the shared camera and pose conventions."""

import math

import numpy as np
import pytest

from navbench.errors import ConfigError
from navbench.geometry import (
    HALF_CAMERA, PAPER_CAMERA, backproject, camera_by_name, camera_pose, camera_rotation,
    pixel_rays, project, transform_points, world_points, wrap_angle,
)


def test_camera_rotation_is_proper_and_looks_along_heading():
    for theta in np.linspace(-math.pi, math.pi, 9):
        R = camera_rotation(theta)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
        np.testing.assert_allclose(R @ [0, 0, 1], [math.cos(theta), math.sin(theta), 0], atol=1e-12)
        np.testing.assert_allclose(R @ [0, 1, 0], [0, 0, -1], atol=1e-12)  # image down = world down
        # image right is the agent's right: heading rotated by -90 degrees
        np.testing.assert_allclose(R @ [1, 0, 0], [math.sin(theta), -math.cos(theta), 0], atol=1e-12)


def test_principal_ray_and_project_roundtrip():
    rays = pixel_rays(PAPER_CAMERA)
    assert rays.shape == (240, 320, 3)
    np.testing.assert_allclose(rays[120, 160], [0, 0, 1])
    depth = np.random.default_rng(0).uniform(0.5, 10, PAPER_CAMERA.shape)
    pts = backproject(depth, PAPER_CAMERA)
    np.testing.assert_allclose(pts[..., 2], depth)
    u, v = project(pts, PAPER_CAMERA)
    jj, ii = np.mgrid[0:240, 0:320]
    np.testing.assert_allclose(u, ii, atol=1e-9)
    np.testing.assert_allclose(v, jj, atol=1e-9)


def test_world_points_on_wall_ahead():
    # camera at (1, 2) facing +y; a wall plane y = 5 at z-depth 3 everywhere
    pose = (1.0, 2.0, math.pi / 2)
    depth = np.full(HALF_CAMERA.shape, 3.0)
    P = world_points(pose, depth, HALF_CAMERA, camera_height=0.5)
    np.testing.assert_allclose(P[..., 1], 5.0, atol=1e-12)
    # the centre pixel is straight ahead at camera height
    np.testing.assert_allclose(P[60, 80], [1.0, 5.0, 0.5], atol=1e-12)
    # rows below the centre are lower in the world
    assert P[100, 80, 2] < 0.5 < P[10, 80, 2]


def test_transform_inverse():
    T = camera_pose((0.3, -1.2, 0.7))
    p = np.random.default_rng(1).normal(size=(10, 3))
    Tinv = np.linalg.inv(T)
    np.testing.assert_allclose(transform_points(Tinv, transform_points(T, p)), p, atol=1e-12)


def test_wrap_angle_range():
    a = np.array([-3 * math.pi, -math.pi, 0.0, math.pi, 2.5 * math.pi])
    w = wrap_angle(a)
    assert np.all(w >= -math.pi) and np.all(w < math.pi)
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)


def test_camera_presets():
    assert camera_by_name("half") == HALF_CAMERA
    assert PAPER_CAMERA.scaled(0.5) == HALF_CAMERA
    with pytest.raises(ConfigError, match="unknown camera"):
        camera_by_name("fisheye")
