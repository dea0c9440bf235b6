"""Overlap (issue 36): the next levels' views and map fits in one background process while
this level's episodes run.

``navbench all`` on several levels with a fitted map used to build every level's inputs first
(collect-views, fit-map, sample-tasks, one after the other, the fit on ``[fit] threads`` torch
threads, 1 by default) and then run the episodes: on an N-core machine N - 1 cores waited
during every fit. With overlap, one *prefetch* process walks the levels after the first, in
order, and runs their cached stages (make-level, collect-views, fit-map, sample-tasks) into the
artifact store, while this process builds the first level and then runs each level's episodes
on the executor. On a machine of more than two cores it starts once the first level's views are
collected, so that its own views do not take the cores those need (:func:`starts_at_once`), and
it runs its compiled kernels on one thread, this process on the cores left while it builds the
first level (:func:`~navbench.pipeline.executor.numba_threads`). Before a level's episodes,
this process builds that level's inputs exactly as without overlap
(:func:`~navbench.pipeline.stages.inputs.build_level_inputs`): the stages find what the
prefetch process stored, under the same keys, so the artifacts, the keys, the database records
and the episode rows are the ones a run without overlap makes (only the order in which rows are
inserted differs: level by level). The prefetch process never touches the database.

The prefetch process is one process beside the ``--workers N`` episode workers (N + 1
processes on N cores while a fit runs): the fit is one thread, and a pool shrunk to N - 1 would
leave a core idle once the fits are done. With ``--workers 1`` (everything in this process, on
one core) there is no overlap.

Interrupts: the prefetch process dies with the command (``PR_SET_PDEATHSIG`` and a watchdog,
as the pool's workers); on Ctrl-C or SIGTERM of the command it is sent SIGINT, which it handles
as a Ctrl-C (the fit stops at its next checkpoint and the cache removes its temporary folder:
writes are atomic, so no half-written entry is ever installed), and it is killed if it has not
ended within :data:`STOP_TIMEOUT_S`. A prefetch process that fails or dies costs nothing but
time: this process then computes that level's stages itself, and reports their errors as it
would have.

"""

from __future__ import annotations

import os
import signal
import threading
import time
from typing import Any, Callable

from navbench.pipeline.artifacts import FORMAT
from navbench.pipeline.cache import run_stage
from navbench.pipeline.executor import FORKSERVER_PRELOAD, die_with_parent, numba_threads, watch_parent
from navbench.pipeline.stages.context import StageContext

#: Seconds the prefetch process gets to stop after SIGINT before it is killed.
STOP_TIMEOUT_S = 15.0
#: Seconds between two progress messages of one bar from the prefetch process.
_BAR_INTERVAL_S = 0.5
#: Machines with at most this many cores start the prefetch process with the command; larger
#: ones once the first level's views are collected (:func:`starts_at_once`).
AT_ONCE_MAX_CORES = 2


def starts_at_once(cores: int | None = None) -> bool:
    """Whether the prefetch process starts with the command (``True``) or once the first
    level's views are collected, before its fit (``False``), on a machine of ``cores`` cores
    (this one's by default). Measured both ways (2026-11-27, the paper camera, two levels):

    - 16 cores (the H100 machine, GPU fit): started with the command, the background's views
      took the cores the first level's views rendered on (the camera renders on every core) and
      the first level's build took ~156 s; started after them, ~74 s.
    - 2 cores: one process's views used about one core (134 views/s each with two at once, about
      as fast as alone), so the two levels' views shared the machine for free; started after
      them, the background's views slowed the first level's fit instead (the first level's fit
      180–210 s with the background started with the command, 193–303 s after the views).
    Between the two, unmeasured: the larger machine's order, the one that keeps the first level's
    views to themselves.
    """
    n = cores if cores is not None else (os.cpu_count() or 1)
    return n <= AT_ONCE_MAX_CORES


def overlap_applies(profile, executor: str, workers: int) -> str | None:
    """Why a run of ``profile`` does not overlap (a phrase), or ``None`` when it does."""
    from navbench.pipeline.stages.online import is_online

    if profile.map_source != "fit" or is_online(profile.map_source):
        return "no map is fitted"
    if len(dict.fromkeys(profile.levels)) < 2:
        return "one level"
    if executor == "local" and workers == 1:
        return "--workers 1 runs everything in this process"
    return None


# ------------------------------------------------------------------------ the prefetch process

