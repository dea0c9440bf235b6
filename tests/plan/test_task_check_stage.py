"""The stage layer checks a task set against its level once, before any episode."""

from __future__ import annotations

import json

import pytest

from navbench.errors import LevelError, TaskError
from navbench.pipeline.cache import ArtifactStore
from navbench.pipeline.stages import (LevelConfig, StageContext, TasksConfig, committed_task_file,
                                      make_level_stage, sample_tasks_stage)
from navbench.plan.tasks import dumps_tasks, read_task_file, task_file_name
from tests.pipeline.test_stages import tiny_level
from navbench.levelio import save_level


@pytest.fixture
def ctx(tmp_path):
    (tmp_path / "levels").mkdir()
    save_level(tiny_level(), tmp_path / "levels" / "tiny.json")
    logs: list[str] = []
    c = StageContext(ArtifactStore(tmp_path / "cache"), None, log=logs.append,
                     levels_dir=tmp_path / "levels", tasks_dir=tmp_path / "tasks")
    c.logs = logs
    return c


def _commit(ctx, ts, edit=lambda d: None):
    doc = json.loads(dumps_tasks(ts.level, ts.tasks, ts.level_sha256, ts.seed))
    edit(doc)
    text = json.dumps(doc, indent=1) + "\n"
    ctx.tasks_dir.mkdir(exist_ok=True)
    p = ctx.tasks_dir / task_file_name("tiny", len(doc["tasks"]), text)
    p.write_text(text)
    return p


def test_sampled_and_committed_sets_are_checked_once(ctx):
    level = make_level_stage(ctx, LevelConfig("tiny"))
    ref = sample_tasks_stage(ctx, level, TasksConfig(3, 0))
    assert sum("verify: computing" in m for m in ctx.logs) == 2  # the level and the task set
    ctx.logs.clear()
    p = _commit(ctx, read_task_file(ref.path))
    again = sample_tasks_stage(ctx, level, TasksConfig(3, 0))
    assert again.path == p and again.key == ref.key  # same text: same key, the check is cached
    assert any("verify: cached" in m for m in ctx.logs)
    assert not any("verify: computing" in m for m in ctx.logs)


def test_a_bad_committed_set_fails_before_use(ctx):
    level = make_level_stage(ctx, LevelConfig("tiny"))
    ts = read_task_file(sample_tasks_stage(ctx, level, TasksConfig(3, 0)).path)
    p = _commit(ctx, ts, lambda d: d["tasks"][1].update(optimal_length=1e9))
    with pytest.raises(TaskError, match=rf"^{p}: tasks\[1\].optimal_length"):
        sample_tasks_stage(ctx, level, TasksConfig(3, 0))


def test_malformed_or_mislabelled_committed_files_are_errors(ctx):
    level = make_level_stage(ctx, LevelConfig("tiny"))
    ts = read_task_file(sample_tasks_stage(ctx, level, TasksConfig(3, 0)).path)
    p = _commit(ctx, ts)
    p.write_text(p.read_text()[:-10])
    with pytest.raises(TaskError, match="not valid JSON"):
        committed_task_file(ctx.tasks_dir, level, TasksConfig(3, 0))
    p.unlink()
    p = _commit(ctx, ts, lambda d: d.update(level="other"))
    with pytest.raises(TaskError, match="says 'other'"):
        committed_task_file(ctx.tasks_dir, level, TasksConfig(3, 0))
    p.unlink()
    # a file for an older version of the level is not an error: it is not this level's set
    _commit(ctx, ts, lambda d: d.update(level_sha256="0" * 64))
    # nor is a file that only starts like this level's name (tiny-extra's)
    (ctx.tasks_dir / "tiny-extra-3-00000000.json").write_text("{")
    assert committed_task_file(ctx.tasks_dir, level, TasksConfig(3, 0)) is None


def test_committed_level_is_checked_and_unsafe_names_refused(ctx):
    with pytest.raises(LevelError, match="not a safe name"):
        make_level_stage(ctx, LevelConfig("../tiny"))
    doc = json.loads((ctx.levels_dir / "tiny.json").read_text())
    doc["walls"].append({"a": [1.0, 0.0], "b": [1.0, 2.4], "thickness": 0.1, "texture": 0})
    (ctx.levels_dir / "tiny.json").write_text(json.dumps(doc))
    with pytest.raises(LevelError, match="connected components"):
        make_level_stage(ctx, LevelConfig("tiny"))


def test_generated_level_is_loaded_from_the_cache_under_its_name(ctx, monkeypatch):
    """A generated level is cached as ``level.json``: it loads under its own name."""
    from navbench import levelgen
    from navbench.levelio import load_level
    from navbench.pipeline.stages import load_level_ref

    monkeypatch.setattr(levelgen, "generate_level", lambda name, seed, *a, **k: tiny_level(name))
    ref = make_level_stage(ctx, LevelConfig("made-up", seed=5))
    assert ref.path.name == "level.json"
    assert load_level_ref(ref).name == "made-up" == load_level(ref.path).name
    tasks = sample_tasks_stage(ctx, ref, TasksConfig(2, 0))
    assert read_task_file(tasks.path).level == "made-up"
