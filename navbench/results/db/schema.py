"""The results database's tables (SQLAlchemy 2 declarative models) and their constants.

The layout is described in :mod:`navbench.results.db`; this module only declares it, plus the
columns each ``add_*`` of :class:`~navbench.results.db.store.ResultsDB` accepts from its caller.
"""

from __future__ import annotations

import os
from datetime import datetime

from sqlalchemy import (
    JSON,
    Boolean,
    DateTime,
    Float,
    ForeignKey,
    Integer,
    String,
    Text,
    UniqueConstraint,
    inspect,
)
from sqlalchemy.engine import Connection
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

from navbench.nav.timing import TIMING_COLUMNS

DEFAULT_DB_URL = "sqlite:///results/navbench.db"
#: Version of the table layout; a database written with another version is refused.
SCHEMA_VERSION = 1
DB_ENV = "NAVBENCH_DB"
RUN_STATUSES = ("running", "done", "failed", "interrupted")


def resolve_db_url(url: str | None = None) -> str:
    """``url``, else ``$NAVBENCH_DB``, else ``sqlite:///results/navbench.db``."""
    return url or os.environ.get(DB_ENV) or DEFAULT_DB_URL


class Base(DeclarativeBase):
    pass


class MetaRow(Base):
    """Key/value facts about the database itself (``schema_version``)."""

    __tablename__ = "navbench_meta"
    key: Mapped[str] = mapped_column(String(64), primary_key=True)
    value: Mapped[str] = mapped_column(String(256))


class Run(Base):
    __tablename__ = "runs"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    profile: Mapped[str] = mapped_column(String(512))  # a name or a path to a profile file
    command: Mapped[str] = mapped_column(Text)
    config: Mapped[dict] = mapped_column(JSON)
    config_hash: Mapped[str] = mapped_column(String(128))
    navbench_version: Mapped[str] = mapped_column(String(32))
    git_commit: Mapped[str | None] = mapped_column(String(64), nullable=True)
    host: Mapped[str] = mapped_column(String(256))
    cpu: Mapped[str] = mapped_column(String(512))
    started: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    finished: Mapped[datetime | None] = mapped_column(DateTime(timezone=True), nullable=True)
    status: Mapped[str] = mapped_column(String(16))
    # added within schema version 1 (nullable, see _ADDED_COLUMNS): the process running it
    pid: Mapped[int | None] = mapped_column(Integer, nullable=True)
    proc_start: Mapped[str | None] = mapped_column(String(128), nullable=True)
    # added within schema version 1: the benchmark version the run produced results under
    # (navbench.benchmark; NULL in runs stored before: navbench-1)
    benchmark_version: Mapped[str | None] = mapped_column(String(32), nullable=True)


#: Nullable columns added to a version-1 layout after it shipped: (table, column).
_ADDED_COLUMNS = (("runs", "pid"), ("runs", "proc_start"),
                  # issue 16: the cell without task set and estimator (a larger --tasks extends it)
                  ("episodes", "condition_key"),
                  # issue 15: the scoring presets' final distances, image goals' localisation
                  ("episodes", "final_dist_m"), ("episodes", "final_geo_m"), ("episodes", "goal"),
                  ("episodes", "goal_status"), ("episodes", "goal_err_m"),
                  ("episodes", "goal_confidence"), ("episodes", "goal_heading"),
                  # issue 14: raw odometry and the kidnapped-robot test of a tracking row
                  ("tracking", "raw_odom_ate_m"), ("tracking", "kidnaps"),
                  ("tracking", "kidnaps_detected"), ("tracking", "kidnaps_recovered"),
                  ("tracking", "alarms"), ("tracking", "false_alarms"),
                  # benchmark versions (navbench.benchmark): NULL is navbench-1
                  ("runs", "benchmark_version"), ("episodes", "benchmark_version"),
                  ("tracking", "benchmark_version"))
#: PostgreSQL advisory lock key held while creating tables ("navbench" in ASCII).
_PG_SCHEMA_LOCK = 0x6E617662656E6368


