"""The navigation grid and its seed plan: cells (level x estimator x noise), the episodes of each
(tasks x seeds) with their derived RNG seeds, and the chunks handed to workers."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from navbench.benchmark import LEGACY_VERSION, key_part
from navbench.config import config_hash, to_jsonable
from navbench.errors import ConfigError
from navbench.pipeline.artifacts import FORMAT
from navbench.pipeline.stages.inputs import LevelInputs


@dataclass(frozen=True)
class NavigationConfig:
    """run-navigation: the grid estimators x noise x tasks x ``seeds`` episode seeds per task.

    ``camera`` is the simulator's and estimators' camera; ``episode`` holds
    :class:`navbench.nav.episode.EpisodeConfig` fields; ``estimator_options`` maps an estimator
    name to its keyword arguments; ``slice_mode`` is the map's horizontal slice for planning.
    """

    estimators: tuple[str, ...] = ("ours", "no-map", "dynamics")
    noise: tuple[str, ...] = ("mid",)
    seeds: int = 1
    camera: str = "half"
    episode: dict = field(default_factory=dict)
    estimator_options: dict = field(default_factory=dict)
    slice_mode: str = "band"
    # issue 15: "point" (the task's coordinates) or "image" (the goal image localised in the map,
    # navbench.pipeline.stages.goals); an ImageGoalConfig for "image" (None: its defaults)
    goal: str = "point"
    image_goal: object = None
    # issue 15 §5: --map online, the unknown-house loop (stages.online.OnlineConfig; None: off)
    online: object = None
    # issue 36: the benchmark version; every cell and condition key carries it (key_part:
    # nothing for navbench-1), so the episodes of two versions are never one another's
    benchmark_version: str = LEGACY_VERSION
    # issue 37: the simulator (navbench.sim.backends); in the cell and condition keys unless pymunk
    sim: str = "pymunk"


@dataclass(frozen=True)
class Cell:
    """One cell of the grid: a level's inputs x estimator x noise. ``key`` is the cell key
    (config hash of level, map, task set, estimator, its options, noise, episode config)."""

    level: str
    level_key: str
    map_key: str
    tasks_key: str
    estimator: str
    options: dict
    noise: str
    episode: dict          # EpisodeConfig overrides (the key hashes the resolved config)
    key: str
    # the key without task set and estimator (level, map, noise, resolved episode config): the
    # episodes of one condition are comparable across task sets (a larger --tasks extends them)
    # and across estimators (paired on the same task and seed); not part of ``key``
    condition_key: str = ""


@dataclass(frozen=True)
class EpisodeJob:
    """One episode to run: its cell, task id, episode seed and the derived RNG seeds."""

    cell: Cell
    task_id: int
    seed: int
    sim_seed: int
    estimator_seed: int


@dataclass(frozen=True)
class ChunkSpec:
    """A batch of episodes of ONE level for a worker (it loads the level, map and tasks once).
    Paths must be readable by the worker (a shared filesystem for Ray clusters)."""

    level_path: str
    map_path: str
    tasks_path: str
    camera: str
    slice_mode: str
    jobs: tuple[EpisodeJob, ...]
    goals_path: str = ""  # image goals: the image-goals artifact (the targets the agent found)
    online: object = None  # --map online: the OnlineConfig (stages.online); goal_seed its goals'
    goal_seed: int = 0
    sim: str = "pymunk"  # the simulator (navbench.sim.backends)


def build_episode_config(overrides: dict):
    """An :class:`navbench.nav.episode.EpisodeConfig` from field overrides; a dict value for a
    dataclass-valued field (``planner``, ``controller``) overrides that dataclass's fields."""
    from navbench.nav.episode import EpisodeConfig

    base = EpisodeConfig()
    kw = {}
    names = {f.name for f in dataclasses.fields(EpisodeConfig)}
    for k, v in dict(overrides).items():
        if k not in names:
            raise ConfigError(f"unknown episode config field {k!r}; known: {sorted(names)}")
        default = getattr(base, k)
        if dataclasses.is_dataclass(default) and isinstance(v, dict):
            try:
                v = dataclasses.replace(default, **v)
            except TypeError as e:
                raise ConfigError(f"invalid episode config {k}: {e}") from None
        kw[k] = v
    out = dataclasses.replace(base, **kw)
    from navbench.sim.texels import check_texture

    check_texture(out.texture, "episode config texture")  # before any worker starts
    return out


def resolved_episode_config(cfg: NavigationConfig) -> dict:
    """The full EpisodeConfig (defaults filled in) plus camera and slice mode, as plain JSON;
    the simulator conditions added after the first stored runs are left out at their neutral
    values (:data:`navbench.sim.conditions.KEY_NEUTRAL_FIELDS`), so those runs keep their keys."""
    from navbench.sim.conditions import KEY_NEUTRAL_FIELDS

    episode = to_jsonable(build_episode_config(cfg.episode))
    for k, neutral in KEY_NEUTRAL_FIELDS.items():
        if episode.get(k) == neutral:
            del episode[k]
    return {"camera": cfg.camera, "slice_mode": cfg.slice_mode, **episode}


