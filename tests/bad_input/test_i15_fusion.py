"""Bad input to track-eval's online map (issue 15): one ``error:`` line naming the problem."""

from __future__ import annotations

from tests.bad_input.conftest import assert_clean_error, nb


def test_online_map_refuses_an_estimator_that_ignores_the_renderer(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = nb("track-eval", "house-1", "--map", "online", "--estimators", "ours,emission",
             "--steps", "3", "--trajectories", "1", "--no-store")
    assert_clean_error(res, "--map online", "emission")
    assert not (tmp_path / "results").exists()  # refused before anything ran


def test_online_map_with_the_default_estimators_says_what_to_drop(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = nb("track-eval", "house-1", "--map", "online", "--steps", "3", "--trajectories", "1",
             "--no-store")
    assert_clean_error(res, "emission", "--estimators")


def test_a_misspelt_map_choice_is_a_missing_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = nb("track-eval", "house-1", "--map", "onlien", "--estimators", "ours", "--steps", "3",
             "--trajectories", "1", "--no-store")
    assert_clean_error(res, "--map", "onlien", "online")
