"""The ViZDoom engine as a camera: load a converted level, teleport, turn, read RGB-D frames.

:class:`DoomEngine` owns one headless ``vizdoom.DoomGame`` (the engine runs as a child process,
``vizdoom``) on a
level converted by :func:`navbench.sim.doom.wad.level_to_map` (once per level content in a
process: :func:`~navbench.sim.doom.wad.cached_level_map`). It never lets the engine move
the player by itself: :meth:`DoomEngine.set_pose` teleports (``warp X Y``, a cheat, so the
game runs with ``+sv_cheats 1``) and turns (``TURN_LEFT_RIGHT_DELTA``) and reads back where
the engine put the player. The measured behaviour (``docs/notebook/vizdoom.md``; the
figures are those of :mod:`navbench.sim.doom`'s docstring) is encoded in the constants below.

The player is a class of its own (a DECORATE actor and a KEYCONF lump in the WAD): Doom's
player has its eye 41 units above the floor and a 16-unit radius; here the eye is at
navbench's camera height (0.5 m = 50 units) and the radius the agent's (0.1 m = 10 units), so
a pose navbench allows never puts the engine's player over a neighbouring raised floor (the
engine takes the highest floor under the player's whole disc). Collisions are navbench's; the
engine's own are never used: ``warp`` does not check them (measured: it lands a player whose
disc is 5 cm into a wall, and one inside the wall, where asked).
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
import tempfile
import weakref

import numpy as np

from navbench.errors import ConfigError, TaskError
from navbench.geometry import AGENT_RADIUS, CAMERA_HEIGHT, Intrinsics
from navbench.level import Level
from navbench.sim.doom.wad import LIGHT_LEVEL, MAX_UNITS, UNITS_PER_METRE, cached_level_map, read_wad, write_wad

#: The engine's resolutions navbench uses, ``(width, height)`` -> vizdoom's enum name.
RESOLUTIONS = {(320, 240): "RES_320X240", (160, 120): "RES_160X120"}

#: The engine's pinhole projection in navbench's pixel convention (pixel ``i`` looks along
#: ``u = i``), calibrated against the converted geometry (package docstring): Doom's 90 deg
#: horizontal field of view gives ``fx = W / 2``; its pixels are not square (Doom's 320 x 200
#: shown at 4:3 would make ``fy = 1.2 fx``; measured 1.19 at 320 x 240 and 1.175 at
#: 160 x 120); the centre is half a pixel left of and above the image middle (Doom samples
#: pixel centres).
DOOM_INTRINSICS = {
    (320, 240): Intrinsics(320, 240, 160.0, 190.0, 159.5, 119.5),
    (160, 120): Intrinsics(160, 120, 80.0, 94.0, 79.5, 59.5),
}

#: Engine angle units per turn: a turn moves the player's angle by whole 1/65536 turns.
ANGLE_UNITS = 65536
#: Tics run after the engine starts before it takes input (it ignores the turns of the first ~8).
WARMUP_TICS = 12

#: The depth buffer's linear map to z-depth, map units = ``a * value + b`` per resolution
#: (least squares against the exact z-depth of the converted geometry; measured, see the
#: package docstring).
DEPTH_LINEAR = {(320, 240): (7.112, 11.109), (160, 120): (7.120, 8.754)}


def saturation_value(height: int) -> int:
    """The depth buffer's largest value at an image ``height``: the engine scales its 8-bit
    depth (at 480 rows) by ``height / 480`` and truncates, so 127 at 240 rows, 63 at 120; a pixel
    at or above it is farther than the buffer reaches (or a far floor or ceiling drawn with
    values above it), and invalid."""
    return int(255 * height / 480)


_PLAYER_DECORATE = (b"actor NavbenchPlayer : DoomPlayer\n{\n"
                    b"  Player.ViewHeight %d\n  Radius %d\n}\n")
_PLAYER_KEYCONF = b"clearplayerclasses\naddplayerclass NavbenchPlayer\n"


def _vizdoom():
    try:
        import vizdoom
    except ImportError as e:  # pragma: no cover - depends on the installation
        raise ConfigError("the Doom backend needs the vizdoom package: pip install 'navbench[vizdoom]' "
                          f"({e})") from None
    return vizdoom


class DoomEngine:
    """One ViZDoom game on ``level``, driven by teleports (see the module docstring).

    ``resolution``: ``(320, 240)`` or ``(160, 120)``; ``seed``: the engine's random seed (Doom's
    random table only drives things the backend does not use; set for reproducibility);
    ``settle_tics``: tics run per teleport before the frame is read (the warp's own tic renders
    with the eye 4 units above the floor; one more tic completes the frame, a third changes
    nothing: measured, see the package docstring); ``sectors_info``: have the engine report the
    map's sectors and lines (:meth:`sectors`; off by default: it copies them every tic);
    ``light_level``: the light level (0..255) of every sector of the converted map
    (:func:`~navbench.sim.doom.wad.level_to_map`; default :data:`~navbench.sim.doom.wad.LIGHT_LEVEL`
    = 192). Below 255 Doom fades a surface with its distance (at 192: full brightness within
    1 m, 0.76 of it at 8 m, measured, ``docs/notebook/vizdoom.md``); at 255 a surface has one
    colour from every distance and angle. ``game_args``: extra engine arguments (``"+r_visibility 0"``;
    for measurements: the pipeline never sets them).
    """

    def __init__(self, level: Level, resolution=(320, 240), seed: int = 0,
                 camera_height: float = CAMERA_HEIGHT, settle_tics: int = 2, sectors_info: bool = False,
                 light_level: int = LIGHT_LEVEL, game_args: str = ""):
        vzd = _vizdoom()
        resolution = tuple(int(v) for v in resolution)
        if resolution not in RESOLUTIONS:
            raise ConfigError(f"Doom resolution must be one of {sorted(RESOLUTIONS)}, got {resolution}")
        if int(settle_tics) < 1:
            raise ConfigError(f"settle_tics must be >= 1, got {settle_tics}")
        if isinstance(light_level, bool) or not isinstance(light_level, int) or not 0 <= light_level <= 255:
            raise ConfigError(f"light_level must be a whole number in 0..255, got {light_level!r}")
        self.level = level
        self.resolution = resolution
        self.settle_tics = int(settle_tics)
        self.sectors_info = bool(sectors_info)
        self._vzd = vzd
        self.map = cached_level_map(level, light_level)  # converted once per level in a process
        eye = int(round(camera_height * UNITS_PER_METRE))
        radius = int(round(AGENT_RADIUS * UNITS_PER_METRE))
        wad = write_wad(read_wad(self.map.wad) + [("DECORATE", _PLAYER_DECORATE % (eye, radius)),
                                                  ("KEYCONF", _PLAYER_KEYCONF)])
        # what a running engine was started with: the WAD's bytes and the engine's settings
        self._key = (hashlib.sha256(wad).hexdigest(), resolution, self.sectors_info, game_args)
        # the engine takes a 32-bit seed; navbench's episode seeds are 63-bit (a converted map has
        # nothing random in it: the seed only fixes the engine's own state)
        seed32 = int(seed) % (1 << 31)
        self._held = _take_parked(self._key)  # inside reuse_engines: a closed one on the same WAD
        if self._held is not None:
            try:
                self._held.game.set_seed(seed32)
                self._held.game.new_episode()  # reloads the map: a fresh engine's first state
            except Exception:  # pragma: no cover - the parked engine died: start another
                try:
                    self._held.stop()
                except Exception:
                    pass
                self._held = None
        if self._held is None:
            self._held = _Held(wad, resolution, self.sectors_info, game_args, seed32, vzd)
        self.game = g = self._held.game
        g.set_action([0.0])
        g.advance_action(WARMUP_TICS, True)  # the engine ignores input in its first tics
        self._state = g.get_state()

    # -------------------------------------------------------------------------- control
    def variables(self) -> np.ndarray:
        """``(4,)`` float64: position x, y (map units), angle (degrees), camera z (map units)."""
        return np.asarray(self._state.game_variables, dtype=np.float64)

    def pose(self) -> np.ndarray:
        """The engine's player pose ``(3,)``: metres, radians (wrapped to ``[-pi, pi)``)."""
        x, y, a, _ = self.variables()
        th = math.radians(a) % (2 * math.pi)
        return np.array([x / UNITS_PER_METRE, y / UNITS_PER_METRE, th - 2 * math.pi if th >= math.pi else th])

    def set_pose(self, pose) -> np.ndarray:
        """Teleport the player to ``pose (3,)`` (metres, radians) and return the pose the engine
        shows: the position rounded to whole map units (``warp`` truncates what it is given, so
        the nearest integer is sent), the heading as the engine turned it."""
        x, y, th = (float(v) for v in pose)
        ix, iy = int(round(x * UNITS_PER_METRE)), int(round(y * UNITS_PER_METRE))
        if not (0 <= ix <= MAX_UNITS and 0 <= iy <= MAX_UNITS):
            raise TaskError(f"the Doom backend cannot warp to ({x:g}, {y:g}) m: outside [0, {MAX_UNITS / UNITS_PER_METRE:g}] m")
        # the turn in whole engine angle units (1/65536 turn): the engine turns clockwise by
        # floor(delta * 65536 / 360) units (measured), so a quarter unit above the whole
        # number of clockwise units lands on it whatever the rounding of the double
        cur = round(float(self._state.game_variables[2]) * ANGLE_UNITS / 360.0)
        want = math.degrees(th) * ANGLE_UNITS / 360.0
        ccw = int(round((want - cur + ANGLE_UNITS / 2) % ANGLE_UNITS - ANGLE_UNITS / 2))
        delta = (-ccw + 0.25) * 360.0 / ANGLE_UNITS
        self.game.send_game_command(f"warp {ix} {iy}")
        self.game.set_action([delta])
        self.game.advance_action(1, self.settle_tics == 1)  # its state only when it is the last
        self.game.set_action([0.0])
        if self.settle_tics > 1:
            self.game.advance_action(self.settle_tics - 1, True)
        self._state = self.game.get_state()
        return self.pose()

    # -------------------------------------------------------------------------- images
    def buffers(self) -> tuple[np.ndarray, np.ndarray]:
        """The last frame: ``rgb (H, W, 3) uint8`` and the raw depth buffer ``(H, W) uint8``."""
        return self._state.screen_buffer, self._state.depth_buffer

    def sectors(self):
        """The engine's sectors of the loaded map (``set_sectors_info_enabled``): each with
        ``floor_height``, ``ceiling_height`` and ``lines`` (``x1, y1, x2, y2, is_blocking``).
        Needs ``sectors_info=True``."""
        if not self.sectors_info:
            raise ConfigError("DoomEngine.sectors() needs an engine started with sectors_info=True")
        return self._state.sectors

    def close(self) -> None:
        """Stop the engine and remove the WAD; inside :func:`reuse_engines`, leave the
        engine running for the next :class:`DoomEngine` on the same WAD and settings."""
        held, self._held, self.game = getattr(self, "_held", None), None, None
        if held is not None:
            _park(self._key, held)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):  # pragma: no cover - best effort: an engine nobody closed stops
        try:
            held, self._held, self.game = getattr(self, "_held", None), None, None
            if held is not None:
                held.stop()
        except Exception:
            pass


