"""Probe (issue 13): ``track-sequence`` with malformed inputs. Each case expects one ``error:``
line naming the file (and line) or option, a non-zero exit, and no estimate written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.bad_input.conftest import assert_clean_error, nb
from tests.bad_input.test_views import TS, make_tum, set_line


@pytest.fixture
def tum(project):
    return make_tum(project.parent / "tum")


def refused(project, *args, names=()):
    res = nb("track-sequence", *args, "--out", "est.txt")
    assert_clean_error(res, *names)
    assert not (project / "est.txt").exists()
    assert not (project / "results" / "sequences").exists()
    return res


def odometry_file(tum: Path, path: Path) -> Path:
    """A valid odometry file: the ground truth's lines, comments dropped."""
    lines = [ln for ln in (tum / "groundtruth.txt").read_text().splitlines() if not ln.startswith("#")]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_ours_without_a_map(project, tum):
    refused(project, tum, names=("--map", "ours"))


def test_no_such_map(project, tum):
    refused(project, tum, "--map", "nothere.npz", names=("--map", "nothere.npz"))


def test_a_file_that_is_not_a_map(project, tum):
    refused(project, tum, "--map", tum / "groundtruth.txt", names=("groundtruth.txt",))


def test_a_cache_key_of_views_is_not_a_map(project, tum):
    from navbench.pipeline.cache import ArtifactStore

    key = "ab" * 32
    ArtifactStore("results/cache").write("collect-views", key, lambda d: (d / "x").write_text("x"),
                                         config={}, inputs={}, version=1)
    refused(project, tum, "--map", key[:10], names=("collect-views", "not a map"))


def test_unknown_estimator_and_noise(project, tum):
    refused(project, tum, "--estimator", "nope", names=("--estimator", "nope"))
    refused(project, tum, "--estimator", "dynamics", "--odometry", "gt+loud", names=("--odometry", "loud"))
    refused(project, tum, "--estimator", "gt", names=("--estimator gt",))


def test_odometry_with_wrong_fields(project, tum):
    odo = odometry_file(tum, project.parent / "odo.txt")
    set_line(odo, 2, f"{TS[1]} 1 2 3 0 0 0")
    refused(project, tum, "--estimator", "dynamics", "--odometry", odo, names=(f"{odo}:2", "8 fields"))


def test_odometry_timestamps_that_do_not_match(project, tum):
    odo = odometry_file(tum, project.parent / "odo.txt")
    set_line(odo, 3, "7.000000 " + " ".join(odo.read_text().splitlines()[2].split()[1:]))
    refused(project, tum, "--estimator", "dynamics", "--odometry", odo, names=(str(odo), "frame 2"))


def test_missing_odometry_file(project, tum):
    refused(project, tum, "--estimator", "dynamics", "--odometry", "odo.txt", names=("odo.txt",))


def test_tilted_ground_truth_is_refused_not_flattened(project, tum):
    from navbench.geometry import camera_pose
    from navbench.worldmodel.tum import _rot_to_quat

    T = camera_pose((1.2, 1.0, 0.3), 0.5)
    c, s = np.cos(np.radians(5)), np.sin(np.radians(5))
    T[:3, :3] = T[:3, :3] @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])  # pitch the camera 5 deg
    q = _rot_to_quat(T[:3, :3])
    set_line(tum / "groundtruth.txt", 3, f"{TS[1]} " + " ".join(f"{v:.9f}" for v in (*T[:3, 3], *q)))
    refused(project, tum, "--estimator", "dynamics", names=("groundtruth.txt:3", "tilted 5 deg"))
    res = nb("track-sequence", tum, "--estimator", "dynamics", "--max-tilt", "6", "--out", "est.txt",
             "--no-store")
    assert res.code == 0, res.output


def test_not_a_directory(project):
    refused(project, "nodir", "--estimator", "dynamics", names=("nodir",))


def test_unknown_estimator_option(project, tum):
    refused(project, tum, "--estimator", "no-map", "-o", "sharpness=3", names=("sharpness",))
    refused(project, tum, "--estimator", "no-map", "-o", "sharpness", names=("--option",))
