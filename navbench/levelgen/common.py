"""Constants, small geometric helpers and textures shared by the level generators."""

from __future__ import annotations

import colorsys
import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from navbench.geometry import AGENT_LENGTH
from navbench.level import Texture

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
    # issue 16's HouseExpo-like set (the ``dense`` style): seeds fixed before generation, rooms
    # and furniture drawn from the style
    "dense-1": {"kind": "dense", "seed": 1101},
    "dense-2": {"kind": "dense", "seed": 1202},
    "dense-3": {"kind": "dense", "seed": 1303},
    "dense-4": {"kind": "dense", "seed": 1404},
    "dense-5": {"kind": "dense", "seed": 1505},
    "dense-6": {"kind": "dense", "seed": 1606},
}

LEVEL_KINDS = ("house", "dense", "maze")

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
