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
caster and the collision world. File format: ``levels/NAME.json`` with ``schema_version`` 1 (see
:func:`level_to_dict`); :func:`load_level` validates every field and names the bad one.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navbench.errors import LevelError
from navbench.geometry import LEVEL_HEIGHT
from navbench.names import check_name

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


# ----------------------------------------------------------------------------------- file I/O

def _r(x: float) -> float:
    """Round to 1e-6 so files are byte-identical across platforms."""
    v = round(float(x), 6)
    return 0.0 if v == 0 else v


def level_to_dict(level: Level) -> dict[str, Any]:
    """The JSON document of a level (schema version 1)."""
    return {
        "schema_version": SCHEMA_VERSION,
        "name": level.name,
        "seed": level.seed,
        "units": "metres",
        "width": _r(level.width),
        "depth": _r(level.depth),
        "height": _r(level.height),
        "floor_texture": level.floor_texture,
        "ceiling_texture": level.ceiling_texture,
        "textures": [
            {"kind": t.kind, "base": [_r(c) for c in t.base], "amp": [_r(c) for c in t.amp],
             "waves": [[_r(c) for c in w] for w in t.waves]}
            for t in level.textures
        ],
        "walls": [
            {"a": [_r(c) for c in w.a], "b": [_r(c) for c in w.b], "thickness": _r(w.thickness),
             "texture": w.texture}
            for w in level.walls
        ],
        "obstacles": [
            {"polygon": [[_r(c) for c in p] for p in o.polygon], "height": _r(o.height),
             "texture": o.texture}
            for o in level.obstacles
        ],
        "meta": level.meta,
    }


def dumps_level(level: Level) -> str:
    """Deterministic JSON text of a level (what ``save_level`` writes)."""
    return json.dumps(level_to_dict(level), indent=1, sort_keys=False) + "\n"


def save_level(level: Level, path: str | Path) -> Path:
    """Write ``level`` atomically to ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(dumps_level(level))
    tmp.replace(path)
    return path


def _short(x, limit: int = 60) -> str:
    """``repr(x)`` cut to ``limit`` characters (error messages stay one short line)."""
    r = repr(x)
    return r if len(r) <= limit else r[: limit - 3] + "..."


class _V:
    """Field validator that names the offending field in its errors."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, where: str, msg: str):
        raise LevelError(f"{self.source}: {where}: {msg}")

    def get(self, d: dict, key: str, where: str):
        if not isinstance(d, dict):
            self.fail(where, "expected an object")
        if key not in d:
            self.fail(f"{where}.{key}" if where else key, "missing field")
        return d[key]

    def num(self, x, where: str, positive: bool = False, minimum: float | None = None,
            maximum: float | None = None) -> float:
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            self.fail(where, f"expected a finite number, got {_short(x)}")
        try:
            ok = math.isfinite(x)
        except OverflowError:  # an integer too large for a float
            ok = False
        if not ok:
            self.fail(where, f"expected a finite number, got {_short(x)}")
        if positive and x <= 0:
            self.fail(where, f"expected a positive number, got {x!r}")
        if minimum is not None and x < minimum:
            self.fail(where, f"expected a number >= {minimum}, got {x!r}")
        if maximum is not None and x > maximum:
            self.fail(where, f"expected a number <= {maximum:g}, got {_short(x)}")
        return float(x)

    def vec(self, x, n: int, where: str) -> tuple[float, ...]:
        if not isinstance(x, list) or len(x) != n:
            self.fail(where, f"expected a list of {n} numbers, got {_short(x)}")
        return tuple(self.num(c, f"{where}[{i}]") for i, c in enumerate(x))

    def point(self, x, where: str, width: float, depth: float) -> tuple[float, float]:
        """An ``[x, y]`` point inside the level box (within :data:`BOX_TOLERANCE`)."""
        p = self.vec(x, 2, where)
        t = BOX_TOLERANCE
        if not (-t <= p[0] <= width + t and -t <= p[1] <= depth + t):
            self.fail(where, f"point {_short(x)} lies outside the level box "
                             f"[0, {width:g}] x [0, {depth:g}]")
        return p

    def idx(self, x, n: int, where: str) -> int:
        if isinstance(x, bool) or not isinstance(x, int) or not 0 <= x < n:
            self.fail(where, f"expected a texture index in [0, {n}), got {x!r}")
        return x


