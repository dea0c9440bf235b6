"""The committed benchmark task sets match the committed levels and respect the constraints."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from navbench.level import distance_to_solids
from navbench.levelio import load_level
from navbench.plan.tasks import level_sha256, read_task_file, task_file_name, dumps_tasks

ROOT = Path(__file__).resolve().parents[2]
TASK_FILES = sorted((ROOT / "tasks").glob("*.json"))


@pytest.mark.parametrize("path", TASK_FILES, ids=[p.stem for p in TASK_FILES])
def test_task_file_matches_its_level(path):
    ts = read_task_file(path)
    level_file = ROOT / "levels" / f"{ts.level}.json"
    assert level_sha256(level_file.read_text()) == ts.level_sha256, (
        f"{path.name} was sampled from an older {level_file.name}: delete it and run "
        f"`navbench sample-tasks {ts.level}`")
    assert ts.count == 200 and ts.seed == 0
    assert path.name == task_file_name(ts.level, ts.count, path.read_text())
    assert dumps_tasks(ts.level, ts.tasks, ts.level_sha256, ts.seed) == path.read_text()
    level = load_level(level_file)
    starts = np.array([t.start[:2] for t in ts.tasks])
    targets = np.array([t.target for t in ts.tasks])
    # 1e-6: the file rounds coordinates to 1e-6 m
    assert distance_to_solids(level, starts).min() >= 0.24 - 1e-6
    assert distance_to_solids(level, targets).min() >= 0.24 - 1e-6
    assert np.linalg.norm(targets - starts, axis=1).min() > 0.6 - 1e-6
    lengths = np.array([t.optimal_length for t in ts.tasks])
    assert np.all(lengths >= np.linalg.norm(targets - starts, axis=1) - 1e-5)


def test_one_task_file_per_level():
    levels = [read_task_file(p).level for p in TASK_FILES]
    assert len(levels) == len(set(levels))


@pytest.mark.parametrize("path", TASK_FILES, ids=[p.stem for p in TASK_FILES])
def test_committed_task_set_passes_the_level_check(path):
    """What the pipeline checks before any episode: free points, exact optimal lengths."""
    from navbench.plan.tasks import check_tasks_on_level

    ts = read_task_file(path)
    check_tasks_on_level(load_level(ROOT / "levels" / f"{ts.level}.json"), ts.tasks, str(path))
