"""An analytic RGB-D renderer of a textured box room, for testing trackers without a simulator.

The room is the box ``[0, 4] x [0, 3] x [0, 1.2]`` m seen from inside; every face has a smooth,
view-independent colour (sums of sines of the face coordinates), so depth and colour are exact
and smooth and the rendering can be evaluated at any pose.
"""

from __future__ import annotations

import numpy as np

from navbench.geometry import CAMERA_HEIGHT, HALF_CAMERA, Frame, camera_pose, pixel_rays

ROOM = (4.0, 3.0, 1.2)


def _colour(face: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Smooth colour (..., 3) of face ``face`` at face coordinates ``a, b`` (m)."""
    f = 1.3 + 0.4 * face
    ph = 0.7 * face
    r = 0.5 + 0.22 * np.sin(2 * np.pi * f * a + ph) + 0.12 * np.sin(2 * np.pi * 1.7 * b)
    g = 0.5 + 0.2 * np.sin(2 * np.pi * (0.8 * a + f * b) + 1.0 + ph)
    bl = 0.45 + 0.2 * np.cos(2 * np.pi * (f * 0.6 * a - 1.1 * b) + ph)
    return np.stack([r, g, bl], axis=-1)


def render_box(pose, intr=HALF_CAMERA, camera_height=CAMERA_HEIGHT, room=ROOM) -> Frame:
    """Exact RGB-D frame of the box room from planar ``pose`` (x, y, theta)."""
    T = camera_pose(pose, camera_height)
    rays = pixel_rays(intr) @ T[:3, :3].T  # (H, W, 3) world directions, camera z = 1
    o = T[:3, 3]
    best = np.full(rays.shape[:2], np.inf)
    face = np.zeros(rays.shape[:2], np.int64)
    for axis in range(3):
        for side, bound in ((0, 0.0), (1, room[axis])):
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (bound - o[axis]) / rays[..., axis]
            t = np.where(t > 0, t, np.inf)
            sel = t < best
            best = np.where(sel, t, best)
            face = np.where(sel, 2 * axis + side, face)
    p = o + rays * best[..., None]
    rgb = np.zeros(rays.shape[:2] + (3,))
    for f in range(6):
        axis = f // 2
        others = [k for k in range(3) if k != axis]
        m = face == f
        rgb[m] = _colour(f, p[m][:, others[0]], p[m][:, others[1]])
    return Frame(np.clip(rgb, 0, 1).astype(np.float32), best.astype(np.float32),
                 np.isfinite(best))


def flat_wall(pose, intr=HALF_CAMERA, camera_height=CAMERA_HEIGHT, wall_x=3.0) -> Frame:
    """A single infinite textured wall at ``x = wall_x`` (nothing else; rays missing it are invalid)."""
    T = camera_pose(pose, camera_height)
    rays = pixel_rays(intr) @ T[:3, :3].T
    o = T[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (wall_x - o[0]) / rays[..., 0]
    ok = np.isfinite(t) & (t > 0)
    t = np.where(ok, t, np.inf)
    p = o + rays * np.where(ok, t, 0.0)[..., None]
    rgb = _colour(1, p[..., 1], p[..., 2])
    return Frame(np.clip(rgb, 0, 1).astype(np.float32), t.astype(np.float32), ok)


def small_level():
    """A closed 5 m x 4 m room with a pillar and a low box (for the exact ray-cast camera)."""
    from navbench.level import Level, Obstacle, Texture, Wall

    tex = (
        Texture("waves", (0.5, 0.4, 0.3), (0.3, 0.2, 0.25), ((1.3, 0.2, 0.1), (0.4, 2.1, 1.0), (2.7, 1.1, 2.0))),
        Texture("tiles", (0.45, 0.5, 0.55), (0.4, 0.3, 0.2), ((1.5, 2.5, 0.3), (0.7, 1.9, 1.2))),
        Texture("waves", (0.3, 0.6, 0.5), (0.2, 0.3, 0.3), ((0.9, 0.0, 0.5), (0.0, 1.7, 0.2), (1.9, 2.2, 0.7))),
    )
    t = 0.1
    walls = (Wall((0.0, 0.0), (5.0, 0.0), t, 0), Wall((5.0, 0.0), (5.0, 4.0), t, 2),
             Wall((5.0, 4.0), (0.0, 4.0), t, 0), Wall((0.0, 4.0), (0.0, 0.0), t, 2))
    obstacles = (Obstacle(((3.0, 1.0), (3.5, 1.0), (3.5, 1.5), (3.0, 1.5)), 1.2, 1),
                 Obstacle(((1.0, 2.8), (1.8, 2.8), (1.8, 3.3), (1.0, 3.3)), 0.35, 1))
    return Level(name="track-room", width=5.0, depth=4.0, walls=walls, obstacles=obstacles,
                 textures=tex, floor_texture=1, ceiling_texture=2)
