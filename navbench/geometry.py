"""Frames, poses and the pinhole camera: the conventions every navbench module shares.

World frame
    Right-handed, metres. ``x`` and ``y`` span the floor plan, ``z`` points up; the floor is the
    plane ``z = 0`` and the ceiling ``z = level.height`` (1.2 m by default). A level occupies the
    box ``[0, width] x [0, depth]`` in ``x, y``.

Planar pose
    ``(x, y, theta)``: the agent's centre in world metres and its heading in radians,
    counter-clockwise from ``+x``. Arrays of poses have shape ``(N, 3)``. Angles are wrapped to
    ``[-pi, pi)`` by :func:`wrap_angle`.

Camera frame (OpenCV)
    ``x`` right, ``y`` down, ``z`` forward along the optical axis. The camera sits
    ``camera_height`` (0.5 m) above the agent's centre, pitch 0, looking along the heading, so
    its axes in the world are ``x_c = (sin t, -cos t, 0)``, ``y_c = (0, 0, -1)``,
    ``z_c = (cos t, sin t, 0)``. ``T_wc`` (4x4) maps camera coordinates to world coordinates.

Pixels
    ``(u, v)`` = (column, row). Pixel ``(i, j)`` (integers, ``0 <= i < W``, ``0 <= j < H``) looks
    along ``K^-1 [i, j, 1]^T`` exactly as the paper's ray ``v = R K^-1 [i j 1]^T``: integer
    coordinates are the sample positions, and :func:`project` returns coordinates in the same
    convention, so bilinear sampling at a projected ``(u, v)`` reads pixel ``(floor u, floor v)``
    and its neighbours.

Images
    RGB ``(H, W, 3)`` float32 in ``[0, 1]``; depth ``(H, W)`` float32 **z-depth** in metres (the
    distance along the optical axis, the ``k`` of the paper's ray ``r = c + k v`` because
    ``v`` has unit ``z``); ``valid`` ``(H, W)`` bool. A pixel that sees nothing within the
    maximum range has ``valid = False`` and depth ``+inf``; consumers must use ``valid``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

#: Agent body length L (m): the agent is a disc of diameter L (paper section 5).
AGENT_LENGTH = 0.2
#: Agent radius (m).
AGENT_RADIUS = AGENT_LENGTH / 2
#: Floor-to-ceiling height of every generated level (m).
LEVEL_HEIGHT = 1.2
#: Camera height above the floor (m).
CAMERA_HEIGHT = 0.5
#: Maximum camera range (m), the paper's n * Delta = 20.
MAX_RANGE = 20.0
#: Shortest ``max_range`` (m) a map fit or a tracker's renderer accepts (issue 34): no depth
#: camera reads nearer (a Kinect from ~0.5 m, a RealSense D435 from ~0.1 m), so a shorter range
#: is a slip (0.001 for 10) that would fit and score a map on no pixel at all.
MIN_RAY_RANGE = 0.1
#: Shortest ray sample spacing (m) of a map's renderer (``meta['step']``, a fit's
#: ``max_range / n_samples``, a tracker's ``step``): 20 000 samples over MAX_RANGE; a map file
#: saying 1e-9 marched 2e10 samples per ray (a hang, issue 34).
MIN_RAY_STEP = 1e-3


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics. ``width``/``height`` in pixels, focal lengths and centre in pixels."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)``."""
        return (self.height, self.width)

    def K(self) -> np.ndarray:
        """3x3 intrinsic matrix (float64)."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def scaled(self, factor: float) -> "Intrinsics":
        """Intrinsics of the image resized by ``factor`` (integer-coordinate convention)."""
        return Intrinsics(
            int(round(self.width * factor)), int(round(self.height * factor)),
            self.fx * factor, self.fy * factor, self.cx * factor, self.cy * factor,
        )


#: The paper's camera (appendix A): 320 x 240, f = 150, centre (160, 120).
PAPER_CAMERA = Intrinsics(320, 240, 150.0, 150.0, 160.0, 120.0)
#: Half resolution, the default for quick runs: 160 x 120, f = 75, centre (80, 60).
HALF_CAMERA = Intrinsics(160, 120, 75.0, 75.0, 80.0, 60.0)
#: The camera presets by name (a profile's ``[views] camera``, ``--camera``).
CAMERAS = {"half": HALF_CAMERA, "paper": PAPER_CAMERA}
#: Their names, in the order choices are listed and benchmarks are run; the one definition
#: every check of a camera name reads.
CAMERA_NAMES = tuple(CAMERAS)


def camera_by_name(name: str) -> Intrinsics:
    """Return a named camera (``paper`` or ``half``)."""
    from navbench.errors import ConfigError

    try:
        return CAMERAS[name]
    except KeyError:
        raise ConfigError(f"unknown camera {name!r}; choose one of {sorted(CAMERAS)}") from None


class Frame(NamedTuple):
    """One RGB-D observation (see the module docstring for units)."""

    rgb: np.ndarray  # (H, W, 3) float32 in [0, 1]
    depth: np.ndarray  # (H, W) float32 z-depth, metres; +inf where invalid
    valid: np.ndarray  # (H, W) bool


def wrap_angle(a):
    """Wrap angle(s) in radians to ``[-pi, pi)``."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def camera_rotation(theta: float) -> np.ndarray:
    """``R_wc`` (3x3): camera-frame vectors to world-frame vectors for heading ``theta``."""
    c, s = math.cos(theta), math.sin(theta)
    # columns: x_c (right), y_c (down), z_c (forward) expressed in the world frame
    return np.array([[s, 0.0, c], [-c, 0.0, s], [0.0, -1.0, 0.0]])


