"""The gymnasium point-goal environment: API conformance, determinism, rewards and termination."""

import math

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from navbench.errors import TaskError
from navbench.geometry import AGENT_LENGTH, Intrinsics
from navbench.level import distance_to_solids
from navbench.sim.dynamics import MAX_STEP
from navbench.sim.env import PointNavEnv

from .fixtures import rooms, single_wall

SMALL = Intrinsics(32, 24, 15.0, 15.0, 16.0, 12.0)


def test_check_env_passes():
    env = PointNavEnv(rooms(), noise="low", intrinsics=SMALL, max_steps=20, seed=0)
    check_env(env.unwrapped, skip_render_check=True)
    env = PointNavEnv(rooms(), noise="mid", intrinsics=None, max_steps=20, seed=0)
    check_env(env.unwrapped, skip_render_check=True)


def test_sampled_tasks_respect_clearance_and_distance():
    level = rooms()
    env = PointNavEnv(level, intrinsics=None, seed=3)
    for _ in range(30):
        obs, info = env.reset()
        start = info["pose"][:2]
        assert distance_to_solids(level, np.stack([start, env.goal])).min() >= 1.2 * AGENT_LENGTH
        assert np.hypot(*(env.goal - start)) > 3 * AGENT_LENGTH
        assert obs["goal"][0] == pytest.approx(info["distance"], abs=1e-5)


def test_same_seed_same_episode():
    def run(seed):
        env = PointNavEnv(rooms(), noise="high", intrinsics=SMALL, seed=seed)
        obs, _ = env.reset()
        out = [obs["goal"].copy()]
        rng = np.random.default_rng(0)
        for _ in range(15):
            obs, r, term, trunc, info = env.step(rng.uniform(env.action_space.low, env.action_space.high))
            out.append(np.concatenate([obs["goal"], [r], info["pose"], [obs["depth"].sum()]]))
            if term:
                break
        return out

    a, b, c = run(5), run(5), run(6)
    assert all(np.array_equal(x, y) for x, y in zip(a, b)) and len(a) == len(b)
    assert not np.array_equal(a[0], c[0])


def test_reward_goal_and_success_on_given_task():
    level = rooms()
    start, goal = (1.0, 3.0, 0.0), (2.0, 3.0)
    env = PointNavEnv(level, noise="none", intrinsics=SMALL, tasks=[(start, goal)], max_steps=50)
    obs, info = env.reset(seed=0)
    np.testing.assert_allclose(obs["goal"], [1.0, 0.0], atol=1e-6)
    assert obs["rgb"].dtype == np.uint8 and obs["depth"].max() <= env.max_range
    total = 0.0
    steps = 0
    while True:
        obs, r, term, trunc, info = env.step(np.array([0.0, 0.0, MAX_STEP], np.float32))
        total += r
        steps += 1
        assert r == pytest.approx(MAX_STEP, abs=1e-6)  # straight at the goal, no noise
        if term or trunc:
            break
    assert term and info["success"] and not info["collided"]
    assert steps == math.ceil((1.0 - 2 * AGENT_LENGTH) / MAX_STEP + 1e-9)
    assert total == pytest.approx(1.0 - info["distance"], abs=1e-9)
    # goal to the left: bearing +90 degrees
    env = PointNavEnv(level, noise="none", intrinsics=None, tasks=[((1.0, 3.0, 0.0), (1.0, 4.0))])
    obs, _ = env.reset(seed=0)
    np.testing.assert_allclose(obs["goal"], [1.0, math.pi / 2], atol=1e-6)


def test_collision_terminates_and_truncation():
    env = PointNavEnv(single_wall(), noise="none", intrinsics=None,
                      tasks=[((2.6, 5.0, 0.0), (1.0, 1.0))], max_steps=3)
    env.reset(seed=0)
    _, _, term, trunc, info = env.step(np.array([0.0, 0.0, MAX_STEP], np.float32))
    assert not term and not trunc
    _, _, term, trunc, info = env.step(np.array([0.0, 0.0, MAX_STEP], np.float32))
    assert term and info["collided"] and not trunc  # face at 2.95: stops at 2.85
    env.reset(seed=0)
    for k in range(3):
        _, _, term, trunc, _ = env.step(np.zeros(3, np.float32))
    assert trunc and not term


