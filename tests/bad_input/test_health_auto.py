"""Bad input to ``ours``'s health threshold and runner-up options (``-o
ours.health_min_inliers=...``, ``-o ours.relocalize_keep=...``): one ``error:`` line naming
the option and the value."""

from __future__ import annotations

import pytest

from tests.bad_input.conftest import assert_clean_error, nb


@pytest.mark.parametrize("option, value, shown", [
    ("health_min_inliers", "sometimes", "'sometimes'"), ("health_min_inliers", "1.5", "1.5"),
    ("health_min_inliers", "true", "True"), ("relocalize_keep", "abc", "'abc'"),
    ("relocalize_keep", "-2", "-2"),
])
def test_bad_health_options(tmp_path, monkeypatch, option, value, shown):
    from navbench.levelio import save_level
    from tests.track.synth import small_level

    monkeypatch.chdir(tmp_path)
    path = save_level(small_level(), tmp_path / "track-room.json")
    res = nb("track-eval", str(path), "--estimators", "ours", "--map", "true", "--steps", "2",
             "--trajectories", "1", "--no-store", "-o", "ours.health=true",
             "-o", f"ours.{option}={value}")
    assert_clean_error(res, option, shown)


def test_bad_collisions_mode_is_refused_before_anything_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = nb("track-eval", "house-1", "--estimators", "dynamics", "--steps", "3",
             "--trajectories", "1", "--no-store", "--collisions", "bounce")
    assert_clean_error(res, "--collisions", "bounce")
    assert not (tmp_path / "results").exists()


@pytest.mark.parametrize("option, shown", [
    ("ours.health_min_inliers=sometimes", "'sometimes'"), ("ours.bogus=1", "bogus"),
    ("ours.reference_scale=2", "reference_scale"), ("dynamics.x=1", "takes no options"),
    # the ranges and shapes a profile's [navigation.options.ours] gets (a one-element list
    # was a ValueError traceback; a negative pixel count was accepted)
    ("ours.prior_sigma=[0.1]", "a list of 2 numbers"), ("ours.yaw_search_pixels=-1", "-1"),
    ("ours.pixel_scale=-3", "> 0"), ("ours.seed=3", "set by the pipeline"),
])
def test_bad_option_values_are_refused_before_anything_runs(tmp_path, monkeypatch, option, shown):
    """An option's value is checked before the level is built, views collected or a map fitted
    (house-1 has no file here: a later check would have tried to build it first)."""
    monkeypatch.chdir(tmp_path)
    res = nb("track-eval", "house-1", "--estimators", "ours,dynamics", "--steps", "3",
             "--trajectories", "1", "--no-store", "-o", option)
    assert_clean_error(res, "--option", shown)
    assert not (tmp_path / "results").exists()


def test_a_profile_refuses_auto_health_for_navigation_and_names_the_field():
    """``health_min_inliers = "auto"`` is the map's calibrated threshold, which only track-eval
    computes: a profile's navigation options refuse it with the field's name (it used to fail
    as 'expected a number'); a number is accepted, and so is 'auto' given to track-eval."""
    from navbench.errors import ConfigError
    from navbench.pipeline.checks import check_estimator_options
    from navbench.pipeline.profiles import load_profile, override

    with pytest.raises(ConfigError, match=r"health_min_inliers: 'auto' .* track-eval only"):
        override(load_profile("quick"), estimator_options={"ours": {"health": True, "health_min_inliers": "auto"}})
    override(load_profile("quick"), estimator_options={"ours": {"health": True, "health_min_inliers": 0.3}})
    check_estimator_options({"ours": {"health": True, "health_min_inliers": "auto"}}, "--option")
    with pytest.raises(ConfigError, match=r"^--option ours: health_min_inliers must be a number"):
        check_estimator_options({"ours": {"health_min_inliers": "often"}}, "--option")
