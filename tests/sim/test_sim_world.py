"""Collision world and simulator: stop at contact, never overlap, prohibited movement, seeding."""

import math
from pathlib import Path

import numpy as np
import pytest

from navbench.errors import TaskError
from navbench.geometry import AGENT_LENGTH, HALF_CAMERA
from navbench.level import distance_to_solids
from navbench.levelio import load_level
from navbench.sim.dynamics import MAX_STEP, MAX_TURN, Control
from navbench.sim.world import CollisionWorld, Simulator, sample_free_points

from .fixtures import box_before_wall, rooms, single_wall

HOUSE_1 = Path(__file__).resolve().parents[2] / "levels" / "house-1.json"


def _level(name):
    if name == "house-1":
        if not HOUSE_1.is_file():
            pytest.skip("levels/house-1.json not generated yet")
        return load_level(HOUSE_1)
    return rooms()


def check_walk_into_wall_stops_at_contact(make_sim, tol=0.0):
    """Contract: a walk into a wall stops at contact (within ``tol`` m, the backend's position
    quantum; never overlapping beyond it), and nothing moves after the collision."""
    sim = make_sim(single_wall(), "none", seed=0, intrinsics=None)  # wall face at x = 2.95
    sim.reset((1.95, 5.0, 0.0))  # 1 m from the face
    for k in range(30):
        res = sim.step(Control(0.0, 0.0, MAX_STEP))
        if res.collided:
            break
    assert res.collided and sim.collision_step == k == int(math.ceil((1.0 - AGENT_LENGTH / 2) / MAX_STEP)) - 1
    assert res.pose[0] == pytest.approx(2.95 - AGENT_LENGTH / 2, abs=1e-3 + tol)
    if tol == 0.0:
        assert res.pose[0] < 2.95 - AGENT_LENGTH / 2  # never overlapping
    else:
        assert res.pose[0] <= 2.95 - AGENT_LENGTH / 2 + tol
    assert res.pose[1] == pytest.approx(5.0, abs=tol)
    frozen = res.pose.copy()
    for u in [Control(0.0, 0.0, MAX_STEP), Control(MAX_TURN, math.pi, MAX_STEP), Control(-0.1, 0.0, 0.0)]:
        res = sim.step(u)
        np.testing.assert_array_equal(res.pose, frozen)
        assert res.collided


def test_walk_into_wall_stops_at_contact():
    check_walk_into_wall_stops_at_contact(Simulator)


def check_low_box_blocks_the_agent(make_sim, tol=0.0):
    """Contract: a box lower than the camera blocks the agent as a wall does."""
    sim = make_sim(box_before_wall(0.3), "none", intrinsics=None)  # box face at x = 2
    sim.reset((1.0, 5.0, 0.0))
    while not sim.step(Control(0.0, 0.0, MAX_STEP)).collided:
        pass
    assert sim.pose[0] == pytest.approx(2.0 - AGENT_LENGTH / 2, abs=1e-3 + tol)


def test_low_box_blocks_the_agent():
    check_low_box_blocks_the_agent(Simulator)


def test_level_boundary_blocks_the_agent():
    world = CollisionWorld(single_wall())
    end, hit = world.sweep((0.5, 5.0), (-1.0, 5.0))
    assert hit and end[0] == pytest.approx(AGENT_LENGTH / 2, abs=1e-5) and end[0] >= AGENT_LENGTH / 2


