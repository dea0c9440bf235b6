"""The unknown-house image-goal loop on the TRUE sensing model (a stepping stone of issue 15
section 3): the frame reveal is the camera's wedge, the seen map hides what was not seen, and an
episode in the twin-rooms level passes the look-alike room and stops at the goal."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.geometry import HALF_CAMERA
from navbench.nav.imagenav import (ImageNavConfig, SeenMap, reveal_frame, run_unknown_image_episode,
                                   score_image_episode)
from navbench.sim.camera import RaycastCamera
from navbench.worldmodel.grid import voxelize_level
from tests.nav.twin import SHIFT, twin_rooms
from tests.plan.levels import open_room


def _cell(xs, x):
    return int(round((x - xs[0]) / (xs[1] - xs[0])))


def test_reveal_is_the_camera_wedge_up_to_the_walls():
    level = open_room()
    full = voxelize_level(level)
    truth, xs, ys = full.occupancy_slice("band")
    known = np.zeros_like(truth)
    pose = np.array([3.0, 3.0, 0.0])
    reveal_frame(known, xs, ys, pose, RaycastCamera(level, HALF_CAMERA).render(pose), HALF_CAMERA)
    assert known[_cell(xs, 5.85), _cell(ys, 3.0)]         # ahead, up to the wall ...
    assert known[_cell(xs, 5.96), _cell(ys, 3.0)]         # ... and the wall's face (x = 5.95)
    assert not known[_cell(xs, 2.0), _cell(ys, 3.0)]      # behind the camera
    assert 40 < math.degrees(math.atan(HALF_CAMERA.cx / HALF_CAMERA.fx)) < 55  # half field of view
    for deg in (40.0, -40.0):                             # inside the field of view
        a = math.radians(deg)
        assert known[_cell(xs, 3 + 2 * math.cos(a)), _cell(ys, 3 + 2 * math.sin(a))]
    for deg in (55.0, -55.0):                             # outside it
        a = math.radians(deg)
        assert not known[_cell(xs, 3 + 2 * math.cos(a)), _cell(ys, 3 + 2 * math.sin(a))]


def test_seen_map_hides_the_unseen():
    level = open_room()
    full = voxelize_level(level)
    truth, xs, ys = full.occupancy_slice("band")
    known = np.zeros_like(truth)
    known[: len(xs) // 2] = True  # the half x < 3 m
    seen = SeenMap(full, known)
    occ, _, _ = seen.occupancy_slice()
    np.testing.assert_array_equal(occ, truth | ~known)
    f = seen.renderer(HALF_CAMERA).render(np.array([1.5, 3.0, 0.0]))  # looking into the unseen half
    # nothing beyond x = 3 m renders: the floor and ceiling end there, the far wall is gone
    assert f.valid.any() and f.depth[f.valid].max() < 1.5 + 0.1  # z-depth = distance along +x
    assert not f.valid[HALF_CAMERA.height // 2].any()  # the horizon row sees nothing
    g = seen.renderer(HALF_CAMERA).render(np.array([1.5, 3.0, math.pi]))  # looking at the seen wall
    assert g.valid.mean() > 0.95


@pytest.fixture(scope="module")
def twin_episode():
    level = twin_rooms()
    goal_pose = np.array([1.6, 1.9, -math.pi / 2 + math.radians(25)])
    goal = RaycastCamera(level, HALF_CAMERA).render(goal_pose)
    start = np.array([1.6 + SHIFT, 0.6, math.pi / 2])  # in the corridor, facing room B's door
    return level, goal_pose, start, goal


def test_episode_passes_the_lookalike_room_and_stops_at_the_goal(twin_episode):
    level, goal_pose, start, goal = twin_episode
    ep = run_unknown_image_episode(level, start, goal, ImageNavConfig(max_steps=400))
    ok, spl, final = score_image_episode(ep, goal_pose[:2], 4.0)
    assert ep.end_reason == "stopped" and ok and final < 0.3, (ep.end_reason, final, ep.match_log)
    # it never stopped in B: every pose before the stop step with x > 3.5 is in B or the corridor
    assert ep.true_poses[-1, 0] < 3.2
    assert 0 < spl <= 1
    # deterministic: a run cut at 80 steps retraces the first 80 steps exactly
    again = run_unknown_image_episode(level, start, goal, ImageNavConfig(max_steps=80))
    assert again.end_reason == "step-limit"
    np.testing.assert_array_equal(ep.true_poses[:81], again.true_poses)


def test_score_image_episode_by_hand():
    from navbench.nav.imagenav import ImageEpisode

    poses = np.array([[0, 0, 0], [3, 0, 0], [3, 4, 0]], float)  # path 7 m
    ep = ImageEpisode(poses, "stopped", 1, 2, 0.5, np.zeros((2, 2), bool), None)
    assert score_image_episode(ep, (3.5, 4.0), 5.0) == (True, 5.0 / 7.0, 0.5)
    assert score_image_episode(ep, (3.0, 5.5), 5.0)[0] is False  # 1.5 m > 1 m
    ep.end_reason = "step-limit"  # there but never decided to stop: a failure
    assert score_image_episode(ep, (3.0, 4.0), 5.0) == (False, 0.0, 0.0)


def test_gt_stopper_ablation_stops_by_the_oracle_only(twin_episode):
    level, goal_pose, _, goal = twin_episode
    near = np.array([goal_pose[0] + 0.5, goal_pose[1] + 0.3, 0.0])
    ep = run_unknown_image_episode(level, near, goal, ImageNavConfig(max_steps=60), oracle_target=goal_pose[:2])
    # the oracle stops it right after the look-around, before any match of its own
    assert ep.end_reason == "stopped" and ep.stop_step == ImageNavConfig().look_around and ep.matches == 0


def test_fused_mapping_never_reads_the_truth(twin_episode):
    """``mapping="fused"``: the agent's map is what its frames measured. Given a wrong "truth"
    (an empty house on the same grid), the episode is the same: the truth only scores it."""
    level, goal_pose, start, goal = twin_episode
    full = voxelize_level(level)
    empty = type(full)(full.spec, np.zeros_like(full.occ), full.col, full.tau, dict(full.meta))
    cfg = ImageNavConfig(max_steps=70)
    a = run_unknown_image_episode(level, start, goal, cfg, full_map=full, mapping="fused")
    b = run_unknown_image_episode(level, start, goal, cfg, full_map=empty, mapping="fused")
    np.testing.assert_array_equal(a.true_poses, b.true_poses)
    np.testing.assert_array_equal(a.known, b.known)
    assert a.match_log == b.match_log and len(a.controls) == len(a.true_poses) - 1
    assert a.known.any() and 0 < a.seen_share <= 1
    # and it is not the perfect sensor's map: the fused known cells differ from the reveal's
    p = run_unknown_image_episode(level, start, goal, ImageNavConfig(max_steps=32), full_map=full)
    f = run_unknown_image_episode(level, start, goal, ImageNavConfig(max_steps=32), full_map=full, mapping="fused")
    np.testing.assert_array_equal(p.true_poses, f.true_poses)  # the look-around: same poses
    assert (p.known != f.known).any()
