"""track-sequence end to end on a sequence navbench renders and exports: the CLI path equals
the Python API path, the estimate file is strict TUM with the input's timestamps, odometry
files drive the trackers, and the row lands in the database."""

from __future__ import annotations

import re

import numpy as np
import pytest

from tests.bad_input.conftest import nb


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    from navbench.geometry import HALF_CAMERA
    from navbench.track.sequence import render_walk
    from navbench.worldmodel.grid import voxelize_level
    from navbench.worldmodel.tum import export_views
    from tests.pipeline.test_stages import tiny_level

    root = tmp_path_factory.mktemp("seq")
    lv = tiny_level()
    views = render_walk(lv, 8, HALF_CAMERA, seed=2)
    seq = export_views(views, root / "seq")
    vmap = voxelize_level(lv)
    vmap.save(root / "map.npz")
    return root, seq, views


def _tum_lines(path):
    return [ln for ln in path.read_text().splitlines()]


def test_cli_equals_api_and_writes_strict_tum(scene, tmp_path, monkeypatch):
    from navbench.results.db import ResultsDB
    from navbench.pipeline.tracking import track_sequence

    root, seq, views = scene
    monkeypatch.chdir(tmp_path)
    api = track_sequence(seq, root / "map.npz", estimator="ours", odometry="gt+mid", seed=2)
    res = nb("track-sequence", seq, "--map", root / "map.npz", "--odometry", "gt+mid", "--seed", "2",
             "--out", "est.txt", "--json", "--db", f"sqlite:///{tmp_path}/t.db")
    assert res.code == 0, res.output
    import json

    out = json.loads(res.out)
    assert out["ate_m"] == pytest.approx(api.ate_m, abs=1e-12)
    assert out["rpe_m"] == pytest.approx(api.rpe_m, abs=1e-12)
    assert api.ate_m < 0.02 < api.odometry_ate_m  # the map corrects the noisy odometry
    lines = _tum_lines(tmp_path / "est.txt")
    gt = [ln for ln in _tum_lines(seq / "groundtruth.txt") if not ln.startswith("#")]
    assert len(lines) == len(gt) == 8
    for ln, g in zip(lines, gt):
        assert re.fullmatch(r"\S+( \S+){7}", ln), ln
        assert ln.split()[0] == g.split()[0]  # the input's timestamps, as written
    # the first pose is given, in the groundtruth's convention (up to its 9 printed decimals)
    np.testing.assert_allclose([float(v) for v in lines[0].split()], [float(v) for v in gt[0].split()],
                               atol=2e-9)
    with ResultsDB(f"sqlite:///{tmp_path}/t.db") as db:
        rows = db.sequence_frame()
    assert len(rows) == 1 and rows.iloc[0]["ate_m"] == pytest.approx(api.ate_m)
    # the same tracking again stores nothing new
    res = nb("track-sequence", seq, "--map", root / "map.npz", "--seed", "2", "--out", "est.txt",
             "--json", "--db", f"sqlite:///{tmp_path}/t.db")
    assert json.loads(res.out)["stored"] == 0


def test_estimate_reads_back_as_the_poses(scene, tmp_path):
    from navbench.pipeline.tracking import track_sequence
    from navbench.worldmodel.tumtraj import read_planar_poses

    root, seq, views = scene
    r = track_sequence(seq, None, estimator="dynamics", odometry="gt+high", out=tmp_path / "e.txt")
    back = np.array([p for _, p, _ in read_planar_poses(tmp_path / "e.txt")])
    np.testing.assert_allclose(back[:, :2], r.est_poses[:, :2], atol=2e-9)
    assert r.ate_m == pytest.approx(r.odometry_ate_m)  # dynamics is dead reckoning


def test_odometry_file_drives_the_tracker(scene, tmp_path):
    """An odometry file holding the ground truth (shifted and rotated: only increments count)
    makes dead reckoning exact."""
    from navbench.pipeline.tracking import track_sequence
    from navbench.worldmodel.tumtraj import write_trajectory

    root, seq, views = scene
    p = views.poses.copy()
    c, s = np.cos(0.7), np.sin(0.7)
    moved = np.stack([c * p[:, 0] - s * p[:, 1] + 3.0, s * p[:, 0] + c * p[:, 1] - 1.0, p[:, 2] + 0.7], 1)
    stamps = [ln.split()[0] for ln in _tum_lines(seq / "rgb.txt") if not ln.startswith("#")]
    write_trajectory(tmp_path / "odo.txt", stamps, moved, views.camera_height)
    r = track_sequence(seq, None, estimator="dynamics", odometry=str(tmp_path / "odo.txt"))
    assert r.ate_m < 1e-8


def test_map_by_cache_key_equals_the_file(scene, tmp_path, monkeypatch):
    """--map KEY (a fit-map / true-map artifact of the cache) tracks on that artifact's map.npz."""
    import json
    import shutil

    from navbench.pipeline.cache import ArtifactStore

    root, seq, views = scene
    monkeypatch.chdir(tmp_path)
    key = "cd" * 32
    ArtifactStore("results/cache").write("true-map", key,
                                         lambda d: shutil.copy(root / "map.npz", d / "map.npz"),
                                         config={}, inputs={}, version=1)
    by_key = nb("track-sequence", seq, "--map", key[:8], "--json", "--no-store", "--out", "a.txt")
    by_file = nb("track-sequence", seq, "--map", root / "map.npz", "--json", "--no-store", "--out", "b.txt")
    assert by_key.code == 0 and by_file.code == 0, by_key.output + by_file.output
    a, b = json.loads(by_key.out), json.loads(by_file.out)
    # one map, one key however it is named: its content hash (the same database row)
    assert a["map_key"] == b["map_key"] != key and a["ate_m"] == b["ate_m"]
    assert (tmp_path / "a.txt").read_text() == (tmp_path / "b.txt").read_text()


def test_intrinsics_on_the_command_line_replace_intrinsics_json(scene, tmp_path, monkeypatch):
    """A TUM directory as the benchmark ships it (no navbench intrinsics.json): --fx/--fy/--cx/
    --cy/--camera-height give the camera, and the tracking equals the one reading the json."""
    import json
    import shutil

    root, seq, views = scene
    monkeypatch.chdir(tmp_path)
    bare = tmp_path / "bare"
    shutil.copytree(seq, bare)
    meta = json.loads((bare / "intrinsics.json").read_text())
    (bare / "intrinsics.json").unlink()
    args = ("--map", root / "map.npz", "--seed", "2", "--json", "--no-store", "--out", "e.txt")
    res = nb("track-sequence", bare, *args)
    assert res.code == 2 and "intrinsics.json" in res.err and "Traceback" not in res.err
    res = nb("track-sequence", bare, *args, "--fx", meta["fx"], "--fy", meta["fy"], "--cx",
             meta["cx"], "--cy", meta["cy"], "--camera-height", meta["camera_height"])
    assert res.code == 0, res.output
    ref = nb("track-sequence", seq, *args)
    assert json.loads(res.out)["ate_m"] == json.loads(ref.out)["ate_m"]
