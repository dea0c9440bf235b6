"""Ctrl-C at a safe point (issue 34).

Python raises ``KeyboardInterrupt`` at the next bytecode of the main thread, which may be a
Python function that torch (pybind11) or numba is calling back: pybind11 then calls
``std::terminate`` (the process aborts with SIGABRT, "terminate called after throwing an
instance of 'pybind11::error_already_set'"), numba returns a ``SystemError``. Long native
loops (the map fit) therefore run inside :func:`deferred`: the first Ctrl-C only sets a flag,
and the loop raises ``KeyboardInterrupt`` itself at its next :func:`checkpoint` (the fit's
progress callback, every 10 steps), in plain Python, where every ``finally`` and ``except``
runs (the cache removes its temporary folder, the CLI prints one line, exit 130). A second
Ctrl-C before that checkpoint interrupts at once, as before.

Light imports only (the standard library).
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from typing import Any, Callable, Iterator

_pending = False


def _handler(signum, frame) -> None:
    global _pending
    if _pending:  # a second Ctrl-C: the user does not want to wait for the checkpoint
        _pending = False
        raise KeyboardInterrupt
    _pending = True


def checkpoint() -> None:
    """Raise ``KeyboardInterrupt`` when Ctrl-C arrived inside :func:`deferred` (and forget it)."""
    global _pending
    if _pending:
        _pending = False
        raise KeyboardInterrupt


def checked(fn: Callable[..., Any] | None) -> Callable[..., Any]:
    """``fn`` (a progress callback; ``None``: a no-op) preceded by a :func:`checkpoint`."""
    def wrapped(*args: Any, **kwargs: Any) -> Any:
        checkpoint()
        return fn(*args, **kwargs) if fn is not None else None

    return wrapped


@contextmanager
def deferred() -> Iterator[None]:
    """Within the block, Ctrl-C is raised at the next :func:`checkpoint` (or on leaving the
    block) instead of wherever the main thread happens to be. A no-op off the main thread and
    where SIGINT is not Python's default handler (ignored in workers, or a caller's own)."""
    global _pending
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield
        return
    _pending = False
    signal.signal(signal.SIGINT, _handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    checkpoint()  # Ctrl-C during the last steps, after the final checkpoint


@contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM is handled as Ctrl-C: as the SIGINT handler of the moment would
    handle it (a ``KeyboardInterrupt``, or inside :func:`deferred` at the next checkpoint), so a
    ``kill`` of a run records it as interrupted and stops its workers, as Ctrl-C does. A no-op
    off the main thread and where SIGTERM is not at its default action (a caller's own)."""
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL):
        yield
        return

    def on_term(signum, frame) -> None:
        handler = signal.getsignal(signal.SIGINT)
        if callable(handler):
            handler(signal.SIGINT, frame)
        else:  # SIGINT ignored (a background job of a shell): SIGTERM still ends the run
            raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, on_term)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
