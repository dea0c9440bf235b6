"""Results database: round trips, duplicate-proof inserts, filters, errors (SQLite + PostgreSQL).

The PostgreSQL variant runs when ``NAVBENCH_TEST_PG_URL`` names a reachable server (for example
``postgresql+psycopg://postgres@localhost/navbench_test``); each test gets its own schema, dropped
afterwards, so the database named there is left as it was.
"""

from __future__ import annotations

import os
import uuid
from dataclasses import dataclass
from urllib.parse import quote

import numpy as np
import pytest

from navbench.errors import DatabaseError
from navbench.nav.metrics import EpisodeScore
from navbench.results.db import ResultsDB, episode_row_from_score

PG_URL = os.environ.get("NAVBENCH_TEST_PG_URL")


@dataclass(frozen=True)
class FakeTask:
    id: int
    start: tuple
    target: tuple
    optimal_length: float


def episode(cell="cellA", task_id=0, seed=0, level="l1", estimator="ours", noise="low",
            success=True, spl_term=0.9, **extra) -> dict:
    row = dict(cell_key=cell, level=level, map_key="mapk", task_set_key="tsk", task_id=task_id,
               estimator=estimator, estimator_options={"steps": 100}, noise=noise, seed=seed,
               success=success, spl_term=spl_term, path_length=5.0, optimal_length=4.5, steps=40,
               end_reason="reached", collided=False, loc_rmse_m=0.05, rot_rmse_deg=1.0,
               step_ms=12.0, traj_key=f"traj-{cell}-{task_id}-{seed}")
    row.update(extra)
    return row


def _pg_schema_url(base: str, schema: str) -> str:
    sep = "&" if "?" in base else "?"
    return f"{base}{sep}options={quote(f'-csearch_path={schema}')}"


@pytest.fixture(params=["sqlite", pytest.param("postgres", marks=pytest.mark.postgres)])
def db(request, tmp_path):
    if request.param == "sqlite":
        d = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
        yield d
        d.close()
        return
    if not PG_URL:
        pytest.skip("NAVBENCH_TEST_PG_URL is not set (no PostgreSQL server to test against)")
    from sqlalchemy import create_engine, text

    try:
        import psycopg  # noqa: F401
    except ImportError:
        pytest.fail("NAVBENCH_TEST_PG_URL is set but psycopg is missing: pip install -e '.[postgres]'")
    schema = f"nbtest_{uuid.uuid4().hex[:12]}"
    admin = create_engine(PG_URL)
    with admin.begin() as conn:
        conn.execute(text(f'CREATE SCHEMA "{schema}"'))
    d = None
    try:
        d = ResultsDB(_pg_schema_url(PG_URL, schema))
        yield d
    finally:
        if d is not None:
            d.close()
        with admin.begin() as conn:
            conn.execute(text(f'DROP SCHEMA "{schema}" CASCADE'))
        admin.dispose()


def test_run_lifecycle(db):
    rid = db.start_run("quick", "run-navigation", {"a": 1, "b": [1.5, 2]}, "h" * 64)
    rid2 = db.start_run("quick", "all", {}, "g" * 64)
    assert rid2 > rid
    runs = db.runs_frame()
    assert list(runs["id"]) == [rid, rid2]
    first = runs.iloc[0]
    assert first["status"] == "running" and first["config"] == {"a": 1, "b": [1.5, 2]}
    assert first["config_hash"] == "h" * 64 and first["host"] and first["cpu"]
    assert first["navbench_version"]
    db.finish_run(rid, "failed")
    runs = db.runs_frame()
    assert runs.iloc[0]["status"] == "failed" and runs.iloc[0]["finished"] is not None
    assert runs.iloc[0]["finished"] >= runs.iloc[0]["started"]
    assert db.latest_run_id() == rid2
    assert db.latest_run_id(command="run-navigation") == rid
    with pytest.raises(DatabaseError):
        db.finish_run(9999)
    with pytest.raises(DatabaseError):
        db.finish_run(rid, "weird")


