"""A level with two identical rooms off one corridor, for the stop-decision tests.

Corridor ``y in [0, 1.2]``, ``x in [0, 7]``; room A ``x in [0, 3.2]`` and room B = A moved by
``+3.8`` in x, both ``y in [1.2, 4.2]``, each with a 0.8 m door in its bottom wall and two
0.9 m boxes (above the 0.5 m camera, so their tops, the only surfaces whose texture is in world
coordinates, are never seen). Floor and ceiling have flat colours and every wall texture is in
wall coordinates, so the inside of B renders exactly as the inside of A from the moved pose.
The corridor is not symmetric: its far wall has another texture opposite each door, and a box
stands opposite A's door only.
"""

from __future__ import annotations

from navbench.level import Level, Obstacle, Texture, Wall

_WAVES = ((1.3, 0.2, 0.1), (0.4, 2.1, 1.0), (2.7, 1.1, 2.0))
TEXTURES = (Texture("waves", (0.5, 0.5, 0.5), (0.0, 0.0, 0.0), _WAVES),  # 0 flat floor
            Texture("waves", (0.3, 0.4, 0.6), (0.0, 0.0, 0.0), _WAVES),  # 1 flat ceiling
            *(Texture("waves", base, (0.25, 0.2, 0.2), _WAVES) for base in (
                (0.5, 0.4, 0.3), (0.15, 0.25, 0.3), (0.7, 0.35, 0.3), (0.3, 0.5, 0.45),
                (0.85, 0.8, 0.6), (0.4, 0.3, 0.7), (0.2, 0.7, 0.2))))
SHIFT = 3.8  # m, room B = room A moved along x


def _box(x0, y0, x1, y1, tex, h=0.9) -> Obstacle:
    return Obstacle(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), h, tex)


def _room(dx: float) -> tuple[list, list]:
    t = 0.1
    walls = [Wall((dx, 1.2), (dx + 1.2, 1.2), t, 2), Wall((dx + 2.0, 1.2), (dx + 3.2, 1.2), t, 3),
             Wall((dx + 3.2, 1.2), (dx + 3.2, 4.2), t, 4), Wall((dx + 3.2, 4.2), (dx, 4.2), t, 5),
             Wall((dx, 4.2), (dx, 1.2), t, 6)]
    boxes = [_box(dx + 0.5, 3.2, dx + 1.0, 3.7, 7), _box(dx + 2.3, 2.0, dx + 2.8, 2.6, 3)]
    return walls, boxes


def twin_rooms(with_a: bool = True) -> Level:
    """The level; ``with_a=False`` leaves room A out (a map that has not seen it yet: its place
    renders nothing)."""
    t = 0.1
    walls = [Wall((0, 0), (3.5, 0), t, 8), Wall((3.5, 0), (7.0, 0), t, 4),
             Wall((7.0, 0), (7.0, 1.2), t, 2), Wall((0, 1.2), (0, 0), t, 2)]
    obstacles = [_box(1.3, 0.1, 1.9, 0.45, 5)]
    for dx in ((0.0, SHIFT) if with_a else (SHIFT,)):
        w, b = _room(dx)
        walls += w
        obstacles += b
    return Level("twin-rooms" if with_a else "twin-rooms-b", 7.0, 4.2, tuple(walls), tuple(obstacles),
                 TEXTURES, 0, 1)
