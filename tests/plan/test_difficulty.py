"""Level difficulty measures (issue 16 section 2) on hand-made levels with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.plan.difficulty import cross_widths, level_difficulty, level_edges, ray_distances, sample_polyline
from navbench.plan.tasks import Task

from .levels import door_rooms, open_room


def test_ray_distances_in_a_square_room():
    # open_room(2, 2): 0.1 m walls centred on the box edges, inner faces at 0.05 and 1.95
    a, b = level_edges(open_room(2.0, 2.0))
    dirs = np.array([[1.0, 0.0], [0.0, -1.0], [math.sqrt(0.5), math.sqrt(0.5)]])
    t = ray_distances([[0.5, 1.0]], dirs, a, b)
    np.testing.assert_allclose(t[0], [1.45, 0.95, 0.95 * math.sqrt(2)], rtol=0, atol=1e-12)
    # across a path heading along x: the vertical chord (1.9 m); along y: the horizontal one
    np.testing.assert_allclose(cross_widths([[0.5, 1.0], [1.0, 1.0]], [0.0, math.pi / 2], a, b), [1.9, 1.9],
                               rtol=0, atol=1e-12)
    # near the bottom wall a chord 30 deg off the normal is shorter: 0.25 / sin 30 + 0.95 / cos 30
    assert cross_widths([[1.0, 0.3]], [math.pi / 2], a, b)[0] == pytest.approx(
        0.25 / math.sin(math.radians(30)) + 0.95 / math.cos(math.radians(30)), abs=1e-12)
    # a path heading diagonally past (0.5, 0.5) cuts the room's corner: 2 * 0.45 * sqrt(2)
    assert cross_widths([[0.5, 0.5]], [math.pi / 4], a, b)[0] == pytest.approx(0.9 * math.sqrt(2), abs=1e-12)


def test_sample_polyline_keeps_corners_and_spacing():
    pts, heads = sample_polyline([[0, 0], [1, 0], [1, 0.5]], 0.3)
    assert pts[0].tolist() == [0, 0] and pts[-1].tolist() == [1, 0.5] and [1, 0] in pts.tolist()
    assert np.max(np.linalg.norm(np.diff(pts, axis=0), axis=1)) <= 0.3
    assert set(heads.tolist()) == {0.0, math.pi / 2}
    inner, _ = sample_polyline([[0, 0], [1, 0], [1, 0.5]], 0.3, end_margin=0.4)
    assert inner[:, 0].min() >= 0.4 - 1e-12 and inner[:, 1].max() <= 0.1 + 1e-12
    mid, _ = sample_polyline([[0, 0], [0.6, 0]], 0.05, end_margin=0.5)  # too short: the midpoint
    np.testing.assert_allclose(mid, [[0.3, 0.0]])


def test_straight_task_through_a_one_metre_door():
    """door_rooms: wall at x = 3 with a door at y in [1.5, 2.5]; the straight walk along y = 2
    is the shortest path (ratio 1, length 3 m, 19 steps of 0.16 m) and its narrowest chord is
    the door's 1 m."""
    d = level_difficulty(door_rooms(), [Task(0, (1.5, 2.0, 0.0), (4.5, 2.0), 3.0)])
    assert d.geodesic_ratio.tolist() == [1.0] and d.length.tolist() == [3.0]
    assert d.min_steps.tolist() == [19]
    assert d.narrowest_passage[0] == pytest.approx(1.0, abs=1e-12)


def test_detour_ratio_around_a_wall():
    """Start and target on both sides of the inner wall, away from the door: the path bends
    around the door jambs, so the ratio exceeds 1 and the narrowest chord is still the door."""
    d = level_difficulty(door_rooms(), [Task(0, (2.0, 0.6, 0.0), (4.0, 0.6), 0.0)])
    # exact: tangent to the disc of radius r = 0.1 around the jamb corner (2.95, 1.5), its arc
    # up to heading 0, 0.1 m along the door's top line y = 1.6 and the mirror image on the right
    r, D = 0.1, math.hypot(0.95, 0.9)
    theta = math.atan2(0.9, 0.95) + math.asin(r / D)
    exact = 2 * (math.sqrt(D * D - r * r) + r * theta) + 0.1
    assert exact <= d.length[0] <= exact * 1.0033  # navbench.plan.shortest's outer approximation
    assert d.geodesic_ratio[0] == pytest.approx(d.length[0] / 2.0)
    assert d.narrowest_passage[0] == pytest.approx(1.0, abs=1e-9)


def test_free_space_clearance_of_a_square_room():
    """Inner square of side s = 1.9: the reachable part (clearance >= r = 0.1) is the square of
    side s - 2r, where the mean clearance is r + (s - 2r) / 6; the planner's share (>= 0.24 m) is
    ((s - 0.48) / (s - 0.2))^2."""
    d = level_difficulty(open_room(2.0, 2.0), [Task(0, (0.5, 0.5, 0.0), (1.5, 1.5), 0.0)], resolution=0.005)
    assert d.free_clearance == pytest.approx(0.1 + 1.7 / 6, abs=2e-3)
    assert d.planner_free == pytest.approx((1.42 / 1.7) ** 2, abs=5e-3)
    # the diagonal path's middle part: chords across it within 30 deg of its normal reach the
    # walls at +-45 deg; the shortest are the room's 1.9 m (only the ends would cut corners)
    assert d.narrowest_passage[0] == pytest.approx(1.9 / math.cos(math.radians(15)), abs=1e-9)
    assert d.summary()["tasks"] == 1