def test_episodes_unique_and_done_keys(db):
    rid = db.start_run("quick", "run-navigation", {}, "x")
    rows = [episode(task_id=t, seed=s) for t in range(3) for s in (0, 1)]
    rows.append(episode(cell="cellB", task_id=0, seed=0, estimator="dynamics"))
    assert db.add_episodes(rid, rows) == 7
    assert db.add_episodes(rid, rows) == 0  # same rows again: nothing new
    # a batch with one new row and an in-batch duplicate of it
    assert db.add_episodes(rid, rows[:2] + [episode(task_id=9), episode(task_id=9)]) == 1
    frame = db.episodes_frame()
    assert len(frame) == 8
    assert not frame.duplicated(["cell_key", "task_id", "seed"]).any()
    done = db.done_episode_keys(["cellA", "cellZ"])
    assert done == {("cellA", t, s) for t in range(3) for s in (0, 1)} | {("cellA", 9, 0)}
    assert db.done_episode_keys([]) == set()
    # the first stored value stays
    assert db.add_episodes(rid, [episode(task_id=0, seed=0, spl_term=0.1)]) == 0
    got = db.episodes_frame(cell_key="cellA", task_id=0, seed=0)
    assert len(got) == 1 and got.iloc[0]["spl_term"] == pytest.approx(0.9)


def test_episodes_frame_filters_and_types(db):
    r1 = db.start_run("quick", "run-navigation", {}, "x")
    r2 = db.start_run("quick", "run-navigation", {}, "y")
    db.add_episodes(r1, [episode(task_id=0, level="l1", noise="low"),
                         episode(task_id=1, level="l2", noise="mid", success=False, spl_term=0.0,
                                 loc_rmse_m=float("nan"))])
    db.add_episodes(r2, [episode(cell="c2", task_id=0, level="l1", noise="high",
                                 estimator="no-map")])
    assert len(db.episodes_frame()) == 3
    assert list(db.episodes_frame(run_ids=[r2])["estimator"]) == ["no-map"]
    assert len(db.episodes_frame(run_ids=[r1, r2], level="l1")) == 2
    assert set(db.episodes_frame(noise=["low", "mid"])["task_id"]) == {0, 1}
    assert len(db.episodes_frame(level="l1", noise="mid")) == 0
    f = db.episodes_frame(level="l2")
    row = f.iloc[0]
    assert not bool(row["success"]) and np.isnan(row["loc_rmse_m"])  # NaN stored as NULL
    assert row["estimator_options"] == {"steps": 100}
    assert f["spl_term"].dtype == float
    with pytest.raises(ValueError):
        db.episodes_frame(colour="red")
    empty = db.episodes_frame(level="nowhere")
    assert len(empty) == 0 and "spl_term" in empty.columns


def test_episode_row_validation(db):
    rid = db.start_run("quick", "run-navigation", {}, "x")
    with pytest.raises(DatabaseError, match="unknown column"):
        db.add_episodes(rid, [episode(colour="red")])
    bad = episode()
    del bad["spl_term"]
    with pytest.raises(DatabaseError, match="spl_term"):
        db.add_episodes(rid, [bad])
    with pytest.raises(DatabaseError):  # foreign key: no such run
        db.add_episodes(rid + 100, [episode()])
    assert len(db.episodes_frame()) == 0


