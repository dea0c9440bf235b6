"""The results database: runs, levels, maps, task sets, episodes, tracking and bench rows.

One small storage interface (:class:`ResultsDB`) for every stage and command: they never build
SQL themselves. Any SQLAlchemy URL works; the default is ``sqlite:///results/navbench.db``
relative to the current working directory (``results/`` is created), overridden by the
``NAVBENCH_DB`` environment variable or an explicit URL (the CLI's ``--db``). SQLite and
PostgreSQL (``postgresql+psycopg://user@host/db``, extra ``navbench[postgres]``) are tested.

Tables (SQLAlchemy 2 declarative models below):

* ``runs`` -- one row per pipeline invocation: profile, command, resolved config (JSON) and its
  hash, navbench version, git commit (null outside a git checkout), host, CPU, start/finish
  times (UTC) and status (``running`` -> ``done`` / ``failed`` / ``interrupted``), and the
  process that runs it (``pid`` and ``proc_start``, see :func:`process_start_token`). A run
  whose process died without closing it (``kill -9``, power loss) becomes ``interrupted`` the
  next time any command opens the database on its host (:meth:`ResultsDB.mark_dead_runs`);
  its ``finished`` stays empty: when it died is unknown.
* ``levels`` -- level name, content hash, meta; unique on (name, content_hash).
* ``maps`` -- a fitted world model (unique map key) with its quality metrics.
* ``task_sets`` / ``tasks`` -- the navigation tasks of a level (unique task set key; a task is
  unique on (task_set_key, task_id)).
* ``episodes`` -- one navigation episode's score, unique on (cell_key, task_id, seed), with the
  medians of the per-step component timings and a pointer (cache key) to its trajectory.
* ``tracking`` -- one tracked trajectory of the tracking study (Fig. 4), unique on
  (study_key, estimator, trajectory_id, seed).
* ``bench`` -- one measured benchmark metric, unique on (run_id, metric, device).

Duplicate rows are impossible: every ``add_*``/``record_*`` inserts with the dialect's
``ON CONFLICT DO NOTHING`` (SQLite, PostgreSQL; other dialects select the existing keys first,
in the same transaction) and reports how many rows were new. The first stored value of a key
therefore stays; a rerun skips the keys :meth:`ResultsDB.done_episode_keys` reports.

Schema changes: ``SCHEMA_VERSION`` counts incompatible layouts (a database of another version
is refused). Compatible additions are nullable columns that opening a database adds when
missing (``_ADDED_COLUMNS``; older navbench versions ignore them). Tables and columns are
created under a lock (SQLite ``BEGIN IMMEDIATE``, a PostgreSQL advisory lock), so commands
that open a fresh database at the same moment do not trip over each other.
"""

from __future__ import annotations

import math
import os
import platform
import socket
import subprocess
import time
from datetime import datetime, timezone
from pathlib import Path
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, Iterable, Iterator

import numpy as np
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
    create_engine,
    event,
    inspect,
    select,
    tuple_,
    update,
)
from sqlalchemy.engine import Connection, Engine, make_url
from sqlalchemy.exc import ArgumentError, NoSuchModuleError, SQLAlchemyError
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

from navbench.errors import DatabaseError
from navbench.pipeline.executor import pid_alive, process_start_token

if TYPE_CHECKING:  # pragma: no cover
    import pandas

DEFAULT_DB_URL = "sqlite:///results/navbench.db"
#: Version of the table layout; a database written with another version is refused.
SCHEMA_VERSION = 1
DB_ENV = "NAVBENCH_DB"
TIMING_COMPONENTS = ("sim", "render", "estimate", "plan", "control")
RUN_STATUSES = ("running", "done", "failed", "interrupted")


def _utcnow() -> datetime:
    return datetime.now(timezone.utc)


# --------------------------------------------------------------------------------------------
# Models
# --------------------------------------------------------------------------------------------


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


