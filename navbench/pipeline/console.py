"""Progress on a console: the stage lines and rich progress bars of the pipeline commands, and
of :func:`navbench.pipeline.run.run_profile` with ``progress=True``; :class:`CallbackProgress`
hands the same events to a function (a notebook, a logger).

Imports only light modules (rich, the standard library).
"""

from __future__ import annotations

import time
from typing import Callable

from rich.console import Console
from rich.progress import (BarColumn, MofNCompleteColumn, Progress, ProgressColumn, SpinnerColumn,
                           TextColumn, TimeRemainingColumn)
from rich.text import Text


class RateColumn(ProgressColumn):
    """Items per second since the bar started (``ep/s``, ``views/s``...), frozen when it ends."""

    def __init__(self, unit: str = "it"):
        super().__init__()
        self.unit = unit

    def render(self, task) -> Text:
        t0, t1 = task.fields.get("t0"), task.fields.get("t_last")
        rate = task.completed / (t1 - t0) if t0 is not None and t1 and t1 > t0 else 0.0
        unit = task.fields.get("unit", self.unit)
        return Text(f"{rate:.2f} {unit}/s", style="progress.data.speed")


class PipelineUI:
    """Log lines and progress bars on one console (stderr when stdout carries JSON)."""

    def __init__(self, json_mode: bool = False, quiet: bool = False):
        self.console = Console(stderr=json_mode, highlight=False, soft_wrap=True)  # as cli._common's
        self.quiet = quiet
        self.progress = Progress(
            SpinnerColumn(), TextColumn("[bold]{task.description}"), BarColumn(bar_width=24),
            MofNCompleteColumn(), RateColumn(), TextColumn("{task.fields[extra]}"),
            TextColumn("ETA"), TimeRemainingColumn(compact=True),
            console=self.console, transient=False, disable=quiet,
        )
        self._shown = False  # the display starts with the first bar (_show)

    def __enter__(self) -> "PipelineUI":
        return self

    def __exit__(self, *exc) -> bool:
        if self._shown:
            self.progress.stop()
            self._shown = False
        return False

    def _show(self) -> None:
        """Start the display with the first bar, not on entry: a display stopped without ever
        showing a bar still writes a blank line (rich), e.g. before a command's error line."""
        if not self._shown:
            self.progress.start()
            self._shown = True

    def log(self, msg: str) -> None:
        if self.quiet:
            return
        style = "dim" if ": cached " in msg or " from " in msg else None
        if msg.startswith("warning"):
            style = "yellow"
        self.console.print(msg, style=style, highlight=False, markup=False)

    def bar(self, description: str, total: int | None, unit: str = "it"):
        """A new bar; returns ``update(done, total=None, loss=None)``."""
        self._show()
        tid = self.progress.add_task(description, total=total, extra="", unit=unit, t0=time.perf_counter())

        def update(done: int, total_: int | None = None, loss: float | None = None) -> None:
            fields = {"completed": done, "t_last": time.perf_counter()}
            if total_ is not None:
                fields["total"] = total_
            if loss is not None:
                fields["extra"] = f"loss {loss:.4f}"
            self.progress.update(tid, **fields)

        return update

    def counter(self, description: str, total: int, unit: str = "ep"):
        """A bar driven by increments: returns ``(advance(n), set_total(total))``."""
        self._show()
        tid = self.progress.add_task(description, total=total, extra="", unit=unit, t0=time.perf_counter())

        def advance(n: int) -> None:
            self.progress.update(tid, advance=n, t_last=time.perf_counter())

        return advance, (lambda t: self.progress.update(tid, total=t))



class CallbackProgress:
    """A :class:`~navbench.pipeline.run.Progress` that calls ``callback(line)`` with every stage
    line (``fit-map: computing 1a2b3c``, warnings start with ``warning``) and with a bar's state
    (``episodes 45/90``) at most once per tenth of the bar and when it completes."""

    def __init__(self, callback: Callable[[str], None]):
        self.callback = callback

    def log(self, msg: str) -> None:
        self.callback(msg)

    def _bar(self, description: str, total: int | None):
        state = {"done": 0, "total": total, "shown": -1}

        def show() -> None:
            t, d = state["total"], state["done"]
            tenth = int(10 * d / t) if t else d
            if tenth != state["shown"] or (t and d >= t and state["shown"] != 10):
                state["shown"] = 10 if t and d >= t else tenth
                self.callback(f"{description} {d}/{t}" if t else f"{description} {d}")

        return state, show

    def bar(self, description: str, total: int | None, unit: str = "it"):
        state, show = self._bar(description, total)

        def update(done: int, total_: int | None = None, loss: float | None = None) -> None:
            state["done"] = done
            if total_ is not None:
                state["total"] = total_
            show()

        return update

    def counter(self, description: str, total: int, unit: str = "ep"):
        state, show = self._bar(description, total)

        def advance(n: int) -> None:
            state["done"] += n
            show()

        def set_total(t: int) -> None:
            state["total"] = t

        return advance, set_total
