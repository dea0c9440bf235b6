"""TUM trajectory files (``timestamp tx ty tz qx qy qz qw``) in and out, and a TUM RGB-D
sequence read for tracking (``navbench track-sequence``, ``export-trajectories``).

A pose line is the **camera-to-world** pose ``T_wc`` of the camera (OpenCV axes: x right, y
down, z forward) in the navbench world frame, quaternion Hamilton scalar last: the convention of
``groundtruth.txt`` in :mod:`navbench.worldmodel.tum`, so a file written here and a sequence's
ground truth compare directly (evo's ``evo_ape tum groundtruth.txt EST.txt``). Written files
are strict: no comments, exactly 8 fields separated by single spaces, one pose per line.

navbench's trackers estimate planar poses ``(x, y, theta)``; a pose read for tracking is refused
when its camera is tilted (or rolled) more than a tolerance from planar, with an error naming
the file and line: it is never flattened silently. Every malformed input is an
:class:`~navbench.errors.ArtifactError` naming the file (and line).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from navbench.errors import ArtifactError
from navbench.geometry import camera_pose
from navbench.worldmodel.tum import (
    _associate,
    _read_groundtruth,
    _read_list,
    _rot_to_quat,
    MAX_TILT_DEG,
    planar_height_tilt,
)
from navbench.worldmodel.views import Views



def pose_line(timestamp: str, T_wc: np.ndarray) -> str:
    """One strict TUM line: ``timestamp tx ty tz qx qy qz qw`` (9 decimals, single spaces)."""
    q = _rot_to_quat(np.asarray(T_wc)[:3, :3])
    return " ".join([str(timestamp), *(f"{v:.9f}" for v in (*np.asarray(T_wc)[:3, 3], *q))])


def format_timestamps(times) -> list[str]:
    """Timestamps as text: strings are kept as given (the input's own digits), numbers get 6
    decimals (TUM's microseconds)."""
    return [t if isinstance(t, str) else f"{float(t):.6f}" for t in times]


def write_trajectory(path, timestamps, poses, camera_height: float) -> Path:
    """Write planar ``poses (N, 3)`` as the camera poses ``camera_pose(pose, camera_height)``,
    one strict TUM line per pose with ``timestamps`` (N strings or numbers)."""
    p = Path(path)
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    ts = format_timestamps(timestamps)
    if len(ts) != len(poses):
        raise ValueError(f"{len(ts)} timestamps for {len(poses)} poses")
    lines = [pose_line(t, camera_pose(pose, camera_height)) for t, pose in zip(ts, poses)]
    from navbench.outpath import write_text_atomic

    try:  # a failed write never leaves half a file at ``path``
        p.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(p, "\n".join(lines) + "\n")
    except OSError as e:
        raise ArtifactError(f"{p}: cannot write the trajectory ({e.strerror or e})") from None
    return p


def check_planar(rows, path: Path, max_tilt_deg: float = MAX_TILT_DEG) -> None:
    """Refuse the first pose of ``rows`` (``(timestamp, T_wc, line)``) whose camera is tilted more
    than ``max_tilt_deg`` from planar (:func:`~navbench.worldmodel.tum.planar_height_tilt`)."""
    for _, T, k in rows:
        tilt = planar_height_tilt(T)[2]
        if tilt > max_tilt_deg:
            raise ArtifactError(
                f"{path}:{k}: the camera is tilted {tilt:.2f} deg from planar (tolerance "
                f"{max_tilt_deg:g} deg); navbench tracks planar poses (x, y, heading) and does "
                f"not flatten 6-DoF ones (--max-tilt to raise the tolerance)")


def read_planar_poses(path, max_tilt_deg: float = MAX_TILT_DEG) -> list[tuple[float, np.ndarray, int]]:
    """A TUM pose file as ``(timestamp, planar pose (3,), line)`` rows, tilt-checked."""
    p = Path(path)
    from navbench.safeio import check_regular_file

    check_regular_file(p, ArtifactError, "TUM pose file")  # missing, a directory, a FIFO: one line
    rows = _read_groundtruth(p)
    if not rows:
        raise ArtifactError(f"{p}: no poses (no data lines)")
    check_planar(rows, p, max_tilt_deg)
    return [(t, planar_height_tilt(T)[0], k) for t, T, k in rows]


@dataclass
class Sequence:
    """A TUM RGB-D sequence read for tracking: its frames and planar ground truth (``views``,
    see :func:`navbench.worldmodel.tum.import_views`) and each kept frame's timestamp as written
    in ``rgb.txt`` (``timestamps``, text) and as a number (``times``)."""

    directory: Path
    views: Views
    timestamps: list[str]
    times: np.ndarray

    def __len__(self) -> int:
        return len(self.views)


def read_sequence(directory, max_tilt_deg: float = MAX_TILT_DEG, max_dt: float = 0.02,
                  read_views=None) -> Sequence:
    """Read a TUM RGB-D directory for tracking: :func:`~navbench.worldmodel.tum.import_views`
    reads and checks the frames (associated within ``max_dt`` s) and refuses a ground-truth pose
    tilted more than ``max_tilt_deg`` (the error names its line), with the fit's tolerances."""
    from navbench.worldmodel.tum import import_views

    d = Path(directory)
    if not d.is_dir():
        raise ArtifactError(f"{d}: no such directory" if not d.exists() else f"{d}: not a directory")
    views = (read_views(d) if read_views is not None
             else import_views(d, max_dt=max_dt, max_tilt_deg=max_tilt_deg))
    times = np.asarray(views.meta.get("timestamps", []), dtype=np.float64)
    rgb_txt = d / "rgb.txt"
    raw = {k: line.split()[0] for k, line in enumerate(rgb_txt.read_text().splitlines(), 1)
           if line.strip() and not line.strip().startswith("#")}
    rows = _read_list(rgb_txt, 1, "timestamp filename")
    stamps, j = [], 0
    for t in times:  # the kept frames are a subsequence of rgb.txt, in its order
        while j < len(rows) and rows[j][0] != t:
            j += 1
        stamps.append(raw[rows[j][2]] if j < len(rows) else f"{t:.6f}")
        j += 1
    if len(views) < 2:
        raise ArtifactError(f"{d}: a sequence to track needs at least 2 frames, got {len(views)}")
    return Sequence(d, views, stamps, times)


def read_odometry(path, times, max_dt: float = 0.02, max_tilt_deg: float = MAX_TILT_DEG) -> np.ndarray:
    """The planar odometry poses ``(N, 3)`` of a TUM pose file at the frame ``times (N,)`` (s):
    each frame takes the pose nearest in time within ``max_dt`` s; a frame without one is an
    error naming the file and the frame. Only differences of consecutive poses are used, so
    the odometry's origin is free."""
    p = Path(path)
    rows = read_planar_poses(p, max_tilt_deg)
    frames = [(float(t),) for t in times]
    match = _associate(frames, rows, max_dt)
    for i, t in enumerate(times):
        if i not in match:
            raise ArtifactError(f"{p}: no odometry pose within {max_dt:g} s of frame {i} "
                                f"(timestamp {float(t):.6f}); the odometry's timestamps must "
                                f"match the sequence's rgb.txt")
    return np.array([rows[match[i]][1] for i in range(len(times))])