class _Held:
    """A running engine process on a WAD of its own (a temporary directory): started here,
    stopped by :meth:`stop`, at the latest at interpreter exit."""

    def __init__(self, wad: bytes, resolution, sectors_info: bool, game_args: str, seed32: int, vzd):
        self._dir = tempfile.TemporaryDirectory(prefix="navbench-doom-")
        path = os.path.join(self._dir.name, "level.wad")
        with open(path, "wb") as fh:
            fh.write(wad)
        g = vzd.DoomGame()
        g.set_doom_game_path(os.path.join(os.path.dirname(vzd.__file__), "freedoom2.wad"))
        g.set_doom_scenario_path(path)
        g.set_doom_map("MAP01")
        g.set_doom_config_path(os.path.join(self._dir.name, "_vizdoom.ini"))  # not the working directory
        g.set_screen_resolution(getattr(vzd.ScreenResolution, RESOLUTIONS[resolution]))
        g.set_screen_format(vzd.ScreenFormat.RGB24)
        g.set_depth_buffer_enabled(True)
        g.set_sectors_info_enabled(bool(sectors_info))
        for setter in ("set_render_hud", "set_render_weapon", "set_render_crosshair", "set_render_decals",
                       "set_render_particles", "set_render_effects_sprites", "set_render_messages",
                       "set_render_corpses", "set_render_screen_flashes"):
            getattr(g, setter)(False)
        g.set_window_visible(False)
        g.set_sound_enabled(False)
        g.set_mode(vzd.Mode.PLAYER)
        g.set_available_buttons([vzd.Button.TURN_LEFT_RIGHT_DELTA])
        gv = vzd.GameVariable
        g.set_available_game_variables([gv.POSITION_X, gv.POSITION_Y, gv.ANGLE, gv.CAMERA_POSITION_Z])
        g.add_game_args("+sv_cheats 1 +movebob 0" + (" " + game_args if game_args else ""))
        g.set_episode_timeout(0)
        g.set_seed(seed32)
        g.init()
        self.game = g
        self.pid = os.getpid()
        # stop the engine before the temporary directory goes (at interpreter exit, finalizers
        # run newest first): the engine writes its ini there when it stops
        self._finalizer = weakref.finalize(self, g.close)

    def stop(self) -> None:
        self._finalizer()
        self._dir.cleanup()


