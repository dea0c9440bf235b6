"""The bad-input probe (issue 11): everything a careless or hostile user can type.

Each module here holds one case per failure the probe found. A case runs the real CLI entry
point (:func:`navbench.cli.main.main`, in process, or ``python -m navbench.cli.main`` in a
subprocess where processes matter) inside a scratch project and checks the contract:

- exit status non-zero, no traceback, and (for a :class:`~navbench.errors.NavbenchError`) one
  line on stderr naming the file, field or option; usage errors end in click's short usage
  message with exit 2;
- nothing written outside ``levels/``, ``tasks/``, ``results/`` of the project and the paths the
  user named as outputs (:func:`tree_snapshot` before and after);
- no file or database row lost.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest

from navbench.levelio import save_level

TINY_PROFILE = """
name = "tinytest"
levels = ["tiny"]
[views]
camera = "half"
count = 12
seed = 0
eval_count = 4
eval_seed = 1
[fit]
steps = 3
grid_shape = [16, 12, 8]
n_samples = 40
images_per_batch = 4
pixels_per_image = 50
threads = 1
[tasks]
count = 3
[navigation]
estimators = ["gt", "dynamics"]
noise = ["low"]
workers = 1
"""


@dataclass
class Result:
    code: int
    out: str
    err: str

    @property
    def output(self) -> str:
        return self.out + self.err


def nb(*args: str) -> Result:
    """Run ``navbench ARGS`` in this process through the console entry point; never raises."""
    import contextlib
    import io

    from navbench.cli import main as cli_main

    out, err = io.StringIO(), io.StringIO()
    code = 0
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            cli_main.main([str(a) for a in args])
        except SystemExit as e:
            code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
        except BaseException as e:  # noqa: BLE001 - a traceback is exactly what the probe looks for
            import traceback

            err.write("Traceback (most recent call last):\n" + "".join(traceback.format_exception(e)))
            code = 99
    return Result(code, out.getvalue(), err.getvalue())


def nb_subprocess(*args: str, cwd: Path, timeout: float = 120, env: dict | None = None) -> Result:
    """Run ``navbench ARGS`` as its own process (for signals, workers, concurrency)."""
    full_env = {**os.environ, **(env or {})}
    p = subprocess.run([sys.executable, "-m", "navbench.cli.main", *map(str, args)], cwd=cwd,
                       capture_output=True, text=True, timeout=timeout, env=full_env)
    return Result(p.returncode, p.stdout, p.stderr)


def assert_clean_error(res: Result, *names: str) -> None:
    """Non-zero exit, no traceback, one ``error:`` line on stderr that mentions every ``names``."""
    assert res.code != 0, f"exit 0 for bad input:\n{res.output}"
    assert "Traceback" not in res.output, res.output
    lines = [ln for ln in res.err.splitlines() if ln.strip()]
    errors = [ln for ln in lines if ln.startswith("error:")]
    assert len(errors) == 1, f"expected one 'error:' line on stderr, got:\n{res.err}"
    for n in names:
        assert n in errors[0], f"{n!r} not named in {errors[0]!r}"


def assert_usage_error(res: Result, *names: str) -> None:
    """Click's short usage message: exit 2, ``Usage:`` and an ``Error:`` line, no traceback."""
    assert res.code == 2, f"exit {res.code}, expected 2:\n{res.output}"
    assert "Traceback" not in res.output, res.output
    assert "Usage:" in res.output and "Error" in res.output, res.output
    assert len(res.output.splitlines()) <= 12, res.output
    for n in names:
        assert n in res.output, f"{n!r} not in {res.output!r}"


def tree_snapshot(root: Path) -> dict[str, tuple[int, int]]:
    """``relative path -> (size, mtime_ns)`` of every file under ``root``."""
    snap = {}
    for dirpath, _dirs, files in os.walk(root):
        for f in files:
            p = Path(dirpath) / f
            try:
                st = p.stat()
            except FileNotFoundError:
                continue
            snap[str(p.relative_to(root))] = (st.st_size, st.st_mtime_ns)
    return snap


def written_outside(before: dict, after: dict, allowed: tuple[str, ...] = ("levels/", "tasks/", "results/")) -> list[str]:
    """Files created or modified between two snapshots outside the ``allowed`` prefixes."""
    changed = [p for p, v in after.items() if before.get(p) != v]
    return [p for p in changed if not p.startswith(allowed)]


@pytest.fixture
def project(tmp_path, monkeypatch):
    """A scratch project ``tmp_path/proj`` (levels/tiny.json, tiny.toml; the database in its
    results/), made the working directory; ``tmp_path/outside`` is where escapes would land."""
    from tests.pipeline.test_stages import tiny_level

    proj = tmp_path / "proj"
    (proj / "levels").mkdir(parents=True)
    (tmp_path / "outside").mkdir()
    save_level(tiny_level(), proj / "levels" / "tiny.json")
    (proj / "tiny.toml").write_text(TINY_PROFILE)
    monkeypatch.chdir(proj)
    monkeypatch.delenv("NAVBENCH_DB", raising=False)
    return proj


def db_row_counts(root: Path) -> dict[str, int]:
    """``{"<db file>:<table>": rows}`` of every SQLite database under ``root`` (the invariant
    "nothing scored": a refused input adds no row to any table, no run either)."""
    import sqlite3

    out = {}
    for db in sorted(Path(root).rglob("*.db")):
        try:
            with sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=1) as con:
                for (t,) in con.execute("SELECT name FROM sqlite_master WHERE type='table'").fetchall():
                    out[f"{db.relative_to(root)}:{t}"] = con.execute(f'SELECT count(*) FROM "{t}"').fetchone()[0]
        except sqlite3.Error:
            out[str(db.relative_to(root))] = -1
    return out


def removed_or_changed(before: dict, after: dict) -> list[str]:
    """Files of ``before`` that are gone or different in ``after`` (the invariant "nothing
    removed that was there")."""
    return [p for p, v in before.items() if after.get(p) != v]


@contextmanager
def deadline(seconds: int):
    """Fail (a ``TimeoutError`` naming a hang) instead of hanging the suite when the body blocks,
    e.g. on a FIFO. Main thread only (``SIGALRM``)."""
    def boom(*_):
        raise TimeoutError(f"no answer within {seconds} s (a hang)")

    old = signal.signal(signal.SIGALRM, boom)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
