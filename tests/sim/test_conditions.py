"""The paper's simulator conditions (issue 16 section 1): ViZDoom's pose quantisation (exact,
and the quantised pose is the truth from then on), both readings of the movement-direction
limit, appendix D's endpoint collision check, and their place in the cache keys."""

import math

import numpy as np
import pytest

from navbench.errors import ConfigError
from navbench.sim.conditions import (CONDITIONS, conditions_to_episode, episode_conditions, merge_conditions,
                                     parse_condition_args, quantise_pose)
from navbench.geometry import AGENT_RADIUS
from navbench.sim.dynamics import Control
from navbench.sim.world import Simulator

from .fixtures import single_wall

R = math.radians


def test_quantise_pose_by_hand():
    np.testing.assert_array_equal(quantise_pose((1.234, 2.345, R(37.6)), "round"), [1.23, 2.35, R(38)])
    np.testing.assert_array_equal(quantise_pose((1.234, 2.345, R(37.6)), "truncate"), [1.23, 2.34, R(37)])
    # headings are quantised in [0, 360) degrees: -0.4 deg is 359.6 deg, truncated to 359 = -1 deg
    np.testing.assert_array_equal(quantise_pose((1.0, 1.0, R(-0.4)), "round"), [1.0, 1.0, 0.0])
    np.testing.assert_array_equal(quantise_pose((1.0, 1.0, R(-0.4)), "truncate"), [1.0, 1.0, R(-1)])
    np.testing.assert_array_equal(quantise_pose((1.0, 1.0, R(-0.6)), "round"), [1.0, 1.0, R(-1)])
    # 2.345 is stored a hair above 2.345 (exact decimal of the double), 1.005 a hair below
    assert quantise_pose((1.005, 2.345, 0.0), "round")[:2].tolist() == [1.0, 2.35]
    np.testing.assert_array_equal(quantise_pose((0.5, 0.7, 3.0), "off"), [0.5, 0.7, 3.0])
    with pytest.raises(ConfigError, match="pose_quantisation"):
        quantise_pose((0, 0, 0), "floor")


@pytest.mark.parametrize("mode", ["round", "truncate"])
def test_quantised_poses_are_fixed_points(mode):
    """A stored grid value stays where it is (0.29 is stored an ulp below 0.29; radians(37)
    converts back to 36.99999999999999 degrees): no drift from re-quantising an unmoved pose."""
    rng = np.random.default_rng(0)
    for p in np.column_stack([rng.uniform(0, 11.4, (500, 2)), rng.uniform(-math.pi, math.pi, 500)]):
        q = quantise_pose(p, mode)
        np.testing.assert_array_equal(quantise_pose(q, mode), q)
        assert np.all(np.abs(q[:2] * 100 - np.round(q[:2] * 100)) < 1e-9)
        assert abs(math.degrees(q[2]) - round(math.degrees(q[2]))) < 1e-9
    np.testing.assert_array_equal(quantise_pose((0.29, 0.57, R(37)), "truncate"), [0.29, 0.57, R(37)])


@pytest.mark.parametrize("mode, after1, after2", [
    # step 0.1 m along 10 deg: (+0.0984808, +0.0173648) per step
    ("round", (1.10, 2.02), (1.20, 2.04)),     # 1.0985 -> 1.10; 1.10 + 0.0985 = 1.1985 -> 1.20
    ("truncate", (1.09, 2.01), (1.18, 2.02)),  # from the continuous pose it would be 1.19, 2.03
])
def test_simulator_steps_from_the_quantised_pose(mode, after1, after2):
    sim = Simulator(single_wall(x_wall=8.0), "none", intrinsics=None, pose_quantisation=mode)
    sim.reset((1.004, 2.0, R(10.3)))
    np.testing.assert_array_equal(sim.pose, [1.0, 2.0, R(10)])
    u = Control(0.0, R(10), 0.1)
    np.testing.assert_array_equal(sim.step(u).pose, [*after1, R(10)])
    np.testing.assert_array_equal(sim.step(u).pose, [*after2, R(10)])
    res = sim.step(Control(R(11.3), R(10), 0.0))  # a turn: 21.3 deg -> 21 both ways
    np.testing.assert_array_equal(res.pose, [*after2, R(21)])


def test_quantisation_off_is_the_continuous_simulator():
    a = Simulator(single_wall(x_wall=8.0), "mid", seed=3, intrinsics=None)
    b = Simulator(single_wall(x_wall=8.0), "mid", seed=3, intrinsics=None, pose_quantisation="off")
    for s in (a, b):
        s.reset((1.0, 2.0, 0.3))
    for _ in range(20):
        np.testing.assert_array_equal(a.step(Control(0.1, 0.3, 0.15)).pose, b.step(Control(0.1, 0.3, 0.15)).pose)