#: The engine a closed :class:`DoomEngine` left running inside :func:`reuse_engines`:
#: ``(key, _Held)``, at most one.
_PARKED: list = []
_REUSE_DEPTH = [0]


@contextlib.contextmanager
def reuse_engines():
    """Within the block, a closed :class:`DoomEngine` leaves its engine running and the next
    one on the same WAD and settings starts a new episode in it (``new_episode`` with its
    seed: ~2 ms against ~0.2-0.4 s for a new engine process; the frames are the same bit for
    bit, ``tests/sim/test_doom.py``). When the block ends, the engine left running stops.
    Scoped, not process-wide: a pool worker ends with ``os._exit`` (no exit handlers), so an
    engine parked past its chunk would outlive it. The pipeline's worker runs each chunk of
    episodes in one block (:func:`navbench.pipeline.worker.run_episode_chunk`)."""
    _REUSE_DEPTH[0] += 1
    try:
        yield
    finally:
        _REUSE_DEPTH[0] -= 1
        if _REUSE_DEPTH[0] == 0:
            stop_parked_engine()


def _park(key, held: _Held) -> None:
    """Keep ``held`` running for the next engine on ``key`` inside :func:`reuse_engines`
    (stopping any other parked one); outside, stop it."""
    stop_parked_engine()
    if _REUSE_DEPTH[0] > 0 and held.pid == os.getpid():
        _PARKED.append((key, held))
    else:
        held.stop()


def _take_parked(key) -> _Held | None:
    """The parked engine if it was started on ``key`` by this process (else None; a parked
    engine on another key stays until the next :func:`_park`)."""
    if _PARKED and _PARKED[0][0] == key and _PARKED[0][1].pid == os.getpid():
        return _PARKED.pop()[1]
    return None


def stop_parked_engine() -> None:
    """Stop the engine a closed :class:`DoomEngine` left running for reuse, if any."""
    while _PARKED:
        _PARKED.pop()[1].stop()


if hasattr(os, "register_at_fork"):
    # a forked child must neither use nor stop (nor free: its destructor joins a thread the
    # child does not have) the parent's parked engine: the parent stops it before forking
    os.register_at_fork(before=stop_parked_engine)
