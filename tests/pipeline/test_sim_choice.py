"""Choosing the simulator (issue 37 §3): ``--sim pymunk|vizdoom`` and a profile's ``sim``.

The simulator is part of every cache key it affects (views, and through them the map; the
navigation cells and episodes; tracking studies), never of the level's or the task set's, and
its part is empty on pymunk: the quick profile's keys are those computed before the choice
existed (recorded below at commit c353b66, under navbench-1). A vizdoom run is benchmark version
``<version>+vizdoom`` (``navbench-5+vizdoom`` under the default version). Bad input is one line, exit 2.
"""

from __future__ import annotations

import json
import sqlite3
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from navbench import benchmark
from navbench.errors import ConfigError
from navbench.levelio import save_level

from .test_stages import tiny_level

#: The quick profile's stage keys for house-1 (make-level's check, both views, the map, the
#: cells, the mid-noise condition and one episode) computed by the code before the simulator
#: could be chosen (commit c353b66), with the task file's content replaced by "[]" (:class:`_KeyContext`).
QUICK_KEYS_BEFORE = {
    "verify level": "61099069c9e6ca83675f744c9a635a5a12dcff1cccaa07a0f73890713d22e386",
    "collect-views train": "34bec6cf24433f06dcb5fed15eada8082e55af2dbdce8456b39a2a7f5309b964",
    "collect-views held-out": "cd7d0bc3474f3cf150580c346d321f4f83885e5f967aed4da632da4fd2f30814",
    "fit-map": "7c35c7f715e1ed1f74549b84c2562dcf6df9b254fc3c14a76eb02c91e1f3764b",
    "sample-tasks": "9017c478b209bb4e04454397bc2df10df6fd20814cdc9e2a46c94c54d3078626",
    "verify tasks": "31893be79e11f329c7f1acf2a4e4822237eb3904e8fd58a4ad8734197284aaa1",
    "cell ours mid": "108ce5c0d1c033e23efb0d69d90b92553f130f401a7edfba2474bcc38be3e486",
    "cell no-map mid": "75c78b6f3e74e955b11689ee11e0bd0300b9813cc7090160284c44c4f5bd531c",
    "cell dynamics mid": "a879aaeb4acbce5658f019011dd3a2e8a36209bdecc66f5715cd10331ca43e16",
    "condition mid": "5b4830808091d95c89f1d0d0f281b02148c35e23a95994e661de579599bbd1cc",
    "episode ours mid 0 0": "a39295105f65a1f683c573886ab36e7c33f96c8aea20c7211d055efdfcfdbdd1",
    # the default tracking study on level "1"*64 and map "2"*64
    "track-eval": "621c85cff03ae2bd323ddbd2614260b9191b1f6fec3fb6aaab76bcb2aa97caef",
}
#: The keys a simulator changes, and those it must not (the level and the task set are the
#: simulator's inputs, not its outputs).
SIM_KEYED = {"collect-views train", "collect-views held-out", "fit-map", "cell ours mid", "cell no-map mid",
             "cell dynamics mid", "condition mid", "episode ours mid 0 0", "track-eval"}


def _stage_keys(tmp_path: Path, sim: str | None) -> dict[str, str]:
    """Every key the quick profile's pipeline computes for house-1 with ``sim`` (None: the
    profile's own), without running a stage: a context whose ``run`` only computes the key."""
    from navbench.pipeline.artifacts import FORMAT
    from navbench.pipeline.cache import stage_key
    from navbench.pipeline.profiles import load_profile, override
    from navbench.pipeline.stages import NavigationConfig, StageContext, build_level_inputs, make_cells
    from navbench.pipeline.stages.grid import EpisodeJob, episode_key
    from navbench.pipeline.stages.track_eval import study_key_config
    from navbench.track.study import TrackingStudyConfig

    class _KeyContext(StageContext):
        def run(self, stage, config, inputs, compute, validate=None):
            key = stage_key(stage, config, inputs, FORMAT[stage])
            self.used.append((stage, key))
            d = tmp_path / stage / key
            d.mkdir(parents=True, exist_ok=True)
            (d / "metrics.json").write_text("{}")
            (d / "tasks.json").write_text("[]")
            return d, key, True

    from navbench.pipeline.versioning import with_version

    # under navbench-1, as the keys were recorded (the default version's cells carry its name)
    prof = override(with_version(load_profile("quick"), "navbench-1"), sim=sim)
    ctx = _KeyContext(store=None, levels_dir=Path(__file__).resolve().parents[2] / "levels")
    li = build_level_inputs(ctx, prof, "house-1")
    names = ["verify level", "collect-views train", "collect-views held-out", "fit-map", "sample-tasks",
             "verify tasks"]
    assert [s for s, _ in ctx.used] == ["verify", "collect-views", "collect-views", "fit-map",
                                         "sample-tasks", "verify"]
    out = dict(zip(names, (k for _, k in ctx.used)))
    cfg = NavigationConfig(estimators=prof.estimators, noise=prof.noise, seeds=prof.seeds,
                           camera=prof.camera, episode=dict(prof.episode), sim=prof.sim)
    cells = make_cells([li], cfg)
    out.update({f"cell {c.estimator} {c.noise}": c.key for c in cells})
    out["condition mid"] = cells[0].condition_key
    out["episode ours mid 0 0"] = episode_key(EpisodeJob(cells[0], 0, 0, 0, 0))
    out["track-eval"] = stage_key("track-eval", study_key_config(TrackingStudyConfig(sim=prof.sim)),
                                  {"level": "1" * 64, "map": "2" * 64}, FORMAT["track-eval"])
    return out


