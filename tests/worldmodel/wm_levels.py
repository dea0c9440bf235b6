"""Small hand-made levels for the world-model tests (imported by conftest and tests)."""

from __future__ import annotations


from navbench.level import Level, Obstacle, Texture, Wall


def room_level(width: float = 4.0, depth: float = 3.0, name: str = "wm-room") -> Level:
    """A closed room with a tall box and a low box (lower than the camera)."""
    tex = (
        Texture("waves", (0.5, 0.4, 0.3), (0.2, 0.2, 0.2), ((0.5, 0.3, 0.0), (0.2, 0.9, 1.0), (1.1, 0.0, 2.0))),
        Texture("tiles", (0.3, 0.5, 0.6), (0.2, 0.15, 0.1), ((1.0, 1.0, 0.3), (0.4, 0.7, 0.5))),
        Texture("waves", (0.7, 0.7, 0.6), (0.1, 0.1, 0.1), ((0.3, 0.2, 0.0), (0.1, 0.5, 1.0), (0.7, 0.1, 2.0))),
        Texture("waves", (0.2, 0.6, 0.3), (0.15, 0.2, 0.1), ((0.9, 0.6, 0.0), (0.3, 1.5, 1.0), (1.2, 0.4, 2.0))),
    )
    t = 0.1
    walls = (
        Wall((0.0, t / 2), (width, t / 2), t, 0),
        Wall((width - t / 2, 0.0), (width - t / 2, depth), t, 0),
        Wall((width, depth - t / 2), (0.0, depth - t / 2), t, 0),
        Wall((t / 2, depth), (t / 2, 0.0), t, 0),
    )
    obstacles = (
        Obstacle(((2.6, 1.6), (3.2, 1.6), (3.2, 2.2), (2.6, 2.2)), 1.2, 3),
        Obstacle(((1.0, 0.8), (1.5, 0.8), (1.5, 1.2), (1.0, 1.2)), 0.3, 3),
    )
    return Level(name=name, width=width, depth=depth, walls=walls, obstacles=obstacles,
                 textures=tex, floor_texture=1, ceiling_texture=2, seed=0)

