"""Levels: the floor-plan data model, its JSON file format, and exact 2D geometry on it.

A level is a box ``[0, width] x [0, depth] x [0, height]`` (metres) holding

* **walls**: segments ``a -> b`` with a thickness, full height; physically and visually each is
  the rectangle of half-width ``thickness / 2`` around the segment (square ends, so that the
  collision shape and the camera see exactly the same solid);
* **obstacles**: convex footprint polygons extruded from the floor to ``height`` (boxes,
  pillars; some lower than the camera, which then sees their top and the wall behind);
* **textures**: view-independent procedural colour functions, one per surface (see
  :func:`surface_colour`), so that a colour voxel grid can model them.

Every solid is therefore a convex prism; :func:`prisms` packs them into flat arrays for the ray
caster and the collision world. The file format (``levels/NAME.json``) and its checks live in
:mod:`navbench.levelio`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from navbench.errors import LevelError
from navbench.geometry import LEVEL_HEIGHT

SCHEMA_VERSION = 1
TEXTURE_KINDS = ("waves", "tiles")

# Bounds of a level file. Rasters and voxel grids are sized from the level: the validation
# raster has (size / 0.05 m)^2 cells, the true-map voxel grid (size / 0.057 m)^2 x 20, so a
# 50 m level needs ~1 M raster cells and ~15 M voxels, and a 1e7 m level would need terabytes.
# The benchmark's houses are about 11.4 m; HouseExpo footprints go up to 30 m.
#: Largest width and depth (m) of a level.
MAX_SIZE = 50.0
#: Largest level height (m).
MAX_HEIGHT = 10.0
#: Largest wall thickness (m).
MAX_WALL_THICKNESS = 1.0
#: Most walls plus obstacles in a level.
MAX_SOLIDS = 2000
#: Most vertices of one obstacle polygon.
MAX_POLYGON_VERTICES = 64
#: Geometry may stick out of the box by this much (m): the file's 1e-6 rounding.
BOX_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Texture:
    """A procedural surface colour ``clip(base + amp * P(u, v), 0, 1)``.

    ``waves`` are ``(fu, fv, phase)`` triples, spatial frequencies in cycles per metre and phase in
    radians. ``kind`` selects ``P`` (see :func:`surface_colour`).
    """

    kind: str
    base: tuple[float, float, float]
    amp: tuple[float, float, float]
    waves: tuple[tuple[float, float, float], ...]


@dataclass(frozen=True)
class Wall:
    """A full-height wall: segment ``a -> b`` (metres) of ``thickness`` (m), texture index."""

    a: tuple[float, float]
    b: tuple[float, float]
    thickness: float
    texture: int


@dataclass(frozen=True)
class Obstacle:
    """A convex prism: footprint polygon (counter-clockwise, metres), height (m), texture index."""

    polygon: tuple[tuple[float, float], ...]
    height: float
    texture: int


@dataclass(frozen=True)
class Level:
    """A floor plan. See the module docstring; all lengths in metres."""

    name: str
    width: float
    depth: float
    walls: tuple[Wall, ...]
    obstacles: tuple[Obstacle, ...]
    textures: tuple[Texture, ...]
    floor_texture: int
    ceiling_texture: int
    height: float = LEVEL_HEIGHT
    seed: int | None = None
    meta: dict = field(default_factory=dict, compare=False, hash=False)


# ----------------------------------------------------------------------------------- textures

def surface_colour(tex: Texture, u, v) -> np.ndarray:
    """Reference colour of ``tex`` at surface coordinates ``u, v`` (arrays, metres) -> ``(..., 3)``.

    Surface coordinates: on a vertical face, ``u`` is the distance along the polygon edge from its
    first vertex and ``v`` the height ``z``; on the floor, the ceiling and obstacle tops,
    ``u = x`` and ``v = y``.

    ``waves``: ``P = mean_k sin(2 pi (fu_k u + fv_k v) + phase_k)``.
    ``tiles``: ``P = 0.7 sin(2 pi fu_0 u + ph_0) sin(2 pi fv_0 v + ph_0)
    + 0.3 sin(2 pi (fu_1 u + fv_1 v) + ph_1)``.
    """
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    w = np.asarray(tex.waves, dtype=np.float64)
    if tex.kind == "waves":
        p = np.zeros(np.broadcast(u, v).shape)
        for fu, fv, ph in w:
            p = p + np.sin(2 * np.pi * (fu * u + fv * v) + ph)
        p = p / len(w)
    elif tex.kind == "tiles":
        p = 0.7 * np.sin(2 * np.pi * w[0, 0] * u + w[0, 2]) * np.sin(2 * np.pi * w[0, 1] * v + w[0, 2])
        p = p + 0.3 * np.sin(2 * np.pi * (w[1, 0] * u + w[1, 1] * v) + w[1, 2])
    else:  # pragma: no cover - rejected on load
        raise LevelError(f"unknown texture kind {tex.kind!r}")
    base = np.asarray(tex.base)
    amp = np.asarray(tex.amp)
    return np.clip(base + amp * p[..., None], 0.0, 1.0)


def texture_table(level: Level) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Textures packed for compiled code.

    Returns ``kind (T,) int64`` (index into :data:`TEXTURE_KINDS`), ``base (T, 3)``,
    ``amp (T, 3)`` and ``waves (T, 3, 3)`` float64 (unused waves are zero; ``waves`` kind always
    averages over 3 waves, so every ``waves`` texture has exactly 3).
    """
    T = len(level.textures)
    kind = np.zeros(T, np.int64)
    base = np.zeros((T, 3))
    amp = np.zeros((T, 3))
    waves = np.zeros((T, 3, 3))
    for t, tex in enumerate(level.textures):
        kind[t] = TEXTURE_KINDS.index(tex.kind)
        base[t] = tex.base
        amp[t] = tex.amp
        w = np.asarray(tex.waves, dtype=np.float64)
        waves[t, : len(w)] = w
    return kind, base, amp, waves