def test_episode_row_from_score_round_trip(db):
    rid = db.start_run("quick", "run-navigation", {}, "x")
    timings = {"sim": np.array([1.0, 2.0, 3.0]), "render": np.array([10.0, 10.0, 40.0]),
               "estimate": np.array([5.0, 7.0, 6.0]), "plan": np.array([0.0, 0.0, 9.0]),
               "control": np.array([0.5, 0.5, 0.5])}
    meta = dict(level="l1", map_key="m", task_set_key="ts", estimator="ours",
                estimator_options={"lr": 0.02}, noise="mid", seed=np.int64(3), task_id=7,
                timings_ms=timings)
    score = EpisodeScore(True, 4.0, 3.6, 0.9, np.float64(0.04), 1.5, 3, "reached", False)
    row = episode_row_from_score("cell", meta, score, "trajkey")
    assert row["sim_ms"] == 2.0 and row["render_ms"] == 10.0 and row["estimate_ms"] == 6.0
    assert row["plan_ms"] == 0.0 and row["control_ms"] == 0.5
    # per-step sums 16.5, 19.5, 58.5 -> median 19.5
    assert row["step_ms"] == pytest.approx(19.5)
    assert db.add_episodes(rid, [row]) == 1
    got = db.episodes_frame().iloc[0]
    assert got["cell_key"] == "cell" and got["task_id"] == 7 and got["seed"] == 3
    assert got["traj_key"] == "trajkey" and got["end_reason"] == "reached" and not bool(got["collided"])
    assert got["loc_rmse_m"] == pytest.approx(0.04) and got["step_ms"] == pytest.approx(19.5)
    assert got["estimator_options"] == {"lr": 0.02} and bool(got["success"])


def test_levels_maps_tasks_idempotent(db):
    db.record_level("l1", "abc", {"rooms": 3})
    db.record_level("l1", "abc", {"rooms": 3})
    db.record_level("l1", "def", {"rooms": 4})
    lv = db.levels_frame()
    assert list(zip(lv["name"], lv["content_hash"])) == [("l1", "abc"), ("l1", "def")]
    db.record_map("l1", "map1", {"depth_mae_m": 0.05, "rgb_l1": 0.1, "steps": 1000, "extra": 2.0})
    db.record_map("l1", "map1", {"depth_mae_m": 9.0})
    maps = db.maps_frame()
    assert len(maps) == 1
    m = maps.iloc[0]
    assert m["depth_mae_m"] == 0.05 and m["steps"] == 1000 and np.isnan(m["slice_recall"])
    assert m["metrics"]["extra"] == 2.0
    tasks = [FakeTask(0, (1.0, 2.0, 0.5), (3.0, 4.0), 2.9), FakeTask(1, (1.5, 2.0, 0.0), (5.0, 4.0), 4.1)]
    db.record_task_set("l1", "ts1", tasks)
    db.record_task_set("l1", "ts1", tasks)
    t = db.tasks_frame("ts1")
    assert list(t["task_id"]) == [0, 1]
    assert t.iloc[1]["target_x"] == 5.0 and t.iloc[0]["start_theta"] == 0.5
    assert len(db.tasks_frame(level="nowhere")) == 0


def test_tracking_and_bench_rows(db):
    rid = db.start_run("quick", "track", {}, "x")
    rows = [dict(study_key="s1", level="l1", estimator=e, estimator_options={}, noise="tracking",
                 trajectory_id=i, seed=0, loc_rmse_m=0.01 * i, rot_rmse_deg=0.5, step_ms_median=30.0)
            for e in ("ours", "emission") for i in range(3)]
    assert db.add_tracking_rows(rid, rows) == 6
    assert db.add_tracking_rows(rid, rows) == 0
    assert len(db.tracking_frame(estimator="ours")) == 3
    assert len(db.tracking_frame(run_ids=[rid], level="l1")) == 6
    bench = [dict(metric="render_ms", value=np.float32(4.5), unit="ms"),
             dict(metric="render_ms", value=1.0, unit="ms", device="cuda:0")]
    assert db.add_bench_rows(rid, bench) == 2
    assert db.add_bench_rows(rid, bench) == 0
    b = db.bench_frame()
    assert list(b["device"]) == ["cpu", "cuda:0"]
    assert b.iloc[0]["value"] == 4.5 and b.iloc[0]["host"] and b.iloc[0]["navbench_version"]
    with pytest.raises(DatabaseError):
        db.add_bench_rows(rid + 50, bench)


