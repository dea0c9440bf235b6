"""gymnasium registration: ``import navbench.envs`` registers ``navbench/PointNav-v0`` and ``-v1``.

    import gymnasium as gym
    import navbench.envs  # noqa: F401  (gym.register_envs(navbench.envs) keeps linters quiet)

    env = gym.make("navbench/PointNav-v1", level="house-1", noise="mid")

The id's suffix follows the benchmark version's images (:data:`navbench.benchmark.GYM_IDS`):
``-v1`` is the current version's (navbench-5: the camera's textures as texel tables), ``-v0``
navbench-1's and navbench-3's (per-pixel procedural textures). Each id's camera defaults to its
version's texture mode; ``texture=`` still chooses either. :data:`ENV_ID` is the current
version's id.

Without the import, ``gym.make("navbench.envs:navbench/PointNav-v1", ...)`` loads this module
itself. The registration lives here rather than in ``navbench/__init__`` because importing
gymnasium costs about 0.1 s, which every ``navbench`` command would otherwise pay.

``level`` is a :class:`~navbench.level.Level`, a level name (``levels/NAME.json`` of the working
directory, as every navbench command reads it) or a path to a level file; every other keyword
argument goes to :class:`navbench.sim.env.PointNavEnv`. ``max_episode_steps`` is left to the
environment's own ``max_steps`` (500 by default), which truncates the episode itself.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from navbench.benchmark import BENCHMARK_VERSION, CANDIDATES, GYM_IDS, version_settings  # noqa: E402

#: The id follows the benchmark version (its suffix changes when the images do).
ENV_ID = GYM_IDS[BENCHMARK_VERSION]
#: Every registered id -> its camera's texture mode (:mod:`navbench.sim.texels`), from the
#: accepted versions' settings (the versions sharing an id share their images).
ENV_TEXTURES: dict[str, str] = {
    GYM_IDS[v]: str(version_settings(v).get("navigation.episode.texture", "procedural"))
    for v in GYM_IDS if v not in CANDIDATES}


def make_pointnav(level, **kwargs):
    """The registered entry point: resolve ``level`` and build a :class:`PointNavEnv`."""
    from navbench.level import Level
    from navbench.levelio import resolve_level
    from navbench.sim.env import PointNavEnv

    if not isinstance(level, Level):
        level = resolve_level(str(level))
    return PointNavEnv(level, **kwargs)


for _id, _texture in ENV_TEXTURES.items():
    if _id not in registry:
        register(id=_id, entry_point="navbench.envs:make_pointnav", kwargs={"texture": _texture},
                 disable_env_checker=False)
