"""Exact shortest paths for the agent's disc: known answers on hand-made obstacle sets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.errors import TaskError
from navbench.plan.shortest import box_walls, inflate_convex, shortest_path
from .levels import two_rooms


def _tangent_arc(a, c, r, b):
    """Length of the path a -> tangent -> arc round circle (c, r) -> tangent -> b.

    The path passes c on the side where the angle a-c-b is reflex (the outside of a corner).
    """
    a, b, c = (np.asarray(v, float) for v in (a, b, c))
    da, db = np.linalg.norm(a - c), np.linalg.norm(b - c)
    ta, tb = math.sqrt(da**2 - r**2), math.sqrt(db**2 - r**2)
    # reflex angle at c between the directions to a and b, minus the two tangent-point offsets
    ang = 2 * math.pi - math.acos(np.dot(a - c, b - c) / (da * db))
    arc = ang - math.acos(r / da) - math.acos(r / db)
    return ta + tb + r * arc


def test_open_corridor_is_straight():
    # a 1 m wide corridor between two long walls; the straight line keeps 0.4 m clearance
    walls = [np.array([[0, -1.0], [10, -1.0], [10, -0.5], [0, -0.5]]),
             np.array([[0, 0.5], [10, 0.5], [10, 1.0], [0, 1.0]])]
    length, poly = shortest_path(walls, (1.0, 0.0), (9.0, 0.1), radius=0.1)
    assert length == pytest.approx(math.hypot(8.0, 0.1), rel=1e-9)
    assert poly.shape == (2, 2)


def test_round_a_box_tangent_arc_tangent():
    # square [-1, 1]^2, disc radius 0.5, from (-3, 0) to (3, 0): over a rounded corner, along
    # the straight offset edge y = 1.5 (length 2), round the other corner, down to the goal.
    sq = [np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)]
    length, poly = shortest_path(sq, (-3.0, 0.0), (3.0, 0.0), radius=0.5)
    # one half: a -> tangent to the circle ((-1, 1), 0.5) -> arc up to the top point (-1, 1.5)
    c = np.array([-1.0, 1.0])
    a = np.array([-3.0, 0.0])
    d = np.linalg.norm(a - c)
    t = math.sqrt(d**2 - 0.25)
    phi = math.atan2(a[1] - c[1], a[0] - c[0]) % (2 * math.pi)  # 206.57 deg
    tangent_angle = phi - math.acos(0.5 / d)  # 129.49 deg
    exact = 2 * (t + 0.5 * (tangent_angle - math.pi / 2)) + 2.0  # = 7.0481
    assert exact == pytest.approx(7.0481, abs=1e-4)
    assert length == pytest.approx(exact, rel=0.01)
    assert length >= exact - 1e-9  # the circumscribed corners only ever lengthen the path
    assert np.all(poly[:, 1] >= -1e-9)  # goes over the top (both sides are equally long)


def test_l_bend_round_the_inner_corner():
    # a 3 x 3 box with a block filling [1, 3] x [1, 3]: an L-shaped corridor 1 m wide.
    # From (2.5, 0.5) to (0.5, 2.5) a disc of radius 0.2 turns round the inner corner (1, 1).
    block = np.array([[1, 1], [3, 1], [3, 3], [1, 3]], float)
    length, _ = shortest_path([block] + box_walls(3.0, 3.0), (2.5, 0.5), (0.5, 2.5), radius=0.2)
    exact = _tangent_arc((2.5, 0.5), (1.0, 1.0), 0.2, (0.5, 2.5))
    assert exact == pytest.approx(2 * math.sqrt(2.46) + 0.2 * math.radians(67.66), abs=1e-3)
    assert length == pytest.approx(exact, rel=0.01)


def test_inflate_square_contains_the_exact_offset():
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    infl = inflate_convex(sq, 0.5, math.radians(10))
    # 4 corners x ceil(90 / 10) = 9 vertices; all at least 0.5 from the square
    assert infl.shape == (36, 2)
    centre = np.array([0.5, 0.5])
    dist_to_square = np.linalg.norm(np.maximum(np.abs(infl - centre) - 0.5, 0.0), axis=1)
    assert np.all(dist_to_square >= 0.5 - 1e-12)
    assert np.all(dist_to_square <= 0.5 / math.cos(math.radians(5)) + 1e-12)


def test_unreachable_and_blocked_points_raise_task_error():
    level = two_rooms()
    with pytest.raises(TaskError, match="unreachable"):
        shortest_path(level, (1.5, 2.0), (4.5, 2.0))
    with pytest.raises(TaskError, match="not free"):
        shortest_path(level, (3.0, 2.0), (4.5, 2.0))  # inside the dividing wall


def test_path_through_a_door_is_feasible_and_tight():
    # the polyline never overlaps a solid (swept exactly by the simulator's collision world with a
    # slightly smaller disc) and touches one (tight), so it is the shortest path, not a detour
    from navbench.sim.world import CollisionWorld

    from .levels import door_rooms

    level = door_rooms()
    length, poly = shortest_path(level, (1.0, 3.5), (5.0, 3.5))
    world = CollisionWorld(level, radius=0.0995)
    assert not any(world.sweep(a, b)[1] for a, b in zip(poly[:-1], poly[1:]))
    assert min(CollisionWorld(level).clearance(p) for p in poly[1:-1]) == pytest.approx(0.1, abs=1e-3)
    assert length == pytest.approx(np.sum(np.linalg.norm(np.diff(poly, axis=0), axis=1)))
    assert length > math.dist((1.0, 3.5), (5.0, 3.5))