def test_default_url_is_relative_sqlite(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("NAVBENCH_DB", raising=False)
    d = ResultsDB()
    assert d.url == "sqlite:///results/navbench.db"
    d.start_run("quick", "x", {}, "h")
    d.close()
    assert (tmp_path / "results" / "navbench.db").is_file()
    monkeypatch.setenv("NAVBENCH_DB", f"sqlite:///{tmp_path / 'other.db'}")
    d = ResultsDB()
    d.close()
    assert (tmp_path / "other.db").is_file()


@pytest.mark.parametrize("url", [
    "not a url",
    "nosuchdialect://x/y",
    "postgresql+psycopg://nobody@127.0.0.1:1/nothing?connect_timeout=2",
])
def test_bad_urls_are_one_line_database_errors(url):
    with pytest.raises(DatabaseError) as info:
        ResultsDB(url)
    assert "\n" not in str(info.value)


def test_generic_insert_fallback_ignores_duplicates(db):
    """The select-then-insert path used for dialects without ON CONFLICT."""
    from navbench.results.db import EpisodeRow

    rid = db.start_run("quick", "run-navigation", {}, "x")
    db.add_episodes(rid, [episode(task_id=0)])
    full = db.episodes_frame().drop(columns=["id"]).iloc[0].to_dict()
    rows = []
    for t in (0, 1, 1, 2):
        r = dict(full, task_id=t)
        r["recorded"] = r["recorded"].to_pydatetime()
        rows.append(r)
    with db._begin() as conn:
        assert db._insert_ignore(conn, EpisodeRow, rows, ("cell_key", "task_id", "seed"),
                                 dialect="generic") == 2
    assert sorted(db.episodes_frame()["task_id"]) == [0, 1, 2]


def test_read_only_open_of_a_missing_sqlite_file(tmp_path):
    with pytest.raises(DatabaseError, match="no results database"):
        ResultsDB(f"sqlite:///{tmp_path / 'missing.db'}", create=False)
    assert not (tmp_path / "missing.db").exists()
    ResultsDB(f"sqlite:///{tmp_path / 'made.db'}").close()
    ResultsDB(f"sqlite:///{tmp_path / 'made.db'}", create=False).close()


def test_schema_version_is_recorded_and_checked(tmp_path):
    from sqlalchemy import text

    url = f"sqlite:///{tmp_path / 'v.db'}"
    d = ResultsDB(url)
    with d.engine.begin() as conn:
        assert conn.execute(text("SELECT value FROM navbench_meta WHERE key='schema_version'")).scalar() == "1"
        conn.execute(text("UPDATE navbench_meta SET value='99' WHERE key='schema_version'"))
    d.close()
    with pytest.raises(DatabaseError, match="schema version 99"):
        ResultsDB(url)


def _open_at_once(barrier, urls, errors) -> None:
    """Child process: for each fresh database URL, wait for the others, then open it."""
    for url in urls:
        barrier.wait(timeout=60)
        try:
            ResultsDB(url).close()
        except Exception as e:  # noqa: BLE001 - reported to the parent
            errors.put(f"{url}: {type(e).__name__}: {e}")


def test_concurrent_first_opens_of_a_fresh_database(tmp_path):
    """Several commands opening one fresh SQLite file at the same moment all succeed (they
    used to race between "is the table there?" and CREATE TABLE: "table runs already exists")."""
    import multiprocessing as mp

    ctx = mp.get_context("fork")  # children start at once, navbench already imported
    procs, rounds = 4, 12
    urls = [f"sqlite:///{tmp_path / f'fresh{i}.db'}" for i in range(rounds)]
    barrier, errors = ctx.Barrier(procs), ctx.Queue()
    children = [ctx.Process(target=_open_at_once, args=(barrier, urls, errors)) for _ in range(procs)]
    for c in children:
        c.start()
    for c in children:
        c.join(timeout=120)
    failures = []
    while not errors.empty():
        failures.append(errors.get())
    assert failures == [] and [c.exitcode for c in children] == [0] * procs, failures
    for url in urls:
        d = ResultsDB(url)
        assert set(d.table_counts()) >= {"runs", "episodes"}
        d.close()


def test_old_database_gains_the_run_process_columns(tmp_path):
    """A database written before runs had pid/proc_start opens, keeps its rows and gets them."""
    import sqlite3

    path = tmp_path / "old.db"
    ResultsDB(f"sqlite:///{path}").close()
    with sqlite3.connect(path) as con:  # back to the layout as first shipped
        con.execute("ALTER TABLE runs DROP COLUMN pid")
        con.execute("ALTER TABLE runs DROP COLUMN proc_start")
        con.execute("INSERT INTO runs (profile, command, config, config_hash, navbench_version, host, "
                    "cpu, started, status) VALUES ('p', 'c', '{}', 'h', '0', 'elsewhere', 'cpu', "
                    "'2026-01-01 00:00:00', 'running')")
    d = ResultsDB(f"sqlite:///{path}")
    runs = d.runs_frame()
    assert list(runs["status"]) == ["running"] and runs["pid"].isna().all()
    rid = d.start_run("p", "c", {}, "h")
    assert int(d.runs_frame().set_index("id").loc[rid, "pid"]) == os.getpid()
    d.close()


def test_runs_of_dead_processes_become_interrupted(tmp_path):
    """A run left ``running`` by a process that is gone (kill -9) is marked interrupted the next
    time the database is opened; a live process's run and other hosts' runs are left alone."""
    import socket
    import subprocess
    import sys

    from sqlalchemy import update

    from navbench.results.db import Run

    url = f"sqlite:///{tmp_path / 'r.db'}"
    d = ResultsDB(url)
    dead_id = d.start_run("p", "c", {}, "h")
    live_id = d.start_run("p", "c", {}, "h")
    other_id = d.start_run("p", "c", {}, "h")
    reused_id = d.start_run("p", "c", {}, "h")
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    with d.engine.begin() as conn:
        conn.execute(update(Run).where(Run.id == dead_id).values(pid=gone.pid, proc_start=None))
        conn.execute(update(Run).where(Run.id == other_id).values(pid=gone.pid, host="other-host"))
        # this process's pid, but recorded for a process that started at another time
        conn.execute(update(Run).where(Run.id == reused_id).values(
            proc_start=(d.runs_frame().set_index("id").loc[reused_id, "proc_start"] or "x:1") + "0"))
    d.close()
    d = ResultsDB(url)
    status = d.runs_frame().set_index("id")["status"]
    assert socket.gethostname() != "other-host"
    assert status[dead_id] == "interrupted" and status[live_id] == "running"
    assert status[other_id] == "running"
    if d.runs_frame().set_index("id").loc[live_id, "proc_start"]:  # start times readable (Linux)
        assert status[reused_id] == "interrupted"
    d.close()


def test_add_episodes_counts_rows_actually_inserted(db):
    """Two writers of the same episodes: each learns how many rows were really its own."""
    rid = db.start_run("p", "c", {}, "h")
    assert db.add_episodes(rid, [episode(task_id=t) for t in (0, 1)]) == 2
    assert db.add_episodes(rid, [episode(task_id=t) for t in (1, 2, 3)]) == 2
    assert db.stored_episode_keys([("cellA", 1, 0), ("cellA", 9, 0), ("cellB", 0, 0)]) == {("cellA", 1, 0)}
    out = db.episode_outcomes(["cellA"])
    assert sorted(out) == [("cellA", t, 0) for t in range(4)]
    assert out[("cellA", 2, 0)]["traj_key"] == "traj-cellA-2-0" and out[("cellA", 2, 0)]["steps"] == 40
