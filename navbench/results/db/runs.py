"""The ``runs`` table's bookkeeping: a run starts, finishes, dies or is discarded.

:class:`RunBookkeeping` is a part of :class:`~navbench.results.db.store.ResultsDB` (it uses the
store's ``_begin`` and ``_frame``): a run row records the process that runs it (pid and start
token, :mod:`navbench.proc`), so a run whose process died without closing it is found and marked
``interrupted``; and the benchmark version it produces results under (:mod:`navbench.benchmark`).
"""

from __future__ import annotations

import os
import socket
from typing import TYPE_CHECKING

from sqlalchemy import delete, select, update

from navbench.errors import DatabaseError
from navbench.proc import pid_alive, process_start_token
from navbench.results.db.rows import _clean_json, _utcnow, cpu_description, git_commit
from navbench.results.db.schema import RUN_STATUSES, Base, Run

if TYPE_CHECKING:  # pragma: no cover
    import pandas


class RunBookkeeping:
    """Run rows: :meth:`start_run`, :meth:`finish_run`, :meth:`discard_run`,
    :meth:`mark_dead_runs`, :meth:`run_version`, :meth:`latest_run_id`, :meth:`runs_frame`."""

    # -- runs -----------------------------------------------------------------------------

    def start_run(self, profile: str, command: str, config: dict, config_hash: str,
                  benchmark_version: str | None = None) -> int:
        """Record the start of a run (status ``running``) by this process under
        ``benchmark_version`` (default: :data:`navbench.benchmark.BENCHMARK_VERSION`); returns its id."""
        from navbench import __version__
        from navbench.benchmark import BENCHMARK_VERSION

        pid = os.getpid()
        row = dict(
            profile=profile, command=command, config=_clean_json(config), config_hash=config_hash,
            navbench_version=__version__, git_commit=git_commit(), host=socket.gethostname(),
            cpu=cpu_description(), started=_utcnow(), finished=None, status="running",
            pid=pid, proc_start=process_start_token(pid),
            benchmark_version=benchmark_version or BENCHMARK_VERSION,
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

    def discard_run(self, run_id: int) -> bool:
        """Delete run ``run_id`` when no row of any table refers to it (a command refused for
        bad input after its run began stored nothing: it was not a run); whether it was deleted."""
        tables = [t for t in Base.metadata.sorted_tables if "run_id" in t.c]
        with self._begin() as conn:
            if any(conn.execute(select(t.c.run_id).where(t.c.run_id == run_id).limit(1)).first() for t in tables):
                return False
            conn.execute(delete(Run.__table__).where(Run.__table__.c.id == run_id))
        return True

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

    def run_version(self, run_id: int) -> str:
        """The benchmark version run ``run_id`` recorded (``navbench-1`` for a run stored before
        versions existed, or an unknown id)."""
        from navbench.benchmark import LEGACY_VERSION

        with self._begin() as conn:
            v = conn.execute(select(Run.benchmark_version).where(Run.id == int(run_id))).scalar()
        return v or LEGACY_VERSION

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