def test_sweep_free_and_grazing():
    world = CollisionWorld(single_wall())
    end, hit = world.sweep((1.0, 5.0), (2.0, 6.0))
    assert not hit and np.array_equal(end, [2.0, 6.0])
    # parallel to the wall at exactly the radius: touching is allowed, not a collision of the path
    end, hit = world.sweep((2.95 - 0.1 - 1e-9, 2.0), (2.95 - 0.1 - 1e-9, 3.0))
    assert not hit
    # around the end of the wall (x in [2.95, 3.05], y <= 10): a disc passing the corner by 1 mm
    end, hit = world.sweep((2.0, 10.101), (4.0, 10.101))
    assert not hit
    end, hit = world.sweep((2.0, 10.099), (4.0, 10.099))
    assert hit and distance_to_solids(single_wall(), end[None])[0] >= AGENT_LENGTH / 2 - 1e-9
    # a zero-length move never collides
    end, hit = world.sweep((1.0, 1.0), (1.0, 1.0))
    assert not hit and np.array_equal(end, [1.0, 1.0])


def check_random_walk_never_overlaps(make_sim, level, steps=10_000, min_collisions=10, tol=0.0):
    """Contract: a random walk with resets never leaves the agent's disc overlapping a solid or
    the level's box (by more than ``tol`` m, the backend's position quantum)."""
    rng = np.random.default_rng(7)
    sim = make_sim(level, "high", seed=3, intrinsics=None)
    starts = sample_free_points(level, rng, 400, 1.2 * AGENT_LENGTH)
    n_start = 0
    sim.reset((*starts[0], 0.0))
    poses = np.empty((steps, 3))
    collisions = 0
    for k in range(steps):
        if sim.collided:
            collisions += 1
            n_start += 1
            sim.reset((*starts[n_start % len(starts)], rng.uniform(-math.pi, math.pi)))
        u = Control(rng.uniform(-MAX_TURN, MAX_TURN), sim.pose[2] + rng.uniform(-0.1, 0.1),
                    rng.uniform(0, MAX_STEP) if rng.random() < 0.9 else 0.0)
        poses[k] = sim.step(u).pose
    d = distance_to_solids(level, poses[:, :2])
    slack = 1e-6 + math.sqrt(2) * tol
    assert d.min() >= AGENT_LENGTH / 2 - slack
    assert collisions >= min_collisions  # the walk did hit things
    assert np.all((poses[:, 0] >= AGENT_LENGTH / 2 - slack) & (poses[:, 0] <= level.width - AGENT_LENGTH / 2 + slack))


@pytest.mark.parametrize("name", ["rooms", "house-1"])
def test_random_walk_never_overlaps(name):
    check_random_walk_never_overlaps(Simulator, _level(name))


def check_same_seed_same_trajectory_and_aligned_stream(make_sim, start_tol=0.0):
    """Contract: one seed, one trajectory; the noise stream is drawn whatever the controls."""
    level = rooms()
    rng = np.random.default_rng(0)
    controls = [Control(rng.uniform(-0.2, 0.2), 0.0, rng.uniform(0, 0.16)) for _ in range(50)]
    a = make_sim(level, "mid", seed=42, intrinsics=None)
    b = make_sim(level, "mid", seed=42, intrinsics=None)
    c = make_sim(level, "mid", seed=43, intrinsics=None)
    pa = [a.reset((1.0, 1.0, 0.5))] and [a.step(u) for u in controls]
    pb = [b.reset((1.0, 1.0, 0.5))] and [b.step(u) for u in controls]
    pc = [c.reset((1.0, 1.0, 0.5))] and [c.step(u) for u in controls]
    assert all(np.array_equal(x.pose, y.pose) and x.eps == y.eps for x, y in zip(pa, pb))
    assert not all(np.array_equal(x.pose, y.pose) for x, y in zip(pa, pc))
    # different controls (standing still) draw the same noise stream
    d = make_sim(level, "mid", seed=42, intrinsics=None)
    d.reset((1.0, 1.0, 0.5))
    start = d.pose.copy()  # (1, 1, 0.5) as the backend places it
    np.testing.assert_allclose(start, [1.0, 1.0, 0.5], rtol=0, atol=start_tol)
    pd = [d.step(Control(0.0, 0.5, 0.0)) for _ in controls]
    assert [x.eps for x in pd] == [x.eps for x in pa]
    assert all(np.array_equal(x.pose, start) for x in pd)
    # reset with a seed restarts the stream
    a.reset((1.0, 1.0, 0.5), seed=42)
    assert a.step(controls[0]).eps == pa[0].eps


