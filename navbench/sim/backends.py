"""The simulators a run can choose (``--sim``, a profile's ``sim``; issue 37): names, checks,
and the one place that builds either.

* ``pymunk`` -- :class:`navbench.sim.world.Simulator` with the exact ray-cast camera (the
  reference: its name is in no cache key and no version name, :func:`navbench.benchmark.sim_key_part`).
* ``vizdoom`` -- :class:`navbench.sim.doom.simulator.DoomSimulator`: the same dynamics and
  collisions, the ViZDoom engine's pose and images (needs the optional ``vizdoom`` package).

Light: nothing here imports ``vizdoom`` or the engine until a simulator is built or
:func:`require_sim` checks the installation.
"""

from __future__ import annotations

import numpy as np

from navbench.benchmark import REFERENCE_SIM, SIMULATORS
from navbench.errors import ConfigError

#: What to run when the engine is missing (the message of :func:`require_sim`).
VIZDOOM_INSTALL = "pip install 'navbench[vizdoom]' (or: pip install vizdoom==1.3.2; make setup installs it)"


def check_sim(name, where: str = "--sim") -> str:
    """``name`` if it is a known simulator, else a one-line :class:`ConfigError` naming the known ones."""
    if not isinstance(name, str) or name not in SIMULATORS:
        raise ConfigError(f"{where}: unknown simulator {name!r}; known: {', '.join(SIMULATORS)}")
    return name


def require_sim(name, where: str = "--sim") -> str:
    """:func:`check_sim`, and for ``vizdoom`` that the engine's package imports: else a one-line
    :class:`ConfigError` saying how to install it (checked before any stage runs)."""
    check_sim(name, where)
    if name == "vizdoom":
        try:
            import vizdoom  # noqa: F401
        except ImportError as e:
            raise ConfigError(f"{where} vizdoom: the vizdoom package is not installed ({e}); "
                              f"install it with {VIZDOOM_INSTALL}") from None
    return name


def ignored_textures(sim: str, views_texture: str = "procedural", episode_texture: str = "procedural") -> str | None:
    """The one-line warning for camera texture modes that ``sim`` ignores (an engine draws its
    own textures: ``texture = "table"`` under ``--sim vizdoom`` changes no frame), or None.
    A profile's: :func:`navbench.pipeline.profiles.ignored_textures_note`."""
    if sim == REFERENCE_SIM:
        return None
    set_ = [f"{where} {t!r}" for where, t in (("views.texture", views_texture),
                                                ("navigation.episode.texture", episode_texture))
            if t != "procedural"]
    if not set_:
        return None
    verb = "changes" if len(set_) == 1 else "change"
    return (f"sim {sim}: {' and '.join(set_)} {verb} no frame (the engine draws its own textures; "
            "the texture modes are the pymunk camera's)")


def make_simulator(sim: str, level, noise="none", seed: int = 0, intrinsics=None, **kwargs):
    """A simulator of kind ``sim`` (keyword arguments as :class:`~navbench.sim.world.Simulator`'s).
    A ``vizdoom`` one runs an engine process: call its ``close()`` (:func:`close_simulator`)."""
    check_sim(sim)
    if sim == REFERENCE_SIM:
        from navbench.sim.world import Simulator

        return Simulator(level, noise=noise, seed=seed, intrinsics=intrinsics, **kwargs)
    require_sim(sim)
    from navbench.sim.doom.simulator import DoomSimulator

    return DoomSimulator(level, noise=noise, seed=seed, intrinsics=intrinsics, **kwargs)


def sim_intrinsics(sim: str, intrinsics):
    """The projection simulator ``sim`` renders ``intrinsics``' image size with: ``intrinsics``
    itself on ``pymunk``, the engine's calibrated one on ``vizdoom``
    (:data:`~navbench.sim.doom.engine.DOOM_INTRINSICS`; Doom's pixels are not square). The
    estimators must project with it."""
    check_sim(sim)
    if sim == REFERENCE_SIM or intrinsics is None:
        return intrinsics
    from navbench.sim.doom.engine import DOOM_INTRINSICS

    size = (int(intrinsics.width), int(intrinsics.height))
    if size not in DOOM_INTRINSICS:
        raise ConfigError(f"--sim {sim}: the engine renders "
                          f"{' or '.join(f'{w}x{h}' for w, h in DOOM_INTRINSICS)}, got {size[0]}x{size[1]}")
    return DOOM_INTRINSICS[size]


def reusing_engines(sim: str):
    """A context in which simulators of kind ``sim`` closed one after another reuse one
    engine (``vizdoom``: :func:`navbench.sim.doom.engine.reuse_engines`, a new episode in the
    running engine instead of a new engine process; the same frames); nothing on ``pymunk``."""
    check_sim(sim)
    if sim == REFERENCE_SIM:
        import contextlib

        return contextlib.nullcontext()
    from navbench.sim.doom.engine import reuse_engines

    return reuse_engines()


def close_simulator(sim) -> None:
    """Stop ``sim``'s engine, if it has one (the pymunk simulator has none)."""
    close = getattr(sim, "close", None)
    if close is not None:
        close()


class PoseRenderer:
    """Frames at given poses from simulator ``sim`` (for views and replayed trajectories).

    ``render(pose) -> Frame``; ``shown`` is the pose the last frame was taken from: the asked
    pose on ``pymunk``; on ``vizdoom`` the engine's (position to the centimetre, heading to
    1/65536 turn: the engine's pose is the truth, :mod:`navbench.sim.doom.simulator`). The
    engine is teleported without navbench's collision check (a view or a recorded pose is
    placed, not driven). ``options``: the engine simulator's own (``depth="exact"``,
    ``edge_steps``; :class:`~navbench.sim.doom.simulator.DoomSimulator`). ``texture``: the pymunk
    camera's texture mode (:mod:`navbench.sim.texels`; an engine renders its own textures and
    ignores it). Use as a context manager or call :meth:`close`.
    """

    def __init__(self, sim: str, level, intrinsics, camera_height: float, texture: str = "procedural",
                 **options):
        check_sim(sim)
        self.sim = sim
        self.shown = None
        if sim == REFERENCE_SIM:
            from navbench.sim.camera import RaycastCamera

            self._camera = RaycastCamera(level, intrinsics, camera_height, texture=texture)
            self._engine = None
        else:
            self._camera = None
            self._engine = make_simulator(sim, level, "none", 0, intrinsics, camera_height=camera_height,
                                          **options)
        self.intrinsics = intrinsics if self._engine is None else self._engine.intrinsics

    def render(self, pose):
        """The frame at ``pose (3,)``; :attr:`shown` is the pose it was taken from."""
        if self._engine is None:
            self.shown = np.asarray(pose, dtype=np.float64).copy()
            return self._camera.render(pose)
        self.shown = self._engine.engine.set_pose(np.asarray(pose, dtype=np.float64))
        self._engine.pose = self.shown
        return self._engine.observe()

    def close(self) -> None:
        if self._engine is not None:
            self._engine.close()
            self._engine = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
