"""Shared glue of the pipeline commands: rich progress bars, the stage context, profile options.

Not a command module (the leading underscore keeps it out of discovery). Imports only light
modules at import time.
"""

from __future__ import annotations

import sys
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

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
        self.console = Console(stderr=json_mode, highlight=False)
        self.quiet = quiet
        self.progress = Progress(
            SpinnerColumn(), TextColumn("[bold]{task.description}"), BarColumn(bar_width=24),
            MofNCompleteColumn(), RateColumn(), TextColumn("{task.fields[extra]}"),
            TextColumn("ETA"), TimeRemainingColumn(compact=True),
            console=self.console, transient=False, disable=quiet,
        )

    def __enter__(self) -> "PipelineUI":
        self.progress.start()
        return self

    def __exit__(self, *exc) -> bool:
        self.progress.stop()
        return False

    def log(self, msg: str) -> None:
        if self.quiet:
            return
        style = "dim" if ": cached " in msg or " from " in msg else None
        if msg.startswith("warning"):
            style = "yellow"
        self.console.print(msg, style=style, highlight=False, markup=False, soft_wrap=True)

    def bar(self, description: str, total: int | None, unit: str = "it"):
        """A new bar; returns ``update(done, total=None, loss=None)``."""
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
        tid = self.progress.add_task(description, total=total, extra="", unit=unit, t0=time.perf_counter())

        def advance(n: int) -> None:
            self.progress.update(tid, advance=n, t_last=time.perf_counter())

        return advance, (lambda t: self.progress.update(tid, total=t))


def make_context(ui: PipelineUI, db=None, force: bool | set = False, cache_root: str = "results/cache"):
    """A :class:`navbench.pipeline.stages.StageContext` that logs and draws on ``ui``."""
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.stages import StageContext

    if force is True:
        force = {"*"}
    elif not force:
        force = set()

    def progress(desc: str, total: int):
        unit = "views" if desc.startswith("views") else "steps" if desc.startswith("fit") else "it"
        return ui.bar(desc, total, unit)

    return StageContext(ArtifactStore(cache_root), db, log=ui.log, progress=progress,
                        force=frozenset(force))


def load_profile_with(profile: str | None, **overrides):
    """Load a profile and apply the CLI's non-None overrides."""
    from navbench.pipeline.profiles import load_profile, override

    return override(load_profile(profile), **overrides)


@contextmanager
def database(url: str | None) -> Iterator:
    from navbench.pipeline.db import ResultsDB

    db = ResultsDB(url)
    try:
        yield db
    finally:
        db.close()


def command_line() -> str:
    """The command line as typed (for the runs table)."""
    return " ".join(["navbench", *sys.argv[1:]])[:256]


def elapsed_since(t0: float) -> str:
    return f"{time.perf_counter() - t0:.1f} s"


#: The file that marks a folder as a report navbench published (the only folders it replaces).
REPORT_MARKER = ".navbench-report"


def protected_paths(db_url: str | None = None, cache_root: str | Path = "results/cache",
                    levels_dir: str | Path = "levels", tasks_dir: str | Path = "tasks") -> list[Path]:
    """What a report must never be written over, into or around: the stage cache, the SQLite
    database file, the level and task folders."""
    from navbench.pipeline.db import resolve_db_url

    paths = [Path(cache_root), Path(levels_dir), Path(tasks_dir)]
    url = resolve_db_url(db_url)
    if url.startswith("sqlite:///"):
        db_file = url[len("sqlite:///"):].split("?", 1)[0]
        if db_file and db_file != ":memory:":
            paths.append(Path(db_file).expanduser())
    return paths


def check_report_dir(dest: str | Path, option: str, protected: list[Path]) -> Path:
    """Refuse a report destination that could lose data; returns ``dest``.

    Allowed: a folder that does not exist yet, an empty folder, or a folder navbench published
    before (it holds :data:`REPORT_MARKER`). Refused (:class:`ConfigError` naming ``option``): a
    file, a symbolic link, a non-empty folder without the marker (``results/``, ``.``, a user's
    folder), and anything that is, contains or lies inside one of the ``protected`` paths.
    """
    from navbench.errors import ConfigError

    dest = Path(dest)
    where = f"{option} {dest}"
    if dest.is_symlink():
        raise ConfigError(f"{where}: is a symbolic link; give a real folder")
    if dest.exists() and not dest.is_dir():
        raise ConfigError(f"{where}: is a file, not a folder")
    target = dest.resolve()
    for p in protected:
        q = p.resolve()
        if target == q or q.is_relative_to(target) or target.is_relative_to(q):
            raise ConfigError(f"{where}: overlaps {p} (the report must not be written into, over "
                              "or around the cache, the database, levels or tasks); choose "
                              "another folder, e.g. results/report")
    if dest.is_dir() and any(dest.iterdir()) and not (dest / REPORT_MARKER).is_file():
        raise ConfigError(f"{where}: the folder is not empty and is not a report navbench "
                          f"published (no {REPORT_MARKER} file); choose a new or empty folder")
    return dest


def publish(src_dir: Path, dest: Path, protected: list[Path] | None = None,
            option: str = "--report") -> Path:
    """Copy an artifact's files (not its manifest) to ``dest``, replaced atomically.

    Only a folder :func:`check_report_dir` accepts is replaced; the published folder gets the
    :data:`REPORT_MARKER` file. The temporary folders are new ones (``mkdtemp``) beside ``dest``,
    so nothing that navbench did not create is removed.
    """
    import shutil
    import tempfile

    protected = protected if protected is not None else protected_paths()
    dest = check_report_dir(dest, option, protected)
    dest.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=f".{dest.name}.", suffix=".tmp", dir=dest.parent))
    try:
        new, old = work / "new", work / "old"
        shutil.copytree(src_dir, new, ignore=shutil.ignore_patterns("manifest.json"))
        mark_report_dir(new)
        if dest.exists():
            check_report_dir(dest, option, protected)  # still a published report just before the swap
            dest.rename(old)
        try:
            new.rename(dest)
        except OSError:
            if old.exists():
                old.rename(dest)
            raise
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return dest


def mark_report_dir(folder: Path) -> None:
    """Mark ``folder`` as a report navbench wrote (so a later report may replace it)."""
    (Path(folder) / REPORT_MARKER).write_text("written by navbench; the next report replaces this folder\n")
