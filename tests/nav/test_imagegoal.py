"""Image goals (issue 15 §1-2): the derived goal view, its localisation outcome, difficulty sampling."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from navbench.errors import TaskError
from navbench.geometry import CAMERA_HEIGHT, camera_by_name
from navbench.nav.imagegoal import GoalRules, classify, goal_heading, goal_pose, render_goal
from navbench.plan.tasks import Task, sample_tasks, sample_tasks_by_difficulty
from navbench.sim.camera import RaycastCamera
from tests.pipeline.test_stages import tiny_level


def test_goal_heading_is_seeded_uniform_and_independent_of_other_streams():
    hs = np.array([goal_heading(0, i) for i in range(2000)])
    assert hs.min() >= -math.pi and hs.max() < math.pi
    assert abs(hs.mean()) < 0.15 and abs(hs.std() - 2 * math.pi / math.sqrt(12)) < 0.1  # uniform
    assert goal_heading(0, 7) == goal_heading(0, 7) and goal_heading(1, 7) != goal_heading(0, 7)


def test_goal_image_is_the_simulator_view_at_the_target_byte_for_byte():
    level = tiny_level()
    task = Task(3, (0.5, 0.5, 0.0), (2.3, 1.8), 2.0)
    intr = camera_by_name("half")
    a, b = render_goal(level, task, intr, seed=5), render_goal(level, task, intr, seed=5)
    want = RaycastCamera(level, intr, CAMERA_HEIGHT).render(np.array([2.3, 1.8, goal_heading(5, 3)]))
    for x, y in ((a, b), (a, want)):
        assert x.rgb.tobytes() == y.rgb.tobytes() and x.depth.tobytes() == y.depth.tobytes()
        assert x.valid.tobytes() == y.valid.tobytes()
    np.testing.assert_array_equal(goal_pose(task, 5), [2.3, 1.8, goal_heading(5, 3)])


def _h(x, y, score, conf):
    return SimpleNamespace(pose=np.array([x, y, 0.0]), score=score, confidence=conf)


def test_classify_ok_ambiguous_failed():
    rules = GoalRules(min_confidence=0.8, ambiguity_radius=1.0, ambiguity_margin=0.02)
    ok = classify([_h(1.0, 1.0, 0.9, 0.95), _h(1.2, 1.0, 0.89, 0.9)], (1.0, 1.3), rules)  # second is near
    assert ok.status == "ok" and ok.error_m == pytest.approx(0.3) and ok.pose == (1.0, 1.0, 0.0)
    far_worse = classify([_h(1.0, 1.0, 0.9, 0.95), _h(4.0, 1.0, 0.85, 0.9)], (1.0, 1.0), rules)
    assert far_worse.status == "ok"  # a lookalike that scores clearly worse
    amb = classify([_h(1.0, 1.0, 0.9, 0.95), _h(4.0, 1.0, 0.89, 0.9)], (4.0, 1.0), rules)
    assert amb.status == "ambiguous" and amb.error_m == pytest.approx(3.0)
    low = classify([_h(1.0, 1.0, 0.9, 0.5)], (1.0, 1.0), rules)
    assert low.status == "failed" and low.pose is not None  # the agent still heads for its best guess
    none = classify([], (1.0, 1.0), rules)
    assert none.status == "failed" and none.pose is None and math.isnan(none.error_m)


def test_tasks_by_difficulty_have_exact_geodesic_bands_and_running_ids():
    from navbench.levelgen import generate_level
    from navbench.plan.shortest import shortest_path_length

    level = generate_level("house-t", 3)
    tasks = sample_tasks_by_difficulty(level, 3, 0, ("easy", "medium", "hard"))
    assert [t.id for t in tasks] == list(range(9))
    for t, (lo, hi) in zip(tasks, [(1.5, 3.0)] * 3 + [(3.0, 5.0)] * 3 + [(5.0, 10.0)] * 3):
        assert lo <= t.optimal_length <= hi
        assert t.optimal_length == shortest_path_length(level, t.start[:2], t.target)
    again = sample_tasks_by_difficulty(level, 3, 0, ("easy", "medium", "hard"))
    assert again == tasks
    # without a band the stream is today's (task files of today keep their tasks)
    assert sample_tasks(level, 4, 0) == sample_tasks(level, 4, 0, geodesic_range=None)
    with pytest.raises(TaskError, match="unknown difficulty 'extreme'"):
        sample_tasks_by_difficulty(level, 1, 0, ("extreme",))


def _run(task, found, noise="low", seed=4):
    from navbench.level import occupancy_raster
    from navbench.nav.episode import EpisodeConfig, run_episode
    from navbench.nav.imagegoal import run_image_goal_episode
    from navbench.sim.world import Simulator
    from navbench.track.registry import make_estimator
    from tests.nav.levels import door_rooms

    level = door_rooms()
    occ, xs, ys = occupancy_raster(level, 0.057)
    sim = Simulator(level, noise=noise, seed=seed, intrinsics=None)
    if found == "point":
        return run_episode(level, occ, xs, ys, task, make_estimator("dynamics"), sim, EpisodeConfig())
    return run_image_goal_episode(level, occ, xs, ys, task, found, make_estimator("dynamics"), sim, EpisodeConfig())


def test_image_goal_episode_found_at_the_target_is_the_point_goal_episode_bit_for_bit():
    from navbench.plan.shortest import shortest_path_length
    from tests.nav.levels import door_rooms

    start, target = (1.0, 1.0, 0.3), (5.0, 2.0)  # through the door, low noise: reached in 38 steps
    task = Task(0, start, target, shortest_path_length(door_rooms(), start[:2], target))
    point = _run(task, "point")
    image = _run(task, (target[0], target[1], 1.0))  # the goal found exactly where it is
    for name in ("true_poses", "est_poses", "controls", "plan", "target"):
        assert getattr(image, name).tobytes() == getattr(point, name).tobytes(), name
    assert (image.end_reason, image.steps, image.replans) == (point.end_reason, point.steps, point.replans)
    assert point.end_reason == "reached" and point.steps > 20
    # found 0.3 m off: the agent plans there, the record keeps the TRUE target for scoring
    off = _run(task, (target[0], target[1] - 0.3, 1.0))
    np.testing.assert_array_equal(off.target, target)
    assert off.plan[-1].tolist() != point.plan[-1].tolist()
    # nothing found: no goal, no step
    none = _run(task, None)
    assert none.end_reason == "no-plan" and none.steps == 0 and none.true_poses.shape == (1, 3)
    np.testing.assert_array_equal(none.target, target)