def test_the_quick_profiles_keys_are_those_from_before_the_choice(tmp_path, monkeypatch):
    monkeypatch.chdir(Path(__file__).resolve().parents[2])
    assert _stage_keys(tmp_path, None) == QUICK_KEYS_BEFORE
    assert _stage_keys(tmp_path, "pymunk") == QUICK_KEYS_BEFORE


def test_vizdoom_changes_exactly_the_keys_it_affects(tmp_path, monkeypatch):
    monkeypatch.chdir(Path(__file__).resolve().parents[2])
    doom = _stage_keys(tmp_path, "vizdoom")
    assert set(doom) == set(QUICK_KEYS_BEFORE)
    changed = {k for k in doom if doom[k] != QUICK_KEYS_BEFORE[k]}
    assert changed == SIM_KEYED
    assert len(set(doom.values())) == len(doom)  # no two stages share a key


def test_versions_name_the_simulator():
    assert benchmark.sim_version("navbench-1", "pymunk") == "navbench-1"
    assert benchmark.sim_version("navbench-1", "vizdoom") == "navbench-1+vizdoom"
    assert benchmark.split_version("navbench-1+vizdoom") == ("navbench-1", "vizdoom")
    assert benchmark.split_version("navbench-1") == ("navbench-1", "pymunk")
    assert benchmark.check_version("navbench-1+vizdoom") == "navbench-1+vizdoom"
    with pytest.raises(benchmark.UnknownVersion, match="known: navbench-1, navbench-1\\+vizdoom"):
        benchmark.check_version("navbench-1+doom")
    # one version on two simulators: the reference simulator's is the default choice
    assert benchmark.newest(["navbench-1+vizdoom", "navbench-1"]) == "navbench-1"
    assert benchmark.version_rank("navbench-1+vizdoom") == benchmark.version_rank("navbench-1")
    assert benchmark.sim_key_part("pymunk") == {} and benchmark.sim_key_part("vizdoom") == {"sim": "vizdoom"}


def test_profile_field_and_set():
    from navbench.pipeline.overrides import apply_sets
    from navbench.pipeline.profiles import load_profile, override, profile_from_dict

    assert load_profile("quick").sim == "pymunk"
    assert load_profile("vizdoom-quick").sim == "vizdoom"
    assert apply_sets(load_profile("quick"), ["sim=vizdoom"]).sim == "vizdoom"
    assert profile_from_dict({"name": "t", "sim": "vizdoom"}, "t.toml").sim == "vizdoom"
    with pytest.raises(ConfigError, match=r"^t.toml: sim: unknown value 'doom' .*\['pymunk', 'vizdoom'\]$"):
        profile_from_dict({"name": "t", "sim": "doom"}, "t.toml")
    with pytest.raises(ConfigError, match=r"^--set sim=unity: unknown value 'unity'.*\['pymunk', 'vizdoom'\]$"):
        apply_sets(load_profile("quick"), ["sim=unity"])
    with pytest.raises(ConfigError, match=r"^command line: --sim: unknown value"):
        override(load_profile("quick"), sim="gazebo")
    # the vizdoom-quick profile differs from quick in its name, description and simulator only
    q, v = load_profile("quick"), load_profile("vizdoom-quick")
    import dataclasses

    assert {f.name for f in dataclasses.fields(q) if getattr(q, f.name) != getattr(v, f.name)} == \
        {"name", "description", "sim"}


