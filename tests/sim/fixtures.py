"""Hand-built levels for the simulator tests (analytic geometry is easy to state on them)."""

from __future__ import annotations

from navbench.level import Level, Obstacle, Texture, Wall

TEXTURES = (
    Texture("waves", (0.5, 0.4, 0.3), (0.3, 0.2, 0.25), ((1.3, 0.2, 0.1), (0.4, 2.1, 1.0), (2.7, 1.1, 2.0))),
    Texture("tiles", (0.45, 0.5, 0.55), (0.4, 0.3, 0.2), ((1.5, 2.5, 0.3), (0.7, 1.9, 1.2))),
    Texture("waves", (0.3, 0.6, 0.5), (0.2, 0.3, 0.3), ((0.9, 0.0, 0.5), (0.0, 1.7, 0.2), (1.9, 2.2, 0.7))),
    Texture("tiles", (0.6, 0.3, 0.4), (0.35, 0.2, 0.3), ((2.2, 1.1, 0.9), (1.4, 0.6, 0.4))),
)


def _level(name, walls=(), obstacles=(), width=10.0, depth=10.0):
    return Level(name=name, width=width, depth=depth, walls=tuple(walls), obstacles=tuple(obstacles),
                 textures=TEXTURES, floor_texture=1, ceiling_texture=2)


def single_wall(x_wall: float = 3.0, thickness: float = 0.1) -> Level:
    """One long wall along ``x = x_wall`` (its face towards -x at ``x_wall - thickness / 2``)."""
    return _level("single-wall", [Wall((x_wall, 0.0), (x_wall, 10.0), thickness, 0)])


def box_before_wall(box_height: float = 0.3) -> Level:
    """A low box (x in [2, 2.5], y in [4, 6]) in front of a wall whose face is at x = 4."""
    return _level("box-wall", [Wall((4.05, 0.0), (4.05, 10.0), 0.1, 0)],
                  [Obstacle(((2.0, 4.0), (2.5, 4.0), (2.5, 6.0), (2.0, 6.0)), box_height, 3)])


def rooms() -> Level:
    """A closed 8 m x 6 m house: outer walls, one inner wall with a door, a pillar and a low box."""
    t = 0.1
    walls = [
        Wall((0.0, 0.0), (8.0, 0.0), t, 0), Wall((8.0, 0.0), (8.0, 6.0), t, 0),
        Wall((8.0, 6.0), (0.0, 6.0), t, 2), Wall((0.0, 6.0), (0.0, 0.0), t, 2),
        # inner wall at x = 4 with a 1 m door at y in [2.5, 3.5]
        Wall((4.0, 0.0), (4.0, 2.5), t, 3), Wall((4.0, 3.5), (4.0, 6.0), t, 3),
        Wall((6.0, 4.5), (7.0, 5.5), 0.15, 1),  # a diagonal wall
    ]
    obstacles = [
        Obstacle(((1.5, 1.5), (2.0, 1.5), (2.0, 2.0), (1.5, 2.0)), 1.2, 1),  # pillar
        Obstacle(((5.5, 1.0), (6.5, 1.2), (6.3, 2.0), (5.6, 1.8)), 0.35, 3),  # low box
        Obstacle(((2.5, 4.0), (3.2, 4.3), (2.9, 4.9)), 0.8, 0),  # triangle table
    ]
    return _level("rooms", walls, obstacles, width=8.0, depth=6.0)
