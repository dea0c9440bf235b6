"""Stages on tiny inputs: committed files are used by content, cache hits skip the work."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from navbench.errors import ConfigError
from navbench.level import Level, Obstacle, Texture, Wall
from navbench.levelio import save_level
from navbench.pipeline import artifacts, stages
from navbench.pipeline.cache import ArtifactStore
from navbench.pipeline.profiles import Profile, load_profile, override, profile_from_dict
from navbench.pipeline.stages import (
    LevelConfig, NavigationConfig, StageContext, TasksConfig, episode_seeds, make_cells,
    make_level_stage, sample_tasks_stage, true_map_stage,
)


def tiny_level(name: str = "tiny") -> Level:
    """A 3 m x 2.4 m closed room with one box (fast to voxelize and to sample tasks in)."""
    tex = (Texture("waves", (0.5, 0.4, 0.3), (0.2, 0.2, 0.2), ((0.5, 0.3, 0.0), (0.2, 0.9, 1.0), (1.1, 0.0, 2.0))),
           Texture("tiles", (0.3, 0.5, 0.6), (0.2, 0.15, 0.1), ((1.0, 1.0, 0.3), (0.4, 0.7, 0.5))))
    w, d, t = 3.0, 2.4, 0.1
    walls = (Wall((0.0, t / 2), (w, t / 2), t, 0), Wall((w - t / 2, 0.0), (w - t / 2, d), t, 0),
             Wall((w, d - t / 2), (0.0, d - t / 2), t, 0), Wall((t / 2, d), (t / 2, 0.0), t, 0))
    obstacles = (Obstacle(((1.3, 1.0), (1.7, 1.0), (1.7, 1.4), (1.3, 1.4)), 1.2, 1),)
    return Level(name=name, width=w, depth=d, walls=walls, obstacles=obstacles, textures=tex,
                 floor_texture=1, ceiling_texture=0, seed=0)


@pytest.fixture
def ctx(tmp_path):
    (tmp_path / "levels").mkdir()
    save_level(tiny_level(), tmp_path / "levels" / "tiny.json")
    logs: list[str] = []
    c = StageContext(ArtifactStore(tmp_path / "cache"), None, log=logs.append,
                     levels_dir=tmp_path / "levels", tasks_dir=tmp_path / "tasks")
    c.logs = logs
    return c


def test_committed_level_key_is_its_content_hash(ctx):
    import hashlib

    ref = make_level_stage(ctx, LevelConfig("tiny"))
    text = (ctx.levels_dir / "tiny.json").read_bytes()
    assert ref.key == hashlib.sha256(text).hexdigest()
    assert ref.meta["source"] == "committed"
    save_level(dataclasses.replace(tiny_level(), width=3.1), ctx.levels_dir / "tiny.json")
    assert make_level_stage(ctx, LevelConfig("tiny")).key != ref.key


def test_missing_level_is_generated_once_and_cached(ctx, monkeypatch):
    from navbench import levelgen

    calls = []

    def fake_generate(name, seed, *a, **k):
        calls.append((name, seed))
        return tiny_level(name)

    monkeypatch.setattr(levelgen, "generate_level", fake_generate)
    a = make_level_stage(ctx, LevelConfig("made-up", seed=5))
    b = make_level_stage(ctx, LevelConfig("made-up", seed=5))
    assert calls == [("made-up", 5)]
    assert a.key == b.key and a.meta["source"] == "generated" and b.cached


def test_tasks_cached_then_committed_file_is_preferred(ctx, monkeypatch):
    from navbench.plan import tasks as tasks_mod

    level = make_level_stage(ctx, LevelConfig("tiny"))
    real = tasks_mod.sample_tasks
    calls = []

    def counting(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(tasks_mod, "sample_tasks", counting)
    t1 = sample_tasks_stage(ctx, level, TasksConfig(3, 0))
    t2 = sample_tasks_stage(ctx, level, TasksConfig(3, 0))
    assert len(calls) == 1 and t1.key == t2.key and t2.cached
    # committing the same file keeps the key; the committed file is then used
    ctx.tasks_dir.mkdir()
    committed = tasks_mod.save_tasks(ctx.tasks_dir, "tiny", tasks_mod.load_tasks(t1.path),
                                     level_hash=level.key, seed=0)
    t3 = sample_tasks_stage(ctx, level, TasksConfig(3, 0))
    assert t3.path == committed and t3.key == t1.key and len(calls) == 1
    # a committed file for another seed does not match
    t4 = sample_tasks_stage(ctx, level, TasksConfig(3, 1))
    assert t4.path != committed and len(calls) == 2


def test_true_map_stage_cached(ctx):
    level = make_level_stage(ctx, LevelConfig("tiny"))
    m1 = true_map_stage(ctx, level)
    m2 = true_map_stage(ctx, level)
    assert not m1.cached and m2.cached and m1.key == m2.key
    from navbench.worldmodel.grid import load_map

    assert load_map(m2.path).occ.shape[2] == 20


def test_episode_seeds_depend_on_level_task_and_seed_only():
    k = "ab" * 32
    assert episode_seeds(k, 3, 0) == episode_seeds(k, 3, 0)
    assert episode_seeds(k, 3, 0) != episode_seeds(k, 4, 0)
    assert episode_seeds(k, 3, 0) != episode_seeds(k, 3, 1)
    assert episode_seeds(k, 3, 0) != episode_seeds("cd" * 32, 3, 0)
    sim, est = episode_seeds(k, 3, 0)
    assert sim != est and 0 <= sim < 2 ** 63


def test_cells_share_tasks_and_differ_by_estimator_noise_and_options():
    ref = stages.Ref("x", "1" * 64, None, name="tiny")
    li = stages.LevelInputs(ref, stages.Ref("m", "2" * 64, None), stages.Ref("t", "3" * 64, None))
    cfg = NavigationConfig(estimators=("gt", "dynamics"), noise=("low", "mid"))
    cells = make_cells([li], cfg)
    assert len({c.key for c in cells}) == 4
    again = make_cells([li], cfg)
    assert [c.key for c in cells] == [c.key for c in again]
    with_opts = make_cells([li], dataclasses.replace(cfg, estimator_options={"gt": {"x": 1}}))
    assert with_opts[0].key != cells[0].key and with_opts[1].key == cells[1].key
    longer = make_cells([li], dataclasses.replace(cfg, episode={"max_steps": 7}))
    assert all(a.key != b.key for a, b in zip(cells, longer))
    with pytest.raises(ConfigError):
        make_cells([li], dataclasses.replace(cfg, episode={"no_such_field": 1}))


def test_record_roundtrip(tmp_path):
    from navbench.nav.episode import EpisodeRecord

    rec = EpisodeRecord(
        level="tiny", task_id=2, estimator="gt", noise="low", seed=1, start=np.zeros(3),
        target=np.ones(2), optimal_length=1.5, true_poses=np.random.default_rng(0).random((4, 3)),
        est_poses=np.zeros((4, 3)), controls=np.zeros((3, 3)), collided=False, collision_step=-1,
        plan=np.zeros((0, 2)), replans=0, end_reason="reached",
        timings_ms={"sim": np.ones(3), "plan": np.arange(3.0)})
    artifacts.save_record(rec, tmp_path / "e.npz")
    back = artifacts.load_record(tmp_path / "e.npz")
    for f in dataclasses.fields(rec):
        a, b = getattr(rec, f.name), getattr(back, f.name)
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b)
        elif isinstance(a, dict):
            assert set(a) == set(b) and all(np.array_equal(a[k], b[k]) for k in a)
        else:
            assert a == b, f.name


def test_bundled_profiles_load_and_validate():
    quick, paper = load_profile("quick"), load_profile("paper")
    assert quick.levels == ("house-1",) and quick.camera == "half" and quick.tasks == 30
    assert quick.noise == ("mid",) and set(quick.estimators) == {"ours", "no-map", "dynamics"}
    assert len(paper.levels) == 6 and paper.views == 5000 and paper.fit_steps == 10000
    assert paper.tasks == 200 and paper.noise == ("low", "mid", "high") and paper.camera == "paper"
    six = load_profile("six")  # the paper's grid with the quick profile's budget
    assert six.levels == paper.levels and six.noise == paper.noise and six.estimators == paper.estimators
    assert (six.camera, six.views, six.fit_steps, six.tasks) == ("half", quick.views, quick.fit_steps, 30)
    assert override(quick, tasks=5, noise=["low"], workers=None).tasks == 5
    with pytest.raises(ConfigError):
        profile_from_dict({"name": "x", "tasks": {"cout": 3}})
    with pytest.raises(ConfigError):
        profile_from_dict({"name": "x", "views": {"camera": "huge"}})
    with pytest.raises(ConfigError):
        load_profile("no-such-profile")
    with pytest.raises(ConfigError):
        Profile(name="x", views_seed=1, eval_seed=1)
    p = profile_from_dict({"name": "x", "fit": {"steps": 3, "lr": 0.1}})
    assert p.fit_steps == 3 and p.fit == {"lr": 0.1}


def test_prefix_of_a_larger_committed_task_set_equals_sampling(ctx, monkeypatch):
    from navbench.plan import tasks as tasks_mod

    level = make_level_stage(ctx, LevelConfig("tiny"))
    sampled = sample_tasks_stage(ctx, level, TasksConfig(2, 0))
    ctx.tasks_dir.mkdir()
    tasks_mod.save_tasks(ctx.tasks_dir, "tiny", tasks_mod.sample_tasks(tiny_level(), 4, 0),
                         level_hash=level.key, seed=0)
    ctx.store = ArtifactStore(ctx.store.root.parent / "fresh-cache")
    monkeypatch.setattr(tasks_mod, "sample_tasks", lambda *a, **k: pytest.fail("sampled again"))
    prefixed = sample_tasks_stage(ctx, level, TasksConfig(2, 0))
    assert prefixed.key == sampled.key and not prefixed.cached
    assert any("first 2 tasks" in m for m in ctx.logs)
