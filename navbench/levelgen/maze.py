"""The training maze: a perfect maze on 1.2 m cells with a few extra openings."""

from __future__ import annotations


import numpy as np

from navbench.errors import ConfigError, LevelError
from navbench.geometry import LEVEL_HEIGHT
from navbench.level import Level, Wall
from navbench.levelgen.common import GENERATOR_VERSION, MAX_ATTEMPTS, MAZE_CELL, MAZE_SIZE, WALL_THICKNESS, _AttemptFailed, _T_CM, _ceiling_texture, _cm, _colour_walls, _exterior_texture, _floor_texture, _palette, _q
from navbench.levelgen.house import _check_name_seed, _retry, _union
from navbench.levelgen.validate import validate_level

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
