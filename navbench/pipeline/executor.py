"""Where episode chunks run: this process, a local process pool, or a Ray cluster.

Every executor has ``workers`` and ``map_unordered(fn, items)``, an iterator over ``fn(item)``
results in completion order, and is a context manager whose exit stops outstanding work (so
Ctrl-C leaves no stray workers). Results travel back to the caller, which is the only writer
to the cache and the database.

* :class:`SerialExecutor` runs everything in the calling process (``--workers 1``).
* :class:`LocalExecutor` is a :class:`concurrent.futures.ProcessPoolExecutor` with the
  ``forkserver`` start method (``spawn`` where forkserver is unavailable): workers start clean,
  without the parent's threads, database connections or torch state, and keep their loaded
  level/map/tasks between chunks.
* :class:`RayExecutor` submits chunks as Ray tasks (``pip install navbench[ray]``); ``address``
  names a running cluster, ``None`` starts a local instance. Workers read the artifacts by
  path, so a multi-machine cluster needs the cache directory on a shared filesystem.
"""

from __future__ import annotations

import multiprocessing as mp
import os
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any, Callable, Iterable, Iterator

from navbench.errors import ConfigError
from navbench.proc import pid_alive, process_start_token  # noqa: F401  (re-exported: their old home)

EXECUTORS = ("local", "ray")


def default_workers() -> int:
    """The number of CPUs this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


class SerialExecutor:
    """Run chunks one after the other in this process."""

    workers = 1

    def map_unordered(self, fn: Callable, items: Iterable) -> Iterator[Any]:
        for item in items:
            yield fn(item)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def die_with_parent() -> bool:
    """Ask Linux to SIGKILL this process when its parent dies (``PR_SET_PDEATHSIG``).

    Returns False where that is unavailable (not Linux, no libc). A parent that died before
    the call is not noticed: pool workers also run :func:`watch_parent`.
    """
    import sys

    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes
        import signal

        libc = ctypes.CDLL(None, use_errno=True)
        PR_SET_PDEATHSIG = 1
        if libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) != 0:
            return False
    except (OSError, AttributeError):
        return False
    return True


def watch_parent(pid: int, start_token: str | None, interval_s: float = 0.5) -> None:
    """A daemon thread that ends this process (exit status 1) once process ``pid`` is gone.

    The portable fallback to :func:`die_with_parent`, and the only guard when the process
    that waits for our results is not our parent (forkserver workers are the forkserver's
    children).
    """
    import threading
    import time

    def watch() -> None:
        while pid_alive(pid, start_token):
            time.sleep(interval_s)
        os._exit(1)

    threading.Thread(target=watch, name="navbench-parent-watch", daemon=True).start()


def _init_worker(parent_pid: int | None = None, parent_token: str | None = None) -> None:
    """Pool worker set-up: ignore Ctrl-C, one thread per kernel, and die with the parent.

    Pool workers ignore Ctrl-C: the parent handles it and terminates them. They die when the
    command that started them dies, even by ``kill -9``: the kernel kills them with their
    parent process (Linux), and a watchdog thread ends them once the command's process is
    gone (everywhere; with the forkserver start method their parent is the forkserver).

    Each worker also runs its compiled kernels (numba) and torch on one thread unless the user
    set ``NUMBA_NUM_THREADS``/``OMP_NUM_THREADS``: the pool already has a process per core, and
    threads on top of that wait on each other's scheduler slices.
    """
    import signal
    import sys

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent()
    if parent_pid is not None:
        watch_parent(parent_pid, parent_token)
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    if "numba" in sys.modules:  # already imported (fork start method): limit it directly
        numba_threads(int(os.environ["NUMBA_NUM_THREADS"]))


def numba_threads(n: int) -> int:
    """Run this (calling) thread's compiled kernels on ``n`` numba threads (at least 1, at most
    numba's pool); returns the count before. The kernels give the same bits on any count (the
    camera's pixels and the fit's rays are independent; ``tests/worldmodel/test_fit.py`` checks
    the fit). Pool workers take their count here; the overlap's background process takes 1."""
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(max(1, min(int(n), numba.config.NUMBA_NUM_THREADS)))
    return before


#: Imported by the forkserver at its start: it dies with the command that started it.
FORKSERVER_PRELOAD = "navbench.pipeline._forkserver_init"


class LocalExecutor:
    """A pool of ``workers`` local processes (forkserver or spawn start method)."""

    def __init__(self, workers: int, start_method: str | None = None):
        self.workers = int(workers)
        if start_method is None:
            start_method = "forkserver" if "forkserver" in mp.get_all_start_methods() else "spawn"
        self.context = mp.get_context(start_method)
        if start_method == "forkserver":
            # the forkserver outlives pools (one per process); it must not outlive the command
            self.context.set_forkserver_preload(["__main__", FORKSERVER_PRELOAD])
        self.pool: ProcessPoolExecutor | None = None

    def __enter__(self):
        me = os.getpid()
        self.pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=self.context,
                                        initializer=_init_worker,
                                        initargs=(me, process_start_token(me)))
        return self

    def __exit__(self, *exc):
        if self.pool is not None:
            self.pool.shutdown(wait=exc[0] is None, cancel_futures=True)
            if exc[0] is not None:
                for p in list((getattr(self.pool, "_processes", None) or {}).values()):
                    p.terminate()
        self.pool = None
        return False

    def map_unordered(self, fn: Callable, items: Iterable) -> Iterator[Any]:
        """Keep at most 2 x workers chunks in flight; yield results as they complete."""
        assert self.pool is not None, "use LocalExecutor as a context manager"
        it = iter(items)
        pending = set()
        for item in it:
            pending.add(self.pool.submit(fn, item))
            if len(pending) >= 2 * self.workers:
                break
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for f in done:
                yield f.result()
                nxt = next(it, None)
                if nxt is not None:
                    pending.add(self.pool.submit(fn, nxt))