def _cli(args, monkeypatch=None, missing_vizdoom=False):
    """``navbench ARGS`` through the console entry point (one-line errors, exit codes)."""
    from navbench.cli.main import main

    if missing_vizdoom:
        monkeypatch.setitem(sys.modules, "vizdoom", None)  # import vizdoom raises ImportError
    monkeypatch.setattr(sys, "argv", ["navbench", *args])
    with pytest.raises(SystemExit) as e:
        main()
    return e.value.code


@pytest.fixture
def project(tmp_path, monkeypatch):
    (tmp_path / "levels").mkdir()
    save_level(tiny_level(), tmp_path / "levels" / "tiny.json")
    (tmp_path / "tiny.toml").write_text(TINY)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("NAVBENCH_DB", f"sqlite:///{tmp_path / 'nb.db'}")
    monkeypatch.setenv("NAVBENCH_CACHE", str(tmp_path / "cache"))
    return tmp_path


TINY = """
name = "tinydoom"
levels = ["tiny"]
sim = "vizdoom"
[views]
camera = "half"
count = 12
seed = 0
eval_count = 4
eval_seed = 1
[fit]
steps = 3
grid_shape = [16, 12, 8]
n_samples = 40
images_per_batch = 4
pixels_per_image = 50
threads = 1
[tasks]
count = 2
[navigation]
estimators = ["no-map", "dynamics"]
noise = ["low"]
workers = 1
"""


@pytest.mark.parametrize("args", [
    ["all", "--profile", "tiny.toml"],
    ["run-navigation", "--profile", "quick", "--sim", "vizdoom"],
    ["collect-views", "tiny", "--sim", "vizdoom"],
    ["fit-map", "tiny", "--set", "sim=vizdoom"],
    ["track-eval", "tiny", "--map", "true", "--sim", "vizdoom"],
    ["render-sequence", "tiny", "seq", "--sim", "vizdoom"],
])
def test_vizdoom_missing_is_one_line_naming_the_install(project, monkeypatch, capsys, args):
    assert _cli(args, monkeypatch, missing_vizdoom=True) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "vizdoom package is not installed" in err and "pip install 'navbench[vizdoom]'" in err
    assert not (project / "nb.db").exists() and not (project / "cache").exists()  # nothing begun


@pytest.mark.parametrize("args", [
    ["all", "--profile", "tiny.toml", "--sim", "doom"],
    ["run-navigation", "--set", "sim=doom"],
    ["collect-views", "tiny", "--sim", "Vizdoom"],
    ["track-eval", "tiny", "--map", "true", "--sim", "unity"],
    ["render-sequence", "tiny", "seq", "--sim", "gazebo"],
])
def test_an_unknown_simulator_is_one_line_listing_the_known(project, monkeypatch, capsys, args):
    assert _cli(args, monkeypatch) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "pymunk" in err and "vizdoom" in err
    assert not (project / "nb.db").exists()


def _require_vizdoom():
    try:
        import vizdoom  # noqa: F401
    except ImportError as e:
        pytest.skip(f"vizdoom cannot be imported here ({e}); pip install 'navbench[vizdoom]'")


@pytest.mark.slow
def test_a_tiny_vizdoom_profile_runs_end_to_end(project):
    _require_vizdoom()
    from navbench.cli.main import app

    res = CliRunner().invoke(app, ["all", "--profile", "tiny.toml", "--report", str(project / "report")])
    assert res.exit_code == 0, res.output + repr(res.exception)
    con = sqlite3.connect(project / "nb.db")
    runs = con.execute("select benchmark_version, config from runs").fetchall()
    assert [(v, json.loads(c)["sim"]) for v, c in runs] == [("navbench-5+vizdoom", "vizdoom")]
    eps = con.execute("select estimator, benchmark_version from episodes").fetchall()
    assert len(eps) == 4 and {v for _, v in eps} == {"navbench-5+vizdoom"}
    # the views are the engine's: keyed by it, labelled with the pose it shows (whole
    # centimetres) and its projection (Doom's pixels are not square)
    from navbench.worldmodel.views import load_views

    manifests = [json.loads(p.read_text()) for p in (project / "cache" / "collect-views").glob("*/manifest.json")]
    assert len(manifests) == 2 and all(m["config"]["sim"] == "vizdoom" for m in manifests)
    views = load_views(next((project / "cache" / "collect-views").glob("*/views")))
    xy = views.poses[:, :2] * 100
    assert np.abs(xy - np.rint(xy)).max() < 1e-6
    assert (views.intrinsics.fx, views.intrinsics.fy) == (80.0, 94.0)
    # a rerun is all cached: nothing new stored
    res = CliRunner().invoke(app, ["all", "--profile", "tiny.toml", "--report", str(project / "report")])
    assert res.exit_code == 0 and "0 new episodes, 4/4 stored" in res.output
    # pymunk on the same profile: other keys, its own version; score keeps the two apart
    res = CliRunner().invoke(app, ["all", "--profile", "tiny.toml", "--sim", "pymunk",
                                   "--report", str(project / "report")])
    assert res.exit_code == 0, res.output + repr(res.exception)
    assert con.execute("select count(*) from episodes where benchmark_version = 'navbench-5'").fetchone() == (4,)
    res = CliRunner().invoke(app, ["score", "--benchmark-version", "navbench-5+vizdoom"])
    assert res.exit_code == 0 and "navbench-5+vizdoom" in res.output