def level_from_dict(doc: Any, source: str = "<level>") -> Level:
    """Validate and build a :class:`Level` from its JSON document; errors name the field."""
    v = _V(source)
    if not isinstance(doc, dict):
        v.fail("document", "expected a JSON object")
    ver = v.get(doc, "schema_version", "")
    if ver != SCHEMA_VERSION:
        v.fail("schema_version", f"unknown schema version {ver!r} (this navbench reads {SCHEMA_VERSION})")
    name = v.get(doc, "name", "")
    if not isinstance(name, str) or not name:
        v.fail("name", "expected a non-empty string")
    check_name(f"{source}: name:", name, LevelError)
    width = v.num(v.get(doc, "width", ""), "width", positive=True, maximum=MAX_SIZE)
    depth = v.num(v.get(doc, "depth", ""), "depth", positive=True, maximum=MAX_SIZE)
    height = v.num(doc.get("height", LEVEL_HEIGHT), "height", positive=True, maximum=MAX_HEIGHT)
    seed = doc.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
        v.fail("seed", f"expected an integer or null, got {seed!r}")

    raw_tex = v.get(doc, "textures", "")
    if not isinstance(raw_tex, list) or not raw_tex:
        v.fail("textures", "expected a non-empty list")
    textures = []
    for i, t in enumerate(raw_tex):
        w = f"textures[{i}]"
        kind = v.get(t, "kind", w)
        if kind not in TEXTURE_KINDS:
            v.fail(f"{w}.kind", f"expected one of {TEXTURE_KINDS}, got {kind!r}")
        waves = v.get(t, "waves", w)
        need = 3 if kind == "waves" else 2
        if not isinstance(waves, list) or len(waves) != need:
            v.fail(f"{w}.waves", f"expected {need} [fu, fv, phase] triples")
        textures.append(Texture(
            kind=kind,
            base=v.vec(v.get(t, "base", w), 3, f"{w}.base"),
            amp=v.vec(v.get(t, "amp", w), 3, f"{w}.amp"),
            waves=tuple(v.vec(wv, 3, f"{w}.waves[{k}]") for k, wv in enumerate(waves)),
        ))
    T = len(textures)
    floor_t = v.idx(v.get(doc, "floor_texture", ""), T, "floor_texture")
    ceil_t = v.idx(v.get(doc, "ceiling_texture", ""), T, "ceiling_texture")

    raw_walls = v.get(doc, "walls", "")
    if not isinstance(raw_walls, list):
        v.fail("walls", "expected a list")
    raw_obs = v.get(doc, "obstacles", "")
    if not isinstance(raw_obs, list):
        v.fail("obstacles", "expected a list")
    if len(raw_walls) + len(raw_obs) > MAX_SOLIDS:
        v.fail("walls", f"{len(raw_walls)} walls and {len(raw_obs)} obstacles: at most "
                        f"{MAX_SOLIDS} solids in all")
    walls = []
    for i, wd in enumerate(raw_walls):
        w = f"walls[{i}]"
        a = v.point(v.get(wd, "a", w), f"{w}.a", width, depth)
        b = v.point(v.get(wd, "b", w), f"{w}.b", width, depth)
        if math.dist(a, b) <= 1e-9:
            v.fail(w, "wall has zero length")
        walls.append(Wall(a, b, v.num(v.get(wd, "thickness", w), f"{w}.thickness", positive=True,
                                      maximum=MAX_WALL_THICKNESS),
                          v.idx(v.get(wd, "texture", w), T, f"{w}.texture")))

    obstacles = []
    for i, od in enumerate(raw_obs):
        w = f"obstacles[{i}]"
        poly = v.get(od, "polygon", w)
        if not isinstance(poly, list) or not 3 <= len(poly) <= MAX_POLYGON_VERTICES:
            v.fail(f"{w}.polygon", f"expected a list of 3 to {MAX_POLYGON_VERTICES} [x, y] points")
        pts = tuple(v.point(p, f"{w}.polygon[{k}]", width, depth) for k, p in enumerate(poly))
        if not _is_convex(np.asarray(pts)):
            v.fail(f"{w}.polygon", "polygon must be convex and non-degenerate")
        h = v.num(v.get(od, "height", w), f"{w}.height", positive=True)
        if h > height + 1e-9:
            v.fail(f"{w}.height", f"{h} exceeds the level height {height}")
        obstacles.append(Obstacle(pts, h, v.idx(v.get(od, "texture", w), T, f"{w}.texture")))
    if not walls and not obstacles:
        v.fail("walls", "a level needs at least one wall or obstacle")
    meta = doc.get("meta", {})
    if not isinstance(meta, dict):
        v.fail("meta", "expected an object")
    return Level(name=name, width=width, depth=depth, walls=tuple(walls), obstacles=tuple(obstacles),
                 textures=tuple(textures), floor_texture=floor_t, ceiling_texture=ceil_t,
                 height=height, seed=seed, meta=meta)