# ----------------------------------------------------------------------------------- geometry

def wall_polygon(w: Wall) -> np.ndarray:
    """The wall's rectangle ``(4, 2)``, counter-clockwise, square ends at ``a`` and ``b``."""
    a = np.asarray(w.a, float)
    b = np.asarray(w.b, float)
    d = b - a
    n = np.array([-d[1], d[0]]) / np.linalg.norm(d) * (w.thickness / 2)
    poly = np.array([a - n, b - n, b + n, a + n])
    return _ccw(poly)


def _ccw(poly: np.ndarray) -> np.ndarray:
    x, y = poly[:, 0], poly[:, 1]
    area2 = np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)
    return poly if area2 > 0 else poly[::-1].copy()


@dataclass(frozen=True)
class Prisms:
    """All solids of a level as convex prisms in flat arrays (for numba and pymunk).

    ``verts (V, 2)`` counter-clockwise polygon vertices, ``start (P + 1,)`` offsets so that prism
    ``p`` has vertices ``verts[start[p]:start[p + 1]]``, ``height (P,)`` metres, ``texture (P,)``
    texture indices, ``is_wall (P,)`` bool. Walls come first, in file order, then obstacles.
    """

    verts: np.ndarray
    start: np.ndarray
    height: np.ndarray
    texture: np.ndarray
    is_wall: np.ndarray

    def __len__(self) -> int:
        return len(self.height)

    def polygon(self, p: int) -> np.ndarray:
        return self.verts[self.start[p]: self.start[p + 1]]


