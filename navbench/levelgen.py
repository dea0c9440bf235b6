"""Procedural levels: HouseExpo-like floor plans, a training maze, HouseExpo import, validation.

Everything here is pure: a seed (or a parsed HouseExpo document) in, a :class:`Level` out, no
file I/O. All lengths are world metres in the level box ``[0, width] x [0, depth]``.

House levels (:func:`generate_level`)
    A rectangular footprint of up to ``size x size`` m is split recursively (binary space
    partition) into rooms of varied sizes, optionally with a corridor along the first split; one
    room at a corner may be cut away (filled, making an L-shaped house). Rooms are joined by doors
    (gaps of 0.8-1.1 m, sometimes a wider opening) along a random spanning tree of the room
    adjacency graph plus a few extra doors for loops. Walls are 0.1 m thick. Furniture-like
    obstacles (low boxes 0.2-0.45 m, below the camera; tall boxes and pillars 0.7-1.2 m) stand
    against walls or free in rooms, never in front of a door, and always leave a gap of at least
    :data:`OBSTACLE_GAP` to other solids, so the agent can pass around every obstacle.

Training maze (:func:`generate_maze`)
    A perfect maze (depth-first search) on a grid of 1.2 m cells, with a few extra openings
    that make loops: corridors about 1.1 m wide, as in the training maze of Savinov et al. (2018).

HouseExpo import (:func:`level_from_houseexpo`)
    The house outline of a HouseExpo document (Li et al., 2020) becomes one wall per edge; the
    outside of the outline inside the level box is filled with full-height *exterior* prisms
    (listed in ``level.meta["exterior_obstacles"]``) so that the free space of every level is
    exactly the navigable inside of the house.

Textures
    Every wall and obstacle gets a ``waves`` texture, the floor ``tiles`` (0.6 m period), the
    ceiling its own ``waves``; spatial frequencies 0.5-3 cycles/m and amplitudes 0.15-0.3, so a
    5.7 cm voxel grid can model them and photometric alignment has gradients everywhere.
    Neighbouring walls never share a texture.

Validation (:func:`validate_level`)
    On a raster of cell centres (0.05 m), the cells whose distance to every solid footprint
    exceeds the planning clearance 1.2 L (L = :data:`navbench.geometry.AGENT_LENGTH`) must form
    one 8-connected component covering a sensible part of the house, every room must contain some
    of it, and every door must pass the agent with that clearance.

Determinism: all randomness comes from ``numpy.random.default_rng((seed, attempt))``; house and
maze geometry lives on an integer centimetre grid, other coordinates are rounded to 1e-4 m with
Python's ``round``, and angles use :mod:`math`, so a seed gives byte-identical level files.
"""

from __future__ import annotations

import colorsys
import math
from dataclasses import dataclass
from typing import Any, Iterable, Sequence

import numpy as np

from navbench.errors import ConfigError, LevelError
from navbench.geometry import AGENT_LENGTH, LEVEL_HEIGHT
from navbench.level import Level, Obstacle, Texture, Wall, prisms, _is_convex

#: Version of the generators; part of ``level.meta`` (bump when the output for a seed changes).
GENERATOR_VERSION = 1
#: Wall thickness (m).
WALL_THICKNESS = 0.1
#: Planning clearance (m): free space is farther than this from every solid (paper appendix B).
CLEARANCE = 1.2 * AGENT_LENGTH
#: Raster cell size (m) used by :func:`validate_level`.
VALIDATION_RESOLUTION = 0.05
#: Minimum gap (m) between an obstacle and any other solid it does not touch; > 2 * CLEARANCE.
OBSTACLE_GAP = 0.6
#: Default number of generation attempts before :func:`generate_level` gives up.
MAX_ATTEMPTS = 40
#: Door widths (m) of ordinary doors.
DOOR_WIDTH = (0.8, 1.1)
#: The paper's level footprint (m).
DEFAULT_SIZE = 11.4
#: Default maze size (m) and cell pitch (m).
MAZE_SIZE = 9.7
MAZE_CELL = 1.2
#: Largest fraction of a house footprint that a cut-away corner room may take.
MAX_CUTAWAY = 0.3
#: Margin (m) between a HouseExpo outline and the level box: room for a wall end extended by
#: half a thickness along a diagonal edge (t / 2 * sqrt 2 < 0.08).
HOUSEEXPO_MARGIN = 0.08
#: The smallest fraction of the house area that must be free at the planning clearance.
MIN_FREE_FRACTION = 0.2

#: The benchmark's levels: name -> options of :func:`make_benchmark_level`. Regenerate them
#: all with ``navbench make-level --benchmark --force``; the files must not change.
BENCHMARK_LEVELS: dict[str, dict[str, Any]] = {
    "house-1": {"kind": "house", "seed": 101, "rooms": 6, "obstacles": 14},
    "house-2": {"kind": "house", "seed": 202, "rooms": 5, "obstacles": 12},
    "house-3": {"kind": "house", "seed": 303, "rooms": 7, "obstacles": 16},
    "house-4": {"kind": "house", "seed": 404, "rooms": 4, "obstacles": 10},
    "house-5": {"kind": "house", "seed": 505, "rooms": 8, "obstacles": 18},
    "house-6": {"kind": "house", "seed": 606, "rooms": 6, "obstacles": 15},
    "maze": {"kind": "maze", "seed": 7, "size": MAZE_SIZE},
}

LEVEL_KINDS = ("house", "maze")

_T_CM = 10  # wall thickness in cm


class _AttemptFailed(Exception):
    """One generation attempt did not produce a valid level (internal; triggers a retry)."""


# ------------------------------------------------------------------------------ small helpers

def _q(x: float, step: float = 1e-4) -> float:
    """Round ``x`` to a multiple of ``step`` (deterministic, Python float)."""
    v = round(float(x) / step) * step
    v = round(v, 6)
    return 0.0 if v == 0 else v


def _cm(x: int) -> float:
    return _q(x / 100.0)


@dataclass(frozen=True)
class _Rect:
    """Axis-aligned rectangle in integer centimetres (wall centre lines for rooms)."""

    x0: int
    y0: int
    x1: int
    y1: int

    @property
    def w(self) -> int:
        return self.x1 - self.x0

    @property
    def h(self) -> int:
        return self.y1 - self.y0

    @property
    def area(self) -> int:
        return self.w * self.h

    def metres(self) -> list[float]:
        return [_cm(self.x0), _cm(self.y0), _cm(self.x1), _cm(self.y1)]


