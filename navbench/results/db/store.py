"""The :class:`ResultsDB` storage interface: opening (and creating) a database, and every
write and query the stages and commands make. See :mod:`navbench.results.db` for the tables
and the rules (no duplicate rows, the first stored value of a key stays)."""

from __future__ import annotations

import time
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Iterator

from sqlalchemy import DateTime, Float, create_engine, event, inspect, select, tuple_
from sqlalchemy.engine import Connection, Engine, make_url
from sqlalchemy.exc import ArgumentError, NoSuchModuleError, SQLAlchemyError

from navbench.errors import DatabaseError
from navbench.results.db.rows import (
    _apply_filters,
    _clean,
    _clean_json,
    _one_line,
    _task_fields,
    _utcnow,
)
from navbench.results.db.schema import (
    _ADDED_COLUMNS,
    _BENCH_FIELDS,
    _BENCH_REQUIRED,
    _EPISODE_FIELDS,
    _EPISODE_REQUIRED,
    _MAP_METRICS,
    _PG_SCHEMA_LOCK,
    _RUN_TIMING_FIELDS,
    _TRACKING_FIELDS,
    _TRACKING_REQUIRED,
    _LOCALIZE_FIELDS,
    _LOCALIZE_REQUIRED,
    SCHEMA_VERSION,
    Base,
    BenchRow,
    EpisodeRow,
    LevelRow,
    MapRow,
    MetaRow,
    Run,
    RunTimingRow,
    TaskRow,
    TaskSetRow,
    TrackingRow,
    LocalizeRow,
    _add_missing_columns,
    resolve_db_url,
)
from navbench.results.db.schema import (  # issue 13's table
    _SEQUENCE_FIELDS,
    _SEQUENCE_REQUIRED,
    SequenceTrackingRow,
)
from navbench.results.db.runs import RunBookkeeping

if TYPE_CHECKING:  # pragma: no cover
    import pandas


class ResultsDB(RunBookkeeping):
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
                folder = Path(database).expanduser().parent
                try:
                    folder.mkdir(parents=True, exist_ok=True)
                except OSError as e:
                    blocker = next((a for a in (folder, *folder.parents)
                                    if a.exists() and not a.is_dir()), None)
                    why = (f"{blocker} is a file, not a folder" if blocker is not None
                           else (e.strerror or str(e)))
                    raise DatabaseError(f"cannot create the folder of {self.display_url}: {why}") from None
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
        version = self.run_version(run_id)
        for r in clean:
            r["run_id"] = int(run_id)
            r["recorded"] = now
            r["benchmark_version"] = version
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
        estimate_ms, traj_key, map_key), ignoring duplicates; returns how many were new. Each
        row copies the run's benchmark version (:meth:`run_version`)."""
        clean = self._normalise(rows, _TRACKING_FIELDS, _TRACKING_REQUIRED, "tracking",
                                json_fields=("estimator_options",))
        now = _utcnow()
        version = self.run_version(run_id)
        for r in clean:
            r["run_id"] = int(run_id)
            r["recorded"] = now
            r["benchmark_version"] = version  # the run's, as every episode row copies it
        with self._begin() as conn:
            return self._insert_ignore(conn, TrackingRow, clean,
                                       ("study_key", "estimator", "trajectory_id", "seed"))

    def tracking_frame(self, run_ids: list[int] | None = None, **filters) -> "pandas.DataFrame":
        stmt = select(TrackingRow.__table__).order_by(TrackingRow.id)
        if run_ids is not None:
            stmt = stmt.where(TrackingRow.run_id.in_([int(r) for r in run_ids]))
        return self._frame(_apply_filters(stmt, TrackingRow, filters))

    # -- tracked sequences (track-sequence, issue 13) --------------------------------------------

    def add_sequence_rows(self, run_id: int, rows: list[dict]) -> int:
        """Insert ``track-sequence`` rows (the columns of
        :class:`~navbench.results.db.schema.SequenceTrackingRow`), ignoring a ``sequence_key``
        already stored; returns how many were new."""
        clean = self._normalise(rows, _SEQUENCE_FIELDS, _SEQUENCE_REQUIRED, "sequence_tracking",
                                json_fields=("estimator_options",))
        return self._add_run_rows(run_id, SequenceTrackingRow, clean, ("sequence_key",))

    def sequence_frame(self, run_ids: list[int] | None = None, **filters) -> "pandas.DataFrame":
        """The ``sequence_tracking`` rows, oldest first (``filters``: column == value or a list)."""
        return self._run_rows_frame(SequenceTrackingRow, run_ids, filters)

    # -- localisation (issue 14) ----------------------------------------------------------------

    def add_localize_rows(self, run_id: int, rows: list[dict]) -> int:
        """Insert localize-eval rows (one per query, see :class:`LocalizeRow`), ignoring
        duplicates of (study_key, query_id); returns how many were new."""
        clean = self._normalise(rows, _LOCALIZE_FIELDS, _LOCALIZE_REQUIRED, "localize")
        return self._add_run_rows(run_id, LocalizeRow, clean, ("study_key", "query_id"))

    def localize_frame(self, run_ids: list[int] | None = None, **filters) -> "pandas.DataFrame":
        """The ``localize`` rows, oldest first (``filters``: column == value or a list)."""
        return self._run_rows_frame(LocalizeRow, run_ids, filters)

    def _add_run_rows(self, run_id: int, table, clean: list[dict], unique: tuple[str, ...]) -> int:
        """Stamp normalised rows with ``run_id`` and the time, insert them into ``table``
        ignoring rows whose ``unique`` columns are already stored; returns how many were new."""
        now = _utcnow()
        for r in clean:
            r["run_id"] = int(run_id)
            r["recorded"] = now
        with self._begin() as conn:
            return self._insert_ignore(conn, table, clean, unique)

    def _run_rows_frame(self, table, run_ids, filters) -> "pandas.DataFrame":
        stmt = select(table.__table__).order_by(table.id)
        if run_ids is not None:
            stmt = stmt.where(table.run_id.in_([int(r) for r in run_ids]))
        return self._frame(_apply_filters(stmt, table, filters))

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

    # -- run timings (the breakdown, navbench.results.breakdown) ---------------------------

    def add_run_timings(self, run_id: int, rows: list[dict]) -> int:
        """Store a run's breakdown rows (kind, name, seconds, count, cached), ignoring duplicates
        of (run_id, kind, name); returns how many were new."""
        clean = self._normalise(rows, _RUN_TIMING_FIELDS, _RUN_TIMING_FIELDS, "run timing")
        for r in clean:
            r.update(run_id=int(run_id), seconds=float(r["seconds"]), count=int(r["count"]),
                     cached=int(r["cached"]))
        with self._begin() as conn:
            return self._insert_ignore(conn, RunTimingRow, clean, ("run_id", "kind", "name"))

    def run_timings_frame(self, run_id: int | None = None) -> "pandas.DataFrame":
        """The breakdown rows of run ``run_id`` (all runs: None), in the order they were stored."""
        stmt = select(RunTimingRow.__table__).order_by(RunTimingRow.id)
        if run_id is not None:
            stmt = stmt.where(RunTimingRow.run_id == int(run_id))
        return self._frame(stmt)

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


def _sqlite_pragmas(dbapi_conn, _record) -> None:
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA foreign_keys=ON")
    cur.execute("PRAGMA busy_timeout=60000")
    cur.close()

