"""The bad-input probe, part "levels, task sets, and names that become paths" (issue 11).

1. a level's name becomes output paths: it must be a safe name equal to its file's stem;
2. a level is validated on load (finite, inside its box, bounded size, connected free space);
3. a task file is checked field by field and against its level before any episode runs;
4. user text printed by these commands is never taken for rich markup.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from navbench.levelio import dumps_level, level_to_dict
from navbench.plan.tasks import dumps_tasks, level_sha256, read_task_file, task_file_name

from .conftest import assert_clean_error, nb, tree_snapshot, written_outside

# The true map (voxelized geometry) and the two frameless estimators keep run-navigation fast.
TRUE_MAP_PROFILE = """
name = "tinytrue"
levels = ["tiny"]
[tasks]
count = 3
[navigation]
estimators = ["gt"]
noise = ["low"]
workers = 1
map = "true"
"""


def _tiny_doc(project: Path) -> dict:
    return json.loads((project / "levels" / "tiny.json").read_text())


def _write_level(project: Path, file_name: str, doc: dict) -> Path:
    p = project / "levels" / file_name
    p.write_text(json.dumps(doc, indent=1) + "\n")
    return p


def _snap(tmp_path: Path) -> dict:
    """One snapshot of the project and of ``tmp_path/outside`` (paths relative to tmp_path)."""
    return tree_snapshot(tmp_path)


def _outside_changes(tmp_path: Path, before: dict) -> list[str]:
    allowed = tuple(f"proj/{d}" for d in ("levels/", "tasks/", "results/"))
    return written_outside(before, _snap(tmp_path), allowed)


# ------------------------------------------------------------------ 1. names that become paths

@pytest.mark.parametrize("command", ["show-level", "sample-tasks"])
@pytest.mark.parametrize("evil", ["../../outside/x", "ABS/x", "../outside/[/x]x"])
def test_level_name_cannot_write_outside_the_project(project, tmp_path, command, evil):
    evil = evil.replace("ABS", str(tmp_path / "outside"))
    doc = _tiny_doc(project)
    doc["name"] = evil
    _write_level(project, "evil.json", doc)
    before = _snap(tmp_path)
    res = nb(command, "levels/evil.json")
    assert_clean_error(res, "levels/evil.json", "name")
    assert _outside_changes(tmp_path, before) == []
    assert not list((tmp_path / "outside").rglob("*")), "a file appeared outside the project"
    assert not (project / "tasks").exists() and not (project / "results").exists()


def test_level_file_named_after_another_level_is_refused(project, tmp_path):
    """``levels/a.json`` that calls itself ``tiny`` would write (and overwrite) tiny's task file."""
    _write_level(project, "a.json", _tiny_doc(project))
    before = _snap(tmp_path)
    res = nb("sample-tasks", "levels/a.json", "--count", "2")
    assert_clean_error(res, "levels/a.json", "name", "'tiny'")
    assert _snap(tmp_path) == before, "something was written"


@pytest.mark.parametrize("command", [("make-level", "--seed", "1"), ("show-level",), ("sample-tasks",)])
@pytest.mark.parametrize("evil", ["../../outside/x", "ABS/x"])
def test_level_name_arguments_are_safe_names(project, tmp_path, command, evil):
    evil = evil.replace("ABS", str(tmp_path / "outside"))
    before = _snap(tmp_path)
    res = nb(command[0], evil, *command[1:])
    assert_clean_error(res, "level name", "not a safe name")
    assert _snap(tmp_path) == before


def test_task_file_level_field_is_a_safe_name(project, tmp_path):
    (project / "tasks").mkdir()
    doc = json.loads(dumps_tasks("tiny", [], level_sha256("x"), 0))
    doc["level"] = "../../outside/x"
    p = project / "tasks" / "tiny-0-00000000.json"
    p.write_text(json.dumps(doc))
    (project / "tinytrue.toml").write_text(TRUE_MAP_PROFILE)
    before = _snap(tmp_path)
    res = nb("run-navigation", "--profile", "tinytrue.toml")
    assert_clean_error(res, "tasks/tiny-0-00000000.json", "level")
    assert _outside_changes(tmp_path, before) == []


# ------------------------------------------------------------------ 2. invalid levels

def _mutations():
    def far_wall(d):
        d["walls"][0]["b"] = [50.0, 0.05]

    def huge(d):
        d["walls"][0]["a"] = [1e300, 0.05]

    def nan(d):
        d["obstacles"][0]["polygon"][0] = [float("nan"), 1.0]

    def wide(d):
        d["width"] = 1e7

    def disconnected(d):  # a full-height wall across the room at x = 1: two rooms
        d["walls"].append({"a": [1.0, 0.0], "b": [1.0, 2.4], "thickness": 0.1, "texture": 0})

    def big_int(d):
        d["depth"] = 10 ** 400

    return [(far_wall, "walls[0].b"), (huge, "walls[0].a"), (nan, "obstacles[0].polygon[0]"),
            (wide, "width"), (disconnected, "connected components"), (big_int, "depth")]


