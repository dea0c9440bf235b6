"""A navbench :class:`~navbench.level.Level` as a Doom map: UDMF text in a PWAD (pure, no engine).

Why written here and not with ``omgifol``: a UDMF map is a few dozen lines of plain text
(``vertex``, ``linedef``, ``sidedef``, ``sector``, ``thing`` blocks) and a PWAD is a 12-byte
header, the lumps and a 16-byte-per-lump directory; ``omgifol`` would add a dependency (and
its own UDMF model to learn) for about forty lines, and the part that needs care is not the
file format but the geometry: turning navbench's overlapping convex prisms into the planar,
closed line set a Doom map is.

Geometry (1 map unit = 1 cm, :data:`UNITS_PER_METRE`)
    Every edge of every solid's footprint (:func:`navbench.level.prisms`: walls as their
    rectangles, obstacles as their polygons) and of the level box ``[0, width] x [0, depth]``
    is split wherever another edge meets it (proper crossings, T-junctions, collinear
    overlaps), so the pieces form a planar arrangement. Each piece is classified by what lies
    just to its left and right: *void* (outside the box, or under a solid at least the level's
    height: walls and full-height furniture), the *floor* sector, or the sector of the tallest
    lower-than-the-ceiling obstacle covering that side. A piece with the same thing on both
    sides is dropped; void on one side gives a one-sided linedef (a wall: blocks movement and
    the view); two sectors give a two-sided linedef whose lower texture is the obstacle's side
    (furniture lower than the level: a raised floor the camera sees over). Every linedef is
    flagged ``blocking``. Sectors: 0 is the floor (``heightfloor = 0``, ``heightceiling =``
    the level height), then one per low obstacle (``heightfloor =`` its height); heights are
    whole map units (UDMF integers), i.e. rounded to 1 cm. ViZDoom builds the nodes itself
    when it loads a UDMF map (no node builder runs here).

Textures: navbench texture ``t`` of a solid is the engine's (freedoom2) wall texture
``WALL_TEXTURES[t % len]``; floor, ceiling and obstacle tops use the flats
``FLATS[t % len]``. They are real Doom textures (the engine's own look: texture filtering,
distance lighting), not navbench's procedural colours; the exact-depth option of the backend
still uses the level's geometry.
"""

from __future__ import annotations

import hashlib
import math
import struct
from collections import OrderedDict
from dataclasses import dataclass, fields

import numpy as np

from navbench.errors import LevelError
from navbench.level import Level, distance_to_solids, prisms

#: Map units per metre: 1 unit = 1 cm, so the engine's integer ``warp`` gives 0.01 m positions.
UNITS_PER_METRE = 100.0
#: The engine's ``warp`` sends coordinates as signed 16-bit integers: the largest coordinate.
MAX_UNITS = 32767
#: Distinct freedoom2 wall textures (a navbench texture index picks one, modulo the length).
WALL_TEXTURES = ("STARTAN2", "BROWN1", "CEMENT1", "COMPBLUE", "MARBLE1", "BRICK1", "METAL1",
                 "GRAY1", "PANEL1", "ROCK4", "SILVER1", "STONE2", "TEKWALL1", "WOOD1", "ZIMMER2")
#: Distinct freedoom2 flats for floors, ceilings and obstacle tops.
FLATS = ("FLOOR0_1", "CEIL1_1", "FLAT1_1", "FLOOR4_8", "FLAT5_4", "CEIL3_5", "FLOOR7_1", "GRNROCK",
         "FLAT14", "RROCK09", "CRATOP1", "FLOOR1_6")
#: Light level of every sector (0..255). Below 255 Doom's diminishing light darkens what is
#: far: at 192 a wall keeps its colour within 1 m and falls to 0.84 of it at 4 m and 0.76 at
#: 8 m; at 255 it keeps it at every distance (measured, docs/notebook/vizdoom.md, 2026-11-27).
#: With the heading search off or spread, maps fitted under either light track alike (the same
#: notebook section); 192 is the default.
LIGHT_LEVEL = 192
#: Doom thing type of the player-1 start.
PLAYER_START = 1

