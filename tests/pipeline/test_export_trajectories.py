"""export-trajectories: stored track-eval trajectories (and episodes) out as TUM pairs, chosen
by level, estimator, noise, task; names, identical timestamps, and the poses read back."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.bad_input.conftest import assert_clean_error, nb, project  # noqa: F401 (fixture)


@pytest.fixture
def study(project):  # noqa: F811
    res = nb("track-eval", "tiny", "--estimators", "dynamics,gt", "--trajectories", "2",
             "--steps", "12", "--seed", "3", "--json")
    assert res.code == 0, res.output
    return project, json.loads(res.out)["meta"]["study_key"]


def test_selection_names_and_timestamps(study):
    from navbench.nav.metrics import location_rmse
    from navbench.pipeline.artifacts import STUDY_FILE, load_study
    from navbench.pipeline.cache import ArtifactStore
    from navbench.worldmodel.tumtraj import read_planar_poses

    project, key = study
    res = nb("export-trajectories", "out", "--estimator", "dynamics", "--task", "1", "--dt", "0.5",
             "--json")
    assert res.code == 0, res.output
    files = json.loads(res.out)["files"]
    assert len(files) == 1
    f = files[0]
    assert f["gt"] == f"out/track-eval/tiny/dynamics_tracking_traj1_seed0_{key[:8]}.gt.txt"
    assert f["est"] == f["gt"].replace(".gt.txt", ".est.txt")
    gt, est = read_planar_poses(project / f["gt"]), read_planar_poses(project / f["est"])
    assert [t for t, _, _ in gt] == [t for t, _, _ in est] == [0.5 * i for i in range(13)]
    s = load_study(ArtifactStore("results/cache").load("track-eval", key) / STUDY_FILE)
    truth = s["trajectories"]["true_poses"][1]
    e = s["estimators"]["dynamics"]
    mine = e["est_poses"][int(np.flatnonzero(e["trajectory"] == 1)[0])]
    np.testing.assert_allclose([p[:2] for _, p, _ in gt], truth[:, :2], atol=2e-9)
    np.testing.assert_allclose([p[:2] for _, p, _ in est], mine[:, :2], atol=2e-9)
    assert f["loc_rmse_m"] == pytest.approx(location_rmse(truth, mine))
    index = (project / "out" / "index.csv").read_text().splitlines()
    assert len(index) == 2 and index[0].startswith("source,level,estimator")


def test_selections_that_match_nothing(study):
    project, _ = study
    for args, names in ((("--level", "house-9"), ("level house-9", "no stored trajectory")),
                        (("--estimator", "ours"), ("estimator ours",)),
                        (("--source", "episodes"), ("source episodes",)),
                        (("--run", "99"), ("--run", "no run with id 99")),
                        (("--task", "7"), ("task 7",))):
        res = nb("export-trajectories", "out", *args)
        assert_clean_error(res, *names)
        assert not (project / "out").exists()


def test_bad_options_and_a_used_directory(study):
    project, _ = study
    assert_clean_error(nb("export-trajectories", "out", "--source", "both"), "--source")
    assert_clean_error(nb("export-trajectories", "out", "--dt", "0"), "--dt")
    assert_clean_error(nb("export-trajectories", "out", "--task", "one"), "--task")
    assert_clean_error(nb("export-trajectories", "out", "--run", "first"), "--run")
    (project / "used").mkdir()
    (project / "used" / "mine.txt").write_text("keep")
    assert_clean_error(nb("export-trajectories", "used"), "used", "not an empty directory")
    assert (project / "used" / "mine.txt").read_text() == "keep"


def test_episodes_by_run_level_estimator_noise(project):  # noqa: F811
    """Two stored episodes (records written as run-navigation writes them); the selection picks
    one, and its files hold the record's true and estimated poses."""
    from navbench.nav.episode import EpisodeRecord
    from navbench.nav.metrics import score_episode
    from navbench.pipeline.artifacts import TRAJ_FILE, save_record
    from navbench.pipeline.cache import ArtifactStore
    from navbench.results.db import ResultsDB, episode_row_from_score
    from navbench.worldmodel.tumtraj import read_planar_poses

    rng = np.random.default_rng(0)
    store = ArtifactStore("results/cache")
    with ResultsDB() as db:
        run = db.start_run("test", "test", {}, "x")
        for i, (est, noise) in enumerate((("ours", "mid"), ("dynamics", "low"))):
            tp = np.cumsum(rng.normal(size=(9, 3)) * 0.05, axis=0)
            rec = EpisodeRecord("tiny", 4, est, noise, 0, tp[0], tp[-1, :2], 1.0, tp,
                                tp + rng.normal(size=tp.shape) * 0.01, np.zeros((8, 3)), False, -1,
                                np.zeros((0, 2)), 0, "reached", {})
            key = f"{i}" * 64
            store.write("episode", key, lambda d, r=rec: save_record(r, d / TRAJ_FILE), config={},
                        inputs={}, version=1)
            meta = {"level": "tiny", "estimator": est, "noise": noise, "seed": 0, "task_id": 4}
            db.add_episodes(run, [episode_row_from_score(f"cell{i}", meta, score_episode(rec), key)])
            if est == "ours":
                wanted = rec
        db.finish_run(run)
    res = nb("export-trajectories", "out", "--run", "latest", "--level", "tiny", "--estimator",
             "ours", "--noise", "mid", "--json")
    assert res.code == 0, res.output
    (f,) = json.loads(res.out)["files"]
    assert f["gt"] == "out/episodes/tiny/ours_mid_task4_seed0_00000000.gt.txt"
    gt, est = read_planar_poses(project / f["gt"]), read_planar_poses(project / f["est"])
    np.testing.assert_allclose([p[:2] for _, p, _ in gt], wanted.true_poses[:, :2], atol=2e-9)
    np.testing.assert_allclose([p[:2] for _, p, _ in est], wanted.est_poses[:, :2], atol=2e-9)
    assert [t for t, _, _ in gt] == [t for t, _, _ in est] == pytest.approx([0.1 * i for i in range(9)])
