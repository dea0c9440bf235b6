"""Tracking and mapping together (issue 15 section 3): ``ours`` on the map it builds."""

from __future__ import annotations

import json

import numpy as np
import pytest

from navbench.errors import ConfigError
from navbench.geometry import HALF_CAMERA
from navbench.sim.dynamics import Control
from navbench.track.slam import OnlineMapping, check_online, online_estimator
from navbench.track.study import TrackingStudyConfig, record_trajectories, run_tracking_study
from navbench.worldmodel.fusion import FusedMap
from navbench.worldmodel.grid import grid_for_level

from .synth import small_level


@pytest.fixture(scope="module")
def level():
    return small_level()


def replay(est, level, traj):
    from navbench.sim.camera import RaycastCamera

    cam = RaycastCamera(level, HALF_CAMERA)
    est.reset(traj.start.copy(), cam.render(traj.start))
    out = [traj.start.copy()]
    for t, u in enumerate(traj.controls):
        out.append(est.update(Control(*u), cam.render(traj.true_poses[t + 1]), None))
    return np.array(out)


def test_ours_tracks_and_maps_from_an_empty_map(level):
    traj = record_trajectories(level, 1, 40, noise="mid", seed=2)[0]
    est = online_estimator("ours", FusedMap.empty(grid_for_level(level, (100, 80, 20))), HALF_CAMERA)
    assert isinstance(est, OnlineMapping) and est.name == "ours"
    est_poses = replay(est, level, traj)
    # the map grew from the start frame, one fused frame per step, at the estimates
    assert est.fused.frames == 41 and est.fused.seen.mean() > 0.2
    assert set(est.last_timing) >= {"render", "estimate", "fuse"}
    assert est.last_timing["estimate"] >= est.last_timing["fuse"] > 0
    ate = float(np.sqrt(np.mean(np.sum((est_poses[:, :2] - traj.true_poses[:, :2]) ** 2, axis=1))))
    from navbench.track.kidnap import dead_reckoning

    raw = dead_reckoning(traj.start, traj.controls, traj.true_poses)
    raw_ate = float(np.sqrt(np.mean(np.sum((raw[:, :2] - traj.true_poses[:, :2]) ** 2, axis=1))))
    assert ate < 0.05 and ate < 0.5 * raw_ate, (ate, raw_ate)
    # reset: the map starts again from the new start frame alone
    from navbench.sim.camera import RaycastCamera

    seen = est.fused.seen.sum()
    est.reset(traj.start.copy(), RaycastCamera(level, HALF_CAMERA).render(traj.start))
    assert est.fused.frames == 1 and 0 < est.fused.seen.sum() < seen


def test_study_with_an_online_map_is_deterministic_and_leaves_other_estimators_alone(level):
    cfg = TrackingStudyConfig(trajectories=2, steps=12, estimators=("ours", "no-map", "dynamics"),
                              noise="mid", seed=4)
    empty = FusedMap.empty(grid_for_level(level, (100, 80, 20)))
    a = run_tracking_study(level, empty, cfg)
    b = run_tracking_study(level, empty, cfg)
    assert not empty.seen.any()  # every run maps on its own copy
    for name in cfg.estimators:
        assert np.array_equal(a["estimators"][name]["est_poses"], b["estimators"][name]["est_poses"])
    plain = run_tracking_study(level, None, TrackingStudyConfig(
        trajectories=2, steps=12, estimators=("no-map", "dynamics"), noise="mid", seed=4))
    for name in ("no-map", "dynamics"):
        assert np.array_equal(a["estimators"][name]["est_poses"], plain["estimators"][name]["est_poses"])
    assert np.all(a["estimators"]["ours"]["loc_rmse_m"] < 0.05)


def test_estimators_that_ignore_the_renderer_are_refused():
    with pytest.raises(ConfigError, match="emission"):
        check_online("emission")
    check_online("ours")


def test_track_eval_map_online_cli(tmp_path, level, monkeypatch):
    from typer.testing import CliRunner

    from navbench.cli.main import app
    from navbench.levelio import save_level

    monkeypatch.chdir(tmp_path)
    path = save_level(level, tmp_path / f"{level.name}.json")
    common = ["track-eval", str(path), "--trajectories", "1", "--steps", "6", "--json",
              "--estimators", "ours,dynamics", "--noise", "mid", "--no-store"]
    args = [*common, "--map", "online"]
    first = CliRunner().invoke(app, args)
    assert first.exit_code == 0, first.output
    out = json.loads(first.stdout)
    assert out["meta"]["map"] == "online" and out["meta"]["map_key"].startswith("online-")
    assert out["ours"]["runs"] == 1 and out["ours"]["loc_rmse_m_median"] < 0.05
    again = json.loads(CliRunner().invoke(app, args).stdout)
    assert again["meta"]["cached"] and again["meta"]["study_key"] == out["meta"]["study_key"]
    # another map is another study
    true = json.loads(CliRunner().invoke(app, [*common, "--map", "true"]).stdout)
    assert true["meta"]["study_key"] != out["meta"]["study_key"]