_VOID = -1


@dataclass(frozen=True)
class DoomMap:
    """A converted level: the UDMF text, the WAD bytes and the arrangement behind them.

    ``lines (L, 4)`` float64 map units ``(x1, y1, x2, y2)`` with the front (right) side towards
    ``front (L,)`` and the back side towards ``back (L,)`` (sector index, -1: none: one-sided);
    ``sector_floor (S,)`` / ``sector_ceiling (S,)`` whole map units; ``start (2,)`` the player
    start in map units.
    """

    textmap: str
    wad: bytes
    lines: np.ndarray
    front: np.ndarray
    back: np.ndarray
    sector_floor: np.ndarray
    sector_ceiling: np.ndarray
    start: np.ndarray


def write_wad(lumps: list[tuple[str, bytes]]) -> bytes:
    """A PWAD holding ``lumps`` (name of at most 8 ASCII characters, body) in order."""
    body, directory, offset = [], [], 12
    for name, data in lumps:
        if len(name) > 8 or not name.isascii():
            raise ValueError(f"a lump name has at most 8 ASCII characters, got {name!r}")
        directory.append(struct.pack("<ii8s", offset, len(data), name.encode()))
        body.append(data)
        offset += len(data)
    return struct.pack("<4sii", b"PWAD", len(lumps), offset) + b"".join(body) + b"".join(directory)


def read_wad(data: bytes) -> list[tuple[str, bytes]]:
    """The lumps ``(name, body)`` of a WAD (for tests and inspection)."""
    kind, n, off = struct.unpack("<4sii", data[:12])
    if kind not in (b"PWAD", b"IWAD"):
        raise ValueError("not a WAD")
    out = []
    for k in range(n):
        pos, size, name = struct.unpack("<ii8s", data[off + 16 * k: off + 16 * k + 16])
        out.append((name.rstrip(b"\0").decode(), data[pos: pos + size]))
    return out


# ------------------------------------------------------------------------------ arrangement

def _segments(level: Level) -> tuple[np.ndarray, list[np.ndarray], np.ndarray, np.ndarray]:
    """Every footprint edge and the box's, ``(N, 4)`` metres; the polygons, heights, textures."""
    pr = prisms(level)
    polys = [pr.polygon(p) for p in range(len(pr))]
    edges = [np.concatenate([poly, np.roll(poly, -1, axis=0)], axis=1) for poly in polys]
    w, d = float(level.width), float(level.depth)
    box = np.array([[0, 0, w, 0], [w, 0, w, d], [w, d, 0, d], [0, d, 0, 0]], float)
    return np.concatenate(edges + [box]), polys, pr.height, pr.texture


def _split_parameters(seg: np.ndarray, tol: float) -> list[np.ndarray]:
    """For each segment, the sorted parameters in ``[0, 1]`` where another segment meets it."""
    a, d = seg[:, :2], seg[:, 2:] - seg[:, :2]
    length = np.linalg.norm(d, axis=1)
    out = [[np.array([0.0, 1.0])] for _ in range(len(seg))]
    lo, hi = np.minimum(seg[:, :2], seg[:, 2:]) - tol, np.maximum(seg[:, :2], seg[:, 2:]) + tol
    for i0 in range(0, len(seg), 256):  # blocks of 256 against all: bounded memory on big levels
        i = np.arange(i0, min(i0 + 256, len(seg)))
        near = np.all((lo[i, None] <= hi[None]) & (hi[i, None] >= lo[None]), axis=2)
        near[np.arange(len(i)), i] = False
        ii, jj = np.nonzero(near)
        ii = i[ii]
        ai, di, aj, dj = a[ii], d[ii], a[jj], d[jj]
        cross = di[:, 0] * dj[:, 1] - di[:, 1] * dj[:, 0]
        r = aj - ai
        # endpoints of j lying on i (T-junctions, collinear overlaps, shared corners)
        for p in (aj, aj + dj):
            q = p - ai
            t = (q * di).sum(1) / length[ii] ** 2
            dist = np.abs(di[:, 0] * q[:, 1] - di[:, 1] * q[:, 0]) / length[ii]
            ok = (dist <= tol) & (t > 0) & (t < 1)
            for k in np.flatnonzero(ok):
                out[ii[k]].append(t[k:k + 1])
        # proper crossings
        par = np.abs(cross) <= 1e-12 * length[ii] * length[jj]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (r[:, 0] * dj[:, 1] - r[:, 1] * dj[:, 0]) / cross
            u = (r[:, 0] * di[:, 1] - r[:, 1] * di[:, 0]) / cross
        ok = ~par & (t > 0) & (t < 1) & (u >= -tol / length[jj]) & (u <= 1 + tol / length[jj])
        for k in np.flatnonzero(ok):
            out[ii[k]].append(t[k:k + 1])
    return [np.unique(np.concatenate(p)) for p in out]