def _prefetch_main(conn, profile, names: list[str], cache_root: str, levels_dir: str, tasks_dir: str,
                   parent_pid: int, parent_token: str | None) -> None:
    """The prefetch process: build ``names``' inputs into the store, reporting over ``conn``:
    ``("log", text)``, ``("bar", description, done, total)``, ``("done", level, timings)``
    (timings: ``[(stage, key, seconds, cached)]``) and ``("error", level, text)``."""
    die_with_parent()
    watch_parent(parent_pid, parent_token)
    # one thread: it always runs beside other work (the first level's build, then the episodes
    # on every core), and numba's parallel kernels on more threads than the cores they get wait
    # on each other: two paper-camera fits at once on 2 cores took 48-68 ms a step each on two
    # threads, 12.4-13.2 on one (alone: 10.0-10.4 and 12.4-12.6; 2026-11-27)
    numba_threads(1)
    from navbench.interrupts import terminate_as_interrupt

    # SIGINT (and SIGTERM) as in a command, a Ctrl-C: the fit stops at its next checkpoint
    # (interrupts.deferred) and the cache removes its temporary folder
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        with terminate_as_interrupt():
            _prefetch(conn, profile, names, cache_root, levels_dir, tasks_dir)
    except KeyboardInterrupt:
        os._exit(130)
    finally:
        try:
            conn.close()
        except OSError:
            pass


def _prefetch(conn, profile, names, cache_root, levels_dir, tasks_dir) -> None:
    from pathlib import Path

    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.stages.inputs import build_level_inputs

    def send(*msg) -> None:
        try:
            conn.send(msg)
        except (OSError, EOFError, BrokenPipeError):  # the command is gone: so are we, soon
            pass

    def bar(desc: str, total: int):
        last = [0.0]

        def update(done: int, total_: int | None = None, loss: float | None = None) -> None:
            now = time.monotonic()
            if now - last[0] >= _BAR_INTERVAL_S or done >= (total_ or total):
                last[0] = now
                send("bar", desc, int(done), int(total_ or total))

        return update

    ctx = _RecordingContext(ArtifactStore(cache_root), None, log=lambda m: send("log", m), progress=bar,
                            levels_dir=Path(levels_dir), tasks_dir=Path(tasks_dir))
    for name in names:
        ctx.calls = []
        try:
            build_level_inputs(ctx, profile, name)
        except KeyboardInterrupt:
            raise
        except BaseException as e:  # noqa: BLE001 - reported; this process (the command) says it again
            send("error", name, f"{type(e).__name__}: {e}")
            return
        send("done", name, list(ctx.calls))


class _RecordingContext(StageContext):
    """A :class:`StageContext` that also records each stage call's key (``calls``)."""

    def run(self, stage, config, inputs, compute, validate=None):
        t0 = time.perf_counter()
        config = self.keyed(stage, config)  # the same keys as the command's own stages
        path, key, cached = run_stage(self.store, stage, config, inputs, FORMAT[stage], compute,
                                      force=self.forced(stage), log=self.log, validate=validate)
        self.calls.append((stage, key, time.perf_counter() - t0, bool(cached)))
        return path, key, cached


# ------------------------------------------------------------------------ this process's side