def camera_pose(pose, camera_height: float = CAMERA_HEIGHT) -> np.ndarray:
    """``T_wc`` (4x4 float64) of the camera mounted on planar pose ``(x, y, theta)``."""
    x, y, theta = (float(v) for v in pose)
    T = np.eye(4)
    T[:3, :3] = camera_rotation(theta)
    T[:3, 3] = (x, y, camera_height)
    return T


def pixel_rays(intr: Intrinsics) -> np.ndarray:
    """Camera-frame ray directions ``K^-1 [i, j, 1]`` for every pixel, shape ``(H, W, 3)``.

    The third component is 1, so a point at z-depth ``d`` along the ray is ``d * ray``.
    """
    i = np.arange(intr.width, dtype=np.float64)
    j = np.arange(intr.height, dtype=np.float64)
    u, v = np.meshgrid(i, j)  # (H, W)
    return np.stack([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, np.ones_like(u)], axis=-1)


def backproject(depth: np.ndarray, intr: Intrinsics) -> np.ndarray:
    """Camera-frame 3D points ``(H, W, 3)`` from a z-depth image ``(H, W)``."""
    return pixel_rays(intr) * np.asarray(depth, dtype=np.float64)[..., None]


def project(points: np.ndarray, intr: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """Project camera-frame points ``(..., 3)`` to pixel coordinates ``(u, v)`` (float arrays)."""
    p = np.asarray(points, dtype=np.float64)
    z = p[..., 2]
    return intr.fx * p[..., 0] / z + intr.cx, intr.fy * p[..., 1] / z + intr.cy


def transform_points(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 4x4 rigid transform to points ``(..., 3)``."""
    p = np.asarray(points, dtype=np.float64)
    return p @ T[:3, :3].T + T[:3, 3]


def world_points(pose, depth: np.ndarray, intr: Intrinsics,
                 camera_height: float = CAMERA_HEIGHT) -> np.ndarray:
    """World-frame 3D points ``(H, W, 3)`` seen at ``depth`` from the camera on ``pose``."""
    return transform_points(camera_pose(pose, camera_height), backproject(depth, intr))
