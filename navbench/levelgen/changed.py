"""Changed rooms (RNR-Map supplementary C.3): a level derived from another by moving, adding and
removing furniture.

:func:`change_level` applies ``changes`` seeded edits to the base level's obstacles, each one of

* ``add``: a new piece of furniture (the house generator's shapes: a low box, a tall box or a
  pillar, with a new texture) standing free in a room;
* ``move``: an obstacle translated 0.3-1.0 m and turned by up to 90 degrees about its centroid;
* ``remove``: an obstacle taken away.

An added or moved obstacle keeps :data:`GAP` metres from every other solid; each edit is redrawn
(up to :data:`TRIES` times) until the level still passes the free-space check every loaded level
passes (:func:`~navbench.levelgen.validate.validate_level`). Walls, textures of existing surfaces
and the level box never change, so the base level's map stays the right map of the building.
The result is a deterministic function of ``(base, name, changes, seed)``.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from navbench.errors import ConfigError, LevelError
from navbench.level import Level, Obstacle, distance_to_solids
from navbench.levelgen.common import _ccw_tuple, _palette, _q
from navbench.levelgen.house import _furniture_shape, _rotated_shape
from navbench.levelgen.validate import meta_rooms, validate_level

#: Clearance (m) of an added or moved obstacle from every other solid.
GAP = 0.1
#: Redraws of one edit before giving up.
TRIES = 200
#: The most edits one call applies.
MAX_CHANGES = 40


def _fits(level: Level, poly: np.ndarray, skip: int | None) -> bool:
    """``poly`` (a convex CCW footprint) keeps :data:`GAP` from every solid but obstacle ``skip``,
    checked on its vertices and a 5 cm raster of its inside, and stays in the box."""
    if poly.min() < GAP or poly[:, 0].max() > level.width - GAP or poly[:, 1].max() > level.depth - GAP:
        return False
    others = level if skip is None else replace(
        level, obstacles=tuple(o for i, o in enumerate(level.obstacles) if i != skip))
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0] + 0.05, 0.05), np.arange(lo[1], hi[1] + 0.05, 0.05))
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    a, d = poly, np.roll(poly, -1, axis=0) - poly
    rel = pts[:, None, :] - a[None]
    inside = np.all(d[None, :, 0] * rel[..., 1] - d[None, :, 1] * rel[..., 0] >= 0, axis=1)
    pts = np.concatenate([poly, pts[inside], poly.mean(axis=0, keepdims=True)])
    return bool(np.all(distance_to_solids(others, pts) >= GAP))


def _room_point(rng: np.random.Generator, level: Level) -> tuple[float, float]:
    rooms = meta_rooms(level) or [(0.0, 0.0, level.width, level.depth)]
    x0, y0, x1, y1 = rooms[int(rng.integers(len(rooms)))]
    return float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1))


def _edit(rng: np.random.Generator, level: Level, op: str) -> tuple[Level, dict]:
    """One drawn edit ``op`` of ``level`` (not yet validated) and its log entry."""
    obs = list(level.obstacles)
    if op == "remove":
        i = int(rng.integers(len(obs)))
        del obs[i]
        return replace(level, obstacles=tuple(obs)), {"op": "remove", "obstacle": i}
    if op == "move":
        i = int(rng.integers(len(obs)))
        poly = np.asarray(obs[i].polygon, float)
        c = poly.mean(axis=0)
        step, direction = rng.uniform(0.3, 1.0), rng.uniform(-math.pi, math.pi)
        turn = rng.uniform(-math.pi / 2, math.pi / 2)
        R = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
        new = (poly - c) @ R.T + c + step * np.array([math.cos(direction), math.sin(direction)])
        if not _fits(level, new, i):
            raise _Retry
        obs[i] = Obstacle(_ccw_tuple([(_q(x), _q(y)) for x, y in new]), obs[i].height, obs[i].texture)
        return replace(level, obstacles=tuple(obs)), {"op": "move", "obstacle": i}
    kind, a, b, h = _furniture_shape(rng)
    cx, cy = _room_point(rng, level)
    poly = _rotated_shape(kind, a, b, cx, cy, float(rng.uniform(0, math.pi)), int(rng.integers(6, 9)))
    if not _fits(level, np.asarray(poly, float), None):
        raise _Retry
    textures = level.textures + tuple(_palette(rng, 1))
    obs.append(Obstacle(_ccw_tuple(poly), h, len(textures) - 1))
    return replace(level, obstacles=tuple(obs), textures=textures), {"op": "add", "obstacle": len(obs) - 1}


class _Retry(Exception):
    pass


def change_level(base: Level, name: str, changes: int, seed: int) -> Level:
    """``base`` with ``changes`` seeded furniture edits (module docstring), named ``name``.

    ``meta`` keeps the base's and adds ``changed_from`` (the base's name), ``changes``,
    ``change_seed`` and ``change_log`` (one ``{"op", "obstacle"}`` per edit, in order).
    :class:`ConfigError` for a bad count; :class:`LevelError` when an edit cannot be placed.
    """
    if not (isinstance(changes, int) and 0 <= changes <= MAX_CHANGES):
        raise ConfigError(f"--changes must be an integer in [0, {MAX_CHANGES}], got {changes!r}")
    rng = np.random.default_rng([int(seed), 0x0C4A]) if seed >= 0 else None
    if rng is None:
        raise ConfigError(f"--seed must be >= 0, got {seed}")
    level, log = replace(base, name=name), []
    for k in range(changes):
        for _ in range(TRIES):
            ops = ["add"] + (["move", "remove"] if level.obstacles else [])
            op = ops[int(rng.integers(len(ops)))]
            try:
                new, entry = _edit(rng, level, op)
                validate_level(new)
            except (_Retry, LevelError):
                continue
            level = new
            log.append(entry)
            break
        else:
            raise LevelError(f"level {base.name!r}: change {k + 1} of {changes} could not be placed "
                             f"in {TRIES} tries")
    meta = {**base.meta, "changed_from": base.name, "changes": changes, "change_seed": int(seed),
            "change_log": log}
    return replace(level, meta=meta)
