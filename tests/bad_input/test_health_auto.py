"""Bad input to ``ours``'s health threshold (``-o ours.health_min_inliers=...``): one
``error:`` line naming the option and the value."""

from __future__ import annotations

import pytest

from tests.bad_input.conftest import assert_clean_error, nb


@pytest.mark.parametrize("value, shown", [("sometimes", "'sometimes'"), ("1.5", "1.5"), ("true", "True")])
def test_bad_health_threshold(tmp_path, monkeypatch, value, shown):
    from navbench.levelio import save_level
    from tests.track.synth import small_level

    monkeypatch.chdir(tmp_path)
    path = save_level(small_level(), tmp_path / "track-room.json")
    res = nb("track-eval", str(path), "--estimators", "ours", "--map", "true", "--steps", "2",
             "--trajectories", "1", "--no-store", "-o", "ours.health=true",
             "-o", f"ours.health_min_inliers={value}")
    assert_clean_error(res, "health_min_inliers", shown)
