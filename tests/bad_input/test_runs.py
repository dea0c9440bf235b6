"""Probe cases for runs, the results database, workers and concurrency (issue 11).

The runs use the tiny profile on the true-geometry map (``--map true``: no fit), a few seconds
each. Process-level cases run the CLI in subprocesses (``nb_subprocess`` or ``Popen``).
"""

from __future__ import annotations

import os
import re
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from .conftest import assert_clean_error, nb, nb_subprocess

TINY = ["run-navigation", "--profile", "tiny.toml", "--map", "true"]
DB = Path("results/navbench.db")


def episode_keys(db: Path = DB) -> list[tuple]:
    with sqlite3.connect(db) as con:
        return con.execute("SELECT cell_key, task_id, seed FROM episodes").fetchall()


def stored_count(db: Path) -> int:
    try:
        with sqlite3.connect(db, timeout=0.2) as con:
            return con.execute("SELECT count(*) FROM episodes").fetchone()[0]
    except sqlite3.Error:
        return 0


def descendants(pid: int) -> set[int]:
    """Every living process below ``pid`` (from /proc; zombies excluded)."""
    parent = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
            except (OSError, IndexError):
                continue
            if fields[0] != "Z":
                parent[int(d.name)] = int(fields[1])
    out, todo = set(), [pid]
    while todo:
        p = todo.pop()
        kids = [c for c, pp in parent.items() if pp == p and c not in out]
        out.update(kids)
        todo.extend(kids)
    return out


def _open_db_at_once(barrier, url, errors) -> None:
    from navbench.results.db import ResultsDB

    barrier.wait(timeout=60)
    try:
        ResultsDB(url).close()
    except Exception as e:  # noqa: BLE001 - reported to the parent
        errors.put(f"{type(e).__name__}: {e}")


def test_concurrent_commands_on_a_fresh_database_all_open_it(project):
    """Failure 1: commands starting together on a fresh SQLite database; one used to fail with
    "table runs already exists" (3 of 14 pairs). Here 3 processes x 8 fresh databases."""
    import multiprocessing as mp

    ctx = mp.get_context("fork")
    errors = ctx.Queue()
    for i in range(8):
        url = f"sqlite:///{project / 'results' / f'fresh{i}.db'}"
        barrier = ctx.Barrier(3)
        procs = [ctx.Process(target=_open_db_at_once, args=(barrier, url, errors)) for _ in range(3)]
        for p in procs:
            p.start()
        for p in procs:
            p.join(timeout=60)
        assert [p.exitcode for p in procs] == [0, 0, 0]
    failures = []
    while not errors.empty():
        failures.append(errors.get())
    assert failures == []


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_kill_9_leaves_no_workers_and_the_run_becomes_interrupted(project):
    """Failure 2: after ``kill -9`` of run-navigation its pool workers and forkserver lived on
    for minutes and its run stayed ``running`` for ever."""
    env = {**os.environ, "NAVBENCH_DB": f"sqlite:///{project / DB}"}
    args = [*TINY, "--workers", "2", "--chunk", "1", "--tasks", "4", "--seeds", "2"]  # 16 episodes
    proc = subprocess.Popen([sys.executable, "-m", "navbench.cli.main", *args], cwd=project, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        while (stored_count(project / DB) < 1 or len(descendants(proc.pid)) < 2) \
                and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        below = descendants(proc.pid)
        os.kill(proc.pid, signal.SIGKILL)  # the command alone, not its process group
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    stored = stored_count(project / DB)
    assert proc.returncode == -signal.SIGKILL and below, proc.stderr.read().decode()[-2000:]
    assert 0 < stored < 16, f"kill landed outside the run ({stored} of 16 stored)"
    deadline = time.monotonic() + 5
    while below & _living() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not below & _living(), f"workers outlived the killed command: {below & _living()}"

    res = nb_subprocess(*args, cwd=project, env=env)
    assert res.code == 0, res.output
    keys = episode_keys(project / DB)
    assert len(keys) == 16 == len(set(keys))  # none lost, none twice
    with sqlite3.connect(project / DB) as con:
        assert [s for (s,) in con.execute("SELECT status FROM runs ORDER BY id")] == ["interrupted", "done"]


def _living() -> set[int]:
    """Pids of every process that is not a zombie."""
    out = set()
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if (d / "stat").read_text().rsplit(")", 1)[1].split()[0] != "Z":
                    out.add(int(d.name))
            except (OSError, IndexError):
                continue
    return out


def test_two_concurrent_identical_runs_report_true_counts(project):
    """Failure 3: two identical runs at once both simulated everything and each claimed to
    have stored every episode. Now one row per episode, and the two "stored N new" add up."""
    args = [*TINY, "--workers", "1", "--chunk", "1", "--tasks", "4"]  # 8 episodes
    results = [None, None]

    def run(i: int) -> None:
        results[i] = nb_subprocess(*args, cwd=project)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        assert r.code == 0, r.output
    keys = episode_keys()
    assert len(keys) == 8 == len(set(keys))
    news = [int(re.search(r"stored (\d+) new episodes; (\d+)/(\d+)", r.out).group(1)) for r in results]
    assert sum(news) == 8, [r.out for r in results]
    for r in results:  # the final line's grid count is true for both
        assert "8/8 of the grid are in the database" in r.out, r.out


def test_corrupt_trajectory_of_a_stored_episode_is_restored(project):
    """Failure 4: a trajectory artifact that fails its checksum while its row exists was
    reported unavailable and never recomputed. The rerun restores it (same score, no new row)."""
    from navbench.pipeline.cache import ArtifactStore

    assert nb(*TINY).code == 0
    with sqlite3.connect(DB) as con:
        (key,) = con.execute("SELECT traj_key FROM episodes ORDER BY id LIMIT 1").fetchone()
        before = con.execute("SELECT * FROM episodes ORDER BY id").fetchall()
    store = ArtifactStore("results/cache")
    f = store.path("episode", key) / "episode.npz"
    data = bytearray(f.read_bytes())
    data[len(data) // 2] ^= 0xFF  # same size, wrong checksum
    f.write_bytes(bytes(data))
    res = nb(*TINY)
    assert res.code == 0, res.output
    assert "restored 1 trajectory" in res.output and "does not reproduce" not in res.output, res.output
    store.verify("episode", key)
    with sqlite3.connect(DB) as con:
        assert con.execute("SELECT * FROM episodes ORDER BY id").fetchall() == before


def test_unreachable_ray_address_fails_fast_naming_it(project):
    """Failure 5: ``--executor ray --address 127.0.0.1:1`` retried for minutes."""
    pytest.importorskip("ray", reason="ray is not installed (optional extra navbench[ray])")
    t0 = time.monotonic()
    res = nb(*TINY, "--executor", "ray", "--address", "127.0.0.1:1")
    assert time.monotonic() - t0 < 30
    assert_clean_error(res, "--address 127.0.0.1:1")