def _cells(points: np.ndarray, level: Level, polys, heights) -> np.ndarray:
    """What lies at each point ``(N, 2)`` metres: -1 void, 0 the floor, ``1 + p`` the tallest
    low prism ``p`` covering it."""
    n = len(points)
    best_h = np.zeros(n)
    cell = np.zeros(n, np.int64)
    x, y = points[:, 0], points[:, 1]
    void = (x <= 0) | (x >= level.width) | (y <= 0) | (y >= level.depth)
    for p, poly in enumerate(polys):
        e = np.roll(poly, -1, axis=0) - poly
        rel = points[:, None, :] - poly[None]
        inside = np.all(e[None, :, 0] * rel[..., 1] - e[None, :, 1] * rel[..., 0] > 0, axis=1)
        if heights[p] >= level.height:
            void |= inside
        else:
            take = inside & (heights[p] > best_h)
            best_h[take] = heights[p]
            cell[take] = 1 + p
    cell[void] = _VOID
    return cell


def level_to_map(level: Level, light_level: int = LIGHT_LEVEL) -> DoomMap:
    """Convert ``level`` to a Doom map (see the module docstring). Raises
    :class:`~navbench.errors.LevelError` for a level larger than the engine's ``warp`` reaches."""
    s = UNITS_PER_METRE
    if max(level.width, level.depth) * s > MAX_UNITS:
        raise LevelError(f"level {level.name!r} is {level.width:g} x {level.depth:g} m; the Doom backend's "
                         f"warp reaches {MAX_UNITS / s:g} m")
    seg, polys, heights, textures = _segments(level)
    params = _split_parameters(seg, tol=1e-7)
    pieces = []
    for k, t in enumerate(params):
        a, d = seg[k, :2], seg[k, 2:] - seg[k, :2]
        pts = a + t[:, None] * d
        pieces.append(np.concatenate([pts[:-1], pts[1:]], axis=1))
    pieces = np.concatenate(pieces)
    # drop zero-length pieces and duplicates (shared or overlapping edges), direction ignored
    key = np.round(pieces * 1e6).astype(np.int64)  # micrometres
    keep = np.any(key[:, :2] != key[:, 2:], axis=1)
    pieces, key = pieces[keep], key[keep]
    flip = (key[:, 0] > key[:, 2]) | ((key[:, 0] == key[:, 2]) & (key[:, 1] > key[:, 3]))
    key[flip] = key[flip][:, [2, 3, 0, 1]]
    _, first = np.unique(key, axis=0, return_index=True)
    pieces = pieces[np.sort(first)]
    # classify both sides (left normal (-dy, dx)) at the midpoint
    mid = (pieces[:, :2] + pieces[:, 2:]) / 2
    d = pieces[:, 2:] - pieces[:, :2]
    nrm = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.linalg.norm(d, axis=1)[:, None]
    left = _cells(mid + 1e-5 * nrm, level, polys, heights)
    right = _cells(mid - 1e-5 * nrm, level, polys, heights)
    keep = left != right
    pieces, left, right = pieces[keep], left[keep], right[keep]
    # Doom's front side is the right side of v1 -> v2: put void (if any) behind
    swap = right == _VOID
    pieces[swap] = pieces[swap][:, [2, 3, 0, 1]]
    front = np.where(swap, left, right)
    back = np.where(swap, right, left)
    # vertices are written to 1e-3 units (10 micrometres): a piece shorter than that would be a
    # zero-length line, which the engine's node builder must not see; dropping it joins its
    # neighbours at one vertex
    lines = np.round(pieces * s, 3)
    keep = np.any(lines[:, :2] != lines[:, 2:], axis=1)
    lines, front, back = lines[keep], front[keep], back[keep]
    # sectors: 0 the floor, then one per low prism that shows up in the map
    low = sorted({int(c) for c in np.concatenate([front, back]) if c > 0})
    sector_of = {0: 0, **{c: k + 1 for k, c in enumerate(low)}}
    height_u = int(round(level.height * s))
    sector_floor = np.array([0] + [int(round(heights[c - 1] * s)) for c in low], np.int64)
    sector_ceiling = np.full(len(sector_floor), height_u, np.int64)
    start = _player_start(level)
    text = _textmap(level, lines, front, back, sector_of, low, sector_floor, height_u, textures,
                    polys, heights, start, light_level)
    wad = write_wad([("MAP01", b""), ("TEXTMAP", text.encode()), ("ENDMAP", b"")])
    fs = np.array([sector_of[int(c)] for c in front], np.int64)
    bs = np.array([sector_of[int(c)] if c != _VOID else -1 for c in back], np.int64)
    return DoomMap(text, wad, lines, fs, bs, sector_floor, sector_ceiling, start)


