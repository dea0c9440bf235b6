"""evo reads navbench's TUM trajectories (issue 13): its APE RMSE (translation, no alignment)
equals navbench's location RMSE within 1e-6 m, for exported episodes / track-eval studies and
for a track-sequence estimate against the sequence's groundtruth.txt. Runs where evo is
installed (``make setup`` installs it through the test extra)."""

from __future__ import annotations

import pytest

evo_file = pytest.importorskip("evo.tools.file_interface")
evo_metrics = pytest.importorskip("evo.core.metrics")

from tests.bad_input.conftest import nb, project  # noqa: E402,F401 (project: a fixture)


def evo_ape_rmse(gt_path, est_path) -> float:
    from evo.core import sync

    ref = evo_file.read_tum_trajectory_file(str(gt_path))
    est = evo_file.read_tum_trajectory_file(str(est_path))
    ref, est = sync.associate_trajectories(ref, est)
    assert ref.num_poses == est.num_poses
    ape = evo_metrics.APE(evo_metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    return float(ape.get_statistic(evo_metrics.StatisticsType.rmse))


def test_exported_study_trajectories(project):
    res = nb("track-eval", "tiny", "--estimators", "dynamics,gt", "--trajectories", "2",
             "--steps", "30", "--seed", "3")
    assert res.code == 0, res.output
    res = nb("export-trajectories", "out", "--source", "track-eval", "--json")
    assert res.code == 0, res.output
    import json

    files = json.loads(res.out)["files"]
    assert len(files) == 4
    assert max(f["loc_rmse_m"] for f in files) > 1e-3  # dynamics drifts: a real comparison
    for f in files:
        gt = [ln.split()[0] for ln in open(f["gt"])]
        est = [ln.split()[0] for ln in open(f["est"])]
        assert gt == est and len(gt) == 31  # identical timestamps, one per pose
        assert evo_ape_rmse(f["gt"], f["est"]) == pytest.approx(f["loc_rmse_m"], abs=1e-6)


def test_track_sequence_estimate_against_groundtruth(tmp_path):
    from navbench.geometry import HALF_CAMERA
    from navbench.pipeline.tracking import track_sequence
    from navbench.track.sequence import render_walk
    from navbench.worldmodel.tum import export_views
    from tests.pipeline.test_stages import tiny_level

    seq = export_views(render_walk(tiny_level(), 12, HALF_CAMERA, seed=2), tmp_path / "seq")
    r = track_sequence(seq, None, estimator="dynamics", odometry="gt+high", out=tmp_path / "est.txt")
    assert r.ate_m > 1e-3
    assert evo_ape_rmse(seq / "groundtruth.txt", tmp_path / "est.txt") == pytest.approx(r.ate_m, abs=1e-6)

