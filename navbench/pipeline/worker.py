"""The worker entry point: run a chunk of episodes of one level (in a pool process, a Ray task
or the parent itself) and return their records and scores. Workers never write: the parent
stores trajectories and rows (:mod:`navbench.pipeline.stages.navigation`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the grid's types only annotate here; importing the stages package at the
    # top would run its __init__, whose navigation module imports this one
    from navbench.pipeline.stages.grid import ChunkSpec, EpisodeJob


_WORKER_MEMO: dict[tuple, Any] = {}


def _worker_inputs(spec: ChunkSpec):
    """Load (once per worker process) the level, map slice and tasks of a chunk."""
    memo_key = (spec.level_path, spec.map_path, spec.tasks_path, spec.slice_mode)
    hit = _WORKER_MEMO.get(memo_key)
    if hit is None:
        from navbench.levelio import load_level
        from navbench.plan.tasks import load_tasks
        from navbench.worldmodel.base import load_world_model

        level = load_level(spec.level_path)
        vmap = load_world_model(spec.map_path)
        occ2d, xs, ys = vmap.occupancy_slice(spec.slice_mode)
        from navbench.nav.metrics import FinalGeodesic

        tasks = {t.id: t for t in load_tasks(spec.tasks_path)}
        hit = (level, vmap, occ2d, xs, ys, tasks, FinalGeodesic(level))
        _WORKER_MEMO.clear()  # one level at a time keeps worker memory flat
        _WORKER_MEMO[memo_key] = hit
    return hit


def run_episode_chunk(spec: ChunkSpec) -> list[tuple[EpisodeJob, Any, Any]]:
    """Worker entry point: run a chunk's episodes; returns ``(job, record, score)`` triples."""
    from navbench.geometry import camera_by_name
    from navbench.sim.backends import reusing_engines, sim_intrinsics

    level, vmap, occ2d, xs, ys, tasks, geodesic = _worker_inputs(spec)
    intr = sim_intrinsics(spec.sim, camera_by_name(spec.camera))  # vizdoom: the engine's projection
    goals = None
    if spec.goals_path:
        from navbench.pipeline.stages.goals import load_goals

        goals = load_goals(spec.goals_path)
    out = []
    with reusing_engines(spec.sim):  # the chunk's episodes on one engine process (vizdoom)
        for job in spec.jobs:
            out.append(_chunk_episode(spec, job, level, vmap, occ2d, xs, ys, tasks, goals, geodesic, intr))
    return out


def _chunk_episode(spec, job, level, vmap, occ2d, xs, ys, tasks, goals, geodesic, intr):
    """One job of a chunk: its simulator, its episode, the simulator closed; ``(job, record, score)``."""
    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.pipeline.stages.grid import build_episode_config
    from navbench.nav.metrics import score_episode
    from navbench.sim.backends import close_simulator, make_simulator
    from navbench.track.registry import uses_frames

    c = job.cell
    ep_cfg = build_episode_config(c.episode)
    # estimators that never look at frames skip rendering; the unknown-house loop maps from them
    frames = uses_frames(c.estimator) or spec.online is not None
    # the texture mode is the pymunk camera's (navbench.sim.texels); the engine records it, unused
    sim = make_simulator(spec.sim, level, noise=c.noise, seed=job.sim_seed,
                         intrinsics=camera_by_name(spec.camera) if frames else None,
                         camera_height=CAMERA_HEIGHT, enforce_direction_limit=ep_cfg.body_fixed_drive,
                         pose_quantisation=ep_cfg.pose_quantisation, collision_check=ep_cfg.collision_check,
                         texture=ep_cfg.texture)
    try:
        record = _run_one(spec, job, c, ep_cfg, level, vmap, occ2d, xs, ys, tasks, goals, sim, intr)
    finally:
        close_simulator(sim)  # the engine's process (vizdoom; kept for the chunk's next episode)
    return job, record, score_episode(record, geodesic=geodesic)


def _run_one(spec, job, c, ep_cfg, level, vmap, occ2d, xs, ys, tasks, goals, sim, intr):
    """One episode's record on ``sim`` (its simulator, built by the caller)."""
    from navbench.geometry import CAMERA_HEIGHT
    from navbench.nav.episode import run_episode
    from navbench.track.registry import make_estimator

    est = None if spec.online is not None else make_estimator(
        c.estimator, vmap=vmap, intrinsics=intr, camera_height=CAMERA_HEIGHT, renderer=None,
        seed=job.estimator_seed, **c.options)
    task = tasks[job.task_id]
    if spec.online is not None:  # the unknown-house loop: no prior map, the true pose
        from navbench.pipeline.stages.online import loop_config, run_online_episode

        record = run_online_episode(level, vmap, task, sim, intr, spec.online,
                                    loop_config(c.episode, spec.online.ablation),
                                    spec.goal_seed, c.noise, job.seed, c.estimator,
                                    job.estimator_seed, c.options)
    elif goals is None:
        record = run_episode(level, occ2d, xs, ys, task, est, sim, config=ep_cfg)
    else:  # plan and track to the goal found in the map; scored against the true target
        from navbench.nav.imagegoal import run_image_goal_episode

        record = run_image_goal_episode(level, occ2d, xs, ys, task, goals[job.task_id]["pose"],
                                        est, sim, ep_cfg)
    return record
