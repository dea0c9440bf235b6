"""Procedural levels: HouseExpo-like floor plans, a training maze, HouseExpo import, validation.

Everything here is pure: a seed (or a parsed HouseExpo document) in, a :class:`Level` out, no
file I/O. All lengths are world metres in the level box ``[0, width] x [0, depth]``.

House levels (:func:`generate_level`)
    A rectangular footprint of up to ``size x size`` m is split recursively (binary space
    partition) into rooms of varied sizes, optionally with a corridor along the first split; one
    room at a corner may be cut away (filled, making an L-shaped house). Rooms are joined by doors
    (gaps of 0.8-1.1 m, sometimes a wider opening) along a random spanning tree of the room
    adjacency graph plus a few extra doors for loops. The ``dense`` style (``kind="dense"``, the
    ``dense-*`` levels) is closer to the HouseExpo floor plans of the paper: 8-12 smaller rooms,
    always a corridor, up to two corners cut away, doors 0.8-0.95 m and few loops. Walls are 0.1 m thick. Furniture-like
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

from typing import Iterable

from navbench.errors import ConfigError
from navbench.level import Level
# the public API, re-exported from the submodules (callers import navbench.levelgen)
from navbench.levelgen.common import (  # noqa: F401
    BENCHMARK_LEVELS,
    CLEARANCE,
    DEFAULT_SIZE,
    DOOR_WIDTH,
    GENERATOR_VERSION,
    HOUSEEXPO_MARGIN,
    LEVEL_KINDS,
    MAX_ATTEMPTS,
    MAX_CUTAWAY,
    MAZE_CELL,
    MAZE_SIZE,
    MIN_FREE_FRACTION,
    OBSTACLE_GAP,
    VALIDATION_RESOLUTION,
    WALL_THICKNESS,
    _poly_area,
    _touching_walls,
)
from navbench.levelgen.validate import (  # noqa: F401
    clearance_mask,
    free_space,
    house_area,
    level_stats,
    meta_doors,
    meta_rooms,
    validate_connectivity,
    validate_free_space,
    validate_level,
)
from navbench.levelgen.house import (  # noqa: F401
    HOUSE_STYLES,
    HouseStyle,
    generate_level,
)
from navbench.levelgen.maze import (  # noqa: F401
    generate_maze,
)
from navbench.levelgen.houseexpo import (  # noqa: F401
    _inside_polygon,
    exterior_fill,
    level_from_houseexpo,
)

# ----------------------------------------------------------------------------------- benchmark

def make_level(name: str, seed: int, kind: str = "house", size: float | None = None,
               rooms: int | None = None, obstacles: int | None = None) -> Level:
    """Dispatch on ``kind`` (``house``, ``dense`` or ``maze``); ``size=None`` takes the kind's
    default. ``dense`` is a house of the ``dense`` style (:data:`HOUSE_STYLES`)."""
    if kind in HOUSE_STYLES:
        return generate_level(name, seed, size=DEFAULT_SIZE if size is None else size,
                              rooms=rooms, obstacles=obstacles, style=kind)
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