def test_a_tracking_study_on_the_engines_frames():
    _require_vizdoom()
    from navbench.track.study import TrackingStudyConfig, record_trajectories, run_tracking_study

    level = tiny_level()
    cfg = TrackingStudyConfig(trajectories=2, steps=6, estimators=("gt", "no-map", "dynamics"),
                              sim="vizdoom")
    trajs = record_trajectories(level, 2, 6, seed=0)
    res = run_tracking_study(level, None, cfg, trajectories=trajs)
    true = res["trajectories"]["true_poses"]
    # the truth is the engine's pose: whole centimetres, within half a centimetre of the recording
    assert np.abs(true[..., :2] * 100 - np.rint(true[..., :2] * 100)).max() < 1e-6
    assert np.abs(true[..., :2] - np.stack([t.true_poses for t in trajs])[..., :2]).max() <= 0.005 + 1e-9
    assert np.all(res["estimators"]["gt"]["loc_rmse_m"] == 0.0)
    assert np.all(np.isfinite(res["estimators"]["no-map"]["loc_rmse_m"]))
    assert res["config"]["sim"] == "vizdoom"


def test_what_the_engine_backend_refuses():
    from navbench.pipeline.overrides import apply_sets
    from navbench.pipeline.profiles import load_profile

    with pytest.raises(ConfigError, match="sim vizdoom: pose_quantisation must be off"):
        apply_sets(load_profile("vizdoom-quick"), ["conditions.pose_quantisation=round"])
    # image goals on a known map run on the engine (tests/pipeline/test_sim_localize.py); the
    # unknown-house loop does not
    assert apply_sets(load_profile("quick"), ["navigation.goal=image", "sim=vizdoom"]).goal == "image"
    with pytest.raises(ConfigError, match="sim vizdoom: map 'online' \\(the unknown-house loop\\) is not supported"):
        apply_sets(load_profile("quick"), ["navigation.goal=image", "navigation.map=online", "sim=vizdoom"])
    assert apply_sets(load_profile("quick"), ["conditions.pose_quantisation=round"]).sim == "pymunk"


def test_the_paper_profile_on_the_engine_with_its_quantisation_off(project, monkeypatch, capsys):
    """--sim is checked after --condition: the paper's profile runs on the engine once its
    emulated quantisation is off (the engine quantises itself); without it, one line saying so."""
    seen = {}

    def fake_run_profile(prof, **kwargs):
        seen["profile"] = prof
        raise ConfigError("stopped before any stage")

    monkeypatch.setattr("navbench.pipeline.run.run_profile", fake_run_profile)
    assert _cli(["run-navigation", "--profile", "paper", "--sim", "vizdoom"], monkeypatch) == 2
    assert "add --condition pose_quantisation=off" in capsys.readouterr().err and not seen
    assert _cli(["run-navigation", "--profile", "paper", "--sim", "vizdoom", "--condition",
                 "pose_quantisation=off"], monkeypatch) == 2
    assert "stopped before any stage" in capsys.readouterr().err
    assert seen["profile"].sim == "vizdoom" and seen["profile"].episode["pose_quantisation"] == "off"


