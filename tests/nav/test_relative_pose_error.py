"""relative_pose_error against hand-computed values (Sturm et al. 2012, eq. 1-2, planar)."""

import math

import numpy as np
import pytest

from navbench.nav.metrics import location_rmse, relative_pose_error


def test_translation_error_in_the_previous_true_frame():
    # truth moves 1 m along x; the estimate moves 1 m along x and 1 m along y: |E| = 1 m
    q = [(0, 0, 0), (1, 0, 0)]
    p = [(0, 0, 0), (1, 1, 0)]
    assert relative_pose_error(q, p) == pytest.approx((1.0, 0.0))


def test_rotation_error_in_degrees():
    q = [(0, 0, 0), (0, 0, math.pi / 2)]
    p = [(0, 0, 0), (0, 0, math.pi / 2 + 0.1)]
    t, r = relative_pose_error(q, p)
    assert t == pytest.approx(0.0, abs=1e-15)
    assert r == pytest.approx(math.degrees(0.1))


def test_frames_are_rotated():
    # truth at heading 90 deg steps 1 m "forward" (world +y): relative motion (1, 0, 0);
    # the estimate stands still: E = A^-1 B = (-1, 0), |E| = 1 m whatever the absolute poses
    q = [(0, 0, math.pi / 2), (0, 1, math.pi / 2)]
    p = [(5, 5, -1.0), (5, 5, -1.0)]
    assert relative_pose_error(q, p) == pytest.approx((1.0, 0.0))
    # a turn of 90 deg in the truth rotates the translation error: truth (0,0,0) -> (0,0,pi/2),
    # estimate (0,0,0) -> (1,0,pi/2): E = R(pi/2)^T (1, 0) = (0, -1), 1 m, 0 deg
    assert relative_pose_error([(0, 0, 0), (0, 0, math.pi / 2)],
                               [(0, 0, 0), (1, 0, math.pi / 2)]) == pytest.approx((1.0, 0.0))


def test_rmse_over_pairs_and_delta():
    q = [(0, 0, 0), (1, 0, 0), (2, 0, 0)]
    p = [(0, 0, 0), (1, 0, 0), (2, 2, 0)]  # errors per frame: 0 m then 2 m
    assert relative_pose_error(q, p) == pytest.approx((math.sqrt((0 + 4) / 2), 0.0))
    assert relative_pose_error(q, p, delta=2) == pytest.approx((2.0, 0.0))
    assert all(math.isnan(v) for v in relative_pose_error(q, p, delta=3))


def test_rigid_offset_has_no_relative_error_but_an_absolute_one():
    rng = np.random.default_rng(0)
    q = np.cumsum(rng.normal(size=(20, 3)) * 0.1, axis=0)
    c, s = math.cos(0.3), math.sin(0.3)
    p = q.copy()
    p[:, 0] = c * q[:, 0] - s * q[:, 1] + 2.0
    p[:, 1] = s * q[:, 0] + c * q[:, 1] - 1.0
    p[:, 2] = q[:, 2] + 0.3
    t, r = relative_pose_error(q, p)
    assert t == pytest.approx(0.0, abs=1e-12) and r == pytest.approx(0.0, abs=1e-9)
    assert location_rmse(q, p) > 0.5


def test_lengths_must_match():
    with pytest.raises(ValueError):
        relative_pose_error([(0, 0, 0), (1, 0, 0)], [(0, 0, 0)])
