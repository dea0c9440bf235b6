"""Odometry increments (navbench.track.odometry): exact SE(2) algebra, seeded noise, and the
prediction every estimator calls (unchanged for controls)."""

import math

import numpy as np
import pytest

from navbench.sim.dynamics import NOISE_LEVELS, Control, apply_dynamics, predict
from navbench.track.odometry import (
    OdometryIncrement,
    compose,
    integrate,
    noisy_increments,
    predict_pose,
    relative_increments,
)


def _walk(n=50, seed=0):
    rng = np.random.default_rng(seed)
    p = np.zeros((n, 3))
    p[:, :2] = np.cumsum(rng.normal(size=(n, 2)) * 0.1, axis=0)
    p[:, 2] = (np.cumsum(rng.normal(size=n)) + np.pi) % (2 * np.pi) - np.pi
    return p


def test_increments_by_hand():
    # heading 90 deg, one step to world +y is 1 m forward; then a 45 deg left turn
    poses = [(1, 1, math.pi / 2), (1, 2, math.pi / 2), (1, 2, 3 * math.pi / 4)]
    np.testing.assert_allclose(relative_increments(poses), [[1, 0, 0], [0, 0, math.pi / 4]], atol=1e-15)
    np.testing.assert_allclose(compose((1, 1, math.pi / 2), (0, 1, 0)), (0, 1, math.pi / 2), atol=1e-15)


def test_integrate_inverts_relative_increments():
    p = _walk()
    back = integrate(p[0], relative_increments(p))
    np.testing.assert_allclose(back[:, :2], p[:, :2], atol=1e-12)
    np.testing.assert_allclose(np.angle(np.exp(1j * (back[:, 2] - p[:, 2]))), 0, atol=1e-12)


def test_noise_free_and_seeded():
    inc = relative_increments(_walk())
    np.testing.assert_allclose(noisy_increments(inc, (0.0, 0.0), np.random.default_rng(1)), inc, atol=1e-15)
    a = noisy_increments(inc, NOISE_LEVELS["mid"], np.random.default_rng(7))
    b = noisy_increments(inc, NOISE_LEVELS["mid"], np.random.default_rng(7))
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, inc)


def test_noise_mirrors_the_dynamics():
    """A forward step with a turn: the noisy increment equals apply_dynamics's step with the same
    draws (two normals per frame), seen from the start pose."""
    sig = NOISE_LEVELS["mid"]
    u = Control(turn=0.1, direction=0.0, speed=0.12)
    rng = np.random.default_rng(3)
    z = np.random.default_rng(3).standard_normal(2)
    noisy = noisy_increments([relative_increments([(0, 0, 0), predict((0, 0, 0), u)])[0]], sig, rng)[0]
    expect = apply_dynamics((0, 0, 0), u, sig[0] * z[0], sig[1] * z[1])
    np.testing.assert_allclose(noisy, expect, atol=1e-12)
    # standing still: no noise, but the two draws are still made
    rng = np.random.default_rng(3)
    assert noisy_increments([(0, 0, 0), (0, 0, 0)], sig, rng).tolist() == [[0, 0, 0], [0, 0, 0]]
    assert rng.standard_normal() == np.random.default_rng(3).standard_normal(5)[4]


def test_predict_pose_dispatch():
    u = Control(turn=0.05, direction=0.3, speed=0.1)
    pose = np.array([1.0, 2.0, 0.25])
    assert predict_pose(pose, u).tolist() == predict(pose, u).tolist()
    assert predict_pose(pose, u.as_array()).tolist() == predict(pose, u).tolist()
    np.testing.assert_allclose(predict_pose(pose, OdometryIncrement(0.1, 0.0, 0.2)),
                               (1 + 0.1 * math.cos(0.25), 2 + 0.1 * math.sin(0.25), 0.45))


@pytest.mark.parametrize("name", ["dynamics", "no-map"])
def test_estimators_follow_odometry(name):
    """``dynamics`` integrates the increments exactly; the interface takes an increment wherever
    it took a control."""
    from navbench.geometry import HALF_CAMERA, Frame
    from navbench.track.registry import make_estimator

    p = _walk(6)
    H, W = HALF_CAMERA.shape
    frame = Frame(np.zeros((H, W, 3), np.float32), np.full((H, W), np.inf, np.float32),
                  np.zeros((H, W), bool))
    est = make_estimator(name, vmap=None, intrinsics=HALF_CAMERA)
    est.reset(p[0], frame)
    out = [p[0]]
    for inc in relative_increments(p):
        out.append(est.update(OdometryIncrement(*inc), frame))
    if name == "dynamics":
        np.testing.assert_allclose(np.array(out), integrate(p[0], relative_increments(p)), atol=1e-12)
    else:  # no valid pixels: nothing to align, the prior keeps the prediction
        np.testing.assert_allclose(np.array(out)[:, :2], p[:, :2], atol=1e-6)
