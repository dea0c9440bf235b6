"""The tracking study library and the track-eval command on tiny configurations."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from navbench.errors import ConfigError
from navbench.sim.dynamics import MAX_STEP, MAX_TURN, Control, predict
from navbench.track.study import TrackingStudyConfig, record_trajectories, run_tracking_study, summarise

from .synth import small_level
from tests.bad_input.conftest import nb, project  # noqa: F401  (the scratch-project fixture)


@pytest.fixture(scope="module")
def level():
    return small_level()


def test_recording_is_deterministic_and_within_the_limits(level):
    a = record_trajectories(level, 2, 15, seed=3)
    b = record_trajectories(level, 2, 15, seed=3)
    for ta, tb in zip(a, b):
        assert np.array_equal(ta.true_poses, tb.true_poses)
        assert np.array_equal(ta.controls, tb.controls)
        assert np.array_equal(ta.noise, tb.noise)
        assert ta.true_poses.shape == (16, 3) and ta.controls.shape == (15, 3)
        assert np.all(np.abs(ta.controls[:, 0]) <= MAX_TURN + 1e-12)
        assert np.all((ta.controls[:, 2] >= 0) & (ta.controls[:, 2] <= MAX_STEP + 1e-12))
        assert np.any(ta.noise != 0)
    assert not np.array_equal(a[0].true_poses, a[1].true_poses)


def test_gt_and_dynamics_replay_exactly(level):
    cfg = TrackingStudyConfig(trajectories=2, steps=8, estimators=("gt", "dynamics", "no-map"), seed=1)
    res = run_tracking_study(level, None, cfg)
    true = res["trajectories"]["true_poses"]
    assert np.array_equal(res["estimators"]["gt"]["est_poses"], true)
    assert np.all(res["estimators"]["gt"]["loc_rmse_m"] == 0)
    dyn = res["estimators"]["dynamics"]["est_poses"]
    for n in range(2):
        pose = true[n, 0]
        for t, u in enumerate(res["trajectories"]["controls"][n]):
            pose = predict(pose, Control(*u))
            assert np.allclose(dyn[n, t + 1], pose, atol=1e-12)
    s = summarise(res)
    assert set(s) == {"gt", "dynamics", "no-map"}
    assert s["gt"]["frac_loc_rmse_below_0_1m"] == 1.0
    assert res["estimators"]["no-map"]["step_ms"].shape == (2, 8)


def test_config_validation():
    with pytest.raises(ConfigError):
        TrackingStudyConfig(trajectories=0)
    with pytest.raises(ConfigError):
        TrackingStudyConfig(estimators=("ours", "ours"))


def test_track_eval_cli_prints_json(tmp_path, level, monkeypatch):
    from navbench.cli.main import app
    from navbench.levelio import save_level

    monkeypatch.chdir(tmp_path)  # the stage cache is results/cache under the working directory
    path = save_level(level, tmp_path / f"{level.name}.json")  # a level file is NAME.json
    result = CliRunner().invoke(app, [
        "track-eval", str(path), "--trajectories", "2", "--steps", "4", "--json", "--map", "true",
        "--estimators", "ours,emission,no-map,dynamics,gt",
        "-o", "emission.steps=3", "-o", "emission.pixels=100", "-o", "ours.optimizer=adam",
        "-o", "ours.adam_steps=10", "--emission-trajectories", "1",
        "--db", f"sqlite:///{tmp_path / 'r.db'}",
    ])
    assert result.exit_code == 0, result.output
    out = json.loads(result.stdout)
    keys = {"loc_rmse_m_median", "loc_rmse_m_p99", "rot_rmse_deg_median", "frac_loc_rmse_below_0_1m",
            "step_ms_median"}
    for name in ("ours", "emission", "no-map", "dynamics", "gt"):
        assert keys <= set(out[name]), name
    assert out["emission"]["runs"] == 1 and out["ours"]["runs"] == 2
    assert out["gt"]["loc_rmse_m_median"] == 0.0
    # the default version's setting (navbench-5: the heading search spread) beside the -o options
    assert out["meta"]["options"]["ours"] == {"yaw_search_spread": True, "optimizer": "adam", "adam_steps": 10}
    # one stored row per (estimator, trajectory, seed): 2 each, emission limited to 1
    assert out["meta"]["stored"]["rows"] == 4 * 2 + 1
    from navbench.results.db import ResultsDB

    frame = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}").tracking_frame()
    assert len(frame) == 9
    ours = frame[frame.estimator == "ours"].sort_values("trajectory_id")
    assert list(ours.trajectory_id) == [0, 1]
    assert ours.loc_rmse_m.median() == pytest.approx(out["ours"]["loc_rmse_m_median"])


def test_track_eval_rerun_stores_no_duplicates(tmp_path, level, monkeypatch):
    from navbench.cli.main import app
    from navbench.levelio import save_level
    from navbench.results.db import ResultsDB

    monkeypatch.chdir(tmp_path)
    path = save_level(level, tmp_path / f"{level.name}.json")  # a level file is NAME.json
    url = f"sqlite:///{tmp_path / 'r.db'}"
    args = ["track-eval", str(path), "--trajectories", "2", "--steps", "3", "--json",
            "--estimators", "dynamics,gt", "--db", url]
    first = json.loads(CliRunner().invoke(app, args).stdout)
    second = json.loads(CliRunner().invoke(app, args).stdout)
    assert first["meta"]["stored"]["rows"] == 4 and second["meta"]["stored"]["rows"] == 0
    assert first["meta"]["stored"]["study_key"] == second["meta"]["stored"]["study_key"]
    # the second run is the cached stage: the same numbers, nothing recomputed
    assert (first["meta"]["cached"], second["meta"]["cached"]) == (False, True)
    assert first["meta"]["map_key"] == "none"  # dynamics and gt read no map
    assert {k: v for k, v in first.items() if k != "meta"} == {k: v for k, v in second.items() if k != "meta"}
    assert len(ResultsDB(url).tracking_frame()) == 4
    none = json.loads(CliRunner().invoke(app, args[:-2] + ["--no-store"]).stdout)
    assert none["meta"]["stored"] is None


def test_track_eval_map_fit_uses_the_profiles_fitted_map(project):
    """``--map fit`` (the default) builds the profile's fitted map through the cached stages and
    keys the study by it; ``--map true`` and a map file give other keys; a rerun is cached."""
    args = ["track-eval", "tiny", "--profile", "tiny.toml", "--trajectories", "1", "--steps", "2",
            "--estimators", "ours,gt", "-o", "ours.optimizer=adam", "-o", "ours.adam_steps=2", "--json"]
    fit = nb(*args)
    assert fit.code == 0, fit.output
    out = json.loads(fit.out)
    fit_maps = list((project / "results" / "cache" / "fit-map").iterdir())
    assert [m.name for m in fit_maps] == [out["meta"]["map_key"]]
    again = json.loads(nb(*args).out)
    assert again["meta"]["cached"] and again["meta"]["study_key"] == out["meta"]["study_key"]
    true = json.loads(nb(*args, "--map", "true").out)
    assert true["meta"]["map_key"] == "true" and true["meta"]["study_key"] != out["meta"]["study_key"]
    from_file = json.loads(nb(*args, "--map", str(fit_maps[0] / "map.npz")).out)
    assert from_file["meta"]["map_key"] not in ("true", out["meta"]["map_key"])
    assert from_file["ours"]["loc_rmse_m_median"] == out["ours"]["loc_rmse_m_median"]  # same map
    missing = nb(*args, "--map", "nope.npz")
    assert missing.code == 2 and "--map" in missing.err and "nope.npz" in missing.err


def test_track_eval_cli_rejects_bad_options(tmp_path, level):
    from navbench.cli.main import app
    from navbench.levelio import save_level

    path = save_level(level, tmp_path / f"{level.name}.json")  # a level file is NAME.json
    result = CliRunner().invoke(app, ["track-eval", str(path), "--trajectories", "1", "--steps", "2",
                                      "--estimators", "dynamics", "-o", "bad-option", "--json"])
    assert result.exit_code != 0
    assert isinstance(result.exception, ConfigError)


def test_no_frame_is_rendered_for_trajectories_only_frameless_estimators_track(level, monkeypatch):
    """dynamics and gt read no frame (issue 36): the camera renders only for the trajectories a
    frame-reading estimator tracks (here no-map, limited to the first of three), and every
    estimate is what it was with every frame rendered (a frame is a function of the pose)."""
    from navbench.sim.camera import RaycastCamera

    cfg = TrackingStudyConfig(trajectories=3, steps=5, estimators=("gt", "dynamics", "no-map"), seed=2,
                              trajectory_limits={"no-map": 1})
    calls = []
    render = RaycastCamera.render
    monkeypatch.setattr(RaycastCamera, "render", lambda self, *a, **k: calls.append(1) or render(self, *a, **k))
    res = run_tracking_study(level, None, cfg)
    assert len(calls) == 6  # trajectory 0 only: its start and its 5 steps
    calls.clear()
    only = run_tracking_study(level, None, TrackingStudyConfig(trajectories=3, steps=5,
                                                              estimators=("gt", "dynamics"), seed=2))
    assert calls == []
    for name in ("gt", "dynamics"):
        assert np.array_equal(only["estimators"][name]["est_poses"], res["estimators"][name]["est_poses"])
