"""run-navigation: every episode of the grid the database does not hold yet, run on an executor,
stored by this (parent) process chunk by chunk."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Any, Callable

from navbench.pipeline.artifacts import FORMAT, TRAJ_FILE, load_record, save_record
from navbench.pipeline.stages.context import StageContext
from navbench.pipeline.stages.grid import Cell, EpisodeJob, NavigationConfig, chunk_jobs, episode_key, plan_jobs
from navbench.pipeline.stages.inputs import LevelInputs
from navbench.pipeline.worker import run_episode_chunk


@dataclass
class NavigationSummary:
    """What run-navigation did: episode counts by origin and the cells it covered.

    ``already_done + stored == total`` once the grid is complete: every episode was either
    stored by this run or by another one (before it started, or while it ran).
    """

    cells: list[Cell]
    total: int = 0            # episodes in the grid
    already_done: int = 0     # stored by another run (before this one, or meanwhile)
    from_cache: int = 0       # trajectory artifact found, scored and stored without simulating
    ran: int = 0              # simulated now (including restored trajectories)
    stored: int = 0           # new database rows written by this run
    stored_elsewhere: int = 0  # of already_done: stored by another run while this one ran
    restored: int = 0         # stored episodes whose missing or corrupt trajectory was rewritten
    # the breakdown of the simulated episodes (pipeline.breakdown): seconds per timing
    # component summed over their steps, the steps, and the parent's storing time
    component_s: dict = field(default_factory=dict)
    estimator_s: dict = field(default_factory=dict)  # estimator -> [seconds of its steps, steps]
    steps: int = 0
    store_s: float = 0.0
    seconds: float | None = None  # the stage's wall-clock time and the executor's workers
    workers: int = 1              # (set by pipeline.run.navigate)


def _row(job: EpisodeJob, record: Any, score: Any, traj_key: str, goals: dict | None = None) -> dict:
    from navbench.results.db import episode_row_from_score
    from navbench.pipeline.stages.goals import goal_row_fields
    from navbench.pipeline.stages.online import online_row_fields

    c = job.cell
    meta = {"level": c.level, "map_key": c.map_key, "task_set_key": c.tasks_key,
            "estimator": c.estimator, "estimator_options": c.options, "noise": c.noise,
            "seed": job.seed, "task_id": job.task_id,
            "timings_ms": record.timings_ms or {}, "end_reason": record.end_reason,
            "collided": record.collided, "condition_key": c.condition_key or None}
    if goals is not None:  # image goals: {level key: {task id: goal record}}
        meta.update(goal_row_fields(goals[c.level_key][job.task_id]))
    meta.update(online_row_fields(record))  # --map online: the goal match the agent made
    return episode_row_from_score(c.key, meta, score, traj_key)


def _store_trajectory(ctx: StageContext, job: EpisodeJob, record: Any) -> str:
    """Write an episode's trajectory artifact (a valid one already there is kept: episodes are
    deterministic); returns its key."""
    key = episode_key(job)
    c = job.cell
    ctx.store.write("episode", key, lambda d: save_record(record, d / TRAJ_FILE),
                    config={"cell": c.key, "task_id": job.task_id, "seed": job.seed,
                            "level": c.level, "estimator": c.estimator, "noise": c.noise},
                    inputs={"level": c.level_key, "map": c.map_key, "tasks": c.tasks_key},
                    version=FORMAT["episode"])
    return key


def _record_class(cfg: NavigationConfig):
    """The class of the trajectory artifacts of ``cfg``'s episodes (``None``: EpisodeRecord)."""
    if cfg.online is None:
        return None
    from navbench.nav.imagenav import OnlineEpisodeRecord

    return OnlineEpisodeRecord


def _triple(job: EpisodeJob) -> tuple[str, int, int]:
    return (job.cell.key, job.task_id, job.seed)


def _score_differs(stored: dict, score: Any) -> list[str]:
    """The fields of a stored episode row that a new simulation of it does not reproduce."""
    def same(a, b) -> bool:
        a = None if a is None or (isinstance(a, float) and a != a) else a
        b = None if b is None or (isinstance(b, float) and b != b) else b
        return a == b

    new = {"success": bool(score.success), "spl_term": float(score.spl_term),
           "path_length": float(score.path_length), "steps": int(score.steps)}
    return [f"{k} {stored[k]} -> {v}" for k, v in new.items() if not same(stored[k], v)]


