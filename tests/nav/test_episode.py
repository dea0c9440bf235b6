"""Navigation episodes on tiny hand-made levels with the real simulator (no camera)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.level import occupancy_raster
from navbench.nav.episode import EpisodeConfig, run_episode
from navbench.nav.metrics import score_episode
from navbench.plan.shortest import shortest_path
from navbench.plan.tasks import Task
from navbench.sim.dynamics import MAX_STEP
from navbench.sim.world import Simulator
from navbench.track.registry import make_estimator

from .levels import door_rooms, open_room, two_rooms

CELL = 0.057


def _episode(level, task, estimator="gt", noise="none", seed=0, occ=None, config=EpisodeConfig()):
    o, xs, ys = occupancy_raster(level, CELL)
    sim = Simulator(level, noise=noise, seed=seed, intrinsics=None)
    est = make_estimator(estimator)
    return run_episode(level, o if occ is None else occ, xs, ys, task, est, sim, config)


def test_straight_shot_in_an_open_room_has_spl_one():
    level = open_room()
    # facing the target 3.6056 m away: 22 full steps of 0.16 m leave 0.0856 m, within the
    # waypoint tolerance (0.5 L = 0.1 m), so the agent stops there
    heading = math.atan2(2.0, 3.0)
    task = Task(0, (1.0, 1.0, heading), (4.0, 3.0), math.sqrt(13.0))
    rec = _episode(level, task)
    assert rec.end_reason == "reached" and rec.plan_status == "shortcut" and not rec.collided
    assert rec.steps == 22
    np.testing.assert_allclose(rec.controls[:, 2], MAX_STEP)
    end = np.array([1.0, 1.0]) + 22 * MAX_STEP * np.array([math.cos(heading), math.sin(heading)])
    np.testing.assert_allclose(rec.true_poses[-1, :2], end, atol=1e-9)
    np.testing.assert_array_equal(rec.true_poses, rec.est_poses)
    s = score_episode(rec)
    assert s.success and s.spl_term == pytest.approx(1.0) and s.loc_rmse_m == 0.0
    assert set(rec.timings_ms) == {"sim", "render", "estimate", "plan", "control"}
    assert all(len(v) == 22 for v in rec.timings_ms.values())
    assert rec.level == "open" and rec.estimator == "gt" and rec.noise == "none"


def test_turns_first_then_walks():
    level = open_room()
    task = Task(1, (1.0, 1.0, 0.0), (1.0, 1.0 + math.sqrt(13.0)), math.sqrt(13.0))
    rec = _episode(level, task)
    # 90 deg: seven turns of 11.5 deg and one of 9.5 deg, then 22 steps
    assert rec.steps == 30
    np.testing.assert_allclose(rec.controls[:7, 0], math.radians(11.5))
    assert rec.controls[7, 0] == pytest.approx(math.radians(9.5))
    assert np.all(rec.controls[:8, 2] == 0.0)
    assert score_episode(rec).spl_term == pytest.approx(1.0)


def test_dynamics_estimator_without_noise_equals_truth():
    level = door_rooms()
    start, target = (1.0, 3.0, 0.0), (5.0, 3.0)
    task = Task(2, start, target, shortest_path(level, start[:2], target)[0])
    rec = _episode(level, task, estimator="dynamics")
    assert rec.end_reason == "reached" and rec.plan_status == "astar"
    np.testing.assert_allclose(rec.est_poses, rec.true_poses, atol=1e-9)
    s = score_episode(rec)
    # through the door: A* on the 0.8 L lattice with a 1.2 L margin is a bit longer than optimal
    assert s.success and 0.8 < s.spl_term < 1.0


def test_no_plan_when_the_model_walls_in_the_target():
    level = open_room()
    occ, xs, ys = occupancy_raster(level, CELL)
    ix = np.abs(xs - 4.0).argmin()
    iy = np.abs(ys - 3.0).argmin()
    occ[ix - 8: ix + 9, iy - 8] = occ[ix - 8: ix + 9, iy + 8] = True
    occ[ix - 8, iy - 8: iy + 9] = occ[ix + 8, iy - 8: iy + 9] = True
    rec = _episode(level, Task(3, (1.0, 1.0, 0.0), (4.0, 3.0), 3.6), occ=occ)
    assert rec.end_reason == "no-plan" and rec.steps == 0 and rec.plan.shape == (0, 2)
    assert rec.true_poses.shape == (1, 3) and not score_episode(rec).success


def test_collision_ends_the_episode_as_stuck():
    level = two_rooms()  # the model below does not know the dividing wall at x = 3
    occ, xs, ys = occupancy_raster(open_room(6.0, 4.0), CELL)
    rec = _episode(level, Task(4, (2.0, 2.0, 0.0), (4.0, 2.0), 2.0), occ=occ)
    assert rec.end_reason == "stuck" and rec.collided
    assert rec.collision_step == rec.steps - 1
    # stopped at contact: the disc (radius 0.1) touches the wall face at x = 2.95
    assert rec.true_poses[-1, 0] == pytest.approx(2.85, abs=1e-4)


def test_step_limit():
    level = open_room()
    rec = _episode(level, Task(5, (1.0, 1.0, 0.0), (4.0, 1.0), 3.0), config=EpisodeConfig(max_steps=5))
    assert rec.end_reason == "step-limit" and rec.steps == 5


def test_same_seed_same_episode():
    level = door_rooms()
    task = Task(6, (1.0, 3.0, 0.0), (5.0, 3.0), 4.5)
    a = _episode(level, task, estimator="dynamics", noise="mid", seed=11)
    b = _episode(level, task, estimator="dynamics", noise="mid", seed=11)
    np.testing.assert_array_equal(a.true_poses, b.true_poses)
    np.testing.assert_array_equal(a.controls, b.controls)


def test_the_simulator_drive_must_match_the_episode_config():
    """EpisodeConfig.body_fixed_drive is part of the cell key, so a simulator built otherwise is
    refused rather than silently giving episodes of the other kind."""
    from navbench.errors import ConfigError

    level = open_room()
    task = Task(0, (1.0, 1.0, 0.0), (3.0, 1.0), 2.0)
    o, xs, ys = occupancy_raster(level, CELL)
    body_fixed = Simulator(level, noise="mid", seed=1, intrinsics=None, enforce_direction_limit=True)
    with pytest.raises(ConfigError, match="body_fixed_drive"):
        run_episode(level, o, xs, ys, task, make_estimator("gt"), body_fixed, EpisodeConfig())
    rec = run_episode(level, o, xs, ys, task, make_estimator("gt"), body_fixed,
                      EpisodeConfig(body_fixed_drive=True))
    assert rec.end_reason == "reached"


def test_dynamics_agent_moves_along_its_commanded_direction():
    """The paper's location equation: each step moves along the commanded o (kept within 5 deg
    of the ESTIMATED heading) plus that step's noise, whatever the true heading has drifted to
    in the noisy in-place turns; a body-fixed drive instead bends every step towards the true
    heading, and path integration misses the drift (seeded: deterministic)."""
    level = open_room()
    task = Task(0, (0.5, 2.0, math.pi / 2), (4.5, 2.0), 4.0)  # a 90 deg turn, then 4 m straight
    o, xs, ys = occupancy_raster(level, CELL)
    off, miss = {}, {}
    for body_fixed in (False, True):
        sim = Simulator(level, noise=(math.radians(9.0), 0.0), seed=0, intrinsics=None,
                        enforce_direction_limit=body_fixed)
        rec = run_episode(level, o, xs, ys, task, make_estimator("dynamics"), sim,
                          EpisodeConfig(body_fixed_drive=body_fixed))
        moves = np.diff(rec.true_poses[:, :2], axis=0)
        moving = rec.controls[:, 2] > 0
        dirs = np.arctan2(moves[moving, 1], moves[moving, 0])
        off[body_fixed] = np.abs(np.angle(np.exp(1j * (dirs - rec.controls[moving, 1]))))
        miss[body_fixed] = float(np.hypot(*(rec.true_poses[-1, :2] - task.target)))
    # commanded: a step's offset is that step's noise (sigma 9 deg), never a drift
    assert np.median(off[False]) < math.radians(9.0) and miss[False] < 0.2
    # body-fixed: the turns' heading error bends the straight walk; the agent ends far off
    assert np.median(off[True]) > math.radians(9.0) and miss[True] > 0.5