def _rect_gap(a: Sequence[float], b: Sequence[float]) -> float:
    """Euclidean gap (m) between boxes ``(x0, y0, x1, y1)``; 0 when they touch or overlap."""
    dx = max(0.0, b[0] - a[2], a[0] - b[2])
    dy = max(0.0, b[1] - a[3], a[1] - b[3])
    return math.hypot(dx, dy)


def _rects_overlap(a: Sequence[float], b: Sequence[float]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _poly_area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _ccw_tuple(pts: list[tuple[float, float]]) -> tuple[tuple[float, float], ...]:
    arr = np.asarray(pts, float)
    if _poly_area(arr) < 0:
        pts = pts[::-1]
    return tuple((float(x), float(y)) for x, y in pts)


# ----------------------------------------------------------------------------------- textures

def _hsv(h: float, s: float, v: float) -> tuple[float, float, float]:
    return tuple(_q(c, 1e-4) for c in colorsys.hsv_to_rgb(h % 1.0, s, v))  # type: ignore[return-value]


def _wave_texture(rng: np.random.Generator, hue: float, sat: tuple[float, float],
                  val: tuple[float, float]) -> Texture:
    """A ``waves`` texture: vertical stripes, a diagonal and horizontal bands (0.5-3 cycles/m)."""
    base = _hsv(hue, rng.uniform(*sat), rng.uniform(*val))
    amp = tuple(_q(rng.uniform(0.15, 0.3)) for _ in range(3))
    sign = 1.0 if rng.random() < 0.5 else -1.0
    waves = (
        (_q(rng.uniform(0.5, 2.5)), 0.0, _q(rng.uniform(0, 2 * math.pi))),
        (_q(sign * rng.uniform(0.5, 1.5)), _q(rng.uniform(0.5, 1.5)), _q(rng.uniform(0, 2 * math.pi))),
        (0.0, _q(rng.uniform(1.0, 2.5)), _q(rng.uniform(0, 2 * math.pi))),
    )
    return Texture("waves", base, amp, waves)


def _palette(rng: np.random.Generator, count: int, sat=(0.35, 0.6), val=(0.45, 0.65)) -> list[Texture]:
    """``count`` wave textures with evenly spaced hues (random offset)."""
    h0 = rng.random()
    return [_wave_texture(rng, h0 + k / count, sat, val) for k in range(count)]


def _floor_texture(rng: np.random.Generator) -> Texture:
    """``tiles`` floor: 0.6 m period checkerboard-like tiles plus a slow diagonal."""
    base = _hsv(rng.uniform(0.05, 0.15), rng.uniform(0.2, 0.4), rng.uniform(0.45, 0.6))
    amp = tuple(_q(rng.uniform(0.18, 0.28)) for _ in range(3))
    f = _q(1 / 0.6)
    waves = ((f, f, _q(rng.uniform(0, 2 * math.pi))),
             (_q(rng.uniform(0.5, 1.0)), _q(rng.uniform(0.5, 1.0)), _q(rng.uniform(0, 2 * math.pi))))
    return Texture("tiles", base, amp, waves)


def _ceiling_texture(rng: np.random.Generator) -> Texture:
    return _wave_texture(rng, rng.random(), (0.05, 0.2), (0.7, 0.8))


def _exterior_texture() -> Texture:
    """Plain grey for the (never visible) exterior fill."""
    return Texture("waves", (0.3, 0.3, 0.3), (0.15, 0.15, 0.15),
                   ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 1.0, 0.0)))


def _touching_walls(walls: list[tuple[tuple[float, float], tuple[float, float]]],
                    tol: float) -> list[set[int]]:
    """For each wall segment, the indices of walls whose segments come within ``tol`` of it."""
    n = len(walls)
    nbr: list[set[int]] = [set() for _ in range(n)]
    for i in range(n):
        for j in range(i + 1, n):
            if _segment_distance(walls[i], walls[j]) <= tol:
                nbr[i].add(j)
                nbr[j].add(i)
    return nbr


def _point_segment_distance(p, a, b) -> float:
    ax, ay = a
    bx, by = b
    dx, dy = bx - ax, by - ay
    dd = dx * dx + dy * dy
    t = 0.0 if dd == 0 else max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / dd))
    return math.hypot(p[0] - ax - t * dx, p[1] - ay - t * dy)


