"""localize-eval's query sampling: ``trajectory`` (RNR-Map C.2: views along the tracking
trajectories) is deterministic, takes its poses from the recorded trajectories, and a wrong name
is a one-line error."""

from __future__ import annotations

import numpy as np
import pytest

from navbench.errors import ConfigError
from navbench.geometry import HALF_CAMERA
from navbench.pipeline.stages.localize import (TRAJECTORY_STEPS, VIEWS_PER_TRAJECTORY, LocalizeEvalConfig,
                                               draw_queries)
from navbench.track.study import record_trajectories
from tests.localize.worlds import room


def test_trajectory_queries_are_views_along_the_trajectories():
    level = room()
    a = list(draw_queries(level, 12, 3, 0.1, HALF_CAMERA, sampling="trajectory"))
    b = list(draw_queries(level, 12, 3, 0.1, HALF_CAMERA, sampling="trajectory"))
    assert len(a) == 12
    for (pa, fa, _), (pb, fb, _) in zip(a, b):
        np.testing.assert_array_equal(pa, pb)
        np.testing.assert_array_equal(fa.depth, fb.depth)
    trs = record_trajectories(level, 2, TRAJECTORY_STEPS, "tracking", 3)
    for n, (pose, _, _) in enumerate(a):
        poses = trs[n // VIEWS_PER_TRAJECTORY].true_poses[1:]
        assert np.min(np.abs(poses - pose).max(axis=1)) == 0.0  # a pose of its trajectory
    uniform = [p for p, _, _ in draw_queries(level, 12, 3, 0.1, HALF_CAMERA)]
    assert not any(np.array_equal(p, q) for p in uniform for q, _, _ in a)


def test_unknown_sampling_is_a_config_error():
    with pytest.raises(ConfigError, match="--sampling"):
        LocalizeEvalConfig(sampling="grid").resolved()