def _is_convex(poly: np.ndarray) -> bool:
    d = np.roll(poly, -1, axis=0) - poly
    cross = d[:, 0] * np.roll(d, -1, axis=0)[:, 1] - d[:, 1] * np.roll(d, -1, axis=0)[:, 0]
    return bool(np.all(cross > 1e-12) or np.all(cross < -1e-12))


def load_level(path: str | Path, validate: bool = True, name: str | None = None) -> Level:
    """Load and validate ``path``; raise :class:`LevelError` naming the file and the bad field.

    Beyond the fields (:func:`level_from_dict`: types, finite numbers, a safe ``name``, size
    bounds, every point inside the level box), with ``name`` the level's own name must equal it.
    The name becomes output paths (``tasks/NAME-...``, ``results/levels/NAME.png``) and labels
    results, so a ``levels/a.json`` that calls itself ``house-2`` would overwrite and mislabel
    house-2's: every loader of a file a user names passes its stem (:func:`resolve_level`), the
    pipeline the name it looked up. (Cached generated levels are stored as ``level.json``.)
    With ``validate`` (the default) the level must also pass :func:`check_level` (the free
    space is one connected region at the generator's clearance); it costs ~10 ms for a
    benchmark house, so every load pays it and no invalid level reaches an episode.
    """
    return read_level_file(path, validate, name)[0]


def read_level_file(path: str | Path, validate: bool = True,
                    name: str | None = None) -> tuple[Level, str]:
    """:func:`load_level` that also returns the file's text (whose sha256 keys the level), read
    once so that the text hashed is the text validated."""
    path = Path(path)
    if not path.is_file():
        raise LevelError(f"{path}: no such level file")
    try:
        text = path.read_text()
        doc = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise LevelError(f"{path}: not valid JSON ({e})") from None
    except RecursionError:
        raise LevelError(f"{path}: not valid JSON (nested too deeply)") from None
    except OSError as e:
        raise LevelError(f"{path}: cannot read the level file ({e.strerror})") from None
    level = level_from_dict(doc, str(path))
    if name is not None and level.name != name:
        raise LevelError(f"{path}: name: the level calls itself {level.name!r} but is loaded as "
                         f"{name!r} (a level file must be named NAME.json after its name)")
    if validate:
        check_level(level, str(path))
    return level, text


def check_level(level: Level, source: str = "<level>") -> None:
    """Raise :class:`LevelError` (prefixed by ``source``) unless ``level`` is usable.

    The free-space checks of :func:`navbench.levelgen.validate_level`, which every generated
    level passes (:func:`navbench.levelgen.validate_free_space`; the box is checked point by
    point when the file is read): the free space at ``1.2 L`` clearance one 8-connected region
    covering at least a fifth of the house, every room and door of ``meta`` reachable. A level
    that fails them has tasks or views that could never be reached, and its scores would mean
    nothing.
    """
    from navbench.levelgen import validate_free_space

    try:
        validate_free_space(level)
    except LevelError as e:
        raise LevelError(f"{source}: {e}") from None


def level_path(name: str, root: str | Path = ".") -> Path:
    """``<root>/levels/<name>.json``."""
    return Path(root) / "levels" / f"{name}.json"


def resolve_level(name_or_path: str, root: str | Path = ".") -> Level:
    """Load a level by name (from ``levels/``) or by path to a ``.json`` file, whose level must
    be named after the file (its stem); a name must be a safe name."""
    p = Path(name_or_path)
    if p.suffix == ".json" or p.is_file():
        return load_level(p, name=p.stem)
    check_name("level name", name_or_path, LevelError)
    return load_level(level_path(name_or_path, root), name=name_or_path)