def _same_task_trajectories(ctx: StageContext, jobs: list[EpisodeJob]) -> dict[tuple[str, int, int], str]:
    """For jobs not stored in their own cell: the trajectory key of a stored episode that is the
    same experiment under another task set -- the identity :func:`navbench.results.score.with_identities`
    counts once (setup, task id with its start and target, seed) -- so a larger ``--tasks``
    extends a cell without simulating its first tasks again. Episodes are deterministic in exactly
    these (their seeds come from the level, task id and seed: :func:`episode_seeds`), so the
    trajectory is the one this job would produce."""
    keys = sorted({j.cell.condition_key for j in jobs if j.cell.condition_key})
    if not keys or ctx.db is None:
        return {}
    stored = ctx.db.episodes_frame(condition_key=keys)
    stored = stored[stored["traj_key"].notna()]
    if stored.empty:
        return {}
    import pandas as pd

    from navbench.results.score import with_identities

    mine = pd.DataFrame([{"cell_key": j.cell.key, "condition_key": j.cell.condition_key,
                          "estimator": j.cell.estimator, "estimator_options": j.cell.options,
                          "task_set_key": j.cell.tasks_key, "task_id": j.task_id, "seed": j.seed,
                          "level": j.cell.level, "map_key": j.cell.map_key, "noise": j.cell.noise}
                         for j in jobs if j.cell.condition_key])
    sets = sorted(set(stored["task_set_key"].dropna()) | set(mine["task_set_key"]))
    tasks = pd.concat([ctx.db.tasks_frame(task_set_key=k) for k in sets], ignore_index=True)
    stored, mine = with_identities(stored, tasks), with_identities(mine, tasks)
    index: dict[tuple, str] = {}
    for setup, uid, seed, traj in zip(stored["setup"], stored["task_uid"], stored["seed"], stored["traj_key"]):
        index.setdefault((setup, uid, int(seed)), traj)
    out = {}
    for cell, tid, seed, setup, uid in zip(mine["cell_key"], mine["task_id"], mine["seed"], mine["setup"],
                                           mine["task_uid"]):
        key = index.get((setup, uid, int(seed)))
        if key is not None:
            out[(cell, int(tid), int(seed))] = key
    return out


