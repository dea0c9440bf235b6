"""Offline scoring: hand-computed SPL terms, path lengths and RMSEs."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from navbench.nav.metrics import (location_rmse, orientation_rmse, path_length, rmse, score_episode,
                                  spl, spl_term, success)


def test_path_length_3_4_5():
    poses = np.array([[0, 0, 0.0], [3, 0, 0.0], [3, 4, 1.0], [3, 4, 2.0]])  # last: turn in place
    assert path_length(poses) == pytest.approx(7.0)
    assert path_length(poses[:1]) == 0.0


def test_spl_term_and_mean():
    assert spl_term(True, 5.0, 7.0) == pytest.approx(5 / 7)
    assert spl_term(True, 5.0, 4.0) == 1.0  # shorter than optimal (ended early but within 2 L)
    assert spl_term(False, 5.0, 5.0) == 0.0
    scores = [SimpleNamespace(spl_term=v) for v in (1.0, 0.5, 0.0)]
    assert spl(scores) == pytest.approx(0.5)
    assert math.isnan(spl([]))


def test_success_threshold_two_body_lengths():
    assert success((0.39, 0.0), (0.0, 0.0))
    assert not success((0.4, 0.0), (0.0, 0.0))  # "closer than 2 L" is strict


def test_rmse_with_wrapped_angles():
    true = np.array([[0, 0, math.pi - 0.01], [1, 0, -math.pi + 0.02]])
    est = np.array([[0, 0.3, -math.pi + 0.01], [1, 0.4, math.pi - 0.02]])
    assert location_rmse(true, est) == pytest.approx(math.sqrt((0.09 + 0.16) / 2))
    # differences 0.02 and 0.04 rad across the +-pi seam
    assert orientation_rmse(true, est) == pytest.approx(math.degrees(math.sqrt((0.02**2 + 0.04**2) / 2)))
    assert rmse(true, est) == (location_rmse(true, est), orientation_rmse(true, est))


def test_score_episode_from_the_record():
    rec = SimpleNamespace(
        true_poses=np.array([[0, 0, 0.0], [3, 0, 0.0], [3, 4, 0.0]]),
        est_poses=np.array([[0, 0, 0.0], [3, 0, 0.1], [3, 4.2, 0.0]]),
        target=np.array([3.0, 4.3]), optimal_length=5.0, end_reason="reached", collided=False)
    s = score_episode(rec)
    assert s.success and s.steps == 2 and s.path_length == pytest.approx(7.0)
    assert s.spl_term == pytest.approx(5 / 7)
    assert s.loc_rmse_m == pytest.approx(math.sqrt(0.04 / 3))
    assert s.rot_rmse_deg == pytest.approx(math.degrees(math.sqrt(0.01 / 3)))
    assert s.end_reason == "reached" and not s.collided
