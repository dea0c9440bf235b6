"""Correlative scan matching of a view's horizon row (the localiser's wide-basin start in changed rooms).

The camera is planar-mounted, so the pixels of the image row through the principal point
(``y_c = 0``) see the world at the camera's height: a 2D range scan. Its points, moved by a
planar pose, should land on the map's occupied cells *at that height* (the world model's
``occupancy_slice("slice", height=camera_height)``). A **likelihood field**
(:func:`likelihood_field`: the distance to the free/occupied boundary, truncated at ``trunc``) scores
a pose by the mean truncated distance of the scan's points (:func:`field_cost`); furniture that was
added, moved or removed costs each point at most ``trunc``. :func:`match_scan` evaluates every pose
of a local grid around a start (positions every ``step`` m within ``radius``, headings every
``deg_step`` degrees within ``max_deg``: Olson's correlative scan matching, exhaustive, so its basin
is the grid rather than a linearisation's) and returns the best. Math layer: arrays in, arrays out.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy import ndimage

from navbench.geometry import Frame, Intrinsics, camera_pose


def horizon_scan(frame: Frame, intr: Intrinsics, camera_height: float, max_range: float = 8.0,
                 stride: int = 1) -> np.ndarray:
    """``(N, 2)`` points of ``frame``'s row through the principal point (every ``stride``-th
    valid pixel nearer than ``max_range``), in the robot's planar frame (metres; the planar pose
    ``(0, 0, 0)`` maps them to the world)."""
    v = int(round(intr.cy))
    if not 0 <= v < intr.height:
        return np.zeros((0, 2))
    z = np.asarray(frame.depth, np.float64)[v, ::stride]
    ok = np.asarray(frame.valid, bool)[v, ::stride] & np.isfinite(z) & (z > 0) & (z < max_range)
    u = np.arange(intr.width, dtype=np.float64)[::stride][ok]
    rays = np.stack([(u - intr.cx) / intr.fx, np.zeros_like(u), np.ones_like(u)], axis=1) * z[ok, None]
    T = camera_pose((0.0, 0.0, 0.0), camera_height)
    return rays @ T[:2, :3].T + T[:2, 3]


def likelihood_field(occ2d: np.ndarray, xs: np.ndarray, ys: np.ndarray, trunc: float) -> np.ndarray:
    """``(nx, ny)`` float32: each cell's distance (m) to the boundary between free and occupied
    cells of ``occ2d`` (a free cell: its distance to the nearest occupied cell less half a cell;
    an occupied one: to the nearest free cell less half a cell), at most ``trunc`` (cells off the
    raster: ``trunc``, see :func:`field_cost`)."""
    occ2d = np.asarray(occ2d, bool)
    if not occ2d.any() or occ2d.all():
        return np.full(occ2d.shape, trunc, np.float32)
    sampling = (float(xs[1] - xs[0]), float(ys[1] - ys[0]))
    half = 0.5 * min(sampling)
    out_d = ndimage.distance_transform_edt(~occ2d, sampling=sampling)  # 0 on occupied cells
    in_d = ndimage.distance_transform_edt(occ2d, sampling=sampling)    # 0 on free cells
    d = np.where(occ2d, in_d, out_d) - half
    return np.clip(d, 0.0, trunc).astype(np.float32)


@njit(cache=True, fastmath=True)
def _cost(field, x0, y0, cell, trunc, pts, x, y, c, s):
    n = pts.shape[0]
    nx, ny = field.shape
    acc = 0.0
    for k in range(n):
        wx = x + c * pts[k, 0] - s * pts[k, 1]
        wy = y + s * pts[k, 0] + c * pts[k, 1]
        fx = (wx - x0) / cell
        fy = (wy - y0) / cell
        i = int(math.floor(fx))
        j = int(math.floor(fy))
        if 0 <= i < nx - 1 and 0 <= j < ny - 1:  # bilinear between the four cell centres
            a = fx - i
            b = fy - j
            acc += ((1 - a) * ((1 - b) * field[i, j] + b * field[i, j + 1])
                    + a * ((1 - b) * field[i + 1, j] + b * field[i + 1, j + 1]))
        else:
            acc += trunc
    return acc / max(n, 1)


def field_cost(field: np.ndarray, xs: np.ndarray, ys: np.ndarray, trunc: float, pts: np.ndarray,
               pose) -> float:
    """Mean truncated distance of the scan ``pts (N, 2)`` moved by planar ``pose`` (bilinear
    between cell centres; off the raster: ``trunc``)."""
    x, y, th = (float(v) for v in pose)
    return float(_cost(field, float(xs[0]), float(ys[0]), float(xs[1] - xs[0]), float(trunc),
                       np.ascontiguousarray(pts, np.float64), x, y, math.cos(th), math.sin(th)))


@njit(cache=True, fastmath=True)
def _match(field, x0, y0, cell, trunc, pts, px, py, pth, radius, step, max_rad, rad_step):
    nr = int(math.floor(radius / step + 1e-9))
    na = int(math.floor(max_rad / rad_step + 1e-9))
    best = np.inf
    bx, by, bth = px, py, pth
    for a in range(-na, na + 1):
        th = pth + a * rad_step
        c = math.cos(th)
        s = math.sin(th)
        for i in range(-nr, nr + 1):
            for j in range(-nr, nr + 1):
                x = px + i * step
                y = py + j * step
                v = _cost(field, x0, y0, cell, trunc, pts, x, y, c, s)
                if v < best:
                    best = v
                    bx, by, bth = x, y, th
    return bx, by, bth, best


def match_scan(field: np.ndarray, xs: np.ndarray, ys: np.ndarray, trunc: float, pts: np.ndarray,
               pose, radius: float = 0.3, step: float = 0.025, max_deg: float = 8.0,
               deg_step: float = 1.0, coarse: int = 1) -> tuple[np.ndarray, float]:
    """``(pose (3,), cost)``: the pose of the grid around ``pose`` (positions every ``step``
    within ``radius`` m per axis, headings every ``deg_step`` within ``max_deg`` degrees) whose
    :func:`field_cost` is lowest (the first of equal costs in heading, x, y order). ``coarse``
    > 1 searches the window on a grid ``coarse`` times sparser first, then the fine grid within
    one coarse step of its best (``coarse^3`` times fewer poses; a minimum narrower than a coarse
    step can be missed)."""
    px, py, pth = (float(v) for v in pose)
    args = (field, float(xs[0]), float(ys[0]), float(xs[1] - xs[0]), float(trunc),
            np.ascontiguousarray(pts, np.float64))
    if coarse > 1:
        px, py, pth, _ = _match(*args, px, py, pth, float(radius), coarse * float(step),
                                math.radians(max_deg), coarse * math.radians(deg_step))
        radius, max_deg = coarse * step, coarse * deg_step
    bx, by, bth, best = _match(*args, px, py, pth, float(radius), float(step), math.radians(max_deg),
                               math.radians(deg_step))
    return np.array([bx, by, bth]), float(best)
