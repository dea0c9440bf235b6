"""Issue 35 §3: ``navbench render-sequence`` (a continuous walk as TUM RGB-D) and track-sequence's
warning for frames that are no sequence (collect-views' independently sampled poses)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.geometry import AGENT_RADIUS, wrap_angle
from navbench.sim.dynamics import MAX_STEP, MAX_TURN
from tests.bad_input.conftest import assert_clean_error, nb, project  # noqa: F401


def test_planner_walk_is_continuous_free_and_seeded():
    from navbench.levelio import load_level
    from navbench.sim.world import CollisionWorld
    from navbench.track.sequence import planner_walk

    from pathlib import Path

    level = load_level(Path(__file__).resolve().parents[2] / "levels" / "house-1.json")
    poses = planner_walk(level, 400, seed=3)
    assert poses.shape == (400, 3)
    d = np.diff(poses, axis=0)
    assert np.hypot(d[:, 0], d[:, 1]).max() <= MAX_STEP + 1e-9  # one step of the dynamics per frame
    assert np.abs(wrap_angle(d[:, 2])).max() <= MAX_TURN + 1e-9
    assert np.hypot(d[:, 0], d[:, 1]).sum() > 20  # it goes somewhere: task to task
    world = CollisionWorld(level)
    assert min(world.clearance(p[:2]) for p in poses) >= AGENT_RADIUS  # the disc never touches a wall
    assert np.array_equal(poses, planner_walk(level, 400, seed=3))
    assert not np.array_equal(poses, planner_walk(level, 400, seed=4))


def test_render_then_track_is_a_small_ate_and_uniform_views_warn(project):
    res = nb("render-sequence", "tiny", "seq", "--frames", "40", "--noise", "mid")
    assert res.code == 0, res.output
    seq = project / "seq"
    for f in ("rgb.txt", "depth.txt", "groundtruth.txt", "intrinsics.json", "odometry.txt"):
        assert (seq / f).is_file(), f
    assert len(list((seq / "rgb").iterdir())) == 40
    res = nb("track-sequence", "seq", "--estimator", "no-map", "--odometry", "seq/odometry.txt",
             "--no-store", "--json")
    assert res.code == 0, res.output
    import json

    s = json.loads(res.out)
    assert s["frames"] == 40 and s["ate_m"] < 0.05 < s["odometry_ate_m"]
    assert "warning" not in res.err
    # collect-views' views exported as a "sequence": the poses jump, track-sequence says so
    res = nb("collect-views", "tiny", "--profile", "tiny.toml", "--count", "12")
    assert res.code == 0, res.output
    key = res.out.split("key ")[1].split()[0]
    assert nb("export-views", key, "uni").code == 0
    res = nb("track-sequence", "uni", "--estimator", "no-map", "--odometry", "gt+mid", "--no-store")
    assert res.code == 0, res.output
    warnings = [ln for ln in res.err.splitlines() if ln.startswith("warning:")]
    assert len(warnings) == 1 and "median motion between frames" in warnings[0]


@pytest.mark.parametrize("args,names", [
    (["tiny", "seq", "--walk", "plannr"], ["--walk plannr", "did you mean 'planner'"]),
    (["tiny", "seq", "--noise", "medium"], ["--noise medium", "mid"]),
    (["tiny", "seq", "--camera", "full"], ["--camera full", "half"]),
    (["tinny", "seq"], ["did you mean 'tiny'"]),
    (["tiny", "tiny.toml"], ["OUT tiny.toml"]),
    (["tiny", "levels"], ["OUT levels", "not empty"]),
])
def test_render_sequence_bad_arguments(project, args, names):
    res = nb("render-sequence", *args)
    assert_clean_error(res, *names)
    assert not (project / "seq").exists()
