"""Probe (issue 14): bad input to localize-eval and make-level --changed-from is one line."""

from __future__ import annotations

import numpy as np

from tests.bad_input.conftest import assert_clean_error, assert_usage_error, nb


def test_unknown_change_difficulty(project):
    assert_clean_error(nb("localize-eval", "tiny", "--map", "true", "--changes", "OC9"), "--changes")


def test_missing_map_file(project):
    assert_clean_error(nb("localize-eval", "tiny", "--map", "nope.npz"), "--map")


def test_zero_queries(project):
    assert_usage_error(nb("localize-eval", "tiny", "--map", "true", "--queries", "0"), "--queries")


def test_empty_map_file(project):
    from navbench.worldmodel.grid import GridSpec, VoxelMap, save_map

    spec = GridSpec((0.0, 0.0, 0.0), (3.0, 3.0, 1.2), (12, 12, 4))
    save_map(VoxelMap(spec, np.zeros(spec.shape, np.float32), np.zeros((*spec.shape, 3), np.float32), 0.5, {}),
             project / "empty.npz")
    assert_clean_error(nb("localize-eval", "tiny", "--map", "empty.npz", "--no-store"), "empty map")


def test_changed_from_bad_inputs(project):
    assert_clean_error(nb("make-level", "x", "--seed", "1", "--changed-from", "nope", "--changes", "2"), "nope")
    assert_clean_error(nb("make-level", "x", "--seed", "1", "--changed-from", "tiny", "--changes", "99"),
                       "--changes")
    assert_clean_error(nb("make-level", "x", "--seed", "1", "--changed-from", "tiny"), "--changes")


def test_bad_localizer_options(project):
    assert_clean_error(nb("localize-eval", "tiny", "--map", "true", "-o", "nope=1"), "nope")
    assert_clean_error(nb("localize-eval", "tiny", "--map", "true", "-o", "bins=abc"), "bins")
    assert_clean_error(nb("localize-eval", "tiny", "--map", "true", "-o", "bins"), "--option")
    assert_clean_error(nb("localize-eval", "tiny", "--map", "true", "-o", "robust_tau=0"), "robust_tau")
    assert_clean_error(nb("localize-eval", "tiny", "--map", "true", "-o", "robust_after=-1"), "robust_after")


def test_a_typod_level_is_an_error_not_a_generated_level(project, tmp_path):
    """Neither localize-eval nor track-eval generates a level it has no file or seed for."""
    for cmd in (("localize-eval", "tyop", "--map", "true", "--queries", "2"),
                ("track-eval", "tyop", "--map", "true", "--trajectories", "1", "--steps", "2")):
        res = nb(*cmd)
        assert_clean_error(res, "tyop", "make-level")
        assert not (project / "levels" / "tyop.json").exists()


def test_unknown_query_sampling(project):
    assert_clean_error(nb("localize-eval", "tiny", "--map", "true", "--sampling", "random"), "--sampling")
