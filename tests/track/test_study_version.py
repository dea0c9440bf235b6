"""``track-eval --benchmark-version`` (issue 36 §3): a version's settings reach the tracking
study's frames (the camera's texture mode) and trackers (their options), its key and its rows;
``navbench-1`` keeps every key it had."""

from __future__ import annotations

import json

import pytest

from navbench import benchmark
from navbench.pipeline.stages.track_eval import study_key_config
from navbench.track.study import TrackingStudyConfig
from tests.bad_input.conftest import assert_clean_error, nb

#: The key config of the default study before versions reached track-eval (every field of the
#: config of then; tests/pipeline/test_sim_choice.py pins the key it hashes to).
_V1_FIELDS = {"trajectories", "seeds", "steps", "estimators", "camera", "camera_height", "noise",
              "seed", "waypoint_clearance", "waypoint_range", "estimator_options", "trajectory_limits"}


def test_navbench_1_adds_nothing_to_the_study_key():
    plain = study_key_config(TrackingStudyConfig())
    assert set(plain) == _V1_FIELDS
    assert study_key_config(TrackingStudyConfig(benchmark_version="navbench-1",
                                                texture="procedural")) == plain


def test_navbench_2_changes_the_study_key_where_it_changes_results():
    from navbench.pipeline.versioning import study_settings

    texture, opts = study_settings("navbench-2", ("ours", "no-map", "dynamics"))
    assert texture == "table" and set(opts) == {"ours", "no-map"}  # dynamics reads no frame
    v2 = study_key_config(TrackingStudyConfig(benchmark_version="navbench-2", texture=texture,
                                              estimator_options=opts))
    plain = study_key_config(TrackingStudyConfig())
    assert v2 != plain
    assert v2["benchmark"] == "navbench-2" and v2["texture"] == "table"
    assert v2["estimator_options"]["ours"]["gn_tol"] == [5e-4, 5e-4]
    # the mapping is the version's table, read through the profile machinery run-navigation uses
    for key, value in benchmark.VERSION_SETTINGS["navbench-2"].items():
        if key.startswith("navigation.options."):
            _, _, est, opt = key.split(".")
            assert opts[est][opt] == value
    assert study_settings("navbench-1", ("ours", "no-map")) == ("procedural", {})


@pytest.fixture
def spied(monkeypatch):
    """Spies on the camera's texture mode and the estimators' keyword arguments: a dict with
    the ``textures`` and ``kwargs`` (by estimator) of the study run last (:func:`_study`)."""
    from navbench.sim import camera as camera_mod
    from navbench.track import registry

    seen = {"textures": [], "kwargs": {}}
    real_init, real_make = camera_mod.RaycastCamera.__init__, registry.make_estimator

    def init(self, *a, **k):
        seen["textures"].append(k.get("texture", "procedural"))
        real_init(self, *a, **k)

    def make(name, **k):
        seen["kwargs"][name] = k
        return real_make(name, **k)

    monkeypatch.setattr(camera_mod.RaycastCamera, "__init__", init)
    monkeypatch.setattr(registry, "make_estimator", make)
    return seen


def _study(tmp_path, monkeypatch, spied, *extra):
    """A 1 x 2-step study on a small room (true map), its rows in ``r.db``; returns (its JSON,
    the camera texture modes, the estimators' keyword arguments by name)."""
    from navbench.levelio import save_level
    from tests.track.synth import small_level

    monkeypatch.chdir(tmp_path)
    path = tmp_path / "track-room.json"
    if not path.exists():
        save_level(small_level(), path)
    spied["textures"], spied["kwargs"] = [], {}
    res = nb("track-eval", str(path), "--map", "true", "--estimators", "no-map,dynamics",
             "--trajectories", "1", "--steps", "2", "--json", "--db", f"sqlite:///{tmp_path / 'r.db'}",
             *extra)
    assert res.code == 0, res.output
    return json.loads(res.out), spied["textures"], spied["kwargs"]


