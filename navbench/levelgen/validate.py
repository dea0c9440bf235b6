"""Free space at the planning clearance and level validation (see :mod:`navbench.levelgen`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from navbench.errors import LevelError
from navbench.level import Level, prisms, _is_convex
from navbench.levelgen.common import CLEARANCE, MIN_FREE_FRACTION, VALIDATION_RESOLUTION, _poly_area

# ----------------------------------------------------------------------------------- free space

_BLOCK = 1 << 16  # points per block of a distance computation


def clearance_mask(level: Level, resolution: float = VALIDATION_RESOLUTION,
                   clearance: float = CLEARANCE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cells whose centre is farther than ``clearance`` (m) from every solid footprint.

    Cells of size ``resolution`` (m) cover ``[0, width] x [0, depth]`` exactly as
    :func:`navbench.level.occupancy_raster`. The distance is exact (point to convex polygon), and
    every solid counts whatever its height. Returns ``free (nx, ny) bool`` (index ``[ix, iy]``),
    ``xs (nx,)`` and ``ys (ny,)`` cell-centre coordinates (m).
    """
    nx = int(math.ceil(level.width / resolution - 1e-9))
    ny = int(math.ceil(level.depth / resolution - 1e-9))
    xs = (np.arange(nx) + 0.5) * resolution
    ys = (np.arange(ny) + 0.5) * resolution
    free = np.ones((nx, ny), bool)
    pr = prisms(level)
    for p in range(len(pr)):
        poly = pr.polygon(p)
        lo = poly.min(0) - clearance
        hi = poly.max(0) + clearance
        i0, i1 = np.searchsorted(xs, lo[0]), np.searchsorted(xs, hi[0], side="right")
        j0, j1 = np.searchsorted(ys, lo[1]), np.searchsorted(ys, hi[1], side="right")
        if i0 >= i1 or j0 >= j1:
            continue
        X, Y = np.meshgrid(xs[i0:i1], ys[j0:j1], indexing="ij")
        pts = np.stack([X.ravel(), Y.ravel()], axis=1)
        # in blocks: the distance needs (points x edges x 2) floats at once
        d = np.concatenate([_distance_to_convex(pts[k:k + _BLOCK], poly)
                            for k in range(0, len(pts), _BLOCK)])
        sub = free[i0:i1, j0:j1]
        sub &= (d > clearance).reshape(sub.shape)
    return free, xs, ys