@pytest.mark.parametrize("mutate, field", _mutations(), ids=lambda x: getattr(x, "__name__", x))
@pytest.mark.parametrize("command", ["show-level", "sample-tasks", "run-navigation"])
def test_invalid_level_is_refused_before_use(project, tmp_path, mutate, field, command):
    doc = _tiny_doc(project)
    mutate(doc)
    # json.dumps writes NaN and a 400-digit integer as Python's json reads them back
    (project / "levels" / "tiny.json").write_text(json.dumps(doc))
    (project / "tinytrue.toml").write_text(TRUE_MAP_PROFILE)
    before = _snap(tmp_path)
    args = ("run-navigation", "--profile", "tinytrue.toml") if command == "run-navigation" else (command, "tiny")
    res = nb(*args)
    assert_clean_error(res, "levels/tiny.json", field)
    assert _outside_changes(tmp_path, before) == []
    assert not (project / "tasks").exists()
    assert not (project / "results" / "levels").exists()


# ------------------------------------------------------------------ 3. task files

def _committed_tasks(project: Path, edit) -> Path:
    """Sample tiny's 3 tasks, let ``edit(doc)`` break them, and commit the result under tasks/."""
    res = nb("sample-tasks", "tiny", "--count", "3", "--out", str(project / "sampled"))
    assert res.code == 0, res.output
    src = next((project / "sampled").glob("tiny-3-*.json"))
    doc = json.loads(src.read_text())
    edit(doc)
    text = json.dumps(doc, indent=1) + "\n"
    (project / "tasks").mkdir(exist_ok=True)
    # a well-formed name (so the pipeline takes it for tiny's), whatever the content
    p = project / "tasks" / task_file_name("tiny", 3, text)
    p.write_text(text)
    return p


def _set(i, **kv):
    def edit(doc):
        doc["tasks"][i].update(kv)
    return edit


def _target_in_box(doc):  # the tiny level's box obstacle is [1.3, 1.7] x [1.0, 1.4]
    doc["tasks"][0].update(target_x=1.5, target_y=1.2)


def _target_outside(doc):
    doc["tasks"][1].update(target_x=7.5, target_y=1.2)


def _dup(doc):
    doc["tasks"][1]["id"] = doc["tasks"][0]["id"]


def _count(doc):
    doc["count"] = 7


def _nan(doc):
    doc["tasks"][2]["start_x"] = float("nan")


def _big_id(doc):
    doc["tasks"][0]["id"] = 2 ** 70


TASK_CASES = [
    (_target_in_box, "tasks[0].target_x"),
    (_target_outside, "tasks[1].target_x"),
    (_set(2, optimal_length=1e9), "tasks[2].optimal_length"),
    (_dup, "tasks[1].id"),
    (_count, "count"),
    (_nan, "tasks[2].start_x"),
    (_big_id, "tasks[0].id"),
]


@pytest.mark.parametrize("edit, field", TASK_CASES, ids=lambda x: getattr(x, "__name__", x))
def test_bad_committed_task_file_is_an_error_before_any_episode(project, tmp_path, edit, field):
    (project / "tinytrue.toml").write_text(TRUE_MAP_PROFILE)
    p = _committed_tasks(project, edit)
    res = nb("run-navigation", "--profile", "tinytrue.toml")
    assert_clean_error(res, f"tasks/{p.name}", field)
    from navbench.results.db import ResultsDB

    db = project / "results" / "navbench.db"
    if db.exists():  # no episode row, whatever the database's layout
        assert len(ResultsDB(f"sqlite:///{db}").episodes_frame()) == 0


def test_committed_task_file_with_bad_json_is_an_error(project):
    (project / "tinytrue.toml").write_text(TRUE_MAP_PROFILE)
    p = _committed_tasks(project, lambda d: None)
    p.write_text(p.read_text()[:-20])
    res = nb("run-navigation", "--profile", "tinytrue.toml")
    assert_clean_error(res, f"tasks/{p.name}", "not valid JSON")


def test_good_committed_task_file_is_used_and_checked_once(project):
    (project / "tinytrue.toml").write_text(TRUE_MAP_PROFILE)
    p = _committed_tasks(project, lambda d: None)
    assert p.read_text() == next((project / "sampled").glob("tiny-3-*.json")).read_text()
    first = nb("run-navigation", "--profile", "tinytrue.toml")
    assert first.code == 0, first.output
    assert f"sample-tasks: tiny from tasks/{p.name}" in first.output
    assert "verify: computing" in first.output
    second = nb("run-navigation", "--profile", "tinytrue.toml")
    assert second.code == 0, second.output
    assert "verify: computing" not in second.output and "verify: cached" in second.output
    assert read_task_file(p).count == 3


# ------------------------------------------------------------------ 4. rich markup

def test_markup_in_paths_is_printed_as_text(project, tmp_path):
    # longer than the 80 columns rich assumes for piped output: the path must stay on one line
    # (it was broken inside "[/x]" on the GPU machine, whose temporary folders are longer)
    out = tmp_path / ("outside-" + "o" * 80) / "[/x]" / "[bold]v.png"
    res = nb("show-level", "tiny", "--out", str(out))
    assert res.code == 0, res.output
    assert out.is_file()
    assert f"top view -> {out}\n" in res.out and "MarkupError" not in res.output
    d = tmp_path / "outside" / "[/y]tasks"
    res = nb("sample-tasks", "tiny", "--count", "2", "--out", str(d))
    assert res.code == 0, res.output
    assert "[/y]" in res.out.replace("\n", "")


def test_markup_in_a_level_name_is_refused_cleanly(project):
    doc = _tiny_doc(project)
    doc["name"] = "a[/x]"
    _write_level(project, "a[/x].json".replace("/", "_"), doc)
    res = nb("show-level", "levels/a[_x].json")
    assert_clean_error(res, "name")