#: Nullable columns added to a version-1 layout after it shipped: (table, column).
_ADDED_COLUMNS = (("runs", "pid"), ("runs", "proc_start"))
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
    "collided", "loc_rmse_m", "rot_rmse_deg", "sim_ms", "render_ms", "estimate_ms", "plan_ms",
    "control_ms", "step_ms", "traj_key",
)
_EPISODE_REQUIRED = (
    "cell_key", "level", "task_id", "estimator", "noise", "seed", "success", "spl_term",
    "path_length", "optimal_length", "steps",
)
_TRACKING_FIELDS = (
    "study_key", "level", "map_key", "estimator", "estimator_options", "noise", "trajectory_id",
    "seed", "steps", "loc_rmse_m", "rot_rmse_deg", "step_ms_median", "render_ms", "estimate_ms",
    "traj_key",
)
_TRACKING_REQUIRED = ("study_key", "level", "estimator", "trajectory_id", "seed")
_BENCH_FIELDS = ("metric", "value", "unit", "device", "host", "cpu", "navbench_version")
_BENCH_REQUIRED = ("metric", "value", "unit")
_MAP_METRICS = ("depth_mae_m", "rgb_l1", "slice_precision", "slice_recall", "fit_seconds", "steps")


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------


def _clean(value: Any) -> Any:
    """numpy scalars -> Python; NaN/inf floats -> None (stored as NULL everywhere)."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _clean_json(obj: Any) -> Any:
    from navbench.config import to_jsonable

    return to_jsonable(obj if obj is not None else {})


def _one_line(exc: BaseException) -> str:
    orig = getattr(exc, "orig", None) or exc
    text = str(orig).strip().splitlines()
    return text[0] if text else type(orig).__name__


def git_commit(cwd: str | Path | None = None) -> str | None:
    """HEAD commit of the git checkout holding ``cwd`` (default: the current directory), else None."""
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=cwd, capture_output=True, text=True, timeout=5,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    sha = out.stdout.strip()
    return sha if out.returncode == 0 and len(sha) == 40 else None


def cpu_description() -> str:
    """CPU model name (from /proc/cpuinfo on Linux) and logical core count."""
    name = ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    name = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    name = name or platform.processor() or platform.machine() or "unknown"
    return f"{name} ({os.cpu_count() or '?'} threads)"


def resolve_db_url(url: str | None = None) -> str:
    """``url``, else ``$NAVBENCH_DB``, else ``sqlite:///results/navbench.db``."""
    return url or os.environ.get(DB_ENV) or DEFAULT_DB_URL


def _median(values: Any) -> float | None:
    arr = np.asarray(values, dtype=float).ravel()
    arr = arr[np.isfinite(arr)]
    return float(np.median(arr)) if arr.size else None


def episode_row_from_score(cell_key: str, meta: dict, score: Any, traj_key: str | None) -> dict:
    """One ``episodes`` row (for :meth:`ResultsDB.add_episodes`) from an episode's score.

    ``meta``: ``level, map_key, task_set_key, estimator, estimator_options (dict), noise, seed,
    task_id, timings_ms`` (component name -> (T,) per-step milliseconds) and optionally
    ``end_reason`` and ``collided`` (taken from ``score`` when it has them). ``score`` is an
    ``EpisodeScore`` (success, path_length, optimal_length, spl_term, loc_rmse_m, rot_rmse_deg,
    steps). Timings are stored as per-component medians; ``step_ms`` is the median over steps of
    the per-step sum of all components (or the sum of the medians when their lengths differ).
    """
    timings = meta.get("timings_ms") or {}
    row: dict[str, Any] = {
        "cell_key": cell_key,
        "level": meta["level"],
        "map_key": meta.get("map_key"),
        "task_set_key": meta.get("task_set_key"),
        "task_id": int(meta["task_id"]),
        "estimator": meta["estimator"],
        "estimator_options": dict(meta.get("estimator_options") or {}),
        "noise": meta["noise"],
        "seed": int(meta["seed"]),
        "success": bool(score.success),
        "spl_term": float(score.spl_term),
        "path_length": float(score.path_length),
        "optimal_length": float(score.optimal_length),
        "steps": int(score.steps),
        "end_reason": getattr(score, "end_reason", None) or meta.get("end_reason"),
        "collided": getattr(score, "collided", meta.get("collided")),
        "loc_rmse_m": score.loc_rmse_m,
        "rot_rmse_deg": score.rot_rmse_deg,
        "traj_key": traj_key,
    }
    if row["collided"] is not None:
        row["collided"] = bool(row["collided"])
    for name in TIMING_COMPONENTS:
        row[f"{name}_ms"] = _median(timings[name]) if name in timings else None
    arrays = [np.asarray(v, dtype=float).ravel() for v in timings.values()]
    if arrays and all(a.size == arrays[0].size for a in arrays) and arrays[0].size:
        row["step_ms"] = _median(np.sum(arrays, axis=0))
    elif arrays:
        meds = [_median(a) for a in arrays]
        row["step_ms"] = float(sum(m for m in meds if m is not None))
    else:
        row["step_ms"] = None
    return row


