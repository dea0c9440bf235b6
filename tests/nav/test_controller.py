"""The waypoint controller's turn / step decisions (appendix B)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.nav.controller import ControllerConfig, control_towards, controller_step, select_waypoint
from navbench.sim.dynamics import MAX_STEP, MAX_TURN


def test_turns_in_place_towards_a_target_behind():
    c = control_towards((0.0, 0.0, 0.0), (-1.0, 0.1))
    assert c.speed == 0.0 and c.turn == pytest.approx(MAX_TURN)  # left is shorter (target at ~174 deg)
    c = control_towards((0.0, 0.0, 0.0), (-1.0, -0.1))
    assert c.turn == pytest.approx(-MAX_TURN)


def test_turn_does_not_overshoot():
    c = control_towards((0.0, 0.0, 0.0), (1.0, math.tan(math.radians(8.0))))
    assert c.speed == 0.0 and c.turn == pytest.approx(math.radians(8.0))


def test_steps_forward_when_aligned_within_5_degrees():
    pose = (1.0, 2.0, math.radians(90))
    c = control_towards(pose, (1.0 + 5 * math.tan(math.radians(4.0)), 7.0))  # 4 deg off, far away
    assert c.turn == 0.0 and c.speed == pytest.approx(MAX_STEP) and c.direction == pytest.approx(pose[2])
    c = control_towards(pose, (1.0, 2.1))  # close: no overshoot
    assert c.speed == pytest.approx(0.1)


def test_select_waypoint_drops_reached_and_passed_ones():
    wp = np.array([[0.0, 0.0], [0.16, 0.0], [0.32, 0.0], [0.48, 0.0]])
    cfg = ControllerConfig(waypoint_tolerance=0.05)
    # at the first waypoint: it is reached, the next one becomes the local target
    np.testing.assert_allclose(select_waypoint((0.01, 0.0), wp, cfg), wp[1:])
    # drifted ahead near the third: the first two are passed, the third is reached
    np.testing.assert_allclose(select_waypoint((0.31, 0.02), wp, cfg), wp[3:])
    # closest is the second (not reached yet)
    np.testing.assert_allclose(select_waypoint((0.2, 0.1), wp, cfg), wp[1:])
    assert len(select_waypoint((0.47, 0.0), wp, cfg)) == 0


def test_lookahead_keeps_far_path_parts_from_capturing_the_agent():
    # a U-turn path: the last waypoint is physically closest but 3 waypoints ahead
    wp = np.array([[1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.2]])
    cfg = ControllerConfig(lookahead=2)
    np.testing.assert_allclose(select_waypoint((0.0, 0.0), wp, cfg), wp)


def test_controller_step_none_when_done():
    c, rest = controller_step((1.0, 1.0, 0.0), np.array([[1.0, 1.0]]))
    assert c is None and len(rest) == 0
    c, rest = controller_step((0.0, 0.0, 0.0), np.array([[1.0, 0.0]]))
    assert c.speed == pytest.approx(MAX_STEP) and len(rest) == 1