#: How many converted maps :func:`cached_level_map` keeps per process (a worker runs one
#: level's episodes at a time; a few cover collect-views and the grid's level changes).
MAP_CACHE_SIZE = 8
_MAP_CACHE: OrderedDict[tuple[str, int], DoomMap] = OrderedDict()


def level_digest(level: Level) -> str:
    """sha256 of every field of ``level`` the conversion reads (all but ``meta``, which the
    level's equality ignores too), as ``repr``: floats by their exact shortest repr, so two
    levels share a digest only when every number is the same double."""
    parts = tuple((f.name, getattr(level, f.name)) for f in fields(level) if f.compare)
    return hashlib.sha256(repr(parts).encode()).hexdigest()


def cached_level_map(level: Level, light_level: int = LIGHT_LEVEL) -> DoomMap:
    """:func:`level_to_map` once per level content and light level in this process (the
    last :data:`MAP_CACHE_SIZE`): the pipeline starts an engine per episode, and the
    conversion is pure, so a repeat returns the same :class:`DoomMap`, its arrays read-only.
    Measured: the conversion took 0.11-0.13 s of house-1's ~0.25 s engine start
    (``docs/data/vizdoom/episode_time.py``)."""
    key = (level_digest(level), int(light_level))
    hit = _MAP_CACHE.get(key)
    if hit is None:
        hit = level_to_map(level, light_level)
        for a in (hit.lines, hit.front, hit.back, hit.sector_floor, hit.sector_ceiling, hit.start):
            a.flags.writeable = False
        _MAP_CACHE[key] = hit
        while len(_MAP_CACHE) > MAP_CACHE_SIZE:
            _MAP_CACHE.popitem(last=False)
    else:
        _MAP_CACHE.move_to_end(key)
    return hit


def _player_start(level: Level) -> np.ndarray:
    """A floor point (map units) with the most clearance on a 0.1 m grid: the engine needs a
    player start inside the map; the backend warps the player away from it at once."""
    xs = np.arange(0.05, level.width, 0.1)
    ys = np.arange(0.05, level.depth, 0.1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel()], axis=1)
    clear = np.minimum(distance_to_solids(level, pts),
                       np.minimum.reduce([pts[:, 0], pts[:, 1], level.width - pts[:, 0], level.depth - pts[:, 1]]))
    k = int(np.argmax(clear))
    if clear[k] <= 0:
        raise LevelError(f"level {level.name!r} has no free floor for the Doom player start")
    return np.round(pts[k] * UNITS_PER_METRE, 3)