class LevelRow(Base):
    __tablename__ = "levels"
    __table_args__ = (UniqueConstraint("name", "content_hash", name="uq_levels_name_hash"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    name: Mapped[str] = mapped_column(String(128))
    content_hash: Mapped[str] = mapped_column(String(64))
    meta: Mapped[dict] = mapped_column(JSON)
    recorded: Mapped[datetime] = mapped_column(DateTime(timezone=True))


class MapRow(Base):
    __tablename__ = "maps"
    __table_args__ = (UniqueConstraint("map_key", name="uq_maps_key"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    level: Mapped[str] = mapped_column(String(128))
    map_key: Mapped[str] = mapped_column(String(128))
    depth_mae_m: Mapped[float | None] = mapped_column(Float, nullable=True)
    rgb_l1: Mapped[float | None] = mapped_column(Float, nullable=True)
    slice_precision: Mapped[float | None] = mapped_column(Float, nullable=True)
    slice_recall: Mapped[float | None] = mapped_column(Float, nullable=True)
    fit_seconds: Mapped[float | None] = mapped_column(Float, nullable=True)
    steps: Mapped[int | None] = mapped_column(Integer, nullable=True)
    metrics: Mapped[dict] = mapped_column(JSON)  # everything given, including the above
    recorded: Mapped[datetime] = mapped_column(DateTime(timezone=True))


class TaskSetRow(Base):
    __tablename__ = "task_sets"
    __table_args__ = (UniqueConstraint("task_set_key", name="uq_task_sets_key"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    level: Mapped[str] = mapped_column(String(128))
    task_set_key: Mapped[str] = mapped_column(String(128))
    count: Mapped[int] = mapped_column(Integer)
    recorded: Mapped[datetime] = mapped_column(DateTime(timezone=True))


class TaskRow(Base):
    __tablename__ = "tasks"
    __table_args__ = (UniqueConstraint("task_set_key", "task_id", name="uq_tasks_key_id"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    task_set_key: Mapped[str] = mapped_column(String(128))
    level: Mapped[str] = mapped_column(String(128))
    task_id: Mapped[int] = mapped_column(Integer)
    start_x: Mapped[float] = mapped_column(Float)  # metres, world frame
    start_y: Mapped[float] = mapped_column(Float)
    start_theta: Mapped[float] = mapped_column(Float)  # rad
    target_x: Mapped[float] = mapped_column(Float)
    target_y: Mapped[float] = mapped_column(Float)
    optimal_length: Mapped[float] = mapped_column(Float)  # metres


class EpisodeRow(Base):
    __tablename__ = "episodes"
    __table_args__ = (UniqueConstraint("cell_key", "task_id", "seed", name="uq_episodes_cell_task_seed"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id"), index=True)
    cell_key: Mapped[str] = mapped_column(String(128), index=True)
    level: Mapped[str] = mapped_column(String(128))
    map_key: Mapped[str | None] = mapped_column(String(128), nullable=True)
    task_set_key: Mapped[str | None] = mapped_column(String(128), nullable=True)
    task_id: Mapped[int] = mapped_column(Integer)
    estimator: Mapped[str] = mapped_column(String(64))
    estimator_options: Mapped[dict] = mapped_column(JSON)
    noise: Mapped[str] = mapped_column(String(32))
    seed: Mapped[int] = mapped_column(Integer)
    success: Mapped[bool] = mapped_column(Boolean)
    spl_term: Mapped[float] = mapped_column(Float)
    path_length: Mapped[float] = mapped_column(Float)  # metres
    optimal_length: Mapped[float] = mapped_column(Float)  # metres
    steps: Mapped[int] = mapped_column(Integer)
    end_reason: Mapped[str | None] = mapped_column(String(32), nullable=True)
    collided: Mapped[bool | None] = mapped_column(Boolean, nullable=True)
    loc_rmse_m: Mapped[float | None] = mapped_column(Float, nullable=True)
    rot_rmse_deg: Mapped[float | None] = mapped_column(Float, nullable=True)
    sim_ms: Mapped[float | None] = mapped_column(Float, nullable=True)  # per-step medians
    render_ms: Mapped[float | None] = mapped_column(Float, nullable=True)
    estimate_ms: Mapped[float | None] = mapped_column(Float, nullable=True)
    plan_ms: Mapped[float | None] = mapped_column(Float, nullable=True)
    control_ms: Mapped[float | None] = mapped_column(Float, nullable=True)
    step_ms: Mapped[float | None] = mapped_column(Float, nullable=True)  # median of per-step sums
    traj_key: Mapped[str | None] = mapped_column(String(128), nullable=True)
    recorded: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    # added within schema version 1 (issue 16): the cell's key without the task set and the
    # estimator (level, map, noise, episode config); NULL in rows stored before it. Scoring
    # counts a (task, seed) once per (condition, estimator) whatever task set it came from,
    # and pairs estimators on the same (condition, task, seed).
    condition_key: Mapped[str | None] = mapped_column(String(128), nullable=True)
    # added within schema version 1 (issue 15; NULL in rows stored before): the final true
    # position's Euclidean and geodesic distance to the target (m, navbench.nav.presets); the
    # goal kind (NULL: a point goal) and, for image goals, the goal localisation: ok /
    # ambiguous / failed, its error (m, localised vs true target) and confidence
    final_dist_m: Mapped[float | None] = mapped_column(Float, nullable=True)
    final_geo_m: Mapped[float | None] = mapped_column(Float, nullable=True)
    goal: Mapped[str | None] = mapped_column(String(16), nullable=True)
    goal_status: Mapped[str | None] = mapped_column(String(16), nullable=True)
    goal_err_m: Mapped[float | None] = mapped_column(Float, nullable=True)
    goal_confidence: Mapped[float | None] = mapped_column(Float, nullable=True)
    goal_heading: Mapped[float | None] = mapped_column(Float, nullable=True)  # rad, of the goal image
    # added within schema version 1: the benchmark version of the episode (its run's;
    # navbench.benchmark). NULL in rows stored before: navbench-1. Never pooled across versions.
    benchmark_version: Mapped[str | None] = mapped_column(String(32), nullable=True)


class TrackingRow(Base):
    __tablename__ = "tracking"
    __table_args__ = (
        UniqueConstraint("study_key", "estimator", "trajectory_id", "seed", name="uq_tracking_key"),
    )
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id"), index=True)
    study_key: Mapped[str] = mapped_column(String(128))
    level: Mapped[str] = mapped_column(String(128))
    map_key: Mapped[str | None] = mapped_column(String(128), nullable=True)
    estimator: Mapped[str] = mapped_column(String(64))
    estimator_options: Mapped[dict] = mapped_column(JSON)
    noise: Mapped[str | None] = mapped_column(String(32), nullable=True)
    trajectory_id: Mapped[int] = mapped_column(Integer)
    seed: Mapped[int] = mapped_column(Integer)
    steps: Mapped[int | None] = mapped_column(Integer, nullable=True)
    loc_rmse_m: Mapped[float | None] = mapped_column(Float, nullable=True)
    rot_rmse_deg: Mapped[float | None] = mapped_column(Float, nullable=True)
    step_ms_median: Mapped[float | None] = mapped_column(Float, nullable=True)
    render_ms: Mapped[float | None] = mapped_column(Float, nullable=True)  # per-step medians
    estimate_ms: Mapped[float | None] = mapped_column(Float, nullable=True)
    traj_key: Mapped[str | None] = mapped_column(String(128), nullable=True)
    recorded: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    # added within schema version 1 (issue 14; nullable, see _ADDED_COLUMNS). loc_rmse_m is
    # the ATE (translation RMSE without alignment); raw_odom_ate_m that of the trajectory's raw
    # odometry; kidnap counts (recovered: within 5 steps) and health alarms where they apply
    raw_odom_ate_m: Mapped[float | None] = mapped_column(Float, nullable=True)
    kidnaps: Mapped[int | None] = mapped_column(Integer, nullable=True)
    kidnaps_detected: Mapped[int | None] = mapped_column(Integer, nullable=True)
    kidnaps_recovered: Mapped[int | None] = mapped_column(Integer, nullable=True)
    alarms: Mapped[int | None] = mapped_column(Integer, nullable=True)
    false_alarms: Mapped[int | None] = mapped_column(Integer, nullable=True)
    # added within schema version 1: the run's benchmark version (navbench.benchmark), copied
    # as the episodes' (NULL in rows stored before: navbench-1)
    benchmark_version: Mapped[str | None] = mapped_column(String(32), nullable=True)


class BenchRow(Base):
    __tablename__ = "bench"
    __table_args__ = (UniqueConstraint("run_id", "metric", "device", name="uq_bench_run_metric_device"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id"), index=True)
    host: Mapped[str] = mapped_column(String(256))
    cpu: Mapped[str] = mapped_column(String(256))
    navbench_version: Mapped[str] = mapped_column(String(32))
    metric: Mapped[str] = mapped_column(String(128))
    value: Mapped[float] = mapped_column(Float)
    unit: Mapped[str] = mapped_column(String(32))
    device: Mapped[str] = mapped_column(String(64))  # "cpu", "cuda:0"...
    recorded: Mapped[datetime] = mapped_column(DateTime(timezone=True))


# Caller-supplied columns of each add_* (everything else is filled in here).
_EPISODE_FIELDS = (
    "cell_key", "level", "map_key", "task_set_key", "task_id", "estimator", "estimator_options",
    "noise", "seed", "success", "spl_term", "path_length", "optimal_length", "steps", "end_reason",
    "collided", "loc_rmse_m", "rot_rmse_deg", *TIMING_COLUMNS, "step_ms", "traj_key",
    "condition_key", "final_dist_m", "final_geo_m", "goal", "goal_status", "goal_err_m",
    "goal_confidence", "goal_heading",
)
_EPISODE_REQUIRED = (
    "cell_key", "level", "task_id", "estimator", "noise", "seed", "success", "spl_term",
    "path_length", "optimal_length", "steps",
)
_TRACKING_FIELDS = (
    "study_key", "level", "map_key", "estimator", "estimator_options", "noise", "trajectory_id",
    "seed", "steps", "loc_rmse_m", "rot_rmse_deg", "step_ms_median", "render_ms", "estimate_ms",
    "traj_key", "raw_odom_ate_m", "kidnaps", "kidnaps_detected", "kidnaps_recovered", "alarms",
    "false_alarms",
)
_TRACKING_REQUIRED = ("study_key", "level", "estimator", "trajectory_id", "seed")
_BENCH_FIELDS = ("metric", "value", "unit", "device", "host", "cpu", "navbench_version")
_BENCH_REQUIRED = ("metric", "value", "unit")
_MAP_METRICS = ("depth_mae_m", "rgb_l1", "slice_precision", "slice_recall", "fit_seconds", "steps")


def _add_missing_columns(conn: Connection) -> None:
    """``ALTER TABLE ... ADD COLUMN`` for each of ``_ADDED_COLUMNS`` the database lacks."""
    insp = inspect(conn)
    for table, name in _ADDED_COLUMNS:
        if name in {c["name"] for c in insp.get_columns(table)}:
            continue
        col = Base.metadata.tables[table].c[name]
        conn.exec_driver_sql(f"ALTER TABLE {table} ADD COLUMN {name} {col.type.compile(conn.dialect)}")


# -- issue 13: tracking a TUM sequence (navbench track-sequence) --------------------------------

class SequenceTrackingRow(Base):
    """One tracked RGB-D sequence: ``track-sequence``'s estimate against its ground truth.

    ``sequence_key`` hashes the sequence (frames and poses), the map key, the odometry and the
    estimator with its options and seed (:func:`navbench.pipeline.stages.sequence.sequence_key`);
    a rerun of the same tracking adds nothing (the first measurement stays)."""

    __tablename__ = "sequence_tracking"
    __table_args__ = (UniqueConstraint("sequence_key", name="uq_sequence_tracking_key"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id"), index=True)
    sequence_key: Mapped[str] = mapped_column(String(128))
    sequence: Mapped[str] = mapped_column(Text)  # the directory as given
    sequence_hash: Mapped[str] = mapped_column(String(64))
    map_key: Mapped[str | None] = mapped_column(String(128), nullable=True)
    estimator: Mapped[str] = mapped_column(String(64))
    estimator_options: Mapped[dict] = mapped_column(JSON)
    odometry: Mapped[str] = mapped_column(Text)  # "gt+mid" or the odometry file as given
    odometry_hash: Mapped[str | None] = mapped_column(String(64), nullable=True)
    seed: Mapped[int] = mapped_column(Integer)
    frames: Mapped[int] = mapped_column(Integer)
    ate_m: Mapped[float | None] = mapped_column(Float, nullable=True)  # location RMSE, no alignment
    rot_rmse_deg: Mapped[float | None] = mapped_column(Float, nullable=True)
    rpe_m: Mapped[float | None] = mapped_column(Float, nullable=True)  # per frame (delta 1)
    rpe_deg: Mapped[float | None] = mapped_column(Float, nullable=True)
    odometry_ate_m: Mapped[float | None] = mapped_column(Float, nullable=True)  # dead reckoning
    ms_per_frame: Mapped[float | None] = mapped_column(Float, nullable=True)  # median, ms
    render_ms: Mapped[float | None] = mapped_column(Float, nullable=True)  # per-frame medians
    estimate_ms: Mapped[float | None] = mapped_column(Float, nullable=True)
    recorded: Mapped[datetime] = mapped_column(DateTime(timezone=True))


_SEQUENCE_FIELDS = (
    "sequence_key", "sequence", "sequence_hash", "map_key", "estimator", "estimator_options",
    "odometry", "odometry_hash", "seed", "frames", "ate_m", "rot_rmse_deg", "rpe_m", "rpe_deg",
    "odometry_ate_m", "ms_per_frame", "render_ms", "estimate_ms",
)
_SEQUENCE_REQUIRED = ("sequence_key", "sequence", "sequence_hash", "estimator", "odometry", "seed",
                      "frames")


class RunTimingRow(Base):
    """Where a run's time went (:mod:`navbench.results.breakdown`): one row per stage (``kind``
    ``stage``: wall-clock seconds, calls, cache hits) and per episode timing component (``kind``
    ``component``: worker seconds summed over steps, ``count`` the steps or episodes)."""

    __tablename__ = "run_timings"
    __table_args__ = (UniqueConstraint("run_id", "kind", "name", name="uq_run_timings_run_kind_name"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id"), index=True)
    kind: Mapped[str] = mapped_column(String(16))   # "stage" | "component"
    name: Mapped[str] = mapped_column(String(64))
    seconds: Mapped[float] = mapped_column(Float)
    count: Mapped[int] = mapped_column(Integer)
    cached: Mapped[int] = mapped_column(Integer)


_RUN_TIMING_FIELDS = ("kind", "name", "seconds", "count", "cached")


# -- issue 14: localisation queries (navbench localize-eval) ------------------------------------

class LocalizeRow(Base):
    """One localisation query of a localize-eval study (issue 14): true and found pose, errors,
    confidence, query time; ``changes`` is the object-change difficulty (None: unchanged)."""

    __tablename__ = "localize"
    __table_args__ = (UniqueConstraint("study_key", "query_id", name="uq_localize_key"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id"), index=True)
    study_key: Mapped[str] = mapped_column(String(128))
    level: Mapped[str] = mapped_column(String(128))
    map_key: Mapped[str | None] = mapped_column(String(128), nullable=True)
    changes: Mapped[str | None] = mapped_column(String(16), nullable=True)
    query_id: Mapped[int] = mapped_column(Integer)
    true_x: Mapped[float] = mapped_column(Float)
    true_y: Mapped[float] = mapped_column(Float)
    true_theta: Mapped[float] = mapped_column(Float)
    est_x: Mapped[float] = mapped_column(Float)
    est_y: Mapped[float] = mapped_column(Float)
    est_theta: Mapped[float] = mapped_column(Float)
    loc_err_m: Mapped[float] = mapped_column(Float)
    heading_err_deg: Mapped[float] = mapped_column(Float)
    confidence: Mapped[float | None] = mapped_column(Float, nullable=True)
    query_ms: Mapped[float | None] = mapped_column(Float, nullable=True)  # wall clock
    query_cpu_ms: Mapped[float | None] = mapped_column(Float, nullable=True)  # process CPU time
    image_diff: Mapped[float | None] = mapped_column(Float, nullable=True)
    recorded: Mapped[datetime] = mapped_column(DateTime(timezone=True))


_LOCALIZE_FIELDS = (
    "study_key", "level", "map_key", "changes", "query_id", "true_x", "true_y", "true_theta",
    "est_x", "est_y", "est_theta", "loc_err_m", "heading_err_deg", "confidence", "query_ms",
    "query_cpu_ms", "image_diff",
)
_LOCALIZE_REQUIRED = ("study_key", "level", "query_id", "loc_err_m", "heading_err_deg")
