"""run-navigation: resumable after kill -9, same results in a pool as in-process, Ray back end."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from navbench.levelio import save_level

from .test_stages import tiny_level

NAVBENCH = str(Path(sys.executable).parent / "navbench")
# 6 tasks x (gt, dynamics) x low noise x 2 seeds = 24 episodes on the true-geometry map
ARGS = ["run-navigation", "tiny", "--estimators", "gt,dynamics", "--noise", "low", "--tasks", "6",
        "--seeds", "2", "--map", "true"]
TOTAL = 24
COLUMNS = "cell_key, task_id, seed, estimator, success, spl_term, path_length, steps, loc_rmse_m, traj_key"


def workdir(root: Path) -> Path:
    (root / "levels").mkdir(parents=True)
    save_level(tiny_level(), root / "levels" / "tiny.json")
    return root


def episodes(db: Path) -> list[tuple]:
    with sqlite3.connect(db) as con:
        return sorted(con.execute(f"SELECT {COLUMNS} FROM episodes").fetchall())


def count(db: Path) -> int:
    """Episodes stored so far (0 before the table exists). The timeout is long enough to wait out
    a writer's lock: with a short one, a loaded machine read 0 until the run had finished, and
    the "interrupt" then landed on a process already exiting (CI, 2026-11-27)."""
    try:
        with sqlite3.connect(db, timeout=10) as con:
            return con.execute("SELECT count(*) FROM episodes").fetchone()[0]
    except sqlite3.Error:
        return 0


def run_cli(root: Path, extra: list[str]):
    env = {**os.environ, "NAVBENCH_DB": f"sqlite:///{root / 'nb.db'}", "COLUMNS": "100"}
    return subprocess.run([NAVBENCH, *ARGS, *extra], cwd=root, env=env, capture_output=True,
                          text=True, timeout=300)


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> list[tuple]:
    """An uninterrupted run, in this process (--workers 1), through the CLI."""
    from navbench.cli.main import app

    root = workdir(tmp_path_factory.mktemp("ref"))
    cwd = os.getcwd()
    os.chdir(root)
    try:
        res = CliRunner().invoke(app, [*ARGS, "--workers", "1", "--db", f"sqlite:///{root / 'nb.db'}"])
    finally:
        os.chdir(cwd)
    assert res.exit_code == 0, res.output
    rows = episodes(root / "nb.db")
    assert len(rows) == TOTAL
    return rows


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT], ids=["kill-9", "ctrl-c"])
def test_interrupt_then_rerun_gives_the_uninterrupted_result(tmp_path, reference, sig):
    root = workdir(tmp_path)
    db = root / "nb.db"
    env = {**os.environ, "NAVBENCH_DB": f"sqlite:///{db}"}
    proc = subprocess.Popen([NAVBENCH, *ARGS, "--workers", "2", "--chunk", "1"], cwd=root, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True,
                            # a background shell may have left SIGINT ignored; a terminal would not
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 240
    while count(db) < 2 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.005)
    running = proc.poll() is None
    os.killpg(proc.pid, sig)  # the parent and its workers, as kill -9 or a terminal's Ctrl-C
    proc.wait(timeout=120)
    stored = count(db)
    assert running and 0 < stored < TOTAL, f"kill landed outside the run ({stored} of {TOTAL} stored)"
    expected_rc = -signal.SIGKILL if sig == signal.SIGKILL else 130
    assert proc.returncode == expected_rc, proc.stderr.read().decode()[-2000:]

    res = run_cli(root, ["--workers", "2"])
    assert res.returncode == 0, res.stderr[-2000:]
    rows = episodes(db)
    assert len(rows) == TOTAL == len({r[:3] for r in rows})  # none lost, none twice
    assert rows == reference  # same cells, scores and trajectory keys as the uninterrupted run
    with sqlite3.connect(db) as con:
        statuses = [s for (s,) in con.execute("SELECT status FROM runs ORDER BY id")]
    # Ctrl-C closes the run as interrupted; a killed run never gets to close itself, and the
    # next command, finding its process gone, marks it interrupted
    assert statuses == ["interrupted", "done"]
    assert "run 2 resumes run(s) 1 of the same setup" in res.stdout + res.stderr
    from navbench.results.db import ResultsDB
    from navbench.results.db.resume import resolve_run_ids

    with ResultsDB(f"sqlite:///{db}") as rdb:  # the measurement is both runs' episodes
        assert resolve_run_ids(rdb, "latest") == [1, 2]

    from navbench.cli.main import app

    cwd = os.getcwd()
    os.chdir(root)
    try:  # nothing left to do
        again = CliRunner().invoke(app, [*ARGS, "--workers", "2", "--db", f"sqlite:///{db}"])
    finally:
        os.chdir(cwd)
    assert again.exit_code == 0 and "stored 0 new episodes" in again.output
    assert "resumes" not in again.output  # run 2 finished: a new run of it resumes nothing
    assert episodes(db) == reference


def test_stored_trajectory_is_scored_without_simulating(tmp_path, monkeypatch, reference):
    """A run killed after writing a trajectory but before its row: the rerun scores the stored
    trajectory instead of simulating it again."""
    from navbench.cli.main import app
    from navbench.pipeline.stages import navigation as stages

    root = workdir(tmp_path)
    monkeypatch.chdir(root)
    url = f"sqlite:///{root / 'nb.db'}"
    assert CliRunner().invoke(app, [*ARGS, "--workers", "1", "--db", url]).exit_code == 0
    with sqlite3.connect(root / "nb.db") as con:
        con.execute("DELETE FROM episodes WHERE task_id = 0")
    calls = []
    real = stages.run_episode_chunk
    monkeypatch.setattr(stages, "run_episode_chunk", lambda spec: calls.append(spec) or real(spec))
    res = CliRunner().invoke(app, [*ARGS, "--workers", "1", "--db", url])
    assert res.exit_code == 0, res.output
    assert calls == [] and "4 from stored trajectories" in res.output
    assert episodes(root / "nb.db") == reference


def test_tampered_trajectory_is_simulated_again(tmp_path, monkeypatch, reference):
    from navbench.cli.main import app
    from navbench.pipeline.cache import ArtifactStore

    root = workdir(tmp_path)
    monkeypatch.chdir(root)
    url = f"sqlite:///{root / 'nb.db'}"
    assert CliRunner().invoke(app, [*ARGS, "--workers", "1", "--db", url]).exit_code == 0
    with sqlite3.connect(root / "nb.db") as con:
        (key,) = con.execute("SELECT traj_key FROM episodes WHERE task_id = 1 AND seed = 0 "
                             "AND estimator = 'gt'").fetchone()
        con.execute("DELETE FROM episodes WHERE traj_key = ?", (key,))
    f = ArtifactStore("results/cache").path("episode", key) / "episode.npz"
    f.write_bytes(f.read_bytes()[:-10])
    res = CliRunner().invoke(app, [*ARGS, "--workers", "1", "--db", url])
    assert res.exit_code == 0, res.output
    assert "warning" in res.output and "1 run now" in res.output
    assert episodes(root / "nb.db") == reference


@pytest.mark.slow
@pytest.mark.xdist_group("ray")  # never beside the other Ray test: two clusters at once collide
def test_ray_executor_matches_local(tmp_path, monkeypatch, reference):
    pytest.importorskip("ray", reason="ray is not installed (optional extra navbench[ray])")
    from navbench.cli.main import app

    root = workdir(tmp_path)
    monkeypatch.chdir(root)
    monkeypatch.setenv("RAY_ENABLE_UV_RUN_RUNTIME_ENV", "0")
    res = CliRunner().invoke(app, [*ARGS, "--executor", "ray", "--workers", "1",
                                   "--db", f"sqlite:///{root / 'nb.db'}"])
    assert res.exit_code == 0, res.output
    assert episodes(root / "nb.db") == reference


def test_make_executor_choices():
    from navbench.errors import ConfigError
    from navbench.pipeline.executor import LocalExecutor, SerialExecutor, make_executor

    assert isinstance(make_executor("local", 1), SerialExecutor)
    assert isinstance(make_executor("local", 3), LocalExecutor)
    with pytest.raises(ConfigError):
        make_executor("dask", 2)
    with pytest.raises(ConfigError):
        make_executor("local", 2, address="ray://head:10001")
    with LocalExecutor(2) as ex:
        assert sorted(ex.map_unordered(abs, [-3, 1, -2, 5, -4])) == [1, 2, 3, 4, 5]