class Prefetcher:
    """The prefetch process of a run, seen from the command (a context manager).

    ``wait(level)`` blocks until the prefetch process has built ``level`` (or given up) and
    returns ``{(stage, key): seconds}`` of the stages it computed (not found cached) for it;
    ``{}`` when it failed or died (this process then computes them). Its log lines go to
    ``log`` prefixed with ``background``, its bars to ``bar``.
    """

    def __init__(self, profile, names: list[str], ctx, log: Callable[[str], None],
                 bar: Callable[[str, int], Callable[..., None]]):
        self.profile, self.names = profile, list(names)
        self.ctx, self.log, self.bar = ctx, log, bar
        self.proc = None
        self._conn = None
        self._done: dict[str, dict | None] = {}
        self._cond = threading.Condition()
        self._reader: threading.Thread | None = None
        self._bars: dict[str, Callable[..., None]] = {}
        self._stopping = False

    def __enter__(self) -> "Prefetcher":
        return self

    def start(self) -> bool:
        """Start the prefetch process (once: a later call does nothing); ``True`` when this
        call started it.

        The command calls it on entry or once its first level's views are collected, as
        :func:`starts_at_once` says for this machine.
        """
        import multiprocessing as mp

        from navbench.proc import process_start_token

        if not self.names or self.proc is not None or self._stopping:
            return False
        method = "forkserver" if "forkserver" in mp.get_all_start_methods() else "spawn"
        mpc = mp.get_context(method)
        if method == "forkserver":  # dies with the command (as LocalExecutor's)
            mpc.set_forkserver_preload(["__main__", FORKSERVER_PRELOAD])
        here, there = mpc.Pipe(duplex=False)
        me = os.getpid()
        self.proc = mpc.Process(target=_prefetch_main, name="navbench-prefetch", daemon=True,
                                args=(there, self.profile, self.names, str(self.ctx.store.root),
                                      str(self.ctx.levels_dir), str(self.ctx.tasks_dir), me,
                                      process_start_token(me)))
        self.proc.start()
        there.close()
        self._conn = here
        self._reader = threading.Thread(target=self._read, name="navbench-prefetch-reader", daemon=True)
        self._reader.start()
        self.log(f"overlap: {', '.join(self.names)} built in a background process (pid "
                 f"{self.proc.pid}) while the episodes run")
        return True

    def _read(self) -> None:
        try:
            while True:
                msg = self._conn.recv()
                kind = msg[0]
                if kind == "log":
                    self.log(f"background {msg[1]}")
                elif kind == "bar":
                    _, desc, done, total = msg
                    if desc not in self._bars:
                        self._bars[desc] = self.bar(f"{desc} (background)", total)
                    self._bars[desc](done, total)
                elif kind in ("done", "error"):
                    if kind == "error":
                        self.log(f"overlap: the background build of {msg[1]} failed ({msg[2]}); "
                                 "building it here")
                    with self._cond:
                        self._done[msg[1]] = ({(s, k): sec for s, k, sec, cached in msg[2] if not cached}
                                              if kind == "done" else None)
                        if kind == "error":
                            for n in self.names:
                                self._done.setdefault(n, None)
                        self._cond.notify_all()
        except (EOFError, OSError):
            pass
        except Exception:  # noqa: BLE001 - a display problem must not stop the run
            pass
        missing = [n for n in self.names if n not in self._done]
        if missing and not self._stopping:
            p = self.proc
            if p is not None:
                p.join(2)
            code = p.exitcode if p is not None else None
            self.log(f"overlap: the background process ended (exit status {code}) before building "
                     f"{', '.join(missing)}; building {'them' if len(missing) > 1 else 'it'} here")
        with self._cond:  # the process ended: whatever it did not report, this process builds
            for n in self.names:
                self._done.setdefault(n, None)
            self._cond.notify_all()

    def wait(self, name: str) -> dict:
        """The stages the prefetch process computed for level ``name`` (see the class)."""
        if self.proc is None or name not in self.names:
            return {}
        with self._cond:
            while name not in self._done:
                self._cond.wait(0.5)
            return dict(self._done[name] or {})

    def stop(self) -> None:
        """End the prefetch process (SIGINT, then SIGKILL after :data:`STOP_TIMEOUT_S`)."""
        p = self.proc
        if p is None:
            return
        self._stopping = True
        if p.is_alive():
            try:
                os.kill(p.pid, signal.SIGINT)
            except ProcessLookupError:
                pass
            p.join(STOP_TIMEOUT_S)
            if p.is_alive():
                p.kill()
                p.join(5)
        else:
            p.join(1)
        if self._reader is not None:
            self._reader.join(2)
        if self._conn is not None:
            self._conn.close()
        self.proc = None

    def __exit__(self, *exc) -> bool:
        self.stop()
        return False


def summed_summary(parts: list) -> Any:
    """One :class:`~navbench.pipeline.stages.navigation.NavigationSummary` of the per-level
    summaries ``parts`` (counts, components and seconds added)."""
    from navbench.pipeline.stages.navigation import NavigationSummary

    out = NavigationSummary([])
    for s in parts:
        out.cells.extend(s.cells)
        for f in ("total", "already_done", "from_cache", "ran", "stored", "stored_elsewhere", "restored",
                  "steps"):
            setattr(out, f, getattr(out, f) + getattr(s, f))
        out.store_s += s.store_s
        for k, v in s.component_s.items():
            out.component_s[k] = out.component_s.get(k, 0.0) + v
        for k, (sec, n) in s.estimator_s.items():
            acc = out.estimator_s.setdefault(k, [0.0, 0])
            acc[0] += sec
            acc[1] += n
        out.seconds = (out.seconds or 0.0) + (s.seconds or 0.0)
    return out