def test_bad_tasks_raise():
    with pytest.raises(TaskError):
        PointNavEnv(rooms(), intrinsics=None, tasks=[])
    with pytest.raises(TaskError):
        PointNavEnv(rooms(), intrinsics=None, tasks=[(1.0, 2.0, 3.0)])


def test_registered_with_gymnasium(tmp_path, monkeypatch):
    """``gymnasium.make("navbench/PointNav-v0", level=...)`` after ``import navbench.envs``, by
    level object and by name (levels/NAME.json of the working directory); depth is (H, W, 1)."""
    import gymnasium as gym

    import navbench.envs  # noqa: F401
    from navbench.levelio import save_level

    env = gym.make("navbench/PointNav-v0", level=rooms(), intrinsics=SMALL, noise="low", seed=0)
    obs, info = env.reset()
    assert obs["depth"].shape == (SMALL.height, SMALL.width, 1)
    assert env.observation_space["depth"].shape == (SMALL.height, SMALL.width, 1)
    assert obs["rgb"].shape == (SMALL.height, SMALL.width, 3)
    direct = PointNavEnv(rooms(), intrinsics=SMALL, noise="low", seed=0)
    obs2, _ = direct.reset()
    np.testing.assert_array_equal(obs["depth"], obs2["depth"])
    np.testing.assert_array_equal(obs["rgb"], obs2["rgb"])  # -v0: navbench-1's procedural textures
    # -v1, the current version's (navbench-5): the camera's texel tables; texture= still chooses
    assert navbench.envs.ENV_ID == "navbench/PointNav-v1"
    obs_v1, _ = gym.make("navbench/PointNav-v1", level=rooms(), intrinsics=SMALL, noise="low", seed=0).reset()
    table, _ = PointNavEnv(rooms(), intrinsics=SMALL, noise="low", seed=0, texture="table").reset()
    np.testing.assert_array_equal(obs_v1["rgb"], table["rgb"])
    np.testing.assert_array_equal(obs_v1["depth"], obs2["depth"])  # the same depth, other colours
    assert not np.array_equal(obs_v1["rgb"], obs2["rgb"])
    chosen, _ = gym.make("navbench/PointNav-v1", level=rooms(), intrinsics=SMALL, noise="low", seed=0,
                         texture="procedural").reset()
    np.testing.assert_array_equal(chosen["rgb"], obs2["rgb"])

    (tmp_path / "levels").mkdir()
    save_level(rooms(), tmp_path / "levels" / f"{rooms().name}.json")
    monkeypatch.chdir(tmp_path)
    env = gym.make("navbench/PointNav-v0", level=rooms().name, intrinsics=None, seed=1)
    obs, _ = env.reset()
    assert set(obs) == {"goal"}


def test_each_registered_id_has_one_texture():
    """The accepted versions sharing a Gymnasium id share their camera's texture mode (the id's
    suffix follows the images)."""
    from navbench import benchmark
    from navbench.envs import ENV_TEXTURES

    for v, gid in benchmark.GYM_IDS.items():
        if v not in benchmark.CANDIDATES:
            assert benchmark.version_settings(v).get("navigation.episode.texture", "procedural") == ENV_TEXTURES[gid], v
    assert set(ENV_TEXTURES) == {"navbench/PointNav-v0", "navbench/PointNav-v1"}


def test_module_prefixed_id_registers_itself():
    import subprocess
    import sys

    code = ("import gymnasium as gym\n"
            "from navbench.geometry import Intrinsics\n"
            "from tests.sim.fixtures import rooms\n"
            "env = gym.make('navbench.envs:navbench/PointNav-v0', level=rooms(), intrinsics=None)\n"
            "print(env.spec.id)\n")
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=root)
    assert out.stdout.strip() == "navbench/PointNav-v0"
