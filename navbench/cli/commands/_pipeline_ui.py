"""Shared glue of the pipeline commands: rich progress bars, the stage context, profile options.

Not a command module (the leading underscore keeps it out of discovery). Imports only light
modules at import time.
"""

from __future__ import annotations

import sys
import time

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


def run_with_ui(body, json_mode: bool = False):
    """``body(ui)`` with rich progress bars drawn around it; Ctrl-C prints how to resume and
    exits 130 (the run is recorded as interrupted by :func:`navbench.pipeline.run.recorded_run`)."""
    ui = PipelineUI(json_mode=json_mode)
    try:
        with ui:
            return body(ui)
    except BaseException as e:
        from navbench.errors import caused_by_interrupt

        # Ctrl-C, also when it arrived inside a numba kernel (a SystemError chained to the
        # KeyboardInterrupt: a standalone fit-map printed that chain)
        if not caused_by_interrupt(e) or isinstance(e, SystemExit):
            raise
        # exit 130 ourselves: the CLI shell would turn it into exit status 0
        ui.console.print("interrupted: rerun the same command to finish; stored episodes are kept",
                         style="yellow")
        raise SystemExit(130) from None


def load_profile_with(profile: str | None, **overrides):
    """Load a profile and apply the CLI's non-None overrides."""
    from navbench.pipeline.profiles import load_profile, override

    return override(load_profile(profile), **overrides)


def command_line() -> str:
    """The command line as typed (for the runs table)."""
    return " ".join(["navbench", *sys.argv[1:]])[:256]


def elapsed_since(t0: float) -> str:
    return f"{time.perf_counter() - t0:.1f} s"
