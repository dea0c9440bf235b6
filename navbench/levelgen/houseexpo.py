"""HouseExpo import: a HouseExpo document's outline as walls, the outside filled."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from navbench.errors import ConfigError, LevelError
from navbench.geometry import LEVEL_HEIGHT
from navbench.level import Level, Obstacle, Wall, _is_convex
from navbench.levelgen.common import DEFAULT_SIZE, GENERATOR_VERSION, HOUSEEXPO_MARGIN, MAX_ATTEMPTS, OBSTACLE_GAP, WALL_THICKNESS, _AttemptFailed, _ccw_tuple, _ceiling_texture, _colour_walls, _exterior_texture, _floor_texture, _palette, _point_segment_distance, _poly_area, _q, _rect_gap, _segments_intersect
from navbench.levelgen.house import _check_name_seed, _furniture_shape, _retry, _rotated_shape
from navbench.levelgen.validate import _distance_to_convex, validate_level

# ----------------------------------------------------------------------------------- HouseExpo

#: Most outline points of a HouseExpo document (one wall per edge; HouseExpo's own have < 100).
#: Checked first: the self-crossing check is quadratic in pure Python (20 000 points: minutes).
MAX_HOUSEEXPO_VERTICES = 1000
#: Largest coordinate magnitude (m) in a HouseExpo document (a house, not a continent).
MAX_HOUSEEXPO_COORD = 1e5


def _parse_houseexpo(doc: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate a HouseExpo document; returns ``verts (N, 2)``, ``bbox_min (2,)``, ``bbox_max (2,)``."""
    def bad(field: str, msg: str):
        raise LevelError(f"HouseExpo document: {field}: {msg}")

    if not isinstance(doc, dict):
        bad("document", "expected a JSON object")

    def vec2(x, field):
        if (not isinstance(x, list) or len(x) != 2
                or any(isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c)
                       or abs(c) > MAX_HOUSEEXPO_COORD for c in x)):
            bad(field, f"expected [x, y] with finite numbers of magnitude at most "
                f"{MAX_HOUSEEXPO_COORD:g}, got {x!r}")
        return np.array([float(x[0]), float(x[1])])

    if "verts" not in doc:
        bad("verts", "missing field")
    verts = doc["verts"]
    if not isinstance(verts, list) or len(verts) < 3:
        bad("verts", "expected a list of at least 3 [x, y] points")
    if len(verts) > MAX_HOUSEEXPO_VERTICES:  # before the self-crossing check, which is quadratic
        bad("verts", f"{len(verts)} points; an outline may have at most {MAX_HOUSEEXPO_VERTICES} "
            "(one wall per edge)")
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
    if len(P) < 3 or abs(_poly_area(np.asarray(P, float))) <= 1e-9:  # e.g. one vertex at 1e300
        raise LevelError("HouseExpo document: verts: the outline collapses to a line or a point "
                         "once scaled to the level size (coordinates of absurd magnitude?)")
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