def goal_key_part(cfg: NavigationConfig) -> dict:
    """What the goal adds to the cell and condition keys: nothing for point goals (so their keys
    stay those stored before image goals existed), else ``{"goal": {"kind": ..., config}}`` and,
    for a goal localised in a given map, every field of the localiser that searched it
    (``localizer_resolved``, since 2026-11-26: before, only the profile's overrides were keyed,
    and a changed localiser default left stored goals under their old keys). The unknown-house
    loop's localiser is keyed by :func:`~navbench.pipeline.stages.online.online_key_part`."""
    if cfg.goal == "point":
        return {}
    if cfg.goal != "image":
        raise ConfigError(f"--goal: expected point or image, got {cfg.goal!r}")
    from navbench.pipeline.stages.goals import ImageGoalConfig

    goal = cfg.image_goal or ImageGoalConfig()
    part = {"kind": "image", **to_jsonable(goal)}
    if getattr(cfg, "online", None) is None:  # the goal search's localiser, every field (its
        part["localizer_resolved"] = goal.localizer_settings()  # defaults change as it improves)
    return {"goal": part}


def make_cells(inputs: list[LevelInputs], cfg: NavigationConfig) -> list[Cell]:
    """All cells of the grid, in (level, noise, estimator) order."""
    from navbench.benchmark import sim_key_part
    from navbench.pipeline.stages.online import online_key_part

    episode = resolved_episode_config(cfg)
    # all {} for point goals on a given map under navbench-1 on pymunk (the keys stored before them)
    extra = {**goal_key_part(cfg), **online_key_part(cfg), **key_part(cfg.benchmark_version),
             **sim_key_part(cfg.sim)}
    cells = []
    for li in inputs:
        for noise in cfg.noise:
            condition = config_hash({"level": li.level.key, "map_key": li.map.key, "noise": noise,
                                     "episode": episode, **extra})
            for est in cfg.estimators:
                options = dict(cfg.estimator_options.get(est, {}))
                key = config_hash({"level": li.level.key, "map_key": li.map.key, "task_set_key": li.tasks.key,
                                   "estimator": est, "estimator_options": options, "noise": noise,
                                   "episode": episode, **extra})
                cells.append(Cell(li.level.name, li.level.key, li.map.key, li.tasks.key, est, options,
                                  noise, dict(cfg.episode), key, condition))
    return cells


def episode_seeds(level_key: str, task_id: int, seed: int) -> tuple[int, int]:
    """``(simulator seed, estimator seed)`` of an episode, from (level, task id, seed) only.

    Every estimator and noise level sees the same simulator noise stream for a given
    (level, task, seed): the seeds come from a :class:`numpy.random.SeedSequence` over the
    level's content key, the task id and the episode seed, never from the estimator.
    """
    ss = np.random.SeedSequence([int(level_key[:16], 16), int(task_id), int(seed)])
    sim, est = ss.spawn(2)
    return int(sim.generate_state(1, np.uint64)[0] >> np.uint64(1)), \
        int(est.generate_state(1, np.uint64)[0] >> np.uint64(1))


def episode_key(job: EpisodeJob) -> str:
    """Cache key of an episode's trajectory artifact."""
    from navbench.pipeline.cache import stage_key

    c = job.cell
    return stage_key("episode", {"cell": c.key, "task_id": job.task_id, "seed": job.seed},
                     {"level": c.level_key, "map": c.map_key, "tasks": c.tasks_key}, FORMAT["episode"])


def plan_jobs(inputs: list[LevelInputs], cfg: NavigationConfig) -> tuple[list[Cell], list[EpisodeJob]]:
    """Every episode of the grid (cells x tasks x seeds) in a stable order: level by level, and
    within a level task by task and seed by seed across all cells, so that a partial run holds
    comparable episodes of every estimator and noise level."""
    from navbench.plan.tasks import load_tasks

    cells = make_cells(inputs, cfg)
    jobs = []
    for li in inputs:
        level_cells = [c for c in cells if c.level_key == li.level.key]
        for tid in [t.id for t in load_tasks(li.tasks.path)]:
            for s in range(cfg.seeds):
                sim_seed, est_seed = episode_seeds(li.level.key, tid, s)
                jobs.extend(EpisodeJob(c, tid, s, sim_seed, est_seed) for c in level_cells)
    return cells, jobs


def chunk_jobs(inputs: list[LevelInputs], cfg: NavigationConfig, jobs: list[EpisodeJob],
               chunk_size: int) -> list[ChunkSpec]:
    """Group jobs by level into chunks of at most ``chunk_size`` episodes (absolute paths, so
    workers with another working directory find the artifacts)."""
    by_level = {li.level.key: li for li in inputs}
    groups: dict[str, list[EpisodeJob]] = {}
    for j in jobs:
        groups.setdefault(j.cell.level_key, []).append(j)
    specs = []
    for lk, js in groups.items():
        li = by_level[lk]
        for i in range(0, len(js), chunk_size):
            goals = getattr(li, "goals", None)
            specs.append(ChunkSpec(str(Path(li.level.path).resolve()), str(Path(li.map.path).resolve()),
                                   str(Path(li.tasks.path).resolve()), cfg.camera, cfg.slice_mode,
                                   tuple(js[i:i + chunk_size]),
                                   str(Path(goals.path).resolve()) if goals is not None else "",
                                   cfg.online, getattr(cfg.image_goal, "seed", 0), cfg.sim))
    return specs
