"""Probe cases of issue 15: scoring presets, image goals and difficulties typed wrong."""

from __future__ import annotations

import pytest

from tests.bad_input.conftest import TINY_PROFILE, assert_clean_error, nb, project  # noqa: F401
from tests.pipeline.test_db import episode


def _store(rows):
    from navbench.pipeline.db import ResultsDB

    db = ResultsDB("sqlite:///results/navbench.db")
    run = db.start_run("probe", "navbench probe", {}, "k")
    db.add_episodes(run, rows)
    db.finish_run(run)
    db.close()


@pytest.mark.parametrize("cmd", [["score"], ["report", "--out", "rep"]])
def test_unknown_preset_is_one_line_naming_the_option(project, cmd):
    _store([episode("c", 0)])
    res = nb(*cmd, "--preset", "nrn")
    assert_clean_error(res, "--preset")
    assert "nrns" in res.err and "habitat" in res.err


def test_rows_stored_before_final_distances_score_under_every_preset(project):
    _store([episode("c", 0), episode("c", 1, final_dist_m=0.5, final_geo_m=0.6)])
    for preset in ("paper", "nrns", "habitat"):
        res = nb("score", "--preset", preset, "--by-difficulty", "--boot", "20")
        assert res.code == 0, res.output
        assert f"preset {preset}" in res.out
    assert "without their final distance" in nb("score", "--preset", "nrns", "--boot", "20").err


def test_unknown_goal_is_one_line_naming_the_option(project):
    assert_clean_error(nb("run-navigation", "--profile", "tiny.toml", "--goal", "picture"), "--goal")


@pytest.mark.parametrize("extra,names", [
    ('[scoring]\npreset = "nrn"\n', ("tiny.toml", "[scoring] preset")),
    ('[scoring]\nstop = true\n', ("tiny.toml", "scoring.stop")),
    ('[navigation.episode]\nmax_steps = 600\n[scoring]\npreset = "habitat"\n', ("tiny.toml", "max_steps")),
], ids=["unknown-preset", "unknown-key", "steps-beyond-limit"])
def test_bad_scoring_table_is_one_line_naming_file_and_field(project, extra, names):
    (project / "tiny.toml").write_text(TINY_PROFILE + extra)
    assert_clean_error(nb("run-navigation", "--profile", "tiny.toml"), *names)


@pytest.mark.parametrize("value", ['["extreme"]', '["easy", "easy"]', '"easy"'])
def test_bad_difficulty_is_one_line_naming_file_and_field(project, value):
    text = TINY_PROFILE.replace("[tasks]\ncount = 3\n", f"[tasks]\ncount = 3\ndifficulty = {value}\n")
    (project / "tiny.toml").write_text(text)
    assert_clean_error(nb("run-navigation", "--profile", "tiny.toml"), "tiny.toml", "[tasks] difficulty")


def test_navigation_goal_table_typo(project):
    text = TINY_PROFILE.replace("[navigation]\n", '[navigation]\ngoal = "img"\n')
    (project / "tiny.toml").write_text(text)
    assert_clean_error(nb("run-navigation", "--profile", "tiny.toml"), "tiny.toml", "[navigation] goal")
