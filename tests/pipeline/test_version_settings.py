"""How a benchmark version is chosen and reaches what it affects (issue 36 §1): a profile's
``benchmark_version``, ``--set benchmark_version=`` and ``--benchmark-version``; the version's
settings as the profile's defaults; the version in the keys it affects (and in no other), on the
run row and every episode row, and in ``navbench all``'s summary.

The versions here are test-only ones registered by monkeypatching (``navbench-test``), so the
mechanism is tested without a real second version."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from navbench import benchmark
from navbench.errors import ConfigError
from navbench.pipeline.overrides import apply_sets
from navbench.pipeline.profiles import Profile, load_profile, override, profile_from_dict
from navbench.pipeline.versioning import departures, locate, setting, version_line, with_version
from tests.bad_input.conftest import project  # noqa: F401  (the scratch-project fixture)

ROOT = Path(__file__).resolve().parents[2]
#: A test version: the fit's seed and learning rate, and an option of ``ours`` (its table is the
#: shape navbench-2's will have: fit, estimator options).
TEST_SETTINGS = {"fit.seed": 7, "fit.lr": 0.02, "navigation.options.ours.reference_scale": 0.5}


@pytest.fixture
def testing_version(monkeypatch):
    monkeypatch.setitem(benchmark.VERSIONS, "navbench-test", "a test-only version")
    monkeypatch.setitem(benchmark.VERSION_SETTINGS, "navbench-test", dict(TEST_SETTINGS))
    return "navbench-test"


def test_every_version_table_holds_profile_settings_that_pass_their_checks():
    """A version's table is code: each key must be a profile setting a version may fix, each
    value one its field accepts; navbench-1 is the empty table (the configs' defaults)."""
    assert benchmark.VERSION_SETTINGS[benchmark.LEGACY_VERSION] == {}
    assert set(benchmark.VERSION_SETTINGS) == set(benchmark.VERSIONS)
    base = Profile(name="t")
    for version in benchmark.VERSIONS:
        benchmark.affected_stages(version)  # every key under SETTING_STAGES
        for key in benchmark.version_settings(version):
            locate(key)
        with_version(base, version)  # each value checked as the profile's own field


def test_a_profile_file_takes_its_versions_settings_and_what_it_writes_wins(testing_version):
    p = profile_from_dict({"name": "t", "benchmark_version": testing_version})
    assert (p.benchmark_version, p.fit_seed, p.fit) == (testing_version, 7, {"lr": 0.02})
    assert p.estimator_options == {"ours": {"reference_scale": 0.5}}
    assert departures(p) == {}
    own = profile_from_dict({"name": "t", "benchmark_version": testing_version, "fit": {"seed": 3},
                             "navigation": {"options": {"ours": {"reference_scale": 1.0, "optimizer": "adam"}}}})
    assert own.fit_seed == 3 and own.fit == {"lr": 0.02}
    assert own.estimator_options == {"ours": {"reference_scale": 1.0, "optimizer": "adam"}}
    assert departures(own) == {"fit.seed": (3, 7), "navigation.options.ours.reference_scale": (1.0, 0.5)}
    assert version_line(own) == ("benchmark navbench-test, departing: fit.seed=3 (the version's: 7); "
                                 "navigation.options.ours.reference_scale=1.0 (the version's: 0.5)")
    # no key: the current version (navbench-5 since 2026-11-27), with its settings, as the
    # bundled profiles, which name none
    assert profile_from_dict({"name": "t"}).benchmark_version == benchmark.BENCHMARK_VERSION == "navbench-5"
    quick = load_profile("quick")
    assert quick.benchmark_version == "navbench-5" and version_line(quick) == "benchmark navbench-5"
    assert quick.estimator_options == {e: {"yaw_search_spread": True} for e in ("ours", "no-map")}


def test_a_navbench_1_profile_using_a_versions_lever_departs_from_navbench_1(testing_version):
    p = profile_from_dict({"name": "t", "fit": {"lr": 0.02}})
    assert departures(p) == {"fit.lr": (0.02, setting(Profile(name="t"), "fit.lr"))}


def test_set_and_the_option_change_the_version_and_typed_values_win(testing_version):
    quick = with_version(load_profile("quick"), "navbench-1")  # the empty table: only the test's settings
    for items in (["fit.seed=3", "benchmark_version=navbench-test"],
                  ["benchmark_version=navbench-test", "fit.seed=3"]):  # the order does not matter
        p = apply_sets(quick, items)
        assert (p.benchmark_version, p.fit_seed, p.fit) == (testing_version, 3, {"lr": 0.02})
        assert p.estimator_options == {"ours": {"reference_scale": 0.5}}
    moved = with_version(quick, testing_version)
    assert (moved.fit_seed, moved.fit) == (7, {"lr": 0.02}) and departures(moved) == {}
    # back: what still holds navbench-test's value takes navbench-1's; a changed value stays
    changed = override(moved, fit_seed=5)
    back = with_version(changed, "navbench-1")
    assert (back.fit_seed, back.fit, back.estimator_options) == (5, {}, {})
    assert departures(back) == {"fit.seed": (5, 0)}
    assert with_version(moved, "navbench-1") == quick  # there and back: the profile itself
    with pytest.raises(ConfigError, match="with_version"):
        override(quick, benchmark_version=testing_version)


def test_an_unknown_version_is_one_line_naming_the_known_ones(tmp_path, testing_version):
    from tests.bad_input.conftest import assert_clean_error, nb

    bad = tmp_path / "bad.toml"
    bad.write_text('name = "bad"\nbenchmark_version = "navbench-0"\n')
    with pytest.raises(ConfigError, match=r"bad.toml: benchmark_version: unknown value 'navbench-0'.*"
                                          r"choose one of \['navbench-1', 'navbench-2', 'navbench-3', 'navbench-4', 'navbench-5', 'navbench-test'\]"):
        load_profile(str(bad))
    with pytest.raises(ConfigError, match="--set: benchmark_version: unknown value 'navbench-0'"):
        apply_sets(load_profile("quick"), ["benchmark_version=navbench-0"])
    for args in (["--benchmark-version", "navbench-0"], ["--set", "benchmark_version=navbench-0"]):
        res = nb("all", "--db", f"sqlite:///{tmp_path / 'r.db'}", *args)
        assert_clean_error(res, "navbench-0", "navbench-1")
        assert res.code == 2
    res = nb("run-navigation", "--db", f"sqlite:///{tmp_path / 'r.db'}", "--benchmark-version", "navbench-0")
    assert_clean_error(res, "--benchmark-version", "navbench-0", "navbench-1")
    assert not (tmp_path / "r.db").exists() or "navbench-0" not in (tmp_path / "r.db").read_bytes().decode("latin-1")


# ------------------------------------------------------------------------------ cache keys

def stage_keys(profile: Profile, tmp_path: Path, monkeypatch) -> dict:
    """Every key a profile's level inputs and navigation cells get, without computing anything:
    the stages' key computation runs, their work is replaced by stand-in files (a task set's
    stand-in holds its sample-tasks key, so the tasks key follows it as the real one does)."""
    import navbench.pipeline.stages.context as context
    from navbench.pipeline.cache import ArtifactStore, stage_key
    from navbench.pipeline.run import navigation_config
    from navbench.pipeline.stages import StageContext, build_level_inputs, make_cells

    seen = []

    def stand_in(store, stage, config, inputs, version, compute, **kw):
        key = stage_key(stage, config, inputs, version)
        seen.append((stage, key[:16]))
        d = tmp_path / "stand-in" / stage / key
        d.mkdir(parents=True, exist_ok=True)
        (d / "metrics.json").write_text("{}")
        (d / "tasks.json").write_text(json.dumps({"stage": stage, "key": key}))
        return d, key, True

    monkeypatch.setattr(context, "run_stage", stand_in)
    ctx = StageContext(ArtifactStore(tmp_path / "cache"), levels_dir=ROOT / "levels", tasks_dir=ROOT / "tasks")
    li = build_level_inputs(ctx, profile, profile.levels[0])
    cells = make_cells([li], navigation_config(profile))
    return {"stages": seen, "level": li.level.key[:16], "map": li.map.key[:16], "tasks": li.tasks.key[:16],
            "cells": [c.key[:16] for c in cells], "conditions": sorted({c.condition_key[:16] for c in cells})}


#: The quick profile's keys as computed before benchmark versions reached the profile (commit
#: c353b66, by this same function): navbench-1 leaves every key as it was.
QUICK_KEYS = {
    "stages": [("verify", "61099069c9e6ca83"), ("collect-views", "34bec6cf24433f06"),
               ("collect-views", "cd7d0bc3474f3cf1"), ("fit-map", "7c35c7f715e1ed1f"),
               ("sample-tasks", "9017c478b209bb4e"), ("verify", "8994148e093cc014")],
    "level": "4122989f690dcb9e", "map": "7c35c7f715e1ed1f", "tasks": "cf7e8137f1067b77",
    "cells": ["66ad18e62f705d08", "8a9ca20730753e85", "7e53b2a54219d24d"],
    "conditions": ["5b4830808091d95c"],
}


def test_the_quick_profiles_keys_are_unchanged(tmp_path, monkeypatch):
    """Under navbench-1 every key is as before versions; under the default version (navbench-5,
    whose settings reach only the episodes) the level, views, map and tasks keys are navbench-1's
    and the cells and conditions carry the version."""
    assert stage_keys(with_version(load_profile("quick"), "navbench-1"), tmp_path, monkeypatch) == QUICK_KEYS
    now = stage_keys(load_profile("quick"), tmp_path, monkeypatch)
    assert {k: now[k] for k in ("stages", "level", "map", "tasks")} == {
        k: QUICK_KEYS[k] for k in ("stages", "level", "map", "tasks")}
    assert not set(now["cells"]) & set(QUICK_KEYS["cells"]) and now["conditions"] != QUICK_KEYS["conditions"]


def test_a_version_changes_the_keys_it_affects_and_no_other(tmp_path, monkeypatch, testing_version):
    """navbench-test fixes fit and navigation settings: the level, views and task keys stay
    navbench-1's; the fit's key and every cell carry the version, also where the profile departs
    from each of its settings (the artifacts of two versions never mix)."""
    assert benchmark.affected_stages(testing_version) == {"fit-map"}
    quick = load_profile("quick")
    new = stage_keys(with_version(quick, testing_version), tmp_path, monkeypatch)
    same = dict(new, map=None, cells=None, conditions=None, stages=[s for s in new["stages"] if s[0] != "fit-map"])
    assert same == dict(QUICK_KEYS, map=None, cells=None, conditions=None,
                        stages=[s for s in QUICK_KEYS["stages"] if s[0] != "fit-map"])
    assert new["map"] != QUICK_KEYS["map"]
    assert not set(new["cells"]) & set(QUICK_KEYS["cells"])
    assert new["conditions"] != QUICK_KEYS["conditions"]
    # every setting set back to navbench-1's value: still the version's own artifacts
    departed = apply_sets(quick, ["benchmark_version=navbench-test", "fit.seed=0", "fit.lr=0.05",
                                  "navigation.options.ours.reference_scale=1.0"])
    assert set(departures(departed)) == set(TEST_SETTINGS)
    apart = stage_keys(departed, tmp_path, monkeypatch)
    assert apart["map"] not in (QUICK_KEYS["map"], new["map"]) and apart["level"] == QUICK_KEYS["level"]
    assert not set(apart["cells"]) & set(QUICK_KEYS["cells"])


def test_a_version_that_fixes_views_reaches_the_views_key(tmp_path, monkeypatch):
    monkeypatch.setitem(benchmark.VERSIONS, "navbench-views", "views only")
    monkeypatch.setitem(benchmark.VERSION_SETTINGS, "navbench-views", {"views.camera": "half"})
    assert benchmark.affected_stages("navbench-views") == {"collect-views"}
    keys = stage_keys(with_version(load_profile("quick"), "navbench-views"), tmp_path, monkeypatch)
    views = [k for s, k in keys["stages"] if s == "collect-views"]
    assert len(views) == 2 and not set(views) & {k for s, k in QUICK_KEYS["stages"] if s == "collect-views"}
    assert keys["level"] == QUICK_KEYS["level"] and keys["tasks"] == QUICK_KEYS["tasks"]


# ------------------------------------------------------------------------------ a whole run

@pytest.mark.slow
def test_runs_of_two_versions_store_their_own_rows_and_are_never_pooled(project, testing_version):
    """tiny.toml under the default version, then under navbench-test in the same database and cache: the
    second run reuses the level, views and task set, fits its own map, runs its own episodes
    (none is 'already stored'), and its run and episode rows carry its version; score takes the
    newest version alone and --benchmark-version the other; navbench all prints the version."""
    from navbench.pipeline.run import run_profile
    from navbench.results.db import ResultsDB
    from navbench.results.score import score_table
    from tests.bad_input.conftest import nb

    url = f"sqlite:///{project / 'v.db'}"
    one = run_profile("tiny.toml", db=url, until="score")
    two = run_profile(apply_sets(load_profile("tiny.toml"), ["benchmark_version=navbench-test"]), db=url,
                      until="score")
    assert two.profile.fit_seed == 7 and two.navigation.already_done == 0
    assert two.navigation.stored == one.navigation.stored == 6
    keys = {v: {s: {k for st, k in r.refs if st == s} for s in ("make-level", "verify", "collect-views",
                                                                  "sample-tasks", "fit-map", "score")}
            for v, r in (("1", one), ("test", two))}
    for stage in ("verify", "collect-views"):
        assert keys["1"][stage] == keys["test"][stage], stage
    assert one.inputs[0].tasks.key == two.inputs[0].tasks.key and one.inputs[0].level.key == two.inputs[0].level.key
    for stage in ("fit-map", "score"):
        assert not keys["1"][stage] & keys["test"][stage], stage
    with ResultsDB(url) as db:
        runs = db.runs_frame().set_index("id")
        assert runs.loc[one.run_id, "benchmark_version"] == benchmark.BENCHMARK_VERSION
        assert runs.loc[two.run_id, "benchmark_version"] == testing_version
        eps = db.episodes_frame()
        assert eps.groupby("run_id")["benchmark_version"].agg(set).to_dict() == {
            one.run_id: {benchmark.BENCHMARK_VERSION}, two.run_id: {testing_version}}
        t = score_table(db, n_boot=20)
        assert set(t["episodes"][t["level"] == "all"]) == {3}  # 3 tasks per estimator, one version
        old = score_table(db, n_boot=20, benchmark_version=benchmark.BENCHMARK_VERSION)
        assert set(old["episodes"][old["level"] == "all"]) == {3}
    res = nb("all", "--profile", "tiny.toml", "--db", url, "--report", "out/r",
             "--benchmark-version", testing_version, "--set", "fit.seed=3")
    assert res.code == 0, res.output
    assert "benchmark navbench-test, departing: fit.seed=3 (the version's: 7)" in res.out


def _stores_what_navbench_1_stores_with(project, version: str, sets: list[str]) -> None:
    """tiny.toml run under ``version`` stores, episode for episode, what navbench-1 with ``sets``
    stores (only the version and the keys that carry it differ), reusing navbench-1's level,
    views and map, with dynamics' rows as navbench-1's."""
    import sqlite3

    from navbench.pipeline.run import run_profile

    base = apply_sets(load_profile("tiny.toml"), ["benchmark_version=navbench-1",
                                                  "navigation.estimators=ours,no-map,dynamics"])
    v1 = run_profile(apply_sets(base, sets), db=f"sqlite:///{project / 'one.db'}", until="score")
    vn = run_profile(apply_sets(base, [f"benchmark_version={version}"]), db=f"sqlite:///{project / 'new.db'}",
                     until="score")
    assert vn.inputs[0].map.key == v1.inputs[0].map.key and vn.navigation.already_done == 0
    cols = ("level, task_id, estimator, noise, seed, success, spl_term, path_length, steps, end_reason, "
            "loc_rmse_m, rot_rmse_deg, map_key")
    rows = {}
    for name in ("one", "new"):
        with sqlite3.connect(project / f"{name}.db") as con:
            rows[name] = con.execute(f"SELECT {cols} FROM episodes ORDER BY estimator, noise, task_id, seed").fetchall()
            versions = {v for (v,) in con.execute("SELECT DISTINCT benchmark_version FROM episodes")}
        assert versions == {"navbench-1" if name == "one" else version}
    assert rows["one"] == rows["new"] and len(rows["one"]) == v1.navigation.stored > 0


_SPREAD = ["navigation.options.ours.yaw_search_spread=true", "navigation.options.no-map.yaw_search_spread=true"]


def test_navbench_3_is_navbench_1_with_the_spread_heading_search(project):
    """navbench-3 (accepted 2026-11-27) fixes exactly ``yaw_search_spread`` of ours and no-map."""
    assert benchmark.version_settings("navbench-3") == {
        "navigation.options.ours.yaw_search_spread": True, "navigation.options.no-map.yaw_search_spread": True}
    assert "navbench-3" not in benchmark.CANDIDATES
    _stores_what_navbench_1_stores_with(project, "navbench-3", _SPREAD)


def test_navbench_5_is_navbench_3_with_table_textured_episode_frames(project):
    """navbench-5 (accepted 2026-11-27) is navbench-3 plus the episode camera's texel tables and
    nothing else: no stage key carries it (views, maps and tasks are navbench-1's) and its
    Gymnasium id is the table images' ``-v1``. navbench-4 (its grid failed) adds the tracker
    levers and stays a candidate."""
    assert benchmark.version_settings("navbench-5") == {
        **benchmark.version_settings("navbench-3"), "navigation.episode.texture": "table"}
    assert benchmark.affected_stages("navbench-5") == frozenset() == benchmark.affected_stages("navbench-4")
    assert "navbench-5" not in benchmark.CANDIDATES and "navbench-4" in benchmark.CANDIDATES
    assert benchmark.BENCHMARK_VERSION == "navbench-5"  # the default since 2026-11-27
    assert benchmark.GYM_IDS["navbench-5"] == benchmark.GYM_IDS["navbench-2"] == "navbench/PointNav-v1"
    assert set(benchmark.version_settings("navbench-4")) - set(benchmark.version_settings("navbench-5")) == {
        f"navigation.options.{e}.{k}" for e in ("ours", "no-map") for k in ("gn_geo_tol", "gn_tol", "yaw_search_turn_deg")}
    _stores_what_navbench_1_stores_with(project, "navbench-5", [*_SPREAD, "navigation.episode.texture=table"])
