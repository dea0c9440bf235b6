"""gymnasium registration: ``import navbench.envs`` registers ``navbench/PointNav-v0``.

    import gymnasium as gym
    import navbench.envs  # noqa: F401  (gym.register_envs(navbench.envs) keeps linters quiet)

    env = gym.make("navbench/PointNav-v0", level="house-1", noise="mid")

Without the import, ``gym.make("navbench.envs:navbench/PointNav-v0", ...)`` loads this module
itself. The registration lives here rather than in ``navbench/__init__`` because importing
gymnasium costs about 0.1 s, which every ``navbench`` command would otherwise pay.

``level`` is a :class:`~navbench.level.Level`, a level name (``levels/NAME.json`` of the working
directory, as every navbench command reads it) or a path to a level file; every other keyword
argument goes to :class:`navbench.sim.env.PointNavEnv`. ``max_episode_steps`` is left to the
environment's own ``max_steps`` (500 by default), which truncates the episode itself.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from navbench.benchmark import BENCHMARK_VERSION, GYM_IDS  # noqa: E402

#: The id follows the benchmark version (its suffix changes when the images do).
ENV_ID = GYM_IDS[BENCHMARK_VERSION]


def make_pointnav(level, **kwargs):
    """The registered entry point: resolve ``level`` and build a :class:`PointNavEnv`."""
    from navbench.level import Level
    from navbench.levelio import resolve_level
    from navbench.sim.env import PointNavEnv

    if not isinstance(level, Level):
        level = resolve_level(str(level))
    return PointNavEnv(level, **kwargs)


if ENV_ID not in registry:
    register(id=ENV_ID, entry_point="navbench.envs:make_pointnav", disable_env_checker=False)
