""":class:`DoomSimulator`: navbench's dynamics and collisions, the ViZDoom engine's pose and images.

The interface is :class:`navbench.sim.world.Simulator`'s (``reset(pose)``, ``step(control) ->
StepResult``, ``observe() -> Frame``; the same noise stream, control clipping, collision rules
and ``collision_check``), and so is everything up to the end of a move: the noisy dynamics
give the next pose, navbench's :class:`~navbench.sim.world.CollisionWorld` stops it at the
first contact (the paper checks collisions itself against the level's segments, appendix D).
Then the engine is teleported there (:meth:`DoomEngine.set_pose
<navbench.sim.doom.engine.DoomEngine.set_pose>`), and **the pose the engine shows is the true
pose from then on**: the position rounded to whole centimetres, the heading to the engine's
1/65536 turn (the paper's "another source of error"). A rounded position whose disc overlaps a
solid counts as a collision (as under ``pose_quantisation``).

Frames: RGB is the engine's (float32 in [0, 1]); depth is the engine's depth buffer converted to
metres (:func:`buffer_to_metres`) by default, or, with ``depth="exact"``, the exact z-depth of
the level's geometry cast by :class:`~navbench.sim.camera.RaycastCamera` with the engine's
projection from the engine's pose. ``valid`` is False where the buffer is saturated (farther
than it reaches, or a far floor or ceiling the engine writes above its range) and on depth
discontinuities (``edge_steps``); in the exact mode
it is the ray caster's (False only beyond its 20 m range). The converted maps hold no
things but the player start, so no sprite is ever drawn (the player's own is not seen from its
eye).

The image size picks the engine's resolution (320 x 240 or 160 x 120); the projection is the
engine's, :data:`~navbench.sim.doom.engine.DOOM_INTRINSICS` (``fx = W / 2``, ``fy = 1.2 fx``),
whatever focal lengths the given ``intrinsics`` carry: read ``sim.intrinsics`` for it.
"""

from __future__ import annotations

import numpy as np

from navbench.errors import ConfigError
from navbench.geometry import CAMERA_HEIGHT, HALF_CAMERA, Frame, Intrinsics
from navbench.level import Level
from navbench.sim.doom.engine import (DEPTH_LINEAR, DOOM_INTRINSICS, RESOLUTIONS, DoomEngine,
                                      saturation_value)
from navbench.sim.doom.wad import LIGHT_LEVEL, UNITS_PER_METRE
from navbench.sim.world import Simulator

#: Depth sources of :class:`DoomSimulator`.
DEPTH_MODES = ("buffer", "exact")


#: Default of ``edge_steps``: a pixel whose depth-buffer value differs from a 4-neighbour's by
#: more than this many steps (3 x 7.1 cm) sits on a discontinuity and is invalid.
EDGE_STEPS = 3


