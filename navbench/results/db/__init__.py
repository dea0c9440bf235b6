"""The results database: runs, levels, maps, task sets, episodes, tracking and bench rows.

One small storage interface (:class:`ResultsDB`) for every stage and command: they never build
SQL themselves. Any SQLAlchemy URL works; the default is ``sqlite:///results/navbench.db``
relative to the current working directory (``results/`` is created), overridden by the
``NAVBENCH_DB`` environment variable or an explicit URL (the CLI's ``--db``). SQLite and
PostgreSQL (``postgresql+psycopg://user@host/db``, extra ``navbench[postgres]``) are tested.

Tables (SQLAlchemy 2 declarative models in :mod:`navbench.results.db.schema`):

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
* ``sequence_tracking`` -- one RGB-D sequence tracked by ``track-sequence`` (ATE, RPE, ms per
  frame), unique on its sequence key (sequence, map, odometry, estimator, options, seed).
* ``bench`` -- one measured benchmark metric, unique on (run_id, metric, device).
* ``run_timings`` -- where a run's time went (:mod:`navbench.results.breakdown`): per stage
  and per episode timing component, unique on (run_id, kind, name).

Duplicate rows are impossible: every ``add_*``/``record_*`` inserts with the dialect's
``ON CONFLICT DO NOTHING`` (SQLite, PostgreSQL; other dialects select the existing keys first,
in the same transaction) and reports how many rows were new. The first stored value of a key
therefore stays; a rerun skips the keys :meth:`ResultsDB.done_episode_keys` reports.

Schema changes: ``SCHEMA_VERSION`` counts incompatible layouts (a database of another version
is refused). Compatible additions are nullable columns that opening a database adds when
missing (``_ADDED_COLUMNS``; older navbench versions ignore them). Tables and columns are
created under a lock (SQLite ``BEGIN IMMEDIATE``, a PostgreSQL advisory lock), so commands
that open a fresh database at the same moment do not trip over each other.

Modules: :mod:`~navbench.results.db.schema` (tables, constants, the database URL),
:mod:`~navbench.results.db.rows` (values into rows, machine facts) and
:mod:`~navbench.results.db.store` (:class:`ResultsDB`). Import from this package: the names
below are its interface.
"""

from navbench.results.db.rows import cpu_description, episode_row_from_score, git_commit
from navbench.results.db.schema import (
    DB_ENV,
    DEFAULT_DB_URL,
    RUN_STATUSES,
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
    resolve_db_url,
)
from navbench.results.db.store import ResultsDB

__all__ = [
    "DB_ENV", "DEFAULT_DB_URL", "RUN_STATUSES", "SCHEMA_VERSION", "Base", "BenchRow", "EpisodeRow",
    "LevelRow", "MapRow", "MetaRow", "ResultsDB", "Run", "RunTimingRow", "TaskRow", "TaskSetRow", "TrackingRow",
    "cpu_description", "episode_row_from_score", "git_commit", "resolve_db_url",
]
