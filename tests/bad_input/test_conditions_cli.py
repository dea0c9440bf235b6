"""Bad input to the paper's conditions (issue 16): run-navigation --condition, a profile's
[conditions] table and level-difficulty's arguments are one error line naming the option or
file and field, before any stage runs."""

from __future__ import annotations

import pytest

from .conftest import TINY_PROFILE, assert_clean_error, assert_usage_error, nb, tree_snapshot


@pytest.mark.parametrize("arg, names", [
    ("nosuch=1", ("--condition", "nosuch", "pose_quantisation")),
    ("pose_quantisation=yes", ("--condition", "pose_quantisation", "round")),
    ("pose_quantisation", ("--condition", "NAME=VALUE")),
    ("=round", ("--condition", "NAME=VALUE")),
    ("direction_limit=", ("--condition", "direction_limit", "believed")),
])
def test_bad_condition_option(project, tmp_path, arg, names):
    before = tree_snapshot(tmp_path)
    res = nb("run-navigation", "--profile", "tiny.toml", "--condition", arg)
    assert_clean_error(res, *names)
    assert tree_snapshot(tmp_path) == before


@pytest.mark.parametrize("table, names", [
    ('[conditions]\nnosuch = "x"\n', ("bad.toml", "[conditions]", "nosuch")),
    ('[conditions]\ncollision_check = true\n', ("bad.toml", "[conditions]", "collision_check")),
    ('conditions = "round"\n', ("bad.toml", "[conditions]", "table")),
    ('[conditions]\ndirection_limit = "believed"\n[navigation.episode]\nbody_fixed_drive = true\n',
     ("bad.toml", "[conditions]", "body_fixed_drive", "one place")),
])
def test_bad_conditions_table(project, tmp_path, table, names):
    text = TINY_PROFILE if not table.startswith("conditions =") else table + TINY_PROFILE
    if table.startswith("["):
        text = TINY_PROFILE + table
    (project / "bad.toml").write_text(text)
    before = tree_snapshot(tmp_path)
    res = nb("run-navigation", "--profile", "bad.toml")
    assert_clean_error(res, *names)
    assert tree_snapshot(tmp_path) == before


def test_level_difficulty_bad_arguments(project):
    assert_clean_error(nb("level-difficulty", "nosuch"), "nosuch")
    assert_clean_error(nb("level-difficulty", "tiny"), "tasks/tiny-")  # no task file
    assert_usage_error(nb("level-difficulty", "tiny", "--count", "0"), "--count")


def test_level_difficulty_prints_the_measures(project):
    """The positive control: with a task file the command prints one row per level."""
    import json

    assert nb("sample-tasks", "tiny", "--count", "3").code == 0
    res = nb("level-difficulty", "--json")
    assert res.code == 0, res.output
    rows = json.loads(res.out)
    assert [r["level"] for r in rows] == ["tiny"] and rows[0]["tasks"] == 3
    assert rows[0]["geodesic_ratio"] >= 1.0 and 0 < rows[0]["planner_free"] <= 1
    table = nb("level-difficulty", "tiny", "--count", "2")
    assert table.code == 0 and table.out.splitlines()[1].split()[:2] == ["tiny", "2"]


def test_run_navigation_names_the_conditions_it_ran(project):
    """A condition set on the command line reaches the episodes and is printed with the result."""
    res = nb("run-navigation", "--profile", "tiny.toml", "--map", "true", "--estimators", "gt",
             "--tasks", "1", "--condition", "pose_quantisation=round")
    assert res.code == 0, res.output
    assert "conditions: pose_quantisation=round" in res.out
    import math

    from navbench.pipeline.artifacts import TRAJ_FILE, load_record

    poses = [load_record(p).true_poses for p in (project / "results" / "cache").rglob(TRAJ_FILE)]
    assert poses, "no episode record stored"
    for x, y, a in poses[0]:  # on ViZDoom's grid: 0.01 m and whole degrees
        assert abs(x * 100 - round(x * 100)) < 1e-9 and abs(y * 100 - round(y * 100)) < 1e-9
        assert a == math.radians(round(math.degrees(a)))
