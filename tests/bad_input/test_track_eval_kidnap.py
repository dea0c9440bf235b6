"""Bad input to track-eval's issue-14 options: one ``error:`` line naming the option."""

from __future__ import annotations

import pytest

from tests.bad_input.conftest import assert_clean_error, nb


@pytest.mark.parametrize("args, names", [
    (["--kidnap-every", "0"], ["--kidnap-every", "0"]),
    (["--kidnap-every", "-3"], ["--kidnap-every", "-3"]),
    (["--kidnap-every", "5", "--odometry", "world"], ["--kidnap-every", "--odometry body"]),
    (["--odometry", "gyro"], ["--odometry", "gyro"]),
    (["--noise", "loud"], ["--noise", "loud"]),
])
def test_bad_kidnap_and_odometry_options(tmp_path, monkeypatch, args, names):
    monkeypatch.chdir(tmp_path)
    res = nb("track-eval", "house-1", "--estimators", "dynamics", "--steps", "3",
             "--trajectories", "1", "--no-store", *args)
    assert_clean_error(res, *names)
    assert not (tmp_path / "results").exists()  # refused before anything ran


def test_unknown_relocalizer_is_refused_before_tracking(tmp_path, monkeypatch):
    from tests.track.synth import small_level
    from navbench.levelio import save_level

    monkeypatch.chdir(tmp_path)
    path = save_level(small_level(), tmp_path / "track-room.json")
    res = nb("track-eval", str(path), "--estimators", "ours", "--map", "true", "--steps", "3",
             "--trajectories", "1", "--no-store", "-o", "ours.recover=true", "-o", "ours.relocalizer_name=magic")
    assert_clean_error(res, "relocalizer", "magic")


def test_kidnap_every_that_leaves_no_room_for_a_kidnap_is_refused_before_anything_is_cached(tmp_path, monkeypatch):
    """Issue 34: --kidnap-every 3 with 6 steps fitted no kidnap, cached a study holding an object
    array and failed on every rerun. Refused up front now (a kidnap needs 5 steps after it)."""
    monkeypatch.chdir(tmp_path)
    for _ in range(2):  # the rerun says the same, nothing was cached in between
        res = nb("track-eval", "house-1", "--estimators", "dynamics", "--steps", "6",
                 "--trajectories", "2", "--kidnap-every", "3")
        assert_clean_error(res, "--kidnap-every 3", "--steps 6", "--steps >= 8")
        assert not (tmp_path / "results" / "cache" / "track-eval").exists()


def test_the_shortest_kidnap_run_stores_a_study_that_loads(tmp_path, monkeypatch):
    """--steps = kidnap_every + 5: one kidnap per trajectory; the study loads back (no object
    array), and a rerun is a cache hit."""
    monkeypatch.chdir(tmp_path)
    args = ("track-eval", "house-1", "--estimators", "dynamics", "--steps", "8", "--trajectories",
            "2", "--kidnap-every", "3", "--no-store")
    first = nb(*args)
    assert first.code == 0, first.output
    from navbench.pipeline.artifacts import STUDY_FILE, load_study

    (study,) = (tmp_path / "results" / "cache" / "track-eval").glob(f"*/{STUDY_FILE}")
    kid = load_study(study)["trajectories"]["kidnapped"]
    assert kid.dtype == bool and kid.shape == (2, 9) and kid[:, 3].all() and kid.sum() == 2
    assert nb(*args).code == 0