def test_navbench_2_reaches_the_frames_the_trackers_the_key_and_the_rows(tmp_path, monkeypatch, spied):
    v1, tex1, kw1 = _study(tmp_path, monkeypatch, spied, "--benchmark-version", "navbench-1")
    v2, tex2, kw2 = _study(tmp_path, monkeypatch, spied, "--benchmark-version", "navbench-2")
    assert v1["meta"]["benchmark_version"] == "navbench-1" and tex1 == ["procedural"]
    assert "gn_tol" not in kw1["no-map"]
    assert v2["meta"]["benchmark_version"] == "navbench-2" and tex2 == ["table"]
    fixed = benchmark.VERSION_SETTINGS["navbench-2"]
    for opt in ("gn_tol", "gn_geo_tol", "yaw_search_turn_deg"):
        assert kw2["no-map"][opt] == fixed[f"navigation.options.no-map.{opt}"]
    assert not {"gn_tol", "gn_geo_tol"} & set(kw2["dynamics"])
    assert v2["meta"]["study_key"] != v1["meta"]["study_key"] and not v2["meta"]["cached"]
    assert v2["meta"]["version_line"] == ("benchmark navbench-2 (a candidate version, not accepted: "
                                          "docs/changelog.md)")
    # the stored rows say their version; the two studies' rows are two sets, never one
    from navbench.results.db import ResultsDB

    db = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    try:
        rows = db.tracking_frame()
        runs = db.runs_frame()
    finally:
        db.close()
    by_key = rows.groupby("study_key")["benchmark_version"].agg(set).to_dict()
    assert by_key == {v1["meta"]["study_key"]: {"navbench-1"}, v2["meta"]["study_key"]: {"navbench-2"}}
    assert sorted(runs["benchmark_version"]) == ["navbench-1", "navbench-2"]


def test_an_option_over_the_versions_departs_and_is_said(tmp_path, monkeypatch, spied):
    out, _, kw = _study(tmp_path, monkeypatch, spied, "--benchmark-version", "navbench-2",
                        "-o", "no-map.yaw_search_turn_deg=0")
    assert kw["no-map"]["yaw_search_turn_deg"] == 0  # --option wins
    assert kw["no-map"]["gn_tol"] == [5e-4, 5e-4]    # the version's other settings stay
    assert out["meta"]["version_line"] == ("benchmark navbench-2 (a candidate version, not accepted: "
                                           "docs/changelog.md), departing: "
                                           "no-map.yaw_search_turn_deg=0 (the version's: 1.0)")


def test_with_map_fit_the_maps_profile_runs_under_the_version(tmp_path, monkeypatch):
    """--map fit: the map's views and fit are the version's (the profile takes its settings)."""
    from navbench.errors import ConfigError
    from navbench.pipeline.stages import track_eval as stage

    seen = []

    def fit(ctx, profile, level, views_key=None):
        seen.append((profile.benchmark_version, profile.views_texture))
        raise ConfigError("stop here")

    monkeypatch.setattr(stage, "fit_map_for_profile", fit)
    monkeypatch.chdir(tmp_path)
    for extra in ((), ("--benchmark-version", "navbench-2")):
        res = nb("track-eval", "house-1", "--estimators", "ours", "--steps", "2", "--trajectories", "1",
                 "--no-store", *extra)
        assert_clean_error(res, "stop here")
    # the default version (navbench-5) fits on navbench-1's procedural views; navbench-2 on tables
    assert seen == [("navbench-5", "procedural"), ("navbench-2", "table")]


@pytest.mark.parametrize("extra", [(), ("--map", "true")])
def test_an_unknown_version_is_one_line_before_anything_runs(tmp_path, monkeypatch, extra):
    monkeypatch.chdir(tmp_path)
    res = nb("track-eval", "house-1", "--estimators", "dynamics", "--steps", "2", "--trajectories", "1",
             "--benchmark-version", "navbench-0", *extra)
    assert res.code == 2
    assert_clean_error(res, "--benchmark-version", "navbench-0", "navbench-1")
    assert not (tmp_path / "results").exists()  # no level, cache or database
