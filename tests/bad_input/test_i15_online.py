"""Bad input for ``run-navigation --map online`` (issue 15 §5): the unknown-house loop runs image
goals with the true pose only; any other combination is one ``error:`` line before any work."""

from __future__ import annotations

import pytest

from tests.bad_input.conftest import assert_clean_error, nb, tree_snapshot, written_outside


def _no_episode_ran(project, before):
    assert written_outside(before, tree_snapshot(project)) == []
    assert not (project / "results" / "cache" / "episode").exists()


@pytest.mark.parametrize("mode", ["online", "online-fused"])
def test_point_goal_with_online_map(project, mode):
    before = tree_snapshot(project)
    res = nb("run-navigation", "tiny", "--profile", "tiny.toml", "--map", mode, "--goal", "point")
    assert_clean_error(res, f"--map {mode}", "--goal image")
    _no_episode_ran(project, before)


def test_profile_point_goal_with_online_map(project):
    res = nb("run-navigation", "tiny", "--profile", "tiny.toml", "--map", "online")  # the profile: point
    assert_clean_error(res, "--map online", "--goal point")


def test_tracked_estimator_with_online_map(project):
    before = tree_snapshot(project)
    res = nb("run-navigation", "tiny", "--profile", "tiny.toml", "--map", "online", "--goal", "image",
             "--estimators", "ours,gt")
    assert_clean_error(res, "--map online", "--estimators gt", "ours,gt")
    _no_episode_ran(project, before)


def test_profile_file_with_online_map_and_its_default_estimators(project):
    text = (project / "tiny.toml").read_text().replace('workers = 1', 'workers = 1\nmap = "online"\ngoal = "image"')
    (project / "online.toml").write_text(text)
    res = nb("all", "--profile", "online.toml")  # estimators gt, dynamics in the file
    assert_clean_error(res, "--map online", "--estimators gt", "gt,dynamics")


def test_misspelt_online_map(project):
    res = nb("run-navigation", "tiny", "--profile", "tiny.toml", "--map", "onlin", "--goal", "image")
    assert_clean_error(res, "--map", "'onlin'", "online")


def test_ablation_without_online_map_is_the_only_output(project):
    """The error line is all there is: the progress display starts with its first bar, so an
    error raised after the pipeline's display was entered leaves no blank line on stdout."""
    before = tree_snapshot(project)
    res = nb("run-navigation", "tiny", "--profile", "tiny.toml", "--online-ablation", "no-goal", "--map", "fit")
    assert_clean_error(res, "--online-ablation no-goal", "--map fit")
    assert res.out == ""
    _no_episode_ran(project, before)
