"""Task sampling constraints, determinism, and the task file format."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from navbench.errors import TaskError
from navbench.level import distance_to_solids
from navbench.plan.tasks import (Task, dumps_tasks, load_tasks, read_task_file, sample_tasks,
                                 save_tasks, task_file_name)

from .levels import door_rooms, two_rooms


@pytest.fixture(scope="module")
def door_tasks():
    return sample_tasks(door_rooms(), count=12, seed=3)


def test_sampled_tasks_respect_the_constraints(door_tasks):
    level = door_rooms()
    assert [t.id for t in door_tasks] == list(range(12))
    starts = np.array([t.start[:2] for t in door_tasks])
    targets = np.array([t.target for t in door_tasks])
    assert np.all(distance_to_solids(level, starts) >= 0.24)
    assert np.all(distance_to_solids(level, targets) >= 0.24)
    assert np.all(np.linalg.norm(targets - starts, axis=1) > 0.6)
    assert all(-math.pi <= t.start[2] < math.pi for t in door_tasks)
    # the optimal length is never shorter than the straight line
    assert all(t.optimal_length >= math.dist(t.start[:2], t.target) - 1e-9 for t in door_tasks)
    # a task crossing the door is longer than the straight line
    crossing = [t for t in door_tasks if (t.start[0] - 3) * (t.target[0] - 3) < 0]
    assert crossing and any(t.optimal_length > math.dist(t.start[:2], t.target) + 1e-3 for t in crossing)


def test_sampling_is_deterministic_in_the_seed(door_tasks):
    assert sample_tasks(door_rooms(), count=12, seed=3) == door_tasks
    assert sample_tasks(door_rooms(), count=12, seed=4) != door_tasks


def test_disconnected_rooms_give_only_reachable_tasks():
    tasks = sample_tasks(two_rooms(), count=8, seed=0)
    for t in tasks:  # start and target always on the same side of the dividing wall at x = 3
        assert (t.start[0] - 3) * (t.target[0] - 3) > 0


def test_round_trip_and_file_name(tmp_path, door_tasks):
    path = save_tasks(tmp_path, "door-rooms", door_tasks, level_hash="ab" * 32, seed=3)
    text = path.read_text()
    assert path.name == task_file_name("door-rooms", 12, text)
    assert path.name.startswith("door-rooms-12-") and len(path.stem.split("-")[-1]) == 8
    ts = read_task_file(path)
    assert ts.level == "door-rooms" and ts.seed == 3 and ts.level_sha256 == "ab" * 32 and ts.count == 12
    loaded = load_tasks(path)
    for a, b in zip(loaded, door_tasks):
        assert a.id == b.id
        np.testing.assert_allclose(a.start, b.start, atol=1e-6)
        np.testing.assert_allclose(a.target, b.target, atol=1e-6)
        assert a.optimal_length == pytest.approx(b.optimal_length, abs=1e-6)
    # the text is deterministic
    assert dumps_tasks("door-rooms", door_tasks, "ab" * 32, 3) == text


def _write(tmp_path, doc):
    p = tmp_path / "t.json"
    p.write_text(json.dumps(doc))
    return p


@pytest.mark.parametrize("mutate, field", [
    (lambda d: d["tasks"][0].pop("target_y"), "tasks[0].target_y"),
    (lambda d: d["tasks"][1].__setitem__("start_x", "1.0"), "tasks[1].start_x"),
    (lambda d: d["tasks"][0].__setitem__("optimal_length", -1.0), "tasks[0].optimal_length"),
    (lambda d: d["tasks"][1].__setitem__("id", 0), "tasks[1].id"),
    (lambda d: d.__setitem__("count", 5), "count"),
    (lambda d: d.__setitem__("version", 99), "version"),
    (lambda d: d.pop("level"), "level"),
    (lambda d: d.__setitem__("level", "../../x"), "level"),
    (lambda d: d["tasks"][1].__setitem__("id", 2 ** 70), "tasks[1].id"),
    (lambda d: d["tasks"][1].__setitem__("id", 2 ** 63), "tasks[1].id"),
    (lambda d: d["tasks"][0].__setitem__("start_y", 10 ** 400), "tasks[0].start_y"),
    (lambda d: d["tasks"][0].__setitem__("optimal_length", float("nan")), "tasks[0].optimal_length"),
    (lambda d: d.__setitem__("count", True), "count"),
    (lambda d: d.__setitem__("count", 2.0), "count"),
    (lambda d: d.__setitem__("agent_length", 0.5), "agent_length"),
])
def test_malformed_files_name_the_field(tmp_path, mutate, field):
    tasks = [Task(0, (1.0, 1.0, 0.0), (2.0, 2.0), 1.5), Task(1, (2.0, 1.0, 0.5), (3.0, 2.5), 2.0)]
    doc = json.loads(dumps_tasks("lv", tasks, "", 0))
    mutate(doc)
    with pytest.raises(TaskError, match=field.replace("[", r"\[").replace("]", r"\]")):
        load_tasks(_write(tmp_path, doc))


def test_missing_and_invalid_json(tmp_path):
    with pytest.raises(TaskError, match="no such task file"):
        load_tasks(tmp_path / "nope.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(TaskError, match="not valid JSON"):
        load_tasks(bad)


def test_largest_task_id_is_accepted(tmp_path):
    tasks = [Task(2 ** 63 - 1, (1.0, 1.0, 0.0), (2.0, 2.0), 1.5)]
    assert load_tasks(_write(tmp_path, json.loads(dumps_tasks("lv", tasks, "", 0))))[0].id == 2 ** 63 - 1


# ------------------------------------------------------------- a task set checked on its level

def test_sampled_tasks_pass_the_level_check(door_tasks, tmp_path):
    """Sampled tasks, stored (rounded to 1e-6) and read back, pass check_tasks_on_level."""
    from navbench.plan.tasks import check_tasks_on_level

    check_tasks_on_level(door_rooms(), door_tasks)
    path = save_tasks(tmp_path, "door-rooms", door_tasks, seed=3)
    check_tasks_on_level(door_rooms(), load_tasks(path), str(path))


@pytest.mark.parametrize("change, field", [
    (dict(target=(4.75, 0.75)), "tasks[2].target_x"),            # inside the low box
    (dict(target=(2.95, 1.0)), "tasks[2].target_x"),             # inside the inner wall
    (dict(start=(0.1, 2.0, 0.0)), "tasks[2].start_x"),           # closer than 1.2 L to a wall
    (dict(start=(-3.0, 2.0, 0.0)), "tasks[2].start_x"),          # outside the level
    (dict(target=(2.0, 99.0)), "tasks[2].target_x"),             # outside the level
    (dict(optimal_length=1e9), "tasks[2].optimal_length"),
    ("short", "tasks[2].optimal_length"),
])
def test_level_check_names_the_bad_task(door_tasks, change, field):
    import dataclasses

    from navbench.plan.tasks import LENGTH_TOLERANCE, check_tasks_on_level

    tasks = list(door_tasks)
    if change == "short":  # off by just more than the tolerance
        change = dict(optimal_length=tasks[2].optimal_length - 3 * LENGTH_TOLERANCE)
    tasks[2] = dataclasses.replace(tasks[2], **change)
    with pytest.raises(TaskError, match=r"^src: " + field.replace("[", r"\[").replace("]", r"\]")):
        check_tasks_on_level(door_rooms(), tasks, "src")


def test_level_check_refuses_unreachable_targets():
    """On two_rooms each room is free but the target room cannot be reached."""
    from navbench.plan.tasks import check_tasks_on_level

    with pytest.raises(TaskError, match=r"tasks\[0\]: target not reachable"):
        check_tasks_on_level(two_rooms(), [Task(0, (1.0, 2.0, 0.0), (5.0, 2.0), 4.0)], "src")