def test_quantised_position_touching_a_wall_is_a_collision():
    """A rounding that puts the disc into a solid is a collision (the teleported pose is checked)."""
    wall = single_wall(x_wall=3.0, thickness=0.106)  # face at x = 2.947, contact at 2.847
    sim = Simulator(wall, "none", intrinsics=None, pose_quantisation="round")
    sim.reset((2.70, 5.0, 0.0))
    res = sim.step(Control(0.0, 0.0, 0.146))  # to 2.846, free; rounds to 2.85, 0.003 m into the wall
    assert res.collided and res.pose[0] == 2.85
    free = Simulator(wall, "none", intrinsics=None, pose_quantisation="round")
    free.reset((2.70, 5.0, 0.0))
    assert not free.step(Control(0.0, 0.0, 0.142)).collided  # to 2.842 -> 2.84: free


@pytest.mark.parametrize("reading, moved_deg", [("believed", 20.0), ("true", 5.0)])
def test_direction_limit_readings(reading, moved_deg):
    """The agent believes its heading is 20 deg and commands o = 20 deg; its true heading is 0.
    believed: it moves along 20 deg; true: o is clipped to within 5 deg of the true heading."""
    ep = conditions_to_episode({"direction_limit": reading})
    sim = Simulator(single_wall(x_wall=8.0), "none", intrinsics=None, enforce_direction_limit=ep["body_fixed_drive"])
    sim.reset((1.0, 5.0, 0.0))
    pose = sim.step(Control(0.0, R(20.0), 0.1)).pose
    np.testing.assert_allclose(pose, [1.0 + 0.1 * math.cos(R(moved_deg)), 5.0 + 0.1 * math.sin(R(moved_deg)), 0.0],
                               rtol=0, atol=1e-15)


def test_endpoint_collision_teleports_then_checks():
    """Appendix D: teleport to the end of the move, collided when the disc there overlaps a solid."""
    swept = Simulator(single_wall(), "none", intrinsics=None)  # wall face at x = 2.95
    end = Simulator(single_wall(), "none", intrinsics=None, collision_check="endpoint")
    for s in (swept, end):
        s.reset((2.75, 5.0, 0.0))
    a, b = swept.step(Control(0.0, 0.0, 0.15)), end.step(Control(0.0, 0.0, 0.15))
    assert a.collided and b.collided
    assert a.pose[0] == pytest.approx(2.85, abs=1e-5) and a.pose[0] < 2.85
    assert b.pose[0] == pytest.approx(2.90)  # overlapping: the move was not checked on the way
    ok = Simulator(single_wall(), "none", intrinsics=None, collision_check="endpoint")
    ok.reset((2.70, 5.0, 0.0))
    assert not ok.step(Control(0.0, 0.0, 0.15)).collided  # ends at 2.85: touching is free


def test_condition_names_values_and_errors():
    assert set(CONDITIONS) == {"pose_quantisation", "direction_limit", "collision_check"}
    assert parse_condition_args(["pose_quantisation=round", "direction_limit = true"]) == {
        "pose_quantisation": "round", "direction_limit": "true"}
    assert conditions_to_episode({"pose_quantisation": "round", "direction_limit": "true",
                                  "collision_check": "endpoint"}) == {
        "pose_quantisation": "round", "body_fixed_drive": True, "collision_check": "endpoint"}
    for bad, msg in [("nosuch=1", "unknown condition 'nosuch'"), ("pose_quantisation", "NAME=VALUE"),
                     ("direction_limit=yes", r"must be one of \['believed', 'true'\]")]:
        with pytest.raises(ConfigError, match=msg):
            parse_condition_args([bad])
    with pytest.raises(ConfigError, match="set it in one place"):
        merge_conditions({"body_fixed_drive": True}, {"direction_limit": "believed"}, "x.toml: [conditions]")
    assert merge_conditions({"body_fixed_drive": True}, {"direction_limit": "true"}, "w") == {"body_fixed_drive": True}
    from navbench.nav.episode import EpisodeConfig

    assert episode_conditions(EpisodeConfig()) == {"pose_quantisation": "off", "direction_limit": "believed",
                                                   "collision_check": "swept"}
    assert episode_conditions({"body_fixed_drive": True})["direction_limit"] == "true"
    with pytest.raises(ConfigError, match="Simulator: condition pose_quantisation"):
        Simulator(single_wall(), "none", intrinsics=None, pose_quantisation="yes")


def test_endpoint_teleport_out_of_the_level_is_a_collision():
    """A noisy step long enough to land beyond the boundary's reach (sigma_s = 1 m) collides."""
    seed = next(k for k in range(100) if np.random.default_rng(k).standard_normal(2)[1] > 1.0)
    step = 0.16 + np.random.default_rng(seed).standard_normal(2)[1]
    sim = Simulator(single_wall(), (0.0, 1.0), seed=seed, intrinsics=None, collision_check="endpoint")
    sim.reset((0.12, 5.0, math.pi))
    res = sim.step(Control(0.0, math.pi, 0.16))
    assert res.pose[0] == pytest.approx(0.12 - step) and res.pose[0] < -AGENT_RADIUS and res.collided