def _segments_intersect(a, b, c, d) -> bool:
    def orient(p, q, r):
        v = (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
        return 0 if abs(v) < 1e-12 else (1 if v > 0 else -1)

    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    return o1 != o2 and o3 != o4 and 0 not in (o1, o2, o3, o4)


def _segment_distance(s, t) -> float:
    if _segments_intersect(s[0], s[1], t[0], t[1]):
        return 0.0
    return min(_point_segment_distance(s[0], *t), _point_segment_distance(s[1], *t),
               _point_segment_distance(t[0], *s), _point_segment_distance(t[1], *s))


def _colour_walls(rng: np.random.Generator, segs, n_textures: int) -> list[int]:
    """Texture index per wall in ``[0, n_textures)`` such that touching walls differ."""
    nbr = _touching_walls(segs, tol=WALL_THICKNESS * 0.51)
    tex = [-1] * len(segs)
    for i in rng.permutation(len(segs)).tolist():
        used = {tex[j] for j in nbr[i]}
        free = [k for k in range(n_textures) if k not in used]
        if not free:  # pragma: no cover - more neighbours than textures
            free = list(range(n_textures))
        tex[i] = int(free[int(rng.integers(len(free)))])
    return tex


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
    """Alias of :func:`validate_level` (the name in docs/ARCHITECTURE.md)."""
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

    :func:`navbench.level.load_level` uses this one: a level file's points are checked to lie
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


# ----------------------------------------------------------------------------------- houses

def _bsp_rooms(rng: np.random.Generator, W: int, D: int, count: int, corridor: bool,
               min_room: int = 190) -> tuple[list[_Rect], int | None]:
    """Split the centre-line box into ``count`` rectangles (cm); returns (rects, corridor index)."""
    h = _T_CM // 2
    root = _Rect(h, h, W - h, D - h)
    rects: list[_Rect] = [root]
    corr: _Rect | None = None
    if corridor and count >= 4:
        cw = int(rng.integers(120, 151))
        horizontal = root.w < root.h  # the corridor runs along the longer side
        length = root.h if horizontal else root.w
        pos = int(round(length * rng.uniform(0.35, 0.6) / 5.0)) * 5
        if horizontal:
            a = _Rect(root.x0, root.y0, root.x1, root.y0 + pos)
            corr = _Rect(root.x0, root.y0 + pos, root.x1, root.y0 + pos + cw)
            b = _Rect(root.x0, root.y0 + pos + cw, root.x1, root.y1)
        else:
            a = _Rect(root.x0, root.y0, root.x0 + pos, root.y1)
            corr = _Rect(root.x0 + pos, root.y0, root.x0 + pos + cw, root.y1)
            b = _Rect(root.x0 + pos + cw, root.y0, root.x1, root.y1)
        if min(a.w, a.h, b.w, b.h) < min_room:
            raise _AttemptFailed("corridor leaves too little room")
        rects = [a, b]
    target = count - (1 if corr is not None else 0)
    while len(rects) < target:
        cands = [r for r in rects if max(r.w, r.h) >= 2 * min_room]
        if not cands:
            raise _AttemptFailed("cannot split rooms further")
        wts = np.array([float(r.area) ** 1.5 for r in cands])
        r = cands[int(rng.choice(len(cands), p=wts / wts.sum()))]
        if r.w >= 2 * min_room and r.h >= 2 * min_room and max(r.w, r.h) < 1.3 * min(r.w, r.h):
            vertical = bool(rng.random() < 0.5)
        else:
            vertical = r.w >= r.h
        length = r.w if vertical else r.h
        lo, hi = max(min_room, int(0.3 * length)), min(length - min_room, int(0.7 * length))
        if lo > hi:
            raise _AttemptFailed("room too small to split")
        pos = int(round(rng.uniform(lo, hi) / 5.0)) * 5
        pos = min(max(pos, lo), hi)
        rects.remove(r)
        if vertical:
            rects += [_Rect(r.x0, r.y0, r.x0 + pos, r.y1), _Rect(r.x0 + pos, r.y0, r.x1, r.y1)]
        else:
            rects += [_Rect(r.x0, r.y0, r.x1, r.y0 + pos), _Rect(r.x0, r.y0 + pos, r.x1, r.y1)]
    rects.sort(key=lambda q: (q.y0, q.x0))
    if corr is not None:
        rects.append(corr)
        return rects, len(rects) - 1
    return rects, None


def _shared_boundary(a: _Rect, b: _Rect) -> tuple[str, int, int, int] | None:
    """``(axis, c, lo, hi)``: a shared wall on the line ``x = c`` (axis "x", the wall's normal)
    or ``y = c`` (axis "y") spanning ``[lo, hi]`` (cm), or None."""
    for c_a, c_b in ((a.x1, b.x0), (a.x0, b.x1)):
        if c_a == c_b:
            lo, hi = max(a.y0, b.y0), min(a.y1, b.y1)
            if hi > lo:
                return ("x", c_a, lo, hi)
    for c_a, c_b in ((a.y1, b.y0), (a.y0, b.y1)):
        if c_a == c_b:
            lo, hi = max(a.x0, b.x0), min(a.x1, b.x1)
            if hi > lo:
                return ("y", c_a, lo, hi)
    return None


def _union(intervals: list[tuple[int, int]]) -> list[tuple[int, int]]:
    out: list[tuple[int, int]] = []
    for lo, hi in sorted(intervals):
        if out and lo <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], hi))
        else:
            out.append((lo, hi))
    return out


def _subtract(intervals: list[tuple[int, int]], gaps: list[tuple[int, int]]) -> list[tuple[int, int]]:
    out = intervals
    for g0, g1 in gaps:
        nxt = []
        for lo, hi in out:
            if g1 <= lo or g0 >= hi:
                nxt.append((lo, hi))
                continue
            if g0 > lo:
                nxt.append((lo, g0))
            if g1 < hi:
                nxt.append((g1, hi))
        out = nxt
    return out