#: Seconds to wait for a Ray cluster's address to accept a connection (``ray.init`` itself
#: retries for minutes on an address where nothing listens).
RAY_CONNECT_TIMEOUT_S = 5.0


def check_reachable(address: str, timeout_s: float = RAY_CONNECT_TIMEOUT_S) -> None:
    """Raise :class:`ConfigError` naming ``address`` unless a TCP connection to it opens within
    ``timeout_s``. ``host:port`` and ``ray://host:port`` are checked; ``auto``, ``local`` and
    addresses without a port are left to Ray."""
    import socket

    hostport = address.split("://", 1)[1] if "://" in address else address
    host, sep, port = hostport.rstrip("/").rpartition(":")
    if not sep or not port.isdigit() or not host:
        return
    host = host.strip("[]")  # [::1]:6379
    try:
        with socket.create_connection((host, int(port)), timeout=timeout_s):
            pass
    except (OSError, ValueError, OverflowError) as e:
        reason = "timed out" if isinstance(e, TimeoutError) else (e.strerror or str(e) or type(e).__name__)
        raise ConfigError(f"cannot reach the Ray cluster at --address {address}: {reason} "
                          f"(waited up to {timeout_s:g} s)") from None


class RayExecutor:
    """Chunks as Ray tasks on the cluster at ``address`` (``None``: a local Ray instance)."""

    def __init__(self, address: str | None = None, workers: int | None = None):
        try:
            import ray
        except ImportError:
            raise ConfigError("the ray executor needs Ray: pip install 'navbench[ray]'") from None
        self.ray = ray
        self.address = address
        self.workers = workers
        self._started = False

    def __enter__(self):
        return self  # Ray starts on the first chunk: a fully cached rerun never starts it

    def _ensure_started(self) -> None:
        if not self.ray.is_initialized():
            kw: dict[str, Any] = {"ignore_reinit_error": True, "include_dashboard": False,
                                  "log_to_driver": False}
            if self.address:
                check_reachable(self.address)
                kw["address"] = self.address
            elif self.workers:
                kw["num_cpus"] = int(self.workers)
            try:
                self.ray.init(**kw)
            except (ConnectionError, TimeoutError, ValueError, RuntimeError) as e:
                where = f"the Ray cluster at --address {self.address}" if self.address else "Ray"
                first = (str(e).strip().splitlines() or [type(e).__name__])[0]
                raise ConfigError(f"cannot connect to {where}: {first}") from None
            self._started = True
        if not self.workers:
            self.workers = max(1, int(self.ray.cluster_resources().get("CPU", 1)))

    def __exit__(self, *exc):
        if self._started:
            self.ray.shutdown()
            self._started = False
        return False

    def map_unordered(self, fn: Callable, items: Iterable) -> Iterator[Any]:
        self._ensure_started()
        remote = self.ray.remote(num_cpus=1)(fn)
        it = iter(items)
        pending = []
        for item in it:
            pending.append(remote.remote(item))
            if len(pending) >= 2 * self.workers:
                break
        try:
            while pending:
                done, pending = self.ray.wait(pending, num_returns=1)
                for ref in done:
                    yield self.ray.get(ref)
                    nxt = next(it, None)
                    if nxt is not None:
                        pending.append(remote.remote(nxt))
        finally:
            for ref in pending:
                self.ray.cancel(ref, force=True)


def check_executor(kind: str, workers: int | None = 0, address: str | None = None) -> None:
    """The checks of :func:`make_executor` that start nothing (the name, ``workers``, an
    ``address`` without Ray, Ray installed, the address reachable): run before a run is
    recorded, so a refused ``--executor``/``--address`` leaves no ``failed`` run that the next
    run would claim to resume (issue 34)."""
    if kind not in EXECUTORS:
        raise ConfigError(f"unknown executor {kind!r}; choose one of {EXECUTORS}")
    if workers is not None and workers < 0:
        raise ConfigError(f"workers must be >= 0, got {workers}")
    if kind != "ray":
        if address:
            raise ConfigError("--address is only for --executor ray")
        return
    import importlib.util

    if importlib.util.find_spec("ray") is None:
        raise ConfigError("the ray executor needs Ray: pip install 'navbench[ray]'")
    if address:
        check_reachable(address)


def make_executor(kind: str = "local", workers: int = 0, address: str | None = None):
    """An executor by name; ``workers`` 0 means the CPU count, 1 (local) runs in-process."""
    if kind not in EXECUTORS:
        raise ConfigError(f"unknown executor {kind!r}; choose one of {EXECUTORS}")
    if workers < 0:
        raise ConfigError(f"workers must be >= 0, got {workers}")
    if kind == "ray":
        return RayExecutor(address, workers or None)
    if address:
        raise ConfigError("--address is only for --executor ray")
    n = workers or default_workers()
    return SerialExecutor() if n == 1 else LocalExecutor(n)