def prisms(level: Level) -> Prisms:
    """Pack the level's walls and obstacles into :class:`Prisms`."""
    polys, heights, texs, walls = [], [], [], []
    for w in level.walls:
        polys.append(wall_polygon(w)); heights.append(level.height); texs.append(w.texture); walls.append(True)
    for o in level.obstacles:
        polys.append(_ccw(np.asarray(o.polygon, float))); heights.append(o.height)
        texs.append(o.texture); walls.append(False)
    start = np.zeros(len(polys) + 1, np.int64)
    start[1:] = np.cumsum([len(p) for p in polys])
    verts = np.concatenate(polys) if polys else np.zeros((0, 2))
    return Prisms(verts.astype(np.float64), start, np.asarray(heights, float),
                  np.asarray(texs, np.int64), np.asarray(walls, bool))


def distance_to_solids(level_or_prisms: Level | Prisms, points, min_height: float = 0.0) -> np.ndarray:
    """Exact 2D distance (m) from ``points (N, 2)`` to the nearest solid footprint; 0 inside one.

    Only solids taller than ``min_height`` count (0 counts every solid).
    """
    pr = level_or_prisms if isinstance(level_or_prisms, Prisms) else prisms(level_or_prisms)
    pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
    best = np.full(len(pts), np.inf)
    for p in range(len(pr)):
        if pr.height[p] <= min_height:
            continue
        poly = pr.polygon(p)
        a = poly
        b = np.roll(poly, -1, axis=0)
        d = b - a  # (E, 2)
        rel = pts[:, None, :] - a[None, :, :]  # (N, E, 2)
        t = np.clip(np.einsum("nej,ej->ne", rel, d) / np.einsum("ej,ej->e", d, d), 0.0, 1.0)
        closest = a[None] + t[..., None] * d[None]
        dist = np.linalg.norm(pts[:, None, :] - closest, axis=-1).min(axis=1)
        # inside a convex CCW polygon: left of every edge
        cross = d[None, :, 0] * rel[..., 1] - d[None, :, 1] * rel[..., 0]
        inside = np.all(cross >= 0, axis=1)
        dist[inside] = 0.0
        best = np.minimum(best, dist)
    return best


def occupancy_raster(level: Level, resolution: float, z_low: float = 0.0,
                     z_high: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """True occupancy of the horizontal band ``[z_low, z_high]`` sampled at cell centres.

    Cells of size ``resolution`` (m) cover ``[0, width] x [0, depth]``. A cell is occupied when
    its centre lies inside the footprint of a solid whose height exceeds ``z_low``. Returns
    ``occ (nx, ny) bool`` (index ``[ix, iy]``), and the cell-centre coordinates ``xs (nx,)``,
    ``ys (ny,)``.
    """
    nx = int(math.ceil(level.width / resolution - 1e-9))
    ny = int(math.ceil(level.depth / resolution - 1e-9))
    xs = (np.arange(nx) + 0.5) * resolution
    ys = (np.arange(ny) + 0.5) * resolution
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel()], axis=1)
    pr = prisms(level)
    occ = np.zeros(len(pts), bool)
    for p in range(len(pr)):
        if pr.height[p] <= z_low:
            continue
        poly = pr.polygon(p)
        lo, hi = poly.min(0), poly.max(0)
        cand = np.all((pts >= lo) & (pts <= hi), axis=1)
        if not cand.any():
            continue
        a = poly
        d = np.roll(poly, -1, axis=0) - a
        idx = np.flatnonzero(cand)
        for k in range(0, len(idx), 1 << 16):  # in blocks: (points x edges x 2) floats at once
            block = idx[k:k + (1 << 16)]
            rel = pts[block][:, None, :] - a[None]
            cross = d[None, :, 0] * rel[..., 1] - d[None, :, 1] * rel[..., 0]
            occ[block[np.all(cross >= 0, axis=1)]] = True
    return occ.reshape(nx, ny), xs, ys


def _is_convex(poly: np.ndarray) -> bool:
    d = np.roll(poly, -1, axis=0) - poly
    cross = d[:, 0] * np.roll(d, -1, axis=0)[:, 1] - d[:, 1] * np.roll(d, -1, axis=0)[:, 0]
    return bool(np.all(cross > 1e-12) or np.all(cross < -1e-12))