def test_a_candidate_versions_texel_tables_on_the_engine_warn_once_and_run(project):
    """navbench-2 sets the pymunk camera's texel tables; the engine draws its own textures, so the
    run says in one line that they change no frame, and its episodes run (they stopped with
    "the simulator's texture='procedural' disagrees with EpisodeConfig.texture='table'")."""
    _require_vizdoom()
    from navbench.cli.main import app

    res = CliRunner().invoke(app, ["run-navigation", "tiny", "--sim", "vizdoom", "--benchmark-version", "navbench-2",
                                   "--map", "true", "--tasks", "1", "--estimators", "dynamics,no-map",
                                   "--noise", "low"])
    assert res.exit_code == 0, res.output + repr(res.exception)
    warned = [ln for ln in res.output.splitlines() if "change no frame" in ln]
    assert warned == ["warning: sim vizdoom: views.texture 'table' and navigation.episode.texture 'table' "
                      "change no frame (the engine draws its own textures; the texture modes are the "
                      "pymunk camera's)"]
    con = sqlite3.connect(project / "nb.db")
    assert con.execute("select count(*), min(benchmark_version) from episodes").fetchone() == (2, "navbench-2+vizdoom")


def test_texture_modes_warn_only_where_the_simulator_ignores_them():
    from navbench.sim.backends import ignored_textures

    assert ignored_textures("pymunk", "table", "table") is None
    assert ignored_textures("vizdoom") is None
    assert ignored_textures("vizdoom", "table") == ("sim vizdoom: views.texture 'table' changes no frame (the "
                                                    "engine draws its own textures; the texture modes are the "
                                                    "pymunk camera's)")


def test_reused_engines_store_the_rows_and_trajectories_of_fresh_ones(project, monkeypatch):
    # a chunk's episodes reuse one engine (navbench.sim.doom.engine.reuse_engines): the tiny
    # profile with 4 tasks (8 episodes in chunks of 2) run with and without reuse stores the
    # same rows, views, map and trajectories, bit for bit
    _require_vizdoom()
    import navbench.sim.doom.engine as engine
    from navbench.cli.main import app

    (project / "tiny.toml").write_text(TINY.replace("\ncount = 2\n", "\ncount = 4\n"))

    def run(tag):
        monkeypatch.setenv("NAVBENCH_DB", f"sqlite:///{project / (tag + '.db')}")
        monkeypatch.setenv("NAVBENCH_CACHE", str(project / ("cache-" + tag)))
        res = CliRunner().invoke(app, ["all", "--profile", "tiny.toml", "--report", str(project / ("report-" + tag))])
        assert res.exit_code == 0, res.output + repr(res.exception)
        con = sqlite3.connect(project / (tag + ".db"))
        # every column but the row's and run's ids, the timings and the time of recording
        cols = [r[1] for r in con.execute("pragma table_info(episodes)")
                if r[1] not in ("id", "run_id", "recorded") and not r[1].endswith("_ms")]
        rows = con.execute(f"select {', '.join(cols)} from episodes order by cell_key, task_id, seed").fetchall()
        # the cached arrays (views, map, trajectories; not the timings) by their path under the cache
        arrays = {(str(f.relative_to(project / ("cache-" + tag))), ""): np.load(f)
                  for f in (project / ("cache-" + tag)).rglob("*.npy")}
        for f in sorted((project / ("cache-" + tag)).rglob("*.npz")):
            with np.load(f) as z:
                for name in z.files:
                    where = (str(f.relative_to(project / ("cache-" + tag))), name)
                    if name == "__meta__":  # a record's JSON fields, its plan time among them
                        meta = json.loads(bytes(z[name]).decode())
                        arrays[where] = np.array(sorted((k, repr(v)) for k, v in meta.items()
                                                        if not k.endswith("_ms")))
                    elif "timing" not in name and not name.endswith("_ms"):
                        arrays[where] = z[name]
        return cols, rows, arrays

    taken = []
    real_take = engine._take_parked
    monkeypatch.setattr(engine, "_take_parked", lambda key: taken.append(real_take(key)) or taken[-1])
    reused = run("reused")
    assert sum(t is not None for t in taken) == 4  # the second episode of each chunk of 2
    assert not engine._PARKED
    monkeypatch.setattr(engine, "_take_parked", lambda key: None)  # as before: a new engine each time
    fresh = run("fresh")
    assert reused[0] == fresh[0] and len(reused[1]) == 8 and reused[1] == fresh[1]
    assert reused[2].keys() == fresh[2].keys()
    assert {k[0].split("/")[0] for k in reused[2]} == {"collect-views", "fit-map", "episode"}
    assert any(k[0].endswith("rgb.npy") for k in reused[2])  # the engine's views themselves
    for k, a in reused[2].items():
        np.testing.assert_array_equal(a, fresh[2][k], err_msg=str(k))
