"""Dynamics: exact integration, sign-preserving noise, noise statistics, limits, seeding."""

import math

import numpy as np
import pytest

from navbench.errors import ConfigError
from navbench.geometry import AGENT_LENGTH
from navbench.sim.dynamics import (
    MAX_DIRECTION_OFFSET, MAX_STEP, MAX_TURN, NOISE_LEVELS, Control, apply_dynamics, clip_control,
    draw_noise, predict, resolve_noise,
)


def test_noise_levels_match_spec():
    assert NOISE_LEVELS["none"] == (0.0, 0.0)
    assert NOISE_LEVELS["low"] == pytest.approx((math.radians(3), 0.10 * AGENT_LENGTH))
    assert NOISE_LEVELS["mid"] == pytest.approx((math.radians(6), 0.15 * AGENT_LENGTH))
    assert NOISE_LEVELS["high"] == pytest.approx((math.radians(9), 0.30 * AGENT_LENGTH))
    assert NOISE_LEVELS["tracking"] == pytest.approx((math.radians(3), 0.05 * AGENT_LENGTH))
    assert MAX_TURN == pytest.approx(math.radians(11.5))
    assert MAX_STEP == pytest.approx(0.16)
    assert MAX_DIRECTION_OFFSET == pytest.approx(math.radians(5))


def test_zero_noise_integrates_exactly():
    pose = np.array([1.0, 2.0, 0.1])
    u = Control(turn=0.1, direction=0.15, speed=0.1)
    out = apply_dynamics(pose, u, 0.0, 0.0)
    np.testing.assert_allclose(out, [1.0 + 0.1 * math.cos(0.15), 2.0 + 0.1 * math.sin(0.15), 0.2],
                               rtol=0, atol=1e-15)
    np.testing.assert_array_equal(predict(pose, u), out)
    # ten steps of a pure turn: heading advances by 10 * turn (wrapped)
    p = pose
    for _ in range(40):
        p = predict(p, Control(MAX_TURN, p[2], 0.0))
    assert p[0] == 1.0 and p[1] == 2.0
    assert p[2] == pytest.approx(float((0.1 + 40 * MAX_TURN + math.pi) % (2 * math.pi) - math.pi), abs=1e-12)


def test_noise_with_explicit_samples():
    pose = np.array([0.0, 0.0, 0.0])
    u = Control(turn=0.1, direction=0.05, speed=0.1)
    out = apply_dynamics(pose, u, 0.02, -0.03)
    np.testing.assert_allclose(out, [0.07 * math.cos(0.07), 0.07 * math.sin(0.07), 0.12], atol=1e-15)
    # negative turn: noise adds to the magnitude
    out = apply_dynamics(pose, Control(-0.1, 0.0, 0.0), 0.02, 0.5)
    np.testing.assert_allclose(out, [0.0, 0.0, -0.12], atol=1e-15)


def test_noise_only_when_moving():
    pose = np.array([1.0, 1.0, 0.5])
    # standing still: no noise at all
    np.testing.assert_array_equal(apply_dynamics(pose, Control(0.0, 0.5, 0.0), 0.3, 0.3), pose)
    # stepping without turning: heading untouched, direction noisy
    out = apply_dynamics(pose, Control(0.0, 0.5, 0.1), 0.2, 0.0)
    assert out[2] == 0.5
    np.testing.assert_allclose(out[:2], [1 + 0.1 * math.cos(0.7), 1 + 0.1 * math.sin(0.7)], atol=1e-15)
    # turning in place: no translation
    out = apply_dynamics(pose, Control(0.1, 0.5, 0.0), 0.2, 0.3)
    np.testing.assert_array_equal(out[:2], pose[:2])
    assert out[2] == pytest.approx(0.8)


def test_noise_never_inverts_turn_or_step():
    rng = np.random.default_rng(3)
    sig = (math.radians(30), 0.5)  # far larger than any level, to stress the clipping
    for _ in range(2000):
        turn = rng.uniform(-MAX_TURN, MAX_TURN)
        speed = rng.uniform(0, MAX_STEP)
        pose = np.array([0.0, 0.0, 0.0])
        ea, es = draw_noise(rng, sig)
        out = apply_dynamics(pose, Control(turn, 0.0, speed), ea, es)
        assert out[2] * turn >= 0.0  # heading never moves against the turn
        step = np.hypot(out[0], out[1])
        assert step == pytest.approx(max(0.0, speed + es), abs=1e-12)
        if step > 0:  # the step goes along the (noisy) direction, never backwards
            assert out[0] * math.cos(ea) + out[1] * math.sin(ea) == pytest.approx(step, abs=1e-12)
    out = apply_dynamics(np.zeros(3), Control(0.05, 0.0, 0.05), -1.0, -1.0)
    np.testing.assert_array_equal(out, np.zeros(3))


@pytest.mark.parametrize("name", ["low", "mid", "high", "tracking"])
def test_noise_statistics(name):
    sig = NOISE_LEVELS[name]
    rng = np.random.default_rng(11)
    e = np.array([draw_noise(rng, sig) for _ in range(20000)])
    assert abs(e[:, 0].std() / sig[0] - 1) < 0.03
    assert abs(e[:, 1].std() / sig[1] - 1) < 0.03
    assert abs(e[:, 0].mean()) < 4 * sig[0] / math.sqrt(20000)


def test_draw_noise_always_draws_two_normals():
    a = np.random.default_rng(5)
    b = np.random.default_rng(5)
    for sig in [(0.0, 0.0), (0.1, 0.0), (0.0, 0.2), (0.1, 0.2)]:
        ea, es = draw_noise(a, sig)
        z = b.standard_normal(2)
        assert (ea, es) == (sig[0] * z[0], sig[1] * z[1])
    assert a.standard_normal() == b.standard_normal()


def test_clip_control_limits():
    c = clip_control(Control(1.0, 0.3, 1.0), heading=0.0)
    assert c.turn == MAX_TURN and c.speed == MAX_STEP
    assert c.direction == pytest.approx(MAX_DIRECTION_OFFSET)
    c = clip_control(Control(-1.0, -0.3, -0.5), heading=0.0)
    assert c.turn == -MAX_TURN and c.speed == 0.0
    assert c.direction == pytest.approx(-MAX_DIRECTION_OFFSET)
    # across the +-pi seam: -3.1 is only 4.8 degrees from 3.1, kept
    c = clip_control(Control(0.0, -3.1, 0.1), heading=3.1)
    assert c.direction == pytest.approx(-3.1)
    c = clip_control((0.05, 0.01, 0.1), heading=0.0)  # within limits: unchanged
    assert (c.turn, c.direction, c.speed) == (0.05, pytest.approx(0.01), 0.1)


def test_resolve_noise():
    assert resolve_noise("mid") == NOISE_LEVELS["mid"]
    assert resolve_noise((0.1, 0.02)) == (0.1, 0.02)
    with pytest.raises(ConfigError):
        resolve_noise("extreme")
    with pytest.raises(ConfigError):
        resolve_noise((-0.1, 0.0))