def test_same_seed_same_trajectory_and_aligned_stream():
    check_same_seed_same_trajectory_and_aligned_stream(Simulator)


def check_controls_are_clipped(make_sim, tol=0.0, angle_tol=0.0):
    """Contract: turn, speed and (with the body-fixed drive) direction are clipped."""
    sim = make_sim(rooms(), "none", intrinsics=None, enforce_direction_limit=True)
    sim.reset((1.0, 3.0, 0.0))
    res = sim.step(Control(1.0, 1.0, 5.0))
    th = MAX_TURN
    off = math.radians(5)
    np.testing.assert_allclose(res.pose, [1.0 + MAX_STEP * math.cos(off), 3.0 + MAX_STEP * math.sin(off), th],
                               atol=1e-12 + max(tol, angle_tol))
    assert sim.last_control.speed == MAX_STEP


def test_controls_are_clipped():
    check_controls_are_clipped(Simulator)


def check_direction_is_the_commanded_world_angle(make_sim, tol=0.0, angle_tol=0.0):
    """Contract: the move goes along the commanded world angle o, not the true heading."""
    # paper section 5: l_{t+1} = l_t + [cos(eps + o), sin(eps + o)] max(0, s + eps_s) depends on o
    # alone; the 5 deg limit is the agent's to keep against its own (estimated) heading
    sim = make_sim(rooms(), "none", intrinsics=None)
    sim.reset((1.0, 3.0, 0.0))
    o = math.radians(12.0)  # the agent believes its heading is 12 deg; the true heading is 0
    res = sim.step(Control(0.0, o, 5.0))
    np.testing.assert_allclose(res.pose, [1.0 + MAX_STEP * math.cos(o), 3.0 + MAX_STEP * math.sin(o), 0.0],
                               atol=1e-12 + max(tol, angle_tol))
    assert sim.last_control.speed == MAX_STEP and sim.last_control.turn == 0.0
    turned = sim.step(Control(1.0, 0.0, 0.0))
    assert turned.pose[2] == pytest.approx(MAX_TURN, abs=1e-12 + angle_tol)


def test_direction_is_the_commanded_world_angle_by_default():
    check_direction_is_the_commanded_world_angle(Simulator)


def check_simulator_frames_and_errors(make_sim, all_valid=True):
    """Contract: frames of the camera's size at reset and after a step; a start inside a
    solid and a malformed pose are TaskErrors. ``all_valid``: every pixel sees something in
    range from this pose (a backend with a shorter depth range may not)."""
    level = rooms()
    sim = make_sim(level, "low", seed=1, intrinsics=HALF_CAMERA)
    f = sim.reset((1.0, 1.0, 0.0))
    assert f.depth.shape == (120, 160) and f.valid.shape == (120, 160) and f.valid.any()
    assert f.valid.all() or not all_valid
    assert np.all(np.isfinite(f.depth[f.valid])) and np.all(f.depth[f.valid] > 0)
    res = sim.step(Control(0.1, 0.0, 0.1))
    assert res.frame is not None and res.frame.rgb.shape == (120, 160, 3) and res.frame.rgb.dtype == np.float32
    with pytest.raises(TaskError):
        sim.reset((1.75, 1.75, 0.0))  # inside the pillar
    with pytest.raises(TaskError):
        sim.reset((1.0, 2.0))


def test_simulator_frames_and_errors():
    check_simulator_frames_and_errors(Simulator)


def test_sample_free_points_clearance():
    level = rooms()
    pts = sample_free_points(level, np.random.default_rng(1), 300, 0.24)
    assert pts.shape == (300, 2) and distance_to_solids(level, pts).min() >= 0.24
    with pytest.raises(TaskError):
        sample_free_points(level, np.random.default_rng(1), 5, 10.0)
