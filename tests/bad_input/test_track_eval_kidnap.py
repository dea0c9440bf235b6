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