def _find(parent: list[int], i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


def _house_attempt(rng: np.random.Generator, name: str, seed: int, size: float,
                   rooms: int | None, obstacles: int | None, attempt: int) -> Level:
    S = int(round(size * 100))
    long_side = S
    short_side = int(round(S * rng.uniform(0.72, 1.0) / 5.0)) * 5
    W, D = (long_side, short_side) if rng.random() < 0.5 else (short_side, long_side)
    n_rooms = int(rng.integers(4, 9)) if rooms is None else rooms
    n_obs = (min(25, int(rng.integers(n_rooms + 4, 2 * n_rooms + 7))) if obstacles is None
             else obstacles)
    min_room = 190 if n_rooms <= 6 else 170
    use_corridor = bool(rng.random() < 0.55)
    use_void = n_rooms >= 4 and bool(rng.random() < 0.4)
    rects, corr = _bsp_rooms(rng, W, D, n_rooms + (1 if use_void else 0), use_corridor, min_room)

    # adjacency between rooms
    n = len(rects)
    bounds: dict[tuple[int, int], tuple[str, int, int, int]] = {}
    for i in range(n):
        for j in range(i + 1, n):
            b = _shared_boundary(rects[i], rects[j])
            if b is not None:
                bounds[(i, j)] = b

    void = None
    if use_void:
        # a corner room (touching two outer sides), not the corridor, whose removal keeps the rest
        # connected through door-sized boundaries
        h = _T_CM // 2
        corners = [i for i, r in enumerate(rects) if i != corr
                   and (r.x0 == h or r.x1 == W - h) and (r.y0 == h or r.y1 == D - h)
                   and r.area <= MAX_CUTAWAY * W * D]
        if corners:
            void = corners[int(rng.integers(len(corners)))]

    margin = 30  # cm between a door and the end of its wall
    min_door = int(DOOR_WIDTH[0] * 100)
    live = [i for i in range(n) if i != void]
    eligible = [(i, j) for (i, j), b in bounds.items()
                if void not in (i, j) and b[3] - b[2] >= min_door + 2 * margin]
    order = rng.permutation(len(eligible)).tolist()
    parent = list(range(n))
    chosen: list[tuple[int, int]] = []
    for k in order:
        i, j = eligible[k]
        ri, rj = _find(parent, i), _find(parent, j)
        if ri != rj:
            parent[ri] = rj
            chosen.append((i, j))
    if len({_find(parent, i) for i in live}) != 1:
        raise _AttemptFailed("rooms cannot all be joined by doors")
    for k in order:
        e = eligible[k]
        if e in chosen:
            continue
        p = 0.6 if corr in e else 0.2
        if rng.random() < p:
            chosen.append(e)
    chosen.sort()

    # doors: (axis, line, lo, hi) gap along the line
    doors = []
    for e in chosen:
        axis, c, lo, hi = bounds[e]
        span = hi - lo - 2 * margin
        if span >= 160 and rng.random() < 0.15:
            w = int(rng.integers(140, min(220, span) + 1))
        else:
            w = int(rng.integers(min_door, min(int(DOOR_WIDTH[1] * 100), span) + 1))
        cmin, cmax = lo + margin + w / 2, hi - margin - w / 2
        centre = int(round(rng.uniform(cmin, cmax)))
        centre = int(min(max(centre, math.ceil(cmin)), math.floor(cmax)))
        doors.append((axis, c, centre - w // 2, centre - w // 2 + w, e))

    # walls: per line, the union of room boundaries minus door gaps; plus the outer walls
    lines: dict[tuple[str, int], list[tuple[int, int]]] = {}
    for (i, j), (axis, c, lo, hi) in bounds.items():
        lines.setdefault((axis, c), []).append((lo, hi))
    gaps: dict[tuple[str, int], list[tuple[int, int]]] = {}
    for axis, c, g0, g1, _ in doors:
        gaps.setdefault((axis, c), []).append((g0, g1))
    segs_cm: list[tuple[tuple[int, int], tuple[int, int]]] = []
    t2 = _T_CM // 2
    segs_cm += [((0, t2), (W, t2)), ((W - t2, 0), (W - t2, D)),
                ((W, D - t2), (0, D - t2)), ((t2, D), (t2, 0))]
    for (axis, c) in sorted(lines):
        for lo, hi in _subtract(_union(lines[(axis, c)]), sorted(gaps.get((axis, c), []))):
            segs_cm.append(((c, lo), (c, hi)) if axis == "x" else ((lo, c), (hi, c)))
    segs = [((_cm(a[0]), _cm(a[1])), (_cm(b[0]), _cm(b[1]))) for a, b in segs_cm]

    # textures: 0 floor, 1 ceiling, 2 exterior, then walls, then obstacles
    n_wall_tex = 9
    n_obs_tex = 6
    textures = [_floor_texture(rng), _ceiling_texture(rng), _exterior_texture()]
    textures += _palette(rng, n_wall_tex)
    textures += _palette(rng, n_obs_tex, sat=(0.4, 0.75), val=(0.35, 0.7))
    wtex = _colour_walls(rng, segs, n_wall_tex)
    walls = [Wall(a, b, WALL_THICKNESS, 3 + k) for (a, b), k in zip(segs, wtex)]

    # exterior fill for the cut-away room
    obs_list: list[Obstacle] = []
    exterior: list[int] = []
    if void is not None:
        r = rects[void].metres()
        obs_list.append(Obstacle(_ccw_tuple([(r[0], r[1]), (r[2], r[1]), (r[2], r[3]), (r[0], r[3])]),
                                 LEVEL_HEIGHT, 2))
        exterior.append(0)

    # furniture
    keepouts = []
    for axis, c, g0, g1, _ in doors:
        a0, a1 = _cm(g0) - 0.3, _cm(g1) + 0.3
        cc = _cm(c)
        keepouts.append((cc - 1.0, a0, cc + 1.0, a1) if axis == "x" else (a0, cc - 1.0, a1, cc + 1.0))
    host_rooms = [i for i in live if i != corr]
    furniture = _place_furniture(rng, [rects[i] for i in host_rooms], keepouts, n_obs,
                                 first_texture=3 + n_wall_tex, n_textures=n_obs_tex)
    obs_list += furniture

    room_meta = [rects[i].metres() for i in live]
    door_meta = [{"center": [_cm((g0 + g1) / 2) if axis == "y" else _cm(c),
                             _cm(c) if axis == "y" else _cm((g0 + g1) / 2)],
                  "width": _cm(g1 - g0), "axis": axis,
                  "rooms": [live.index(e[0]), live.index(e[1])]}
                 for axis, c, g0, g1, e in doors]
    meta = {
        "generator": "navbench.levelgen.house", "version": GENERATOR_VERSION,
        "kind": "house", "size": _q(size), "rooms_requested": rooms,
        "obstacles_requested": obstacles, "attempt": attempt,
        "rooms": room_meta,
        "corridor": live.index(corr) if corr is not None else None,
        "doors": door_meta, "exterior_obstacles": exterior,
    }
    level = Level(name=name, width=_cm(W), depth=_cm(D), walls=tuple(walls),
                  obstacles=tuple(obs_list), textures=tuple(textures), floor_texture=0,
                  ceiling_texture=1, height=LEVEL_HEIGHT, seed=seed, meta=meta)
    try:
        validate_level(level)
    except LevelError as e:
        raise _AttemptFailed(str(e)) from None
    return level


def _box(x0: float, y0: float, x1: float, y1: float) -> list[tuple[float, float]]:
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def _furniture_shape(rng: np.random.Generator) -> tuple[str, float, float, float]:
    """``(kind, a, b, height)``: a low box, a tall box (a along the wall) or a pillar (a = radius)."""
    u = rng.random()
    if u < 0.45:
        return ("box", _q(rng.uniform(0.5, 1.4), 0.01), _q(rng.uniform(0.4, 0.9), 0.01),
                _q(rng.uniform(0.2, 0.45), 0.01))
    if u < 0.8:
        return ("box", _q(rng.uniform(0.4, 1.0), 0.01), _q(rng.uniform(0.3, 0.6), 0.01),
                _q(rng.uniform(0.7, 1.2), 0.01))
    return ("pillar", _q(rng.uniform(0.1, 0.2), 0.01), 0.0, _q(rng.uniform(0.8, 1.2), 0.01))


def _rotated_shape(kind: str, a: float, b: float, cx: float, cy: float, ang: float,
                   sides: int) -> list[tuple[float, float]]:
    if kind == "pillar":
        return [(_q(cx + a * math.cos(ang + 2 * math.pi * k / sides)),
                 _q(cy + a * math.sin(ang + 2 * math.pi * k / sides))) for k in range(sides)]
    c, s = math.cos(ang), math.sin(ang)
    pts = []
    for px, py in ((-a / 2, -b / 2), (a / 2, -b / 2), (a / 2, b / 2), (-a / 2, b / 2)):
        pts.append((_q(cx + c * px - s * py), _q(cy + s * px + c * py)))
    return pts


def _place_furniture(rng: np.random.Generator, rooms: list[_Rect], keepouts: list, count: int,
                     first_texture: int, n_textures: int, tries: int = 300) -> list[Obstacle]:
    """Place ``count`` convex obstacles in ``rooms`` (rectangles in cm, wall centre lines).

    Each obstacle either stands flush against a wall (overlapping it by 2 cm, snapped into the
    corner when near one) or free with a gap of at least :data:`OBSTACLE_GAP` to the walls; its
    bounding box keeps that gap from every other obstacle's and avoids the door ``keepouts``.
    """
    if count <= 0:
        return []
    if not rooms:
        raise _AttemptFailed("no room for furniture")
    g = OBSTACLE_GAP
    t2 = WALL_THICKNESS / 2
    areas = np.array([float(r.area) for r in rooms])
    placed: list[tuple[list[tuple[float, float]], tuple[float, float, float, float], float]] = []
    for _ in range(count):
        for _try in range(tries):
            room = rooms[int(rng.choice(len(rooms), p=areas / areas.sum()))]
            rm = room.metres()
            R = (rm[0] + t2, rm[1] + t2, rm[2] - t2, rm[3] - t2)
            kind, a, b, height = _furniture_shape(rng)
            against = kind == "box" and rng.random() < 0.6
            if against:
                side = int(rng.integers(4))
                along_x = side in (0, 2)  # bottom/top walls
                L_room = (R[2] - R[0]) if along_x else (R[3] - R[1])
                depth_room = (R[3] - R[1]) if along_x else (R[2] - R[0])
                if a > L_room - g or b > depth_room - g - 0.1:
                    continue
                lo_a = (R[0] if along_x else R[1]) - 0.02
                hi_a = (R[2] if along_x else R[3]) + 0.02
                s0 = _q(rng.uniform(lo_a, hi_a - a), 0.01)
                if s0 - lo_a < g:
                    s0 = lo_a
                if hi_a - (s0 + a) < g:
                    s0 = hi_a - a
                if side == 0:
                    bb = (s0, R[1] - 0.02, s0 + a, R[1] + b)
                elif side == 2:
                    bb = (s0, R[3] - b, s0 + a, R[3] + 0.02)
                elif side == 1:
                    bb = (R[2] - b, s0, R[2] + 0.02, s0 + a)
                else:
                    bb = (R[0] - 0.02, s0, R[0] + b, s0 + a)
                bb = tuple(_q(v) for v in bb)
                poly = _box(*bb)
            else:
                ang = _q(rng.uniform(0, math.pi), 1e-3)
                rad = a if kind == "pillar" else 0.5 * math.hypot(a, b)
                lo_x, hi_x = R[0] + g + rad, R[2] - g - rad
                lo_y, hi_y = R[1] + g + rad, R[3] - g - rad
                if lo_x > hi_x or lo_y > hi_y:
                    continue
                cx, cy = _q(rng.uniform(lo_x, hi_x), 0.01), _q(rng.uniform(lo_y, hi_y), 0.01)
                poly = _rotated_shape(kind, a, b, cx, cy, ang, 8 if rng.random() < 0.5 else 6)
                xs_ = [p[0] for p in poly]
                ys_ = [p[1] for p in poly]
                bb = (min(xs_), min(ys_), max(xs_), max(ys_))
                if bb[0] < R[0] + g or bb[1] < R[1] + g or bb[2] > R[2] - g or bb[3] > R[3] - g:
                    continue
            if any(_rects_overlap(bb, k) for k in keepouts):
                continue
            if any(_rect_gap(bb, q[1]) < g for q in placed):
                continue
            placed.append((poly, bb, height))
            break
        else:
            raise _AttemptFailed("could not place all obstacles")
    out = []
    for poly, _, height in placed:
        out.append(Obstacle(_ccw_tuple(poly), height, first_texture + int(rng.integers(n_textures))))
    return out


def _check_name_seed(name: str, seed: int) -> None:
    from navbench.names import check_name

    check_name("level name", name, ConfigError)  # it becomes levels/NAME.json
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"seed must be a non-negative integer, got {seed!r}")


def _retry(make, name: str, seed: int, max_attempts: int) -> Level:
    last = ""
    for attempt in range(max_attempts):
        rng = np.random.default_rng((seed, attempt))
        try:
            return make(rng, attempt)
        except _AttemptFailed as e:
            last = str(e)
    raise LevelError(f"could not generate a valid level {name!r} from seed {seed} in "
                     f"{max_attempts} attempts (last problem: {last})")


def generate_level(name: str, seed: int, size: float = DEFAULT_SIZE, rooms: int | None = None,
                   obstacles: int | None = None, max_attempts: int = MAX_ATTEMPTS) -> Level:
    """A HouseExpo-like house level (see the module docstring), valid per :func:`validate_level`.

    ``size`` (m): the longer side of the footprint (the other is 72-100 % of it); ``rooms``: the
    number of rooms including a corridor (4-8 drawn from the seed when None); ``obstacles``: the
    number of furniture obstacles (drawn when None). Attempt ``k`` draws from
    ``numpy.random.default_rng((seed, k))``; the first valid attempt is returned.
    """
    _check_name_seed(name, seed)
    if not (isinstance(size, (int, float)) and math.isfinite(size) and 5.0 <= size <= 30.0):
        raise ConfigError(f"size must be between 5 and 30 m, got {size!r}")
    if rooms is not None and not (isinstance(rooms, int) and 1 <= rooms <= 16):
        raise ConfigError(f"rooms must be an integer in [1, 16], got {rooms!r}")
    if obstacles is not None and not (isinstance(obstacles, int) and 0 <= obstacles <= 40):
        raise ConfigError(f"obstacles must be an integer in [0, 40], got {obstacles!r}")
    return _retry(lambda rng, k: _house_attempt(rng, name, seed, float(size), rooms, obstacles, k),
                  name, seed, max_attempts)


# ----------------------------------------------------------------------------------- maze

def generate_maze(name: str, seed: int, size: float = MAZE_SIZE, cell: float = MAZE_CELL,
                  loops: float = 0.12, max_attempts: int = MAX_ATTEMPTS) -> Level:
    """A maze of corridors (training/tracking-study level, cf. Savinov et al. 2018).

    The square of side ``size`` (m) holds ``round((size - 0.1) / cell)`` cells per side of pitch
    ``cell`` (m, wall centre lines); a depth-first perfect maze is opened further at a fraction
    ``loops`` of the remaining internal walls. No obstacles. Corridors are ``cell - 0.1`` m wide.
    """
    _check_name_seed(name, seed)
    if not (isinstance(cell, (int, float)) and 0.9 <= cell <= 3.0):
        raise ConfigError(f"maze cell must be between 0.9 and 3 m, got {cell!r}")
    n = int(round((size - WALL_THICKNESS) / cell))
    if not 2 <= n <= 20:
        raise ConfigError(f"maze size {size!r} m gives {n} cells per side; need 2 to 20")
    return _retry(lambda rng, k: _maze_attempt(rng, name, seed, float(size), float(cell), n,
                                               float(loops), k), name, seed, max_attempts)


def _maze_attempt(rng: np.random.Generator, name: str, seed: int, size: float, cell: float,
                  n: int, loops: float, attempt: int) -> Level:
    c = int(round(cell * 100))
    t2 = _T_CM // 2
    W = n * c + _T_CM
    # open[(i, j, d)]: passage from cell (i, j) east (d=0) or north (d=1)
    opened: set[tuple[int, int, int]] = set()
    seen = np.zeros((n, n), bool)
    stack = [(int(rng.integers(n)), int(rng.integers(n)))]
    seen[stack[0]] = True
    while stack:
        i, j = stack[-1]
        nbrs = [(di, dj) for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))
                if 0 <= i + di < n and 0 <= j + dj < n and not seen[i + di, j + dj]]
        if not nbrs:
            stack.pop()
            continue
        di, dj = nbrs[int(rng.integers(len(nbrs)))]
        ni, nj = i + di, j + dj
        if di:
            opened.add((min(i, ni), j, 0))
        else:
            opened.add((i, min(j, nj), 1))
        seen[ni, nj] = True
        stack.append((ni, nj))
    closed = sorted({(i, j, 0) for i in range(n - 1) for j in range(n)}
                    | {(i, j, 1) for i in range(n) for j in range(n - 1)} - opened)
    for e in closed:
        if rng.random() < loops:
            opened.add(e)
    lines: dict[tuple[str, int], list[tuple[int, int]]] = {}
    for i in range(n - 1):  # vertical lines x = t2 + (i + 1) c between cells i and i + 1
        for j in range(n):
            if (i, j, 0) not in opened:
                lines.setdefault(("x", t2 + (i + 1) * c), []).append((t2 + j * c, t2 + (j + 1) * c))
    for j in range(n - 1):
        for i in range(n):
            if (i, j, 1) not in opened:
                lines.setdefault(("y", t2 + (j + 1) * c), []).append((t2 + i * c, t2 + (i + 1) * c))
    segs_cm = [((0, t2), (W, t2)), ((W - t2, 0), (W - t2, W)), ((W, W - t2), (0, W - t2)),
               ((t2, W), (t2, 0))]
    for (axis, x) in sorted(lines):
        for lo, hi in _union(lines[(axis, x)]):
            segs_cm.append(((x, lo), (x, hi)) if axis == "x" else ((lo, x), (hi, x)))
    segs = [((_cm(a[0]), _cm(a[1])), (_cm(b[0]), _cm(b[1]))) for a, b in segs_cm]
    n_wall_tex = 10
    textures = [_floor_texture(rng), _ceiling_texture(rng), _exterior_texture()]
    textures += _palette(rng, n_wall_tex)
    wtex = _colour_walls(rng, segs, n_wall_tex)
    walls = [Wall(a, b, WALL_THICKNESS, 3 + k) for (a, b), k in zip(segs, wtex)]
    meta = {
        "generator": "navbench.levelgen.maze", "version": GENERATOR_VERSION, "kind": "maze",
        "size": _q(size), "cell": _q(cell), "cells": n, "loops": _q(loops), "attempt": attempt,
        "rooms": [], "doors": [], "exterior_obstacles": [],
    }
    level = Level(name=name, width=_cm(W), depth=_cm(W), walls=tuple(walls), obstacles=(),
                  textures=tuple(textures), floor_texture=0, ceiling_texture=1,
                  height=LEVEL_HEIGHT, seed=seed, meta=meta)
    try:
        validate_level(level)
    except LevelError as e:
        raise _AttemptFailed(str(e)) from None
    return level


