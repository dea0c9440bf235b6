"""Probe cases of issue 15: scoring presets, image goals and difficulties typed wrong."""

from __future__ import annotations

import pytest

from tests.bad_input.conftest import TINY_PROFILE, assert_clean_error, nb, project  # noqa: F401
from tests.pipeline.test_db import episode


def _store(rows):
    from navbench.results.db import ResultsDB

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


@pytest.mark.parametrize("value,says", [
    ('{ acept = 2.0 }', "acept"), ('{ k = 3 }', "k:"), ('{ accept = "high" }', "accept"),
    ('{ max_candidates = -1 }', "max_candidates"), ('3', "table")],
    ids=["unknown-field", "k", "type", "negative", "not-a-table"])
def test_bad_goal_localizer_is_one_line_naming_file_and_field(project, value, says):
    text = TINY_PROFILE.replace("[navigation]\n", f'[navigation]\ngoal = "image"\ngoal_localizer = {value}\n')
    (project / "tiny.toml").write_text(text)
    res = nb("run-navigation", "--profile", "tiny.toml")
    assert_clean_error(res, "tiny.toml", "[navigation] goal_localizer", says)
    assert not (project / "results").exists()  # refused before any stage ran


def test_goal_localizer_reaches_the_goal_search_and_its_key():
    """``[navigation] goal_localizer`` overrides the image-goal stage's LocalizerConfig (k stays
    the stage's 2); none keeps the image-goal config as it was (the keys also hold the resolved
    localiser since 2026-11-26: tests/pipeline/test_image_goals.py)."""
    import dataclasses

    from navbench.pipeline.profiles import profile_from_dict
    from navbench.pipeline.stages.goals import ImageGoalConfig
    from navbench.config import config_hash

    doc = {"name": "g", "navigation": {"goal": "image",
                                       "goal_localizer": {"accept": 2.0, "max_candidates": 64}}}
    p = profile_from_dict(doc, "g.toml")
    cfg = ImageGoalConfig(camera=p.camera, localizer=dict(p.goal_localizer))
    lc = cfg.localizer_config()
    assert (lc.accept, lc.max_candidates, lc.k) == (2.0, 64, 2)
    plain = profile_from_dict({"name": "g", "navigation": {"goal": "image"}}, "g.toml")
    assert plain.goal_localizer == {}
    assert config_hash(ImageGoalConfig(camera=plain.camera, localizer=dict(plain.goal_localizer))) \
        == config_hash(ImageGoalConfig(camera=plain.camera))
    assert config_hash(cfg) != config_hash(dataclasses.replace(cfg, localizer={}))
