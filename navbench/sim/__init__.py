"""The simulator: noisy dynamics, the exact RGB-D camera, the collision world, a gymnasium env.

Modules (import them directly; this package imports nothing heavy):

* :mod:`navbench.sim.dynamics` -- controls, limits, noise levels, the paper's dynamics (pure).
* :mod:`navbench.sim.camera` -- :class:`RaycastCamera` (numba) and a numpy reference renderer.
* :mod:`navbench.sim.world` -- :class:`CollisionWorld` (pymunk) and the :class:`Simulator`.
* :mod:`navbench.sim.env` -- the gymnasium :class:`PointNavEnv`.
* :mod:`navbench.sim.bench` -- plain timing functions for ``navbench bench``.
* :mod:`navbench.sim.doom` -- the ViZDoom backend (levels as Doom maps, :class:`DoomSimulator`;
  needs the optional ``vizdoom`` extra).
"""