def buffer_to_metres(buffer: np.ndarray, resolution, edge_steps: int | None = EDGE_STEPS
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The engine's raw depth buffer ``(H, W) uint8`` as z-depth ``(H, W) float32`` metres and
    ``valid (H, W) bool``: ``z = (a * value + b) / 100`` with the measured
    :data:`~navbench.sim.doom.engine.DEPTH_LINEAR` ``(a, b)`` of ``resolution``. Invalid
    (depth ``+inf``): values at or above the saturation value, and, unless ``edge_steps`` is
    None, pixels on a depth discontinuity (a 4-neighbour more than ``edge_steps`` values
    away), where the engine's and the geometry's silhouettes may disagree by a pixel."""
    a, b = DEPTH_LINEAR[tuple(resolution)]
    v = np.asarray(buffer)
    valid = v < saturation_value(v.shape[0])
    if edge_steps is not None:
        vi = v.astype(np.int16)
        jump = np.zeros(v.shape, np.int16)
        for axis in (0, 1):
            d = np.abs(np.diff(vi, axis=axis))
            lo = [slice(None)] * 2
            hi = [slice(None)] * 2
            lo[axis], hi[axis] = slice(None, -1), slice(1, None)
            jump[tuple(lo)] = np.maximum(jump[tuple(lo)], d)
            jump[tuple(hi)] = np.maximum(jump[tuple(hi)], d)
        valid &= jump <= edge_steps
    depth = np.where(valid, (a * v.astype(np.float32) + np.float32(b)) / np.float32(UNITS_PER_METRE),
                     np.float32(np.inf)).astype(np.float32)
    return depth, valid


class DoomSimulator(Simulator):
    """The simulator with ViZDoom as its world's pose and camera (see the module docstring).

    Parameters as :class:`~navbench.sim.world.Simulator`'s, plus ``depth`` (``"buffer"``: the
    engine's depth buffer, or ``"exact"``), ``settle_tics`` (tics per teleport before the
    frame is read; 2: the warp's own tic renders from near the floor, measured) and
    ``edge_steps`` (:func:`buffer_to_metres`; None keeps discontinuity pixels valid) and
    ``light_level`` (the sectors' light, :class:`~navbench.sim.doom.engine.DoomEngine`; the
    default 192 fades distant surfaces, 255 does not); ``texture`` is recorded but changes no
    frame (the engine draws its own textures). With
    ``intrinsics=None`` nothing is read from the engine but its pose (it still runs, at
    160 x 120: the pose is its). ``pose_quantisation`` must stay ``"off"``: the engine
    quantises. Call :meth:`close` (or use ``with``) to stop the engine.
    """

    def __init__(self, level: Level, noise="none", seed: int = 0,
                 intrinsics: Intrinsics | None = HALF_CAMERA, camera_height: float = CAMERA_HEIGHT,
                 enforce_direction_limit: bool = False, pose_quantisation: str = "off",
                 collision_check: str = "swept", depth: str = "buffer", settle_tics: int = 2,
                 edge_steps: int | None = EDGE_STEPS, light_level: int = LIGHT_LEVEL,
                 texture: str = "procedural"):
        if pose_quantisation != "off":
            raise ConfigError(f"DoomSimulator: pose_quantisation must be 'off' (the engine quantises the pose "
                              f"itself), got {pose_quantisation!r}")
        if depth not in DEPTH_MODES:
            raise ConfigError(f"DoomSimulator: depth must be one of {list(DEPTH_MODES)}, got {depth!r}")
        if edge_steps is not None and (isinstance(edge_steps, bool) or not isinstance(edge_steps, int) or edge_steps < 0):
            raise ConfigError(f"DoomSimulator: edge_steps must be None or a whole number >= 0, got {edge_steps!r}")
        res = (160, 120) if intrinsics is None else (int(intrinsics.width), int(intrinsics.height))
        if res not in RESOLUTIONS:
            raise ConfigError(f"DoomSimulator: the engine renders {' or '.join(f'{w}x{h}' for w, h in RESOLUTIONS)}, "
                              f"got {res[0]}x{res[1]}")
        self.engine = None
        # texture: checked and recorded as the episode's config names it, but the engine draws its
        # own textures, so it changes no frame (the mode is the pymunk camera's)
        super().__init__(level, noise, seed, intrinsics=None, camera_height=camera_height,
                         enforce_direction_limit=enforce_direction_limit, collision_check=collision_check,
                         texture=texture)
        self.engine = DoomEngine(level, res, seed=seed, camera_height=camera_height, settle_tics=settle_tics,
                                 light_level=light_level)
        self.resolution = res
        self.depth_mode = depth
        self.edge_steps = edge_steps
        self.intrinsics = DOOM_INTRINSICS[res] if intrinsics is not None else None
        self.camera = None
        if self.intrinsics is not None and depth == "exact":
            from navbench.sim.camera import RaycastCamera

            self.camera = RaycastCamera(level, self.intrinsics, self.camera_height)

    def _realise(self, pose: np.ndarray) -> np.ndarray:
        """Teleport the engine to ``pose``; the pose it shows (a new array)."""
        return self.engine.set_pose(pose)

    def observe(self, pixels=None) -> Frame | None:
        """The engine's frame at the current pose (None without a camera); ``pixels``: only
        those (flat indices) are returned, the others unseen (NaN, not valid), as
        :meth:`Simulator.observe <navbench.sim.world.Simulator.observe>` (the engine renders
        the whole image either way)."""
        if self.intrinsics is None:
            return None
        rgb8, buf = self.engine.buffers()
        rgb = rgb8.astype(np.float32) / np.float32(255.0)
        depth, valid = buffer_to_metres(buf, self.resolution, self.edge_steps)
        if self.depth_mode == "exact":
            exact = self.camera.render(self.pose)
            depth, valid = exact.depth, exact.valid
        if pixels is not None:
            idx = np.asarray(pixels, dtype=np.int64).reshape(-1)
            if idx.size and (idx.min() < 0 or idx.max() >= depth.size):
                raise ValueError(f"pixel indices must lie in [0, {depth.size}), got {idx.min()}..{idx.max()}")
            keep = np.zeros(depth.size, bool)
            keep[idx] = True
            keep = keep.reshape(depth.shape)
            rgb = np.where(keep[..., None], rgb, np.float32(np.nan))
            depth = np.where(keep, depth, np.float32(np.nan))
            valid = valid & keep
        return Frame(rgb, depth, valid)

    def close(self) -> None:
        """Stop the engine."""
        if self.engine is not None:
            self.engine.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