def _task_fields(task: Any) -> tuple[int, tuple, tuple, float]:
    if isinstance(task, dict):
        return int(task["id"]), tuple(task["start"]), tuple(task["target"]), float(task["optimal_length"])
    return int(task.id), tuple(task.start), tuple(task.target), float(task.optimal_length)


# --------------------------------------------------------------------------------------------
# The database
# --------------------------------------------------------------------------------------------


class ResultsDB:
    """The results database at ``url`` (None: ``$NAVBENCH_DB`` or ``sqlite:///results/navbench.db``).

    Tables are created on first use (``create=False``: a missing SQLite file is an error
    instead, for read-only commands). Raises :class:`DatabaseError` (one line) when the URL is
    invalid or the server cannot be reached.
    """

    def __init__(self, url: str | None = None, create: bool = True):
        # create=False (read-only commands): a missing SQLite file is an error, not a new database.
        self.url = resolve_db_url(url)
        try:
            parsed = make_url(self.url)
        except (ArgumentError, ValueError) as e:
            raise DatabaseError(f"invalid database URL {self.url!r}: {_one_line(e)}") from None
        self.display_url = parsed.render_as_string(hide_password=True)
        kwargs: dict[str, Any] = {}
        if parsed.get_backend_name() == "sqlite":
            database = parsed.database
            if database and database != ":memory:" and not database.startswith("file:"):
                if not create and not Path(database).expanduser().is_file():
                    raise DatabaseError(f"no results database at {database}; "
                                        "run `navbench all` (or pass --db / set NAVBENCH_DB)")
                try:
                    Path(database).expanduser().parent.mkdir(parents=True, exist_ok=True)
                except OSError as e:
                    raise DatabaseError(f"cannot create the folder of {self.display_url}: {e}") from None
            kwargs["connect_args"] = {"timeout": 60}
        try:
            self.engine: Engine = create_engine(parsed, future=True, **kwargs)
        except (ArgumentError, NoSuchModuleError, ImportError, ValueError) as e:
            raise DatabaseError(f"cannot use database URL {self.display_url}: {_one_line(e)}") from None
        if self.engine.dialect.name == "sqlite":
            event.listen(self.engine, "connect", _sqlite_pragmas)
        try:
            if not self._schema_complete():
                self._create_schema()
        except SQLAlchemyError as e:
            self.engine.dispose()
            raise DatabaseError(f"cannot open results database {self.display_url}: {_one_line(e)}") from None
        self._check_schema_version()
        self.mark_dead_runs()

    def _schema_complete(self) -> bool:
        """Whether every table and added column exists (read only: no lock, no write)."""
        insp = inspect(self.engine)
        tables = set(insp.get_table_names())
        if not set(Base.metadata.tables) <= tables:
            return False
        columns = {t: {c["name"] for c in insp.get_columns(t)} for t in {t for t, _ in _ADDED_COLUMNS}}
        return all(c in columns[t] for t, c in _ADDED_COLUMNS)

    def _create_schema(self, attempts: int = 5) -> None:
        """Create the missing tables and added columns in one transaction holding the write lock.

        Checking for a table and creating it are two statements; without the lock two commands
        opening a fresh database together could both see it missing, and the second failed with
        "table ... already exists". A dialect without a lock here retries on that error.
        """
        for attempt in range(attempts):
            try:
                with self.engine.connect() as conn:
                    if conn.dialect.name == "sqlite":
                        conn.exec_driver_sql("BEGIN IMMEDIATE")  # the write lock, before checking
                    elif conn.dialect.name == "postgresql":
                        conn.exec_driver_sql(f"SELECT pg_advisory_xact_lock({_PG_SCHEMA_LOCK})")
                    Base.metadata.create_all(conn, checkfirst=True)
                    _add_missing_columns(conn)
                    conn.commit()
                return
            except SQLAlchemyError as e:
                text = _one_line(e).lower()
                if attempt + 1 == attempts or not ("already exists" in text or "duplicate" in text):
                    raise
                time.sleep(0.05 * (attempt + 1))

    def _check_schema_version(self) -> None:
        with self._begin() as conn:
            found = conn.execute(select(MetaRow.value).where(MetaRow.key == "schema_version")).scalar()
            if found is None:
                self._insert_ignore(conn, MetaRow, [{"key": "schema_version",
                                                     "value": str(SCHEMA_VERSION)}], ("key",))
                found = conn.execute(select(MetaRow.value).where(MetaRow.key == "schema_version")).scalar()
        if found != str(SCHEMA_VERSION):
            self.engine.dispose()
            raise DatabaseError(f"results database {self.display_url} has schema version {found}; "
                                f"this navbench reads version {SCHEMA_VERSION}")

    def __repr__(self) -> str:
        return f"ResultsDB({self.display_url!r})"

    def close(self) -> None:
        """Release the connection pool."""
        self.engine.dispose()

    def __enter__(self) -> "ResultsDB":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- low level ------------------------------------------------------------------------

    @contextmanager
    def _begin(self) -> Iterator[Connection]:
        """One transaction; SQLAlchemy errors inside it become a one-line DatabaseError."""
        try:
            with self.engine.begin() as conn:
                yield conn
        except SQLAlchemyError as e:
            raise DatabaseError(f"results database {self.display_url}: {_one_line(e)}") from None

    def _insert_ignore(self, conn, model, rows: list[dict], keys: tuple[str, ...],
                       dialect: str | None = None) -> int:
        """Insert ``rows`` (dicts with identical keys), skipping any whose ``keys`` exist.

        ``dialect`` overrides the connection's (tests use ``"generic"`` for the fallback path).
        """
        if not rows:
            return 0
        table = model.__table__
        dialect = dialect or conn.dialect.name
        ncols = len(rows[0])
        chunk = max(1, 900 // max(ncols, 1))  # stay under SQLite's oldest variable limit
        inserted = 0
        if dialect in ("sqlite", "postgresql"):
            if dialect == "sqlite":
                from sqlalchemy.dialects.sqlite import insert as dialect_insert
            else:
                from sqlalchemy.dialects.postgresql import insert as dialect_insert
            for i in range(0, len(rows), chunk):
                stmt = dialect_insert(table).values(rows[i:i + chunk]).on_conflict_do_nothing(
                    index_elements=list(keys))
                if dialect == "postgresql":  # psycopg reports no rowcount here: count RETURNING
                    inserted += len(conn.execute(stmt.returning(*table.primary_key.columns)).all())
                else:
                    inserted += conn.execute(stmt).rowcount
            return inserted
        # Generic fallback: select existing keys in this transaction, insert the rest.
        cols = [table.c[k] for k in keys]
        seen: set = set()
        fresh = []
        for row in rows:
            key = tuple(row[k] for k in keys)
            if key in seen:
                continue
            seen.add(key)
            fresh.append(row)
        existing: set = set()
        for i in range(0, len(fresh), chunk):
            wanted = [tuple(r[k] for k in keys) for r in fresh[i:i + chunk]]
            existing.update(tuple(r) for r in conn.execute(select(*cols).where(tuple_(*cols).in_(wanted))))
        fresh = [r for r in fresh if tuple(r[k] for k in keys) not in existing]
        if fresh:
            conn.execute(table.insert(), fresh)
        return len(fresh)

    @staticmethod
    def _normalise(rows: Iterable[dict], fields: tuple[str, ...], required: tuple[str, ...],
                   what: str, json_fields: tuple[str, ...] = ()) -> list[dict]:
        out = []
        for i, row in enumerate(rows):
            unknown = set(row) - set(fields)
            if unknown:
                raise DatabaseError(f"{what} row {i}: unknown column(s) {sorted(unknown)}; "
                                    f"allowed: {list(fields)}")
            missing = [k for k in required if row.get(k) is None]
            if missing:
                raise DatabaseError(f"{what} row {i}: missing value(s) for {missing}")
            clean = {}
            for k in fields:
                v = row.get(k)
                clean[k] = _clean_json(v) if k in json_fields else _clean(v)
            out.append(clean)
        return out

    # -- runs -----------------------------------------------------------------------------

    def start_run(self, profile: str, command: str, config: dict, config_hash: str) -> int:
        """Record the start of a run (status ``running``) by this process; returns its id."""
        from navbench import __version__

        pid = os.getpid()
        row = dict(
            profile=profile, command=command, config=_clean_json(config), config_hash=config_hash,
            navbench_version=__version__, git_commit=git_commit(), host=socket.gethostname(),
            cpu=cpu_description(), started=_utcnow(), finished=None, status="running",
            pid=pid, proc_start=process_start_token(pid),
        )
        with self._begin() as conn:
            result = conn.execute(Run.__table__.insert().values(row))
            return int(result.inserted_primary_key[0])

    def finish_run(self, run_id: int, status: str = "done") -> None:
        """Mark run ``run_id`` finished now with ``status`` (done, failed, interrupted)."""
        if status not in RUN_STATUSES:
            raise DatabaseError(f"unknown run status {status!r}; choose one of {list(RUN_STATUSES)}")
        with self._begin() as conn:
            n = conn.execute(update(Run).where(Run.id == run_id).values(
                finished=_utcnow(), status=status)).rowcount
        if n == 0:
            raise DatabaseError(f"no run with id {run_id} in {self.display_url}")

    def mark_dead_runs(self) -> list[int]:
        """Mark ``interrupted`` the runs still ``running`` on this host whose process is gone
        (or whose pid now belongs to a later process); returns their ids.

        Runs of other hosts, of another PID namespace (a container) or boot of this host's
        name, and runs recorded without a pid are left alone: their liveness cannot be judged
        here. Best effort: a database this process cannot write to is left as it is.
        """
        here = process_start_token(os.getpid())
        space = here.rsplit(":", 1)[0] if here else None
        try:
            with self._begin() as conn:
                candidates = conn.execute(select(Run.id, Run.pid, Run.proc_start).where(
                    Run.status == "running", Run.host == socket.gethostname(),
                    Run.pid.is_not(None))).all()
        except DatabaseError:
            return []
        dead = []
        for run_id, pid, token in candidates:
            if token and space and token.rsplit(":", 1)[0] != space:
                continue  # another PID namespace or boot: its pid means nothing here
            if not pid_alive(pid, token):
                dead.append(int(run_id))
        if dead:
            try:
                with self._begin() as conn:
                    conn.execute(update(Run).where(Run.id.in_(dead), Run.status == "running")
                                 .values(status="interrupted"))
            except DatabaseError:
                return []
        return dead

    def latest_run_id(self, command: str | None = None) -> int | None:
        """Id of the most recently started run (optionally of one ``command``), else None."""
        stmt = select(Run.id).order_by(Run.id.desc()).limit(1)
        if command is not None:
            stmt = stmt.where(Run.command == command)
        with self._begin() as conn:
            return conn.execute(stmt).scalar()

    def runs_frame(self) -> "pandas.DataFrame":
        """All runs, oldest first."""
        return self._frame(select(Run.__table__).order_by(Run.id))

    # -- levels, maps, tasks -----------------------------------------------------------------

    def record_level(self, name: str, content_hash: str, meta: dict) -> None:
        """Record a level version (idempotent on (name, content_hash))."""
        with self._begin() as conn:
            self._insert_ignore(conn, LevelRow, [{
                "name": name, "content_hash": content_hash, "meta": _clean_json(meta),
                "recorded": _utcnow()}], ("name", "content_hash"))

    def levels_frame(self) -> "pandas.DataFrame":
        return self._frame(select(LevelRow.__table__).order_by(LevelRow.id))

    def record_map(self, level: str, map_key: str, metrics: dict) -> None:
        """Record a fitted map's quality metrics (idempotent on map_key: the first record stays).

        Known metrics get their own columns (depth_mae_m, rgb_l1, slice_precision, slice_recall,
        fit_seconds, steps); all of ``metrics`` is also kept as JSON.
        """
        metrics = _clean_json(metrics)
        row = {"level": level, "map_key": map_key, "metrics": metrics, "recorded": _utcnow()}
        for k in _MAP_METRICS:
            v = _clean(metrics.get(k))
            row[k] = (int(v) if k == "steps" else float(v)) if isinstance(v, (int, float)) else None
        with self._begin() as conn:
            self._insert_ignore(conn, MapRow, [row], ("map_key",))

    def maps_frame(self) -> "pandas.DataFrame":
        return self._frame(select(MapRow.__table__).order_by(MapRow.level, MapRow.id))

    def record_task_set(self, level: str, task_set_key: str, tasks: list) -> None:
        """Record a level's task set (Task objects or dicts: id, start, target, optimal_length)."""
        rows = []
        for t in tasks:
            tid, start, target, opt = _task_fields(t)
            rows.append({"task_set_key": task_set_key, "level": level, "task_id": tid,
                         "start_x": float(start[0]), "start_y": float(start[1]),
                         "start_theta": float(start[2]) if len(start) > 2 else 0.0,
                         "target_x": float(target[0]), "target_y": float(target[1]),
                         "optimal_length": opt})
        with self._begin() as conn:
            self._insert_ignore(conn, TaskSetRow, [{
                "level": level, "task_set_key": task_set_key, "count": len(rows),
                "recorded": _utcnow()}], ("task_set_key",))
            self._insert_ignore(conn, TaskRow, rows, ("task_set_key", "task_id"))

    def tasks_frame(self, task_set_key: str | None = None, level: str | None = None) -> "pandas.DataFrame":
        stmt = select(TaskRow.__table__).order_by(TaskRow.task_set_key, TaskRow.task_id)
        if task_set_key is not None:
            stmt = stmt.where(TaskRow.task_set_key == task_set_key)
        if level is not None:
            stmt = stmt.where(TaskRow.level == level)
        return self._frame(stmt)

    # -- episodes ---------------------------------------------------------------------------

    def done_episode_keys(self, cell_keys: list[str]) -> set[tuple[str, int, int]]:
        """The stored (cell_key, task_id, seed) triples of the given cells."""
        keys = list(dict.fromkeys(cell_keys))
        out: set[tuple[str, int, int]] = set()
        with self._begin() as conn:
            for i in range(0, len(keys), 500):
                stmt = select(EpisodeRow.cell_key, EpisodeRow.task_id, EpisodeRow.seed).where(
                    EpisodeRow.cell_key.in_(keys[i:i + 500]))
                out.update((c, int(t), int(s)) for c, t, s in conn.execute(stmt))
        return out

    def stored_episode_keys(self, keys: Iterable[tuple[str, int, int]]) -> set[tuple[str, int, int]]:
        """Which of these (cell_key, task_id, seed) triples are stored (a cheap check of a few
        episodes, for example just before running them)."""
        wanted = list(dict.fromkeys((str(c), int(t), int(s)) for c, t, s in keys))
        out: set[tuple[str, int, int]] = set()
        cols = (EpisodeRow.cell_key, EpisodeRow.task_id, EpisodeRow.seed)
        with self._begin() as conn:
            for i in range(0, len(wanted), 300):
                stmt = select(*cols).where(tuple_(*cols).in_(wanted[i:i + 300]))
                out.update((c, int(t), int(s)) for c, t, s in conn.execute(stmt))
        return out

    def episode_outcomes(self, cell_keys: list[str]) -> dict[tuple[str, int, int], dict]:
        """The stored episodes of these cells: (cell_key, task_id, seed) -> ``traj_key``,
        ``success``, ``spl_term``, ``path_length`` and ``steps`` (to check a trajectory against)."""
        keys = list(dict.fromkeys(cell_keys))
        out: dict[tuple[str, int, int], dict] = {}
        e = EpisodeRow
        with self._begin() as conn:
            for i in range(0, len(keys), 500):
                stmt = select(e.cell_key, e.task_id, e.seed, e.traj_key, e.success, e.spl_term,
                              e.path_length, e.steps).where(e.cell_key.in_(keys[i:i + 500]))
                for r in conn.execute(stmt):
                    out[(r.cell_key, int(r.task_id), int(r.seed))] = {
                        "traj_key": r.traj_key, "success": bool(r.success), "spl_term": r.spl_term,
                        "path_length": r.path_length, "steps": int(r.steps)}
        return out

    def add_episodes(self, run_id: int, rows: list[dict]) -> int:
        """Insert episode rows (see :func:`episode_row_from_score`), ignoring duplicates of
        (cell_key, task_id, seed); returns how many were new."""
        clean = self._normalise(rows, _EPISODE_FIELDS, _EPISODE_REQUIRED, "episode",
                                json_fields=("estimator_options",))
        now = _utcnow()
        for r in clean:
            r["run_id"] = int(run_id)
            r["recorded"] = now
            r["success"] = bool(r["success"])
            if r["collided"] is not None:
                r["collided"] = bool(r["collided"])
        with self._begin() as conn:
            return self._insert_ignore(conn, EpisodeRow, clean, ("cell_key", "task_id", "seed"))

    def episodes_frame(self, run_ids: list[int] | None = None, **filters) -> "pandas.DataFrame":
        """Stored episodes, optionally of some runs; ``filters`` are column=value or
        column=[values] (for example ``level="l1", noise=["low", "mid"]``)."""
        stmt = select(EpisodeRow.__table__).order_by(EpisodeRow.id)
        if run_ids is not None:
            stmt = stmt.where(EpisodeRow.run_id.in_([int(r) for r in run_ids]))
        stmt = _apply_filters(stmt, EpisodeRow, filters)
        return self._frame(stmt)

    # -- tracking study -----------------------------------------------------------------------

    def add_tracking_rows(self, run_id: int, rows: list[dict]) -> int:
        """Insert tracking-study rows (study_key, level, estimator, estimator_options, noise,
        trajectory_id, seed, steps, loc_rmse_m, rot_rmse_deg, step_ms_median, render_ms,
        estimate_ms, traj_key, map_key), ignoring duplicates; returns how many were new."""
        clean = self._normalise(rows, _TRACKING_FIELDS, _TRACKING_REQUIRED, "tracking",
                                json_fields=("estimator_options",))
        now = _utcnow()
        for r in clean:
            r["run_id"] = int(run_id)
            r["recorded"] = now
        with self._begin() as conn:
            return self._insert_ignore(conn, TrackingRow, clean,
                                       ("study_key", "estimator", "trajectory_id", "seed"))

    def tracking_frame(self, run_ids: list[int] | None = None, **filters) -> "pandas.DataFrame":
        stmt = select(TrackingRow.__table__).order_by(TrackingRow.id)
        if run_ids is not None:
            stmt = stmt.where(TrackingRow.run_id.in_([int(r) for r in run_ids]))
        return self._frame(_apply_filters(stmt, TrackingRow, filters))

    # -- bench ----------------------------------------------------------------------------------

    def add_bench_rows(self, run_id: int, rows: list[dict]) -> int:
        """Insert benchmark rows (metric, value, unit, device="cpu"; host, cpu and version default
        to the run's), ignoring duplicates of (run_id, metric, device); returns how many were new."""
        clean = self._normalise(rows, _BENCH_FIELDS, _BENCH_REQUIRED, "bench")
        with self._begin() as conn:
            run = conn.execute(select(Run.host, Run.cpu, Run.navbench_version).where(
                Run.id == run_id)).first()
            if run is None:
                raise DatabaseError(f"no run with id {run_id} in {self.display_url}")
            now = _utcnow()
            for r in clean:
                r["run_id"] = int(run_id)
                r["host"] = r["host"] or run.host
                r["cpu"] = r["cpu"] or run.cpu
                r["navbench_version"] = r["navbench_version"] or run.navbench_version
                r["device"] = r["device"] or "cpu"
                r["value"] = float(r["value"])
                r["recorded"] = now
            return self._insert_ignore(conn, BenchRow, clean, ("run_id", "metric", "device"))

    def bench_frame(self) -> "pandas.DataFrame":
        """All benchmark rows, oldest first."""
        return self._frame(select(BenchRow.__table__).order_by(BenchRow.id))

    # -- frames ---------------------------------------------------------------------------------

    def table_counts(self) -> dict[str, int]:
        """Number of rows in every table, by table name."""
        from sqlalchemy import func

        with self._begin() as conn:
            return {t.name: int(conn.execute(select(func.count()).select_from(t)).scalar())
                    for t in Base.metadata.sorted_tables}

    def _frame(self, stmt) -> "pandas.DataFrame":
        import pandas as pd

        with self._begin() as conn:
            result = conn.execute(stmt)
            columns = list(result.keys())
            data = [tuple(r) for r in result]
        frame = pd.DataFrame.from_records(data, columns=columns)
        for col in frame.columns:
            ctype = stmt.selected_columns[col].type
            if isinstance(ctype, Float):
                frame[col] = pd.to_numeric(frame[col], errors="coerce").astype(float)
            elif isinstance(ctype, DateTime):
                frame[col] = pd.to_datetime(frame[col], utc=True)
        return frame


def _apply_filters(stmt, model, filters: dict):
    table = model.__table__
    for name, value in filters.items():
        if value is None:
            continue
        if name not in table.c:
            raise ValueError(f"unknown {table.name} column {name!r}")
        col = table.c[name]
        if isinstance(value, (list, tuple, set, frozenset)):
            stmt = stmt.where(col.in_(list(value)))
        else:
            stmt = stmt.where(col == value)
    return stmt


def _add_missing_columns(conn: Connection) -> None:
    """``ALTER TABLE ... ADD COLUMN`` for each of ``_ADDED_COLUMNS`` the database lacks."""
    insp = inspect(conn)
    for table, name in _ADDED_COLUMNS:
        if name in {c["name"] for c in insp.get_columns(table)}:
            continue
        col = Base.metadata.tables[table].c[name]
        conn.exec_driver_sql(f"ALTER TABLE {table} ADD COLUMN {name} {col.type.compile(conn.dialect)}")


def _sqlite_pragmas(dbapi_conn, _record) -> None:
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA foreign_keys=ON")
    cur.execute("PRAGMA busy_timeout=60000")
    cur.close()
