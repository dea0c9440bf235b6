"""An estimator's update() output (P-001 of the third probe): whatever an estimator returns is
read through one check (:func:`navbench.track.registry.checked_pose`) in every loop that calls
``update`` (navigation episodes, image-goal episodes, the tracking study, track-sequence, the
online-mapping wrapper). A NaN pose or something that is no pose fails in one line naming the
estimator (a plugin: its entry point and distribution) and the step, never a database
constraint message or a traceback, and nothing is stored."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from navbench.errors import TrackingError
from tests.bad_input.conftest import assert_clean_error, db_row_counts, nb_subprocess

PLUGIN = '''
import numpy as np


class NanEst:
    uses_frames = False
    uses_map = False
    options = None

    def __init__(self, **kw):
        self.pose = None
        self.last_timing = {}

    def reset(self, pose0, frame0=None):
        self.pose = np.asarray(pose0, float)

    def update(self, control, frame=None, true_pose=None):
        return np.array([np.nan, 0.0, 0.0])


class WordEst(NanEst):
    def update(self, control, frame=None, true_pose=None):
        return "here"


class InfEst(NanEst):
    def update(self, control, frame=None, true_pose=None):
        return np.array([np.inf, 1.0, 0.0])


class RaiseEst(NanEst):
    def update(self, control, frame=None, true_pose=None):
        raise RuntimeError("plugin bug")


class NoTimingEst(NanEst):
    def __init__(self, **kw):
        self.pose = None

    def update(self, control, frame=None, true_pose=None):
        return np.asarray(self.pose)


class ShortEst(NanEst):
    def update(self, control, frame=None, true_pose=None):
        return [1.0, 2.0]
'''


@pytest.fixture
def plugin_env(tmp_path):
    """A real distribution ``probeplug 0.1`` on PYTHONPATH with three broken estimators."""
    d = tmp_path / "plug"
    (d / "probeplug-0.1.dist-info").mkdir(parents=True)
    (d / "probeplug-0.1.dist-info" / "METADATA").write_text("Metadata-Version: 2.1\nName: probeplug\nVersion: 0.1\n")
    (d / "probeplug-0.1.dist-info" / "entry_points.txt").write_text(
        "[navbench.estimators]\nnanest = probeplug:NanEst\nwordest = probeplug:WordEst\n"
        "shortest = probeplug:ShortEst\ninfest = probeplug:InfEst\nraiseest = probeplug:RaiseEst\n"
        "notiming = probeplug:NoTimingEst\nexitest = exitplug:Est\n")
    (d / "probeplug.py").write_text(PLUGIN)
    (d / "exitplug.py").write_text("import sys\nsys.exit(0)\n")
    root = Path(__file__).resolve().parents[2]
    return {"PYTHONPATH": os.pathsep.join([str(root), str(d)])}


@pytest.mark.parametrize("est, shown", [
    ("nanest", "returned a non-finite pose [nan, 0.0, 0.0]"),
    ("infest", "returned a non-finite pose [inf, 1.0, 0.0]"),  # P-003: was stored and scored
    ("wordest", "returned 'here', not a pose"),
    ("shortest", "returned [1.0, 2.0], not a pose"),
])
def test_a_plugin_returning_no_pose_fails_navigation_in_one_line_naming_it(project, plugin_env, est, shown):
    res = nb_subprocess("run-navigation", "--profile", "tiny.toml", "--estimators", est,
                        "--set", "navigation.map=true", cwd=project, env=plugin_env, timeout=300)
    assert res.code == 2, res.output
    assert_clean_error(res, f"plugin {est!r}", "from probeplug 0.1", "update() at step 1", shown)
    assert "database" not in res.err and "constraint" not in res.err
    assert db_row_counts(project).get("results/navbench.db:episodes", 0) == 0


def test_a_plugin_returning_nan_fails_track_eval_in_one_line(tmp_path, plugin_env):
    from navbench.levelio import save_level
    from tests.track.synth import small_level

    save_level(small_level(), tmp_path / "track-room.json")
    res = nb_subprocess("track-eval", "track-room.json", "--estimators", "nanest", "--steps", "3",
                        "--trajectories", "1", cwd=tmp_path, env=plugin_env, timeout=300)
    assert res.code == 2, res.output
    assert_clean_error(res, "plugin 'nanest'", "update() at step 1", "non-finite pose")
    assert all(n == 0 for k, n in db_row_counts(tmp_path).items() if "track" in k), db_row_counts(tmp_path)


def test_a_plugin_returning_inf_fails_track_sequence_and_stores_no_row(project, plugin_env):
    """P-009: track-sequence stored a row (ATE NULL) for an estimator with no finite pose."""
    from navbench.geometry import Intrinsics
    from navbench.levelio import load_level
    from navbench.worldmodel.grid import grid_for_level, voxelize_level
    from navbench.worldmodel.tum import export_views
    from navbench.worldmodel.views import collect_views

    lv = load_level(project / "levels" / "tiny.json")
    export_views(collect_views(lv, 4, Intrinsics(16, 12, 7.5, 7.5, 8.0, 6.0), seed=0), project / "seq")
    voxelize_level(lv, grid_for_level(lv, shape=(16, 12, 6))).save(project / "map.npz")
    res = nb_subprocess("track-sequence", "seq", "--map", "map.npz", "--estimator", "infest",
                        "--out", "e.txt", cwd=project, env=plugin_env, timeout=300)
    assert res.code == 2, res.output
    assert_clean_error(res, "plugin 'infest'", "non-finite pose [inf, 1.0, 0.0]")
    assert not (project / "e.txt").exists()
    assert db_row_counts(project).get("results/navbench.db:sequence_tracking", 0) == 0


@pytest.mark.parametrize("command, est, shown", [
    ("run-navigation", "raiseest", "update() raised RuntimeError: plugin bug"),    # P-014
    ("track-eval", "raiseest", "update() raised RuntimeError: plugin bug"),        # P-012
    ("run-navigation", "notiming", "update() left no last_timing dict"),
    ("track-eval", "exitest", "failed to load: SystemExit"),                      # P-015: was rc 0, silent
])
def test_a_plugin_that_raises_is_one_line_naming_it(project, plugin_env, command, est, shown):
    """A plugin's own bug (an exception in update(), sys.exit() at import, an update() that
    leaves no last_timing) is one line naming the plugin and the method, exit 2, as a plugin
    failing at import already was; no episode stored."""
    args = (["run-navigation", "--profile", "tiny.toml", "--set", "navigation.map=true"]
            if command == "run-navigation" else
            ["track-eval", "tiny", "--map", "true", "--steps", "3", "--trajectories", "1", "--no-store"])
    res = nb_subprocess(*args, "--estimators", est, cwd=project, env=plugin_env, timeout=300)
    assert res.code == 2, res.output
    assert_clean_error(res, f"plugin {est!r}", "from probeplug 0.1", shown)
    assert db_row_counts(project).get("results/navbench.db:episodes", 0) == 0


class _Bad:
    name = "bad"
    uses_frames = True
    uses_map = False
    last_timing: dict = {}

    def __init__(self, out):
        self.out, self.pose = out, None

    def reset(self, pose0, frame0=None):
        self.pose = np.asarray(pose0, float)

    def update(self, control, frame=None, true_pose=None):
        return self.out


@pytest.mark.parametrize("out, shown", [
    (np.array([0.0, np.inf, 0.0]), "non-finite pose"), (None, "None, not a pose"),
    (np.zeros(4), "not a pose"), ({"x": 1}, "not a pose"),
])
def test_track_frames_and_online_mapping_read_update_through_the_check(out, shown):
    """track-sequence's loop and the online-mapping wrapper (which would fuse the NaN pose into
    its map before returning it) refuse the same outputs; a good pose passes unchanged."""
    from navbench.geometry import HALF_CAMERA
    from navbench.track.registry import checked_pose
    from navbench.track.sequence import frame_at, track_frames
    from navbench.track.slam import OnlineMapping
    from navbench.worldmodel.fusion import FusedMap
    from navbench.worldmodel.grid import grid_for_level
    from navbench.worldmodel.views import collect_views
    from tests.track.synth import small_level

    views = collect_views(small_level(), 3, HALF_CAMERA, seed=0)
    with pytest.raises(TrackingError, match=rf"estimator 'bad': update\(\) at step 1 returned .*{shown}"):
        track_frames(_Bad(out), views, views.poses[0], np.zeros((2, 3)))
    lv = small_level()
    online = OnlineMapping(_Bad(out), FusedMap.empty(grid_for_level(lv, shape=(20, 16, 6))), HALF_CAMERA)
    online.reset(np.asarray(views.poses[0]), frame_at(views, 0))
    with pytest.raises(TrackingError, match=shown):
        online.update(None, frame_at(views, 1))
    good = checked_pose(_Bad(None), [1, 2, 3], 1)
    assert good.dtype == np.float64 and good.tolist() == [1.0, 2.0, 3.0]
