"""A* on an occupancy slice: optimal 8-connected costs on hand-made grids, safety, shortcut."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.errors import PlanningError
from navbench.plan.astar import PlannerConfig, make_planner_map, plan_path

STEP = 0.16  # 0.8 L


def _grid(nx, ny, cell=STEP):
    xs = (np.arange(nx) + 0.5) * cell
    ys = (np.arange(ny) + 0.5) * cell
    return np.zeros((nx, ny), bool), xs, ys


def _cost(start, waypoints):
    pts = np.vstack([np.asarray(start, float)[None], waypoints])
    return float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))


def _centre(ix, iy):
    return ((ix + 0.5) * STEP, (iy + 0.5) * STEP)


EXACT = PlannerConfig(safety=0.0, goal_tolerance=0.01, shortcut=False)


def test_free_grid_cost_is_octile_distance():
    occ, xs, ys = _grid(12, 8)
    plan = plan_path(occ, xs, ys, _centre(1, 1), _centre(6, 3), EXACT)
    assert plan.status == "astar"
    # 5 right, 2 up: 2 diagonal + 3 straight moves
    assert _cost(_centre(1, 1), plan.waypoints) == pytest.approx((2 * math.sqrt(2) + 3) * STEP)
    np.testing.assert_allclose(plan.waypoints[-1], _centre(6, 3))
    # of the equally long paths, the tie-break picks one with a single turn (no staircase)
    moves = np.diff(np.vstack([_centre(1, 1), plan.waypoints]), axis=0)
    assert np.count_nonzero(np.any(np.abs(np.diff(moves, axis=0)) > 1e-9, axis=1)) == 1


def test_wall_with_gap_optimal_cost():
    # cell size = lattice step, so lattice points are cell centres: a classic 8-connected grid.
    # Column ix = 4 is occupied for iy = 0..4; the gap is iy = 5, 6.
    occ, xs, ys = _grid(10, 7)
    occ[4, :5] = True
    plan = plan_path(occ, xs, ys, _centre(1, 1), _centre(7, 1), EXACT)
    # (1,1) -> (4,5): 3 diagonal + 1 straight; (4,5) -> (7,1): the same
    assert _cost(_centre(1, 1), plan.waypoints) == pytest.approx((6 * math.sqrt(2) + 2) * STEP)


def test_safety_distance_forces_a_wider_detour():
    occ, xs, ys = _grid(10, 7)
    occ[4, :5] = True
    cfg = PlannerConfig(safety=1.5 * STEP, goal_tolerance=0.01, shortcut=False)
    plan = plan_path(occ, xs, ys, _centre(1, 1), _centre(7, 1), cfg)
    # cells within 0.24 m of the wall are banned, so the path crosses at (4, 6):
    # (1,1)->(2,5): 1 diag + 3 straight; ->(3,6) diag; ->(4,6) straight; mirrored on the right
    assert _cost(_centre(1, 1), plan.waypoints) == pytest.approx((4 * math.sqrt(2) + 8) * STEP)
    occupied = np.stack(np.meshgrid(xs, ys, indexing="ij"), -1)[occ]
    d = np.linalg.norm(plan.waypoints[:, None, :] - occupied[None], axis=-1).min(axis=1)
    assert np.all(d >= 1.5 * STEP - 1e-9)


def test_safety_on_a_fine_map():
    # 0.05 m cells, a block in the middle; every waypoint keeps 1.2 L from occupied centres
    cell = 0.05
    occ, xs, ys = _grid(80, 80, cell)
    occ[30:50, 10:70] = True
    plan = plan_path(occ, xs, ys, (0.5, 2.0), (3.5, 2.0), PlannerConfig())
    assert plan.status == "astar" and plan.expansions > 0
    occupied = np.stack(np.meshgrid(xs, ys, indexing="ij"), -1)[occ]
    d = np.linalg.norm(plan.waypoints[:, None, :] - occupied[None], axis=-1).min(axis=1)
    # exact at cell centres, within half a cell diagonal elsewhere (nearest-cell lookup)
    assert np.all(d >= 0.24 - cell * math.sqrt(2) / 2)
    np.testing.assert_allclose(plan.waypoints[-1], (3.5, 2.0))


def test_shortcut_when_the_target_is_in_sight():
    occ, xs, ys = _grid(40, 40, 0.05)
    plan = plan_path(occ, xs, ys, (0.5, 0.5), (1.5, 1.2))
    assert plan.status == "shortcut" and plan.expansions == 0
    np.testing.assert_allclose(plan.waypoints, [[1.5, 1.2]])


def test_no_plan_when_the_goal_is_walled_in():
    occ, xs, ys = _grid(40, 40, 0.05)
    occ[25:35, 25] = occ[25:35, 34] = occ[25, 25:35] = occ[34, 25:35] = True
    plan = plan_path(occ, xs, ys, (0.4, 0.4), (1.5, 1.5))
    assert plan.status == "no-plan" and plan.waypoints is None and plan.expansions > 0


def test_planner_map_validates_shapes():
    occ, xs, ys = _grid(10, 7)
    with pytest.raises(PlanningError, match="shape"):
        make_planner_map(occ, xs, ys[:-1])
    pm = make_planner_map(occ, xs, ys)
    assert np.all(np.isinf(pm.clearance))
    occ[3, 3] = True
    pm = make_planner_map(occ, xs, ys)
    assert pm.clearance[3, 3] == 0.0 and pm.clearance[5, 3] == pytest.approx(2 * STEP)
    assert pm.clearance[4, 4] == pytest.approx(math.sqrt(2) * STEP)


def test_escape_from_a_start_inside_the_safety_margin():
    # a start 0.05 m from the occupied centres: its neighbours are inside the 0.24 m margin too
    cell = 0.05
    occ, xs, ys = _grid(60, 60, cell)
    occ[:, 0:20] = True  # a solid band y < 1.0; occupied centres up to y = 0.975
    start, goal = (1.0, 1.025), (2.0, 2.5)
    strict = PlannerConfig(shortcut=False, escape=False)
    assert plan_path(occ, xs, ys, start, goal, strict).status == "no-plan"
    plan = plan_path(occ, xs, ys, start, goal, PlannerConfig(shortcut=False))
    assert plan.status == "astar"
    # the clearance grows along the path until the margin is left
    d = plan.waypoints[:, 1] - 0.975
    first_safe = int(np.argmax(d >= 0.24))
    assert np.all(np.diff(d[: first_safe + 1]) > 0) and np.all(d[first_safe:] >= 0.24 - cell)


def test_goal_just_inside_the_margin_is_reachable_with_goal_safety():
    cell = 0.05
    occ, xs, ys = _grid(60, 60, cell)
    occ[:, 0:20] = True  # occupied centres up to y = 0.975
    # lattice rows (from the start) at y = 1.22 and 1.06; only the row 1.06 is within 0.16 m of
    # the goal, and its points are 0.1 m from occupied centres (inside the 0.24 m margin)
    start, goal = (1.0, 2.5), (2.0, 1.05)
    strict = PlannerConfig(shortcut=False, goal_safety=0.24)
    assert plan_path(occ, xs, ys, start, goal, strict).status == "no-plan"
    plan = plan_path(occ, xs, ys, start, goal, PlannerConfig(shortcut=False, goal_safety=0.09))
    assert plan.status == "astar"
    # only the points within the goal tolerance (0.16 m) of the goal use the smaller margin
    near = np.linalg.norm(plan.waypoints - goal, axis=1) <= 0.16 + 1e-9
    assert np.all(plan.waypoints[~near, 1] - 0.975 >= 0.24 - cell)
