"""The profile glue: everything navigation needs for one level (level, map, task set), built
from a profile's settings through the cached stages."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Callable

from navbench.errors import ArtifactError, ConfigError
from navbench.pipeline.artifacts import VIEWS_FILE
from navbench.pipeline.stages.context import Ref, StageContext
from navbench.pipeline.stages.level import LevelConfig, make_level_stage
from navbench.pipeline.stages.maps import (LEVEL_PLACEHOLDER, FitMapConfig, fit_map_stage, map_file_stage,
                                           true_map_stage)
from navbench.pipeline.stages.tasks import TasksConfig, sample_tasks_stage
from navbench.pipeline.stages.views import ViewsConfig, collect_views_stage


@dataclass(frozen=True)
class LevelInputs:
    """Everything navigation needs for one level: the level, its map and its task set."""

    level: Ref
    map: Ref
    tasks: Ref
    goals: Ref | None = None  # image goals: the image-goals artifact (stages.goals)


def build_level_inputs(ctx: StageContext, profile, level_name: str,
                       views_key: str | None = None,
                       before_fit: Callable[[], None] | None = None) -> LevelInputs:
    """Run (or fetch from the cache) make-level -> collect-views (train and held-out) -> fit-map
    -> sample-tasks for one level with ``profile``'s settings. ``views_key`` replaces the
    training views by a stored collect-views artifact. ``profile.map_source``: ``fit`` (the
    fitted world model), ``true`` (the voxelized true geometry; no views are collected) or a
    map file path, where ``{level}`` stands for the level's name (:func:`map_file_stage`).
    ``before_fit`` is called once the views are there, before the fit (the overlap's start)."""
    from navbench.pipeline.stages.online import is_online

    under_version(ctx, profile)
    source = profile.map_source
    one_file = source not in ("fit", "true") and not is_online(source) and LEVEL_PLACEHOLDER not in source
    if one_file and len(set(profile.levels)) > 1:
        raise ConfigError(f"--map {source}: one map file for {len(set(profile.levels))} levels; "
                          f"put {LEVEL_PLACEHOLDER} in the path for one map per level")
    level = make_level_stage(ctx, LevelConfig(level_name, profile.level_seed))
    if source == "true" or is_online(source):  # online: the truth the unknown-house loop is
        # scored against and its perfect sensor reads (stages.online)
        return LevelInputs(level, true_map_stage(ctx, level),
                           sample_tasks_stage(ctx, level, tasks_config(profile)))
    if source != "fit":
        return LevelInputs(level, map_file_stage(ctx, level, source),
                           sample_tasks_stage(ctx, level, tasks_config(profile)))
    vmap = fit_map_for_profile(ctx, profile, level, views_key, before_fit)
    tasks = sample_tasks_stage(ctx, level, tasks_config(profile))
    return LevelInputs(level, vmap, tasks)


def under_version(ctx: StageContext, profile) -> None:
    """Run ``ctx``'s stages under ``profile``'s benchmark version (the keys it affects carry it)."""
    ctx.benchmark_version = getattr(profile, "benchmark_version", ctx.benchmark_version)


def tasks_config(profile) -> TasksConfig:
    """The profile's sample-tasks config (``[tasks]`` count, seed and difficulty)."""
    return TasksConfig(profile.tasks, profile.tasks_seed, tuple(getattr(profile, "tasks_difficulty", ())))


def with_image_goals(ctx: StageContext, inputs: LevelInputs, cfg, sim: str = "pymunk") -> LevelInputs:
    """``inputs`` with their image-goals artifact (goals localised in the level's map; ``cfg`` an
    :class:`~navbench.pipeline.stages.goals.ImageGoalConfig`; the goal images rendered by
    simulator ``sim``)."""
    import dataclasses

    from navbench.pipeline.stages.goals import image_goals_stage

    return dataclasses.replace(inputs, goals=image_goals_stage(ctx, inputs.level, inputs.map, inputs.tasks, cfg,
                                                               sim))


def fit_map_for_profile(ctx: StageContext, profile, level: Ref, views_key: str | None = None,
                        before_fit: Callable[[], None] | None = None) -> Ref:
    """collect-views (train and held-out) -> fit-map for one level with ``profile``'s settings;
    ``before_fit`` is called between the two."""
    under_version(ctx, profile)
    cfg = FitMapConfig(profile.fit_steps, profile.fit_seed, dict(profile.fit), profile.eval_views,
                       profile.eval_seed)
    fit_cfg = cfg.fit_config()  # a bad fit option fails here, before any views are collected
    if fit_cfg.device.startswith("cuda"):  # an explicit GPU request (imports torch only then)
        from navbench.worldmodel.fit import resolve_fit_device

        resolve_fit_device(fit_cfg.device)
    camera = profile.camera
    sim = getattr(profile, "sim", "pymunk")  # issue 37: views (and so the map) of the profile's simulator
    if views_key:
        stage, key = ctx.store.find(views_key, "collect-views")
        p = ctx.store.load(stage, key)
        man = json.loads((p / "manifest.json").read_text())
        if man.get("inputs", {}).get("level") != level.key:
            raise ArtifactError(f"views {key[:12]} were not collected on level {level.name} "
                                f"(level key {level.key[:12]})")
        camera = man.get("config", {}).get("camera", camera)
        sim = man.get("config", {}).get("sim", "pymunk")  # the held-out views of the same simulator
        views = Ref(stage, key, p / VIEWS_FILE, True, level.name)
    else:
        views = collect_views_stage(ctx, level, ViewsConfig(profile.views, camera, profile.views_seed,
                                                            texture=profile.views_texture, sim=sim))
    held = collect_views_stage(ctx, level, ViewsConfig(profile.eval_views, camera, profile.eval_seed,
                                                       texture=profile.views_texture, sim=sim))
    if before_fit is not None:
        before_fit()
    return fit_map_stage(ctx, level, views, held, cfg)
