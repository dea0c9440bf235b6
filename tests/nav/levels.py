"""Tiny hand-made levels with easily stated geometry for the planning and navigation tests."""

from __future__ import annotations

from navbench.level import Level, Obstacle, Texture, Wall

TEXTURES = (
    Texture("waves", (0.5, 0.4, 0.3), (0.3, 0.2, 0.25), ((1.3, 0.2, 0.1), (0.4, 2.1, 1.0), (2.7, 1.1, 2.0))),
    Texture("tiles", (0.45, 0.5, 0.55), (0.4, 0.3, 0.2), ((1.5, 2.5, 0.3), (0.7, 1.9, 1.2))),
)


def make_level(name, walls=(), obstacles=(), width=6.0, depth=6.0) -> Level:
    return Level(name=name, width=width, depth=depth, walls=tuple(walls), obstacles=tuple(obstacles),
                 textures=TEXTURES, floor_texture=0, ceiling_texture=1)


def box(x0, y0, x1, y1, height=1.2) -> Obstacle:
    return Obstacle(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), height, 0)


def open_room(width=6.0, depth=6.0) -> Level:
    """A closed empty room: four 0.1 m walls centred on the box edges."""
    t = 0.1
    w, d = width, depth
    return make_level("open", [Wall((0, 0), (w, 0), t, 0), Wall((w, 0), (w, d), t, 0),
                               Wall((w, d), (0, d), t, 0), Wall((0, d), (0, 0), t, 0)], width=w, depth=d)


def two_rooms() -> Level:
    """6 m x 4 m, a full inner wall at x = 3 (no door): two disconnected rooms."""
    t = 0.1
    walls = [Wall((0, 0), (6, 0), t, 0), Wall((6, 0), (6, 4), t, 0), Wall((6, 4), (0, 4), t, 0),
             Wall((0, 4), (0, 0), t, 0), Wall((3, 0), (3, 4), t, 0)]
    return make_level("two-rooms", walls, width=6.0, depth=4.0)


def door_rooms() -> Level:
    """6 m x 4 m, an inner wall at x = 3 with a 1 m door at y in [1.5, 2.5]."""
    t = 0.1
    walls = [Wall((0, 0), (6, 0), t, 0), Wall((6, 0), (6, 4), t, 0), Wall((6, 4), (0, 4), t, 0),
             Wall((0, 4), (0, 0), t, 0), Wall((3, 0), (3, 1.5), t, 0), Wall((3, 2.5), (3, 4), t, 0)]
    return make_level("door-rooms", walls, [box(4.5, 0.5, 5.0, 1.0, 0.4)], width=6.0, depth=4.0)
