"""Small hand-made levels and an exact world model (the level's own ray caster) for the
localiser tests: any :class:`~navbench.worldmodel.base.WorldModel` must work."""

from __future__ import annotations

import hashlib

from navbench.geometry import CAMERA_HEIGHT, MAX_RANGE
from navbench.level import Level, Obstacle, Texture, Wall, occupancy_raster

_WAVES = ((1.3, 0.2, 0.1), (0.4, 2.1, 1.0), (2.7, 1.1, 2.0))
TEXTURES = tuple(Texture("waves", base, (0.25, 0.2, 0.2), _WAVES) for base in (
    (0.5, 0.4, 0.3), (0.15, 0.25, 0.3), (0.7, 0.35, 0.3), (0.3, 0.5, 0.45), (0.85, 0.8, 0.6), (0.4, 0.3, 0.7)))
#: Constant colours: a level built of them looks the same from mirror poses.
FLAT = tuple(Texture("waves", base, (0.0, 0.0, 0.0), _WAVES) for base in ((0.5, 0.5, 0.5), (0.3, 0.4, 0.6)))


def _box(x0, y0, x1, y1, height, tex) -> Obstacle:
    return Obstacle(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), height, tex)


def room(width=4.0, depth=3.0) -> Level:
    """A closed room, each wall its own texture, two boxes of different heights."""
    t, w, d = 0.1, width, depth
    walls = (Wall((0, 0), (w, 0), t, 1), Wall((w, 0), (w, d), t, 2), Wall((w, d), (0, d), t, 3),
             Wall((0, d), (0, 0), t, 4))
    obs = (_box(0.8, 0.6, 1.3, 1.0, 0.9, 5), _box(2.8, 1.9, 3.3, 2.5, 1.2, 2))
    return Level("loc-room", w, d, walls, obs, TEXTURES, 0, 1)


def symmetric_room() -> Level:
    """A 4 x 3 m room, symmetric under the half turn about its centre (2, 1.5), flat colours."""
    t, w, d = 0.1, 4.0, 3.0
    walls = (Wall((0, 0), (w, 0), t, 0), Wall((w, 0), (w, d), t, 0), Wall((w, d), (0, d), t, 0),
             Wall((0, d), (0, 0), t, 0))
    obs = (_box(0.8, 0.6, 1.4, 1.0, 0.9, 1), _box(w - 1.4, d - 1.0, w - 0.8, d - 0.6, 0.9, 1))
    return Level("loc-sym", w, d, walls, obs, FLAT, 0, 0)


class ExactWorld:
    """A :class:`~navbench.worldmodel.base.WorldModel` that is the level itself."""

    kind = "exact"

    def __init__(self, level: Level):
        self.level = level
        self.meta: dict = {}

    def occupancy_slice(self, mode="band", z_low=0.05, z_high=1.0, height=CAMERA_HEIGHT):
        return occupancy_raster(self.level, 0.05, z_low, z_high)

    def renderer(self, intrinsics, camera_height=CAMERA_HEIGHT, max_range=MAX_RANGE, step=None):
        from navbench.sim.camera import RaycastCamera

        return RaycastCamera(self.level, intrinsics, camera_height, max_range)

    def save(self, path):  # pragma: no cover - not needed by the localiser
        raise NotImplementedError

    @classmethod
    def load(cls, path):  # pragma: no cover
        raise NotImplementedError

    def content_hash(self) -> str:
        from navbench.levelio import dumps_level

        return hashlib.sha256(dumps_level(self.level).encode()).hexdigest()
