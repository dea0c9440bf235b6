"""Bad input to `navbench all --condition` (issue 16): one error line naming the option before
any stage runs; and the positive control, a tiny pipeline under a changed condition whose
tables state it and whose episodes never pool with the default run's."""

from __future__ import annotations

import json

import pytest

from .conftest import assert_clean_error, nb, tree_snapshot


@pytest.mark.parametrize("arg, names", [
    ("nosuch=1", ("--condition", "nosuch", "pose_quantisation")),
    ("pose_quantisation=yes", ("--condition", "pose_quantisation", "round")),
    ("pose_quantisation", ("--condition", "NAME=VALUE")),
    ("=round", ("--condition", "NAME=VALUE")),
    ("direction_limit=", ("--condition", "direction_limit", "believed")),
    ("collision_check=Endpoint", ("--condition", "collision_check", "endpoint")),
])
def test_bad_condition_option(project, tmp_path, arg, names):
    before = tree_snapshot(tmp_path)
    res = nb("all", "--profile", "tiny.toml", "--condition", arg)
    assert_clean_error(res, *names)
    assert tree_snapshot(tmp_path) == before


def test_condition_without_a_value_and_a_bad_profile(project, tmp_path):
    before = tree_snapshot(tmp_path)
    res = nb("all", "--profile", "tiny.toml", "--condition")  # click: one line, exit 2
    assert res.code == 2 and "Traceback" not in res.output and "--condition" in res.err
    assert len(res.err.strip().splitlines()) <= 12
    assert_clean_error(nb("all", "--profile", "nosuch.toml", "--condition", "direction_limit=true"),
                       "nosuch.toml")
    assert tree_snapshot(tmp_path) == before


def test_all_under_a_condition_states_it_and_keeps_it_apart(project):
    """`all --condition direction_limit=true` runs the grid under the true-heading limit: the
    run records it, the printed tables and the report state it; the default run afterwards
    makes new cells, and `score` over both shows each condition in its own rows."""
    # the default version (navbench-5) names its episode camera's texel tables after the conditions
    true_limit = "pose_quantisation=off, direction_limit=true, collision_check=swept, texture=table"
    defaults = "pose_quantisation=off, direction_limit=believed, collision_check=swept, texture=table"
    res = nb("all", "--profile", "tiny.toml", "--condition", "direction_limit=true", "--report", "rep")
    assert res.code == 0, res.output
    assert true_limit in " ".join(res.out.split())
    page = (project / "rep" / "index.html").read_text()
    assert f"conditions: {true_limit}" in page and defaults not in page
    res = nb("all", "--profile", "tiny.toml", "--report", "rep")
    assert res.code == 0, res.output
    assert f"conditions: {defaults}" in " ".join(res.out.split())
    assert true_limit not in " ".join(res.out.split())  # this run's cells only
    res = nb("score", "--format", "json", "--boot", "50")
    assert res.code == 0, res.output
    rows = json.loads(res.out)["scores"]
    by = {}
    for r in rows:
        by.setdefault((r["level"], r["estimator"], r["noise"]), []).append((r["conditions"], r["episodes"]))
    assert by and all(sorted(v) == sorted([(true_limit, 3), (defaults, 3)]) for v in by.values())
    assert all(r["setups"] == 1 for r in rows)