def _f(v: float) -> str:
    """A UDMF float (map units; 1e-3 unit = 10 micrometres)."""
    v = round(float(v), 3)
    return f"{0.0 if v == 0 else v:.3f}"


def _textmap(level, lines, front, back, sector_of, low, sector_floor, height_u, textures, polys,
             heights, start, light_level) -> str:
    out = ['namespace = "zdoom";', ""]
    verts: dict[tuple[str, str], int] = {}
    vidx = []
    for x1, y1, x2, y2 in lines:
        pair = []
        for x, y in ((x1, y1), (x2, y2)):
            k = (_f(x), _f(y))
            if k not in verts:
                verts[k] = len(verts)
                out.append(f"vertex {{ x = {k[0]}; y = {k[1]}; }}")
            pair.append(verts[k])
        vidx.append(pair)
    flats = lambda t: FLATS[int(t) % len(FLATS)]  # noqa: E731
    walls = lambda t: WALL_TEXTURES[int(t) % len(WALL_TEXTURES)]  # noqa: E731
    out.append(f'sector {{ heightfloor = 0; heightceiling = {height_u}; texturefloor = "{flats(level.floor_texture)}"; '
               f'textureceiling = "{flats(level.ceiling_texture)}"; lightlevel = {int(light_level)}; }}')
    for c, h in zip(low, sector_floor[1:]):
        out.append(f'sector {{ heightfloor = {int(h)}; heightceiling = {height_u}; '
                   f'texturefloor = "{flats(textures[c - 1])}"; textureceiling = "{flats(level.ceiling_texture)}"; '
                   f"lightlevel = {int(light_level)}; }}")
    sides = 0
    pts = (lines[:, :2] + lines[:, 2:]) / 2 / UNITS_PER_METRE
    for k in range(len(lines)):
        f, b = int(front[k]), int(back[k])
        if b == _VOID:  # a wall: the texture of the full-height solid behind (the box: texture 0)
            behind = _solid_at(pts[k], lines[k], polys, heights, level.height)
            tex = walls(textures[behind]) if behind >= 0 else walls(0)
            out.append(f'sidedef {{ sector = {sector_of[f]}; texturemiddle = "{tex}"; }}')
            out.append(f"linedef {{ v1 = {vidx[k][0]}; v2 = {vidx[k][1]}; sidefront = {sides}; blocking = true; }}")
            sides += 1
        else:  # between floor levels: the lower texture is the taller side's obstacle
            top = f if (f > 0 and (b == 0 or heights[f - 1] >= heights[b - 1])) else b
            tex = walls(textures[top - 1])
            out.append(f'sidedef {{ sector = {sector_of[f]}; texturebottom = "{tex}"; }}')
            out.append(f'sidedef {{ sector = {sector_of[b]}; texturebottom = "{tex}"; }}')
            out.append(f"linedef {{ v1 = {vidx[k][0]}; v2 = {vidx[k][1]}; sidefront = {sides}; "
                       f"sideback = {sides + 1}; twosided = true; blocking = true; }}")
            sides += 2
    out.append(f"thing {{ x = {_f(start[0])}; y = {_f(start[1])}; angle = 0; type = {PLAYER_START}; "
               "skill1 = true; skill2 = true; skill3 = true; skill4 = true; skill5 = true; single = true; }")
    return "\n".join(out) + "\n"


def _solid_at(mid: np.ndarray, line: np.ndarray, polys, heights, level_height: float) -> int:
    """The full-height prism just behind (left of) a one-sided line's midpoint, -1 if none."""
    d = line[2:] - line[:2]
    p = mid + np.array([-d[1], d[0]]) / math.hypot(*d) * 1e-5
    for k, poly in enumerate(polys):
        if heights[k] < level_height:
            continue
        e = np.roll(poly, -1, axis=0) - poly
        rel = p[None] - poly
        if np.all(e[:, 0] * rel[:, 1] - e[:, 1] * rel[:, 0] > 0):
            return k
    return -1
