"""Level files: ``levels/NAME.json`` (``schema_version`` 1, see :func:`level_to_dict`), read with
every field checked and the bad one named (:func:`level_from_dict`), and the free-space check
every loaded level passes (:func:`check_level`).

Separate from :mod:`navbench.level` (the data model and its geometry) so that the checks can
use :mod:`navbench.levelgen`'s validators, which themselves build on the data model, without
an import cycle.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from navbench.errors import LevelError
from navbench.geometry import LEVEL_HEIGHT
from navbench.level import (BOX_TOLERANCE, MAX_HEIGHT, MAX_POLYGON_VERTICES, MAX_SIZE, MAX_SOLIDS,
                            MAX_WALL_THICKNESS, SCHEMA_VERSION, TEXTURE_KINDS, Level, Obstacle,
                            Texture, Wall, _is_convex)
from navbench.levelgen import validate_free_space
from navbench.names import check_name

#: Largest level file read (bytes): a benchmark house is ~30 kB, MAX_SOLIDS walls ~ 1 MB.
MAX_LEVEL_BYTES = 8 * 1024 * 1024


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
    from navbench.outpath import write_text_atomic

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_text_atomic(path, dumps_level(level))


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
    from navbench.safeio import loads_json, read_text

    path = Path(path)
    # safeio: a regular file of bounded size, bounded nesting, finite numbers (issue 34)
    text = read_text(path, LevelError, "level file", MAX_LEVEL_BYTES)
    doc = loads_json(text, str(path), LevelError)
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
    from navbench.safeio import names_a_file

    p = Path(name_or_path)
    if names_a_file(name_or_path):  # /dev/zero, a FIFO: read (and refused) as a file
        return load_level(p, name=p.stem)
    check_name("level name", name_or_path, LevelError)
    path = level_path(name_or_path, root)
    if not path.is_file():
        from navbench.names import did_you_mean

        known = sorted(q.stem for q in path.parent.glob("*.json"))
        raise LevelError(f"{path}: no such level file{did_you_mean(name_or_path, known)}")
    return load_level(path, name=name_or_path)