def run_navigation_stage(ctx: StageContext, run_id: int, inputs: list[LevelInputs],
                         cfg: NavigationConfig, executor=None, chunk_size: int | None = None,
                         on_progress: Callable[[int], None] | None = None,
                         on_total: Callable[[int], None] | None = None) -> NavigationSummary:
    """Run every episode of the grid that the database does not hold yet.

    Episodes already in the database are skipped; an episode whose trajectory artifact exists
    (a run killed between writing it and committing its row) is scored from it without
    simulating. The rest run in chunks on ``executor`` (see :mod:`navbench.pipeline.executor`;
    ``None`` runs them in this process). This process is the only writer: after each chunk it
    stores the trajectories in the cache and commits the chunk's rows in one transaction, so
    an interruption loses at most the chunks in flight, and a rerun finishes the rest.

    Another run of the same grid may work at the same time: just before a chunk is handed to a
    worker, its episodes that are stored by now are dropped from it, and rows that another run
    inserted first are counted as theirs (``stored`` counts only rows this run inserted).

    A stored episode whose trajectory artifact is missing or fails its checksum is simulated
    again (same seeds) and its artifact rewritten, without a new row; a score that differs from
    the stored one is reported as a warning and the stored row is kept.
    """
    from navbench.nav.metrics import score_episode

    cells, jobs = plan_jobs(inputs, cfg)
    summary = NavigationSummary(cells, total=len(jobs))
    stored_rows = ctx.db.episode_outcomes([c.key for c in cells])
    todo = [j for j in jobs if _triple(j) not in stored_rows]
    summary.already_done = len(jobs) - len(todo)
    # stored rows whose trajectory artifact is gone or damaged: simulate again to restore it
    restore = [j for j in jobs if _triple(j) in stored_rows
               and stored_rows[_triple(j)]["traj_key"] == episode_key(j)
               and ctx.store.lookup("episode", episode_key(j), ctx.log) is None]
    if restore:
        ctx.log(f"warning: {len(restore)} stored episode(s) have no valid trajectory artifact; "
                "simulating them again to restore it (their rows are kept)")
    if on_total:
        on_total(len(todo) + len(restore))
    goals = None
    if any(li.goals is not None for li in inputs):
        from navbench.pipeline.stages.goals import load_goals

        goals = {li.level.key: load_goals(li.goals.path) for li in inputs if li.goals is not None}
    geodesics: dict[str, Any] = {}

    def geodesic(job: EpisodeJob):  # the final geodesic distance on the job's true level
        if job.cell.level_key not in geodesics:
            from navbench.nav.metrics import FinalGeodesic
            from navbench.pipeline.stages.level import load_level_ref

            li = next(li for li in inputs if li.level.key == job.cell.level_key)
            geodesics[job.cell.level_key] = FinalGeodesic(load_level_ref(li.level))
        return geodesics[job.cell.level_key]

    # trajectories stored by an interrupted run, or by a run of a smaller (or other) task set
    # holding the same task: score them, no simulation
    same_task = _same_task_trajectories(ctx, todo)
    rerun, rows = [], []
    for j in todo:
        key = episode_key(j)
        p = ctx.store.lookup("episode", key, ctx.log)
        if p is None and _triple(j) in same_task:
            key = same_task[_triple(j)]
            p = ctx.store.lookup("episode", key, ctx.log)
        if p is None:
            rerun.append(j)
            continue
        record = load_record(p / TRAJ_FILE, _record_class(cfg))
        rows.append(_row(j, record, score_episode(record, geodesic=geodesic(j)), key, goals))
        ctx.used.append(("episode", key))
    if rows:
        new = ctx.db.add_episodes(run_id, rows)
        summary.stored += new
        summary.from_cache = len(rows)
        summary.already_done += len(rows) - new
        summary.stored_elsewhere += len(rows) - new
        if on_progress:
            on_progress(len(rows))
    work = rerun + restore
    if not work:
        return summary
    restoring = {_triple(j) for j in restore}
    if chunk_size is None:
        workers = (executor.workers if executor is not None else 1) or 1
        chunk_size = max(1, min(8, len(work) // (4 * workers) or 1))

    def still_missing(specs):
        """Each chunk without the episodes another run has stored since this one started
        (asked just before the chunk goes to a worker)."""
        for spec in specs:
            wanted = [_triple(j) for j in spec.jobs if _triple(j) not in restoring]
            there = ctx.db.stored_episode_keys(wanted) if wanted else set()
            if there:
                summary.already_done += len(there)
                summary.stored_elsewhere += len(there)
                if on_progress:
                    on_progress(len(there))
            left = tuple(j for j in spec.jobs if _triple(j) not in there)
            if left:
                yield dataclasses.replace(spec, jobs=left)

    specs = still_missing(chunk_jobs(inputs, cfg, work, chunk_size))
    results = executor.map_unordered(run_episode_chunk, specs) if executor is not None \
        else map(run_episode_chunk, specs)
    simulated_twice = 0
    for triples in results:
        t_store = time.perf_counter()
        batch = []
        for job, record, score in triples:
            per = summary.estimator_s.setdefault(job.cell.estimator, [0.0, 0])
            for k, v in (record.timings_ms or {}).items():
                summary.component_s[k] = summary.component_s.get(k, 0.0) + float(sum(v)) / 1e3
                per[0] += float(sum(v)) / 1e3
            summary.steps += int(record.steps)
            per[1] += int(record.steps)
            key = _store_trajectory(ctx, job, record)
            ctx.used.append(("episode", key))
            if _triple(job) in restoring:
                summary.restored += 1
                differs = _score_differs(stored_rows[_triple(job)], score)
                if differs:
                    c = job.cell
                    ctx.log(f"warning: episode {c.level}/{c.estimator}/{c.noise} task {job.task_id} "
                            f"seed {job.seed} simulated again does not reproduce its stored score "
                            f"({', '.join(differs)}); the stored row is kept")
                continue
            batch.append(_row(job, record, score, key, goals))
        new = ctx.db.add_episodes(run_id, batch) if batch else 0
        summary.stored += new
        summary.already_done += len(batch) - new
        summary.stored_elsewhere += len(batch) - new
        simulated_twice += len(batch) - new
        summary.ran += len(triples)
        summary.store_s += time.perf_counter() - t_store
        if on_progress:
            on_progress(len(triples))
    if summary.stored_elsewhere:
        ctx.log(f"run-navigation: {summary.stored_elsewhere} episode(s) were stored by another run "
                f"while this one ran ({simulated_twice} of them simulated here too; the first "
                "stored row stays)")
    if summary.restored:
        ctx.log(f"run-navigation: restored {summary.restored} trajectory artifact(s) of stored episodes")
    return summary