def _distance_to_convex(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance (m) from ``pts (N, 2)`` to the CCW convex polygon ``poly (E, 2)``; 0 inside."""
    a = poly
    d = np.roll(poly, -1, axis=0) - a
    rel = pts[:, None, :] - a[None]
    t = np.clip(np.einsum("nej,ej->ne", rel, d) / np.einsum("ej,ej->e", d, d), 0.0, 1.0)
    dist = np.linalg.norm(rel - t[..., None] * d[None], axis=-1).min(axis=1)
    cross = d[None, :, 0] * rel[..., 1] - d[None, :, 1] * rel[..., 0]
    dist[np.all(cross >= 0, axis=1)] = 0.0
    return dist


def free_space(level: Level, resolution: float = VALIDATION_RESOLUTION,
               clearance: float = CLEARANCE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The largest 8-connected component of :func:`clearance_mask` (the navigable space).

    Same returns as :func:`clearance_mask`. For a valid level this is the whole mask.
    """
    from scipy import ndimage

    free, xs, ys = clearance_mask(level, resolution, clearance)
    labels, n = ndimage.label(free, structure=np.ones((3, 3), bool))
    if n <= 1:
        return free, xs, ys
    sizes = np.bincount(labels.ravel())[1:]
    return labels == (1 + int(np.argmax(sizes))), xs, ys


def house_area(level: Level) -> float:
    """Area (m^2) of the box minus the exterior fill listed in ``meta["exterior_obstacles"]``."""
    area = level.width * level.depth
    for i in level.meta.get("exterior_obstacles", []):
        if isinstance(i, int) and 0 <= i < len(level.obstacles):
            area -= abs(_poly_area(np.asarray(level.obstacles[i].polygon, float)))
    return area


def level_stats(level: Level, resolution: float = VALIDATION_RESOLUTION) -> dict[str, Any]:
    """Counts for summaries: rooms, walls, furniture obstacles, free area (m^2) at the clearance."""
    free, _, _ = clearance_mask(level, resolution)
    n_ext = len(level.meta.get("exterior_obstacles", []))
    rooms = level.meta.get("rooms")
    return {
        "rooms": len(rooms) if isinstance(rooms, list) else None,
        "walls": len(level.walls),
        "obstacles": len(level.obstacles) - n_ext,
        "free_area_m2": float(free.sum()) * resolution * resolution,
        "house_area_m2": house_area(level),
    }


def validate_connectivity(level: Level, resolution: float = VALIDATION_RESOLUTION,
                          clearance: float = CLEARANCE) -> None:
    """Alias of :func:`validate_level` (the name in docs/concepts/architecture.md)."""
    validate_level(level, resolution, clearance)


def validate_level(level: Level, resolution: float = VALIDATION_RESOLUTION,
                   clearance: float = CLEARANCE) -> None:
    """Raise :class:`LevelError` unless the free space at ``clearance`` is one connected region.

    Checks, on a raster of ``resolution`` (m): (1) every solid lies inside the level box and every
    obstacle is convex; (2) the cells farther than ``clearance`` from every solid form exactly one
    8-connected component; (3) it covers at least :data:`MIN_FREE_FRACTION` of the house area;
    (4) each room rectangle in ``meta["rooms"]`` contains some of it; (5) each door in
    ``meta["doors"]`` passes the agent: its centre and the points 0.4 m to either side along the
    door's normal are free cells.
    """
    tol = 1e-6
    pr = prisms(level)
    if len(pr) and (pr.verts.min() < -tol or pr.verts[:, 0].max() > level.width + tol
                    or pr.verts[:, 1].max() > level.depth + tol):
        raise LevelError(f"level {level.name!r}: a wall or obstacle lies outside the level box")
    for i, o in enumerate(level.obstacles):
        if not _is_convex(np.asarray(o.polygon, float)):
            raise LevelError(f"level {level.name!r}: obstacles[{i}] is not convex")
    validate_free_space(level, resolution, clearance)


def validate_free_space(level: Level, resolution: float = VALIDATION_RESOLUTION,
                        clearance: float = CLEARANCE) -> None:
    """Checks (2)-(5) of :func:`validate_level`: the free space alone, not the box.

    :func:`navbench.levelio.load_level` uses this one: a level file's points are checked to lie
    in the box by the file reader, and a hand-made wall centred on the box edge may stick out
    by half its thickness (the generator's own levels never do, and keep the strict check).
    """
    from scipy import ndimage

    free, xs, ys = clearance_mask(level, resolution, clearance)
    labels, n = ndimage.label(free, structure=np.ones((3, 3), bool))
    if n != 1:
        raise LevelError(f"level {level.name!r}: free space at {clearance:.2f} m clearance has "
                         f"{n} connected components (need exactly 1)")
    area = float(free.sum()) * resolution ** 2
    if area < MIN_FREE_FRACTION * house_area(level):
        raise LevelError(f"level {level.name!r}: free area {area:.1f} m^2 is under "
                         f"{MIN_FREE_FRACTION:.0%} of the house")

    def cell(x: float, y: float) -> tuple[int, int]:
        return (min(max(int(x / resolution), 0), len(xs) - 1),
                min(max(int(y / resolution), 0), len(ys) - 1))

    for k, (x0, y0, x1, y1) in enumerate(meta_rooms(level)):
        i0, j0 = cell(x0, y0)
        i1, j1 = cell(x1, y1)
        if not free[i0:i1 + 1, j0:j1 + 1].any():
            raise LevelError(f"level {level.name!r}: room {k} has no free space at "
                             f"{clearance:.2f} m clearance")
    for k, (cx, cy, axis) in enumerate(meta_doors(level)):
        nxn, nyn = (1.0, 0.0) if axis == "x" else (0.0, 1.0)
        for s in (-0.4, 0.0, 0.4):
            if not free[cell(cx + s * nxn, cy + s * nyn)]:
                raise LevelError(f"level {level.name!r}: door {k} at ({cx:.2f}, {cy:.2f}) does "
                                 f"not pass the agent at {clearance:.2f} m clearance")


def _is_num(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def meta_rooms(level: Level) -> list[tuple[float, float, float, float]]:
    """``meta["rooms"]`` as ``(x0, y0, x1, y1)`` rectangles (m); LevelError if malformed."""
    rooms = level.meta.get("rooms") or []
    if not isinstance(rooms, list):
        raise LevelError(f"level {level.name!r}: meta.rooms: expected a list")
    out = []
    for k, r in enumerate(rooms):
        if not (isinstance(r, list) and len(r) == 4 and all(_is_num(c) for c in r)):
            raise LevelError(f"level {level.name!r}: meta.rooms[{k}]: expected [x0, y0, x1, y1]")
        out.append(tuple(float(c) for c in r))
    return out


def meta_doors(level: Level) -> list[tuple[float, float, str]]:
    """``meta["doors"]`` as ``(cx, cy, axis)``; LevelError if malformed."""
    doors = level.meta.get("doors") or []
    if not isinstance(doors, list):
        raise LevelError(f"level {level.name!r}: meta.doors: expected a list")
    out = []
    for k, d in enumerate(doors):
        c = d.get("center") if isinstance(d, dict) else None
        axis = d.get("axis") if isinstance(d, dict) else None
        if not (isinstance(c, list) and len(c) == 2 and all(_is_num(v) for v in c)
                and axis in ("x", "y")):
            raise LevelError(f"level {level.name!r}: meta.doors[{k}]: expected "
                             '{"center": [x, y], "axis": "x" or "y"}')
        out.append((float(c[0]), float(c[1]), axis))
    return out
