"""The paper's conditions are part of the cache keys; their defaults keep the earlier keys
(issue 16 section 1). Profiles select them by name in a [conditions] table."""

from __future__ import annotations

import dataclasses

import pytest

from navbench.errors import ConfigError
from navbench.pipeline import stages
from navbench.pipeline.profiles import profile_from_dict
from navbench.pipeline.stages import NavigationConfig, make_cells, resolved_episode_config
from navbench.sim.conditions import CONDITIONS, conditions_to_episode


def _cells(episode=None):
    ref = stages.Ref("x", "1" * 64, None, name="tiny")
    li = stages.LevelInputs(ref, stages.Ref("m", "2" * 64, None), stages.Ref("t", "3" * 64, None))
    cfg = NavigationConfig(estimators=("ours", "dynamics"), noise=("low", "high"), episode=episode or {})
    return [c.key for c in make_cells([li], cfg)]


def test_default_conditions_keep_the_keys():
    # the fields hashed before the conditions existed (the golden rows test pins the stored keys)
    assert set(resolved_episode_config(NavigationConfig())) == {
        "camera", "slice_mode", "max_steps", "goal_tolerance", "max_replans", "body_fixed_drive",
        "planner", "controller"}
    base = _cells()
    defaults = {c.name: c.default for c in CONDITIONS.values()}
    assert _cells(conditions_to_episode(defaults)) == base


@pytest.mark.parametrize("name", sorted(CONDITIONS))
def test_every_other_value_changes_every_key(name):
    base = _cells()
    seen = {tuple(base)}
    for value in CONDITIONS[name].values:
        if value == CONDITIONS[name].default:
            continue
        keys = _cells(conditions_to_episode({name: value}))
        assert all(a != b for a, b in zip(base, keys))
        seen.add(tuple(keys))
    assert len(seen) == len(CONDITIONS[name].values)


def test_the_simulator_must_match_the_episode_conditions():
    import math

    from navbench.level import occupancy_raster
    from navbench.nav.episode import EpisodeConfig, run_episode
    from navbench.plan.tasks import Task
    from navbench.sim.world import Simulator
    from navbench.track.registry import make_estimator

    from tests.plan.levels import open_room

    level = open_room()
    task = Task(0, (1.0, 1.0, 0.0), (3.0, 1.0), 2.0)
    occ, xs, ys = occupancy_raster(level, 0.05)
    sim = Simulator(level, "low", seed=1, intrinsics=None, pose_quantisation="round")
    with pytest.raises(ConfigError, match="pose_quantisation"):
        run_episode(level, occ, xs, ys, task, make_estimator("gt"), sim, EpisodeConfig())
    rec = run_episode(level, occ, xs, ys, task, make_estimator("gt"), sim, EpisodeConfig(pose_quantisation="round"))
    assert rec.end_reason == "reached"
    # every recorded true pose is on ViZDoom's grid: 0.01 m and whole degrees
    for x, y, a in rec.true_poses:
        assert abs(x * 100 - round(x * 100)) < 1e-9 and abs(y * 100 - round(y * 100)) < 1e-9
        assert a == math.radians(round(math.degrees(a)))


def _doc(**sections):
    # under navbench-1 (an empty settings table): the episode table is what the sections write
    doc = {"name": "t", "levels": ["house-1"], "benchmark_version": "navbench-1"}
    doc.update(sections)
    return doc


def test_profile_conditions_table():
    p = profile_from_dict(_doc(conditions={"pose_quantisation": "round", "direction_limit": "true"}), "t.toml")
    assert p.episode == {"pose_quantisation": "round", "body_fixed_drive": True}
    p = profile_from_dict(_doc(conditions={"direction_limit": "true"},
                               navigation={"episode": {"max_steps": 100}}), "t.toml")
    assert p.episode == {"max_steps": 100, "body_fixed_drive": True}
    for conditions, episode, msg in [
        ({"nosuch": "x"}, {}, r"t.toml: \[conditions\]: unknown condition 'nosuch'"),
        ({"pose_quantisation": 1}, {}, r"t.toml: \[conditions\]: condition pose_quantisation must be one of"),
        ({"direction_limit": "believed"}, {"body_fixed_drive": True}, "set it in one place"),
    ]:
        with pytest.raises(ConfigError, match=msg):
            profile_from_dict(_doc(conditions=conditions, navigation={"episode": episode}), "t.toml")
    with pytest.raises(ConfigError, match=r"\[conditions\] must be a table"):
        profile_from_dict(_doc(conditions="round"), "t.toml")
    with pytest.raises(ConfigError, match="pose_quantisation"):
        profile_from_dict(_doc(navigation={"episode": {"pose_quantisation": "yes"}}), "t.toml")


def test_bundled_paper_profile_states_its_conditions():
    from navbench.pipeline.profiles import load_profile

    from navbench.sim.conditions import episode_conditions

    p = load_profile("paper")
    assert episode_conditions(p.episode) == {"pose_quantisation": "round", "direction_limit": "true",
                                             "collision_check": "endpoint"}
    # six states no condition: its episode table is the default version's settings alone
    from navbench.benchmark import BENCHMARK_VERSION, settings_document

    version_episode = settings_document(BENCHMARK_VERSION).get("navigation", {}).get("episode", {})
    assert dataclasses.asdict(load_profile("six"))["episode"] == version_episode
