"""The frontier explorer (issue 15 section 7): exact pieces on hand-made grids, and a simulated
perfect-sensing loop on a tiny hand-made level that must see every reachable cell, terminate
within a bound and be deterministic."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.errors import PlanningError
from navbench.level import Wall, occupancy_raster
from navbench.plan.explore import (Explorer, ExplorerConfig, exploration_score, frontier_cells,
                                   reachable_distances, safe_cells, voronoi_cells)
from tests.plan.levels import box, make_level
from tests.plan.sensing import reveal

RES = 0.05
SENSE = 1.5  # m, the test sensor's range
STEP = 0.16  # m per step (MAX_STEP)


def explore_level():
    """6 m x 4 m: two rooms joined by a 1 m door at x = 3, an alcove behind a wall stub in the
    right room, a box in the left room, and a slit (0.1 m, narrower than the agent) into a
    closet at the top left that the agent can see into but never enter."""
    t = 0.1
    walls = [Wall((0, 0), (6, 0), t, 0), Wall((6, 0), (6, 4), t, 0), Wall((6, 4), (0, 4), t, 0),
             Wall((0, 4), (0, 0), t, 0), Wall((3, 0), (3, 1.5), t, 0), Wall((3, 2.5), (3, 4), t, 0),
             Wall((4.5, 2.8), (6, 2.8), t, 0),  # the alcove's wall stub, open at x < 4.5
             Wall((0, 3.2), (1.0, 3.2), t, 1), Wall((1.2, 3.2), (3, 3.2), t, 1)]  # closet, 0.1 m slit
    return make_level("explore", walls, [box(1.2, 1.2, 1.8, 1.8, 0.6)], width=6.0, depth=4.0)


def _follow(xy, waypoints):
    """Positions every STEP metres along the polyline xy -> waypoints (the last one exact)."""
    pts = np.vstack([np.asarray(xy)[None], np.asarray(waypoints)])
    out = []
    for a, b in zip(pts[:-1], pts[1:]):
        n = max(1, int(math.ceil(np.linalg.norm(b - a) / STEP)))
        out.extend(a + (b - a) * (k / n) for k in range(1, n + 1))
    return out


def run_exploration(level, start, config=ExplorerConfig(), goal_score=None, max_steps=3000):
    """Sense, decide, walk the plan (sensing at every step), repeat until "done"."""
    occ, xs, ys = occupancy_raster(level, RES, 0.05, 1.0)
    known = np.zeros_like(occ)
    explorer = Explorer(config)
    xy = np.asarray(start, float)
    trail = [xy]
    reveal(known, occ, xs, ys, xy, SENSE)
    decisions = 0
    while len(trail) < max_steps:
        d = explorer.decide(known, occ & known, xs, ys, xy, goal_score)
        decisions += 1
        if d.status == "done":
            return known, occ, xs, ys, np.array(trail), decisions, True
        for p in _follow(xy, d.plan.waypoints):
            assert not occ[int(round((p[0] - xs[0]) / RES)), int(round((p[1] - ys[0]) / RES))]
            xy = p
            trail.append(xy)
            reveal(known, occ, xs, ys, xy, SENSE)
        explorer.reached(d.target)
    return known, occ, xs, ys, np.array(trail), decisions, False


# ----------------------------------------------------------------------------- exact pieces

def test_frontier_cells_by_hand():
    known = np.zeros((5, 5), bool)
    known[:3, :] = True
    occ = np.zeros((5, 5), bool)
    occ[2, 0] = True
    f = frontier_cells(known, occ)
    expected = np.zeros((5, 5), bool)
    expected[2, 1:] = True  # row 2 borders the unseen rows 3-4; (2, 0) is occupied
    np.testing.assert_array_equal(f, expected)
    # the grid edge is not a frontier
    assert not frontier_cells(np.ones((4, 4), bool), np.zeros((4, 4), bool)).any()


def test_voronoi_cells_by_hand():
    # a corridor: free rows 1..7 between walls at rows 0 and 8 (the grid's x ends count as walls
    # too): the graph is the middle row 4 away from the ends, one cell wide
    free = np.zeros((20, 9), bool)
    free[:, 1:8] = True
    v = voronoi_cells(free)
    mid = v[5:15]
    assert mid[:, 4].all() and mid.sum() == 10
    assert not (v & ~free).any()
    # along one straight wall (row 0), away from the corners it makes with the grid's edges
    # (their bisectors are graph branches), no graph cell within 3 cells of it
    free = np.ones((30, 30), bool)
    free[:, 0] = False
    assert not voronoi_cells(free)[5:25, :4].any()
    # an L-shaped room: the graph reaches into both arms
    free = np.zeros((20, 20), bool)
    free[1:6, 1:19] = True
    free[1:19, 1:6] = True
    v = voronoi_cells(free)
    assert v[10:16, 3].all() and v[3, 10:16].all()
    assert not voronoi_cells(np.zeros((4, 4), bool)).any()


def test_safe_cells_use_unknown_as_obstacle():
    known = np.ones((9, 9), bool)
    known[0, :] = False  # unseen column
    safe = safe_cells(known, np.zeros((9, 9), bool), 1.0, 2.0)
    # distance to the unseen column x = 0 must be >= 2 cells
    np.testing.assert_array_equal(safe.any(axis=1), [False, False] + [True] * 7)


def test_reachable_distances_exact_on_a_corridor():
    safe = np.zeros((6, 3), bool)
    safe[:, 1] = True
    d = reachable_distances(safe, (0, 1), 0.5)
    np.testing.assert_allclose(d[:, 1], 0.5 * np.arange(6))
    assert np.isinf(d[:, 0]).all() and np.isinf(d[:, 2]).all()
    # a blocked source reaches nothing
    assert np.isinf(reachable_distances(safe, (0, 0), 0.5)).all()


def test_exploration_score_limits_and_walls():
    xs = ys = (np.arange(41) + 0.5) * 0.1
    occ = np.zeros((41, 41), bool)
    p = np.array([[2.05, 2.05]])
    assert exploration_score(np.zeros_like(occ), occ, xs, ys, p)[0] == 1.0
    assert exploration_score(np.ones_like(occ), occ, xs, ys, p)[0] == 0.0
    # seen half-plane x < 2.05 - 0.05: about half the samples unseen
    known = np.zeros_like(occ)
    known[:20, :] = True
    s = exploration_score(known, occ, xs, ys, p, rays=360)[0]
    assert 0.45 < s < 0.55
    # a seen wall ring at 0.5 m cuts every ray: nothing beyond it counts
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    r = np.hypot(X - 2.05, Y - 2.05)
    ring = (r > 0.45) & (r < 0.6)
    known2 = r < 0.6
    assert exploration_score(known2, ring, xs, ys, p)[0] == 0.0


def test_goal_score_hook_picks_the_goal_side():
    xs = ys = (np.arange(60) + 0.5) * 0.05
    known = np.zeros((60, 60), bool)
    known[20:40, :] = True  # a seen band open at both ends (x < 1 and x > 2 unseen)
    occ = np.zeros_like(known)
    robot = np.array([1.5, 1.5])
    left = Explorer(ExplorerConfig()).candidates(known, occ, xs, ys, robot)
    assert len(left) == 2
    # goal scoring without exploration: the candidate with the larger goal score wins
    cfg = ExplorerConfig(explore_weight=0.0, near_weight=0.0)
    for side in (-1, 1):
        d = Explorer(cfg).decide(known, occ, xs, ys, robot, goal_score=lambda p: np.maximum(0, side * (p[:, 0] - 1.5)))
        assert d.status == "target" and side * (d.target[0] - 1.5) > 0
    with pytest.raises(PlanningError, match="goal score"):
        Explorer().decide(known, occ, xs, ys, robot, goal_score=lambda p: np.zeros(len(p) + 1))


def test_config_and_shape_errors():
    with pytest.raises(PlanningError, match="frontier, voronoi"):
        ExplorerConfig(candidates="skeleton")
    with pytest.raises(PlanningError, match="weights"):
        ExplorerConfig(goal_weight=-1)
    with pytest.raises(PlanningError, match="known"):
        Explorer().decide(np.zeros((3, 4), bool), np.zeros((3, 3), bool), np.arange(3.0), np.arange(3.0), (1, 1))


# ----------------------------------------------------------------------------- the loop

@pytest.fixture(scope="module")
def explored():
    return run_exploration(explore_level(), (0.6, 0.6))


def test_loop_terminates_and_sees_every_reachable_cell(explored):
    known, occ, xs, ys, trail, decisions, done = explored
    assert done, f"not done after {len(trail)} steps"
    assert len(trail) < 1500 and decisions < 60
    # every cell the agent could stand on (true clearance >= the planner's safety, connected
    # to the start) has been seen
    safe_true = safe_cells(np.ones_like(occ), occ, RES, ExplorerConfig().planner.safety)
    reach = np.isfinite(reachable_distances(safe_true, (12, 12), RES))
    assert reach.sum() > 2000
    missing = reach & ~known
    assert not missing.any(), f"{missing.sum()} reachable cells never seen"
    # the closet behind the slit is not reachable, but the explorer stopped anyway
    assert not reach[int(2.0 / RES), int(3.6 / RES)]


def test_loop_is_deterministic(explored):
    again = run_exploration(explore_level(), (0.6, 0.6))
    np.testing.assert_array_equal(explored[4], again[4])
    np.testing.assert_array_equal(explored[0], again[0])


def test_voronoi_loop_terminates_and_sees_every_reachable_cell(explored):
    """RNR-Map's candidate kind on the same level: it too ends, having seen every reachable cell."""
    known, occ, xs, ys, trail, decisions, done = run_exploration(
        explore_level(), (0.6, 0.6), ExplorerConfig(candidates="voronoi"))
    assert done, f"not done after {len(trail)} steps"
    assert len(trail) < 1500 and decisions < 100
    safe_true = safe_cells(np.ones_like(occ), occ, RES, ExplorerConfig().planner.safety)
    reach = np.isfinite(reachable_distances(safe_true, (12, 12), RES))
    missing = reach & ~known
    assert not missing.any(), f"{missing.sum()} reachable cells never seen"
    assert not np.array_equal(trail[:len(explored[4])], explored[4])  # not the frontier walk