# ----------------------------------------------------------------------------------- HouseExpo

def _parse_houseexpo(doc: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate a HouseExpo document; returns ``verts (N, 2)``, ``bbox_min (2,)``, ``bbox_max (2,)``."""
    def bad(field: str, msg: str):
        raise LevelError(f"HouseExpo document: {field}: {msg}")

    if not isinstance(doc, dict):
        bad("document", "expected a JSON object")

    def vec2(x, field):
        if (not isinstance(x, list) or len(x) != 2
                or any(isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c)
                       for c in x)):
            bad(field, f"expected [x, y] with finite numbers, got {x!r}")
        return np.array([float(x[0]), float(x[1])])

    if "verts" not in doc:
        bad("verts", "missing field")
    verts = doc["verts"]
    if not isinstance(verts, list) or len(verts) < 3:
        bad("verts", "expected a list of at least 3 [x, y] points")
    pts = np.array([vec2(p, f"verts[{k}]") for k, p in enumerate(verts)])
    if len(pts) > 3 and np.allclose(pts[0], pts[-1]):
        pts = pts[:-1]  # closed ring
    if "bbox" not in doc:
        bad("bbox", "missing field")
    bbox = doc["bbox"]
    if not isinstance(bbox, dict):
        bad("bbox", "expected an object with min and max")
    for key in ("min", "max"):
        if key not in bbox:
            bad(f"bbox.{key}", "missing field")
    bmin, bmax = vec2(bbox["min"], "bbox.min"), vec2(bbox["max"], "bbox.max")
    if np.any(bmax <= bmin):
        bad("bbox", "max must exceed min on both axes")
    ext = bmax - bmin
    tol = 1e-3 * float(ext.max())
    if np.any(pts < bmin - tol) or np.any(pts > bmax + tol):
        bad("bbox", "does not contain all verts")
    e = np.roll(pts, -1, axis=0) - pts
    if np.any(np.hypot(e[:, 0], e[:, 1]) <= 1e-9):
        bad("verts", "repeated consecutive vertex")
    m = len(pts)
    for i in range(m):
        for j in range(i + 1, m):
            if j == i + 1 or (i == 0 and j == m - 1):
                continue
            if _segments_intersect(pts[i], pts[(i + 1) % m], pts[j], pts[(j + 1) % m]):
                bad("verts", f"outline crosses itself (edges {i} and {j})")
    if abs(_poly_area(pts)) <= 1e-9:
        bad("verts", "outline has zero area")
    return pts, bmin, bmax


def _inside_polygon(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd point-in-polygon test for ``pts (N, 2)`` and a simple polygon ``(E, 2)``."""
    x, y = pts[:, 0][:, None], pts[:, 1][:, None]
    ax, ay = poly[:, 0][None], poly[:, 1][None]
    bx, by = np.roll(poly[:, 0], -1)[None], np.roll(poly[:, 1], -1)[None]
    cond = (ay > y) != (by > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xint = ax + (y - ay) * (bx - ax) / (by - ay)
    return (np.sum(cond & (x < xint), axis=1) % 2) == 1


def exterior_fill(outline: np.ndarray, width: float, depth: float) -> list[list[tuple[float, float]]]:
    """Convex pieces covering ``[0, width] x [0, depth]`` minus the simple polygon ``outline``.

    Vertical-slab (trapezoidal) decomposition: between consecutive vertex ``x`` coordinates the
    outline's edges cross every slab completely, and the pieces between the box bottom, the edges
    in ``y`` order and the box top alternate outside/inside. Horizontally adjacent pieces bounded
    by the same lines are merged. Returns CCW polygons ``[(x, y), ...]`` (metres).
    """
    P = np.asarray(outline, float)
    m = len(P)
    xs = sorted({0.0, float(width), *(float(v) for v in P[:, 0])})
    xs = [x for x in xs if 0.0 <= x <= width]
    edges = [(P[k], P[(k + 1) % m]) for k in range(m) if P[k][0] != P[(k + 1) % m][0]]

    def line_of(a, b):  # (slope, intercept) of a non-vertical edge
        s = (b[1] - a[1]) / (b[0] - a[0])
        return (s, a[1] - s * a[0])

    pieces: list[dict] = []  # open pieces: x0, x1, lower line, upper line
    done: list[dict] = []
    for xa, xb in zip(xs[:-1], xs[1:]):
        if xb - xa <= 1e-9:
            continue
        xm = 0.5 * (xa + xb)
        crossing = []
        for a, b in edges:
            lo, hi = min(a[0], b[0]), max(a[0], b[0])
            if lo <= xa + 1e-12 and hi >= xb - 1e-12:
                s, c0 = line_of(a, b)
                crossing.append((s * xm + c0, (s, c0)))
        crossing.sort()
        bounds = [(0.0, (0.0, 0.0))] + crossing + [(float(depth), (0.0, float(depth)))]
        new_open = []
        for k in range(0, len(bounds) - 1, 2):
            lower, upper = bounds[k][1], bounds[k + 1][1]
            match = next((p for p in pieces if p["x1"] == xa and p["lo"] == lower and p["hi"] == upper),
                         None)
            if match is not None:
                pieces.remove(match)
                match["x1"] = xb
                new_open.append(match)
            else:
                new_open.append({"x0": xa, "x1": xb, "lo": lower, "hi": upper})
        done += pieces
        pieces = new_open
    done += pieces
    out = []
    for p in done:
        x0, x1 = p["x0"], p["x1"]
        (s_l, c_l), (s_u, c_u) = p["lo"], p["hi"]
        pts = [(x0, s_l * x0 + c_l), (x1, s_l * x1 + c_l), (x1, s_u * x1 + c_u), (x0, s_u * x0 + c_u)]
        pts = [(_q(x), _q(y)) for x, y in pts]
        uniq = []
        for q in pts:
            if not uniq or q != uniq[-1]:
                uniq.append(q)
        if len(uniq) > 1 and uniq[0] == uniq[-1]:
            uniq.pop()
        if len(uniq) >= 3 and abs(_poly_area(np.asarray(uniq))) > 1e-8 and _is_convex(np.asarray(uniq)):
            out.append(list(_ccw_tuple(uniq)))
    return out


def level_from_houseexpo(doc: Any, name: str, seed: int, size: float = DEFAULT_SIZE,
                         obstacles: int = 8, max_attempts: int = MAX_ATTEMPTS) -> Level:
    """A level from a HouseExpo document (Li et al., 2020): its outline, textures and obstacles.

    ``doc`` keys: ``verts`` (the house outline, ``[[x, y], ...]`` metres), ``bbox``
    (``{"min": [x, y], "max": [x, y]}``); others are ignored. The outline is translated so
    ``bbox.min`` lands at ``(m, m)`` with the margin ``m`` = :data:`HOUSEEXPO_MARGIN` and scaled
    uniformly (aspect kept) so that its longer side spans ``size - 2 m``: the level box is the
    outline's box plus the margin, which holds the walls (one per outline edge, extended by half
    a thickness at both ends to close the corners). The outside of the outline is filled
    (:func:`exterior_fill`); ``obstacles`` free-standing furniture obstacles are placed inside
    with :data:`OBSTACLE_GAP` to every wall. Malformed documents raise :class:`LevelError`
    naming the field.
    """
    _check_name_seed(name, seed)
    pts, bmin, bmax = _parse_houseexpo(doc)
    if not (isinstance(size, (int, float)) and math.isfinite(size) and 3.0 <= size <= 30.0):
        raise ConfigError(f"size must be between 3 and 30 m, got {size!r}")
    if not (isinstance(obstacles, int) and 0 <= obstacles <= 40):
        raise ConfigError(f"obstacles must be an integer in [0, 40], got {obstacles!r}")
    m = HOUSEEXPO_MARGIN
    scale = (size - 2 * m) / float((bmax - bmin).max())
    P = [(_q((x - bmin[0]) * scale + m), _q((y - bmin[1]) * scale + m)) for x, y in pts]
    # drop vertices made duplicate by rounding
    P = [p for k, p in enumerate(P) if p != P[k - 1]]
    poly = np.asarray(_ccw_tuple(P), float)
    width = _q((bmax[0] - bmin[0]) * scale + 2 * m)
    depth = _q((bmax[1] - bmin[1]) * scale + 2 * m)
    poly[:, 0] = np.clip(poly[:, 0], m, width - m)
    poly[:, 1] = np.clip(poly[:, 1], m, depth - m)
    fill = exterior_fill(poly, width, depth)
    return _retry(lambda rng, k: _houseexpo_attempt(rng, name, seed, poly, width, depth, fill,
                                                    float(size), scale, obstacles, doc, k),
                  name, seed, max_attempts)


def _houseexpo_attempt(rng, name, seed, poly, width, depth, fill, size, scale, n_obs, doc, attempt):
    m = len(poly)
    segs = []
    for k in range(m):
        a, b = poly[k], poly[(k + 1) % m]
        d = (b - a) / np.linalg.norm(b - a) * (WALL_THICKNESS / 2)
        # extend each wall by half a thickness at both ends so that corners are closed
        segs.append(((_q(a[0] - d[0]), _q(a[1] - d[1])), (_q(b[0] + d[0]), _q(b[1] + d[1]))))
    n_wall_tex, n_obs_tex = 8, 6
    textures = [_floor_texture(rng), _ceiling_texture(rng), _exterior_texture()]
    textures += _palette(rng, n_wall_tex)
    textures += _palette(rng, n_obs_tex, sat=(0.4, 0.75), val=(0.35, 0.7))
    wtex = _colour_walls(rng, segs, n_wall_tex)
    walls = [Wall(a, b, WALL_THICKNESS, 3 + k) for (a, b), k in zip(segs, wtex)]
    obs = [Obstacle(tuple(p), LEVEL_HEIGHT, 2) for p in fill]
    exterior = list(range(len(obs)))
    g = OBSTACLE_GAP + WALL_THICKNESS / 2
    lo, hi = poly.min(0), poly.max(0)
    placed = []
    for _ in range(n_obs):
        for _try in range(400):
            kind, a, b, height = _furniture_shape(rng)
            ang = _q(rng.uniform(0, math.pi), 1e-3)
            cx, cy = _q(rng.uniform(lo[0], hi[0]), 0.01), _q(rng.uniform(lo[1], hi[1]), 0.01)
            shape = _rotated_shape(kind, a, b, cx, cy, ang, 8 if rng.random() < 0.5 else 6)
            arr = np.asarray(shape)
            if not _inside_polygon(arr, poly).all():
                continue
            dmin = min(_point_segment_distance(p, poly[k], poly[(k + 1) % m])
                       for p in shape for k in range(m))
            dmin = min(dmin, float(_distance_to_convex(poly, np.asarray(_ccw_tuple(shape))).min()))
            if dmin < g:
                continue
            bb = (float(arr[:, 0].min()), float(arr[:, 1].min()), float(arr[:, 0].max()), float(arr[:, 1].max()))
            if any(_rect_gap(bb, q[1]) < OBSTACLE_GAP for q in placed):
                continue
            placed.append((shape, bb, height))
            break
        else:
            raise _AttemptFailed("could not place all obstacles")
    first = 3 + n_wall_tex
    obs += [Obstacle(_ccw_tuple(s), h, first + int(rng.integers(n_obs_tex))) for s, _, h in placed]
    meta = {
        "generator": "navbench.levelgen.houseexpo", "version": GENERATOR_VERSION, "kind": "houseexpo",
        "size": _q(size), "scale": _q(scale, 1e-6), "obstacles_requested": n_obs, "attempt": attempt,
        "houseexpo_id": str(doc.get("id", "")),
        "rooms": [], "doors": [], "exterior_obstacles": exterior,
    }
    level = Level(name=name, width=width, depth=depth, walls=tuple(walls), obstacles=tuple(obs),
                  textures=tuple(textures), floor_texture=0, ceiling_texture=1,
                  height=LEVEL_HEIGHT, seed=seed, meta=meta)
    try:
        validate_level(level)
    except LevelError as e:
        raise _AttemptFailed(str(e)) from None
    return level


# ----------------------------------------------------------------------------------- benchmark

def make_level(name: str, seed: int, kind: str = "house", size: float | None = None,
               rooms: int | None = None, obstacles: int | None = None) -> Level:
    """Dispatch on ``kind`` (``house`` or ``maze``); ``size=None`` takes the kind's default."""
    if kind == "house":
        return generate_level(name, seed, size=DEFAULT_SIZE if size is None else size,
                              rooms=rooms, obstacles=obstacles)
    if kind == "maze":
        if rooms is not None or obstacles:
            raise ConfigError("maze levels take no --rooms or --obstacles")
        return generate_maze(name, seed, size=MAZE_SIZE if size is None else size)
    raise ConfigError(f"unknown level kind {kind!r}; choose one of {LEVEL_KINDS}")


def make_benchmark_level(name: str) -> Level:
    """Regenerate one of :data:`BENCHMARK_LEVELS` from its table entry."""
    if name not in BENCHMARK_LEVELS:
        raise ConfigError(f"unknown benchmark level {name!r}; choose one of {sorted(BENCHMARK_LEVELS)}")
    opts = dict(BENCHMARK_LEVELS[name])
    return make_level(name, **opts)


def benchmark_levels(names: Iterable[str] | None = None) -> list[Level]:
    """All (or the named) benchmark levels, in table order."""
    return [make_benchmark_level(n) for n in (names if names is not None else BENCHMARK_LEVELS)]
