"""A measurement resumed over several runs: ``--run latest`` takes the runs it resumed."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from navbench.errors import DatabaseError
from navbench.results.db import ResultsDB
from navbench.results.db.resume import describe_selection, resolve_run_ids, resume_chain
from navbench.results.score import score_table

from .test_db import episode

CONFIG = {"name": "quick", "levels": ["l1"], "tasks": 4, "workers": 2}
CMD = "navbench run-navigation l1 --tasks 4 --workers 2"


@pytest.fixture
def db(tmp_path):
    d = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    yield d
    d.close()


def _run(db, status, task_ids, config=CONFIG, command=CMD, profile="quick", cell="c1"):
    run_id = db.start_run(profile, command, config, "h")
    if task_ids:
        db.add_episodes(run_id, [episode(cell, t, spl_term=0.1 * (t + 1)) for t in task_ids])
    db.finish_run(run_id, status)
    return run_id


def test_latest_is_the_newest_run_with_the_runs_it_resumed(db):
    done_before = _run(db, "done", [], config={**CONFIG, "tasks": 2})      # another measurement
    a = _run(db, "interrupted", [0])
    other = _run(db, "done", [0], config={**CONFIG, "levels": ["l2"]}, cell="c9")  # in between
    b = _run(db, "failed", [1], config={**CONFIG, "workers": 4},           # other worker count:
             command="navbench run-navigation l1 --tasks 4 --workers 4")   # the same measurement
    c = _run(db, "done", [2, 3])
    assert resume_chain(db.runs_frame(), c) == [a, b, c]
    assert resolve_run_ids(db, "latest") == [a, b, c]
    assert resolve_run_ids(db, f"{c}") == [c]  # explicit ids stay literal
    assert resolve_run_ids(db, "all") is None
    assert done_before not in resolve_run_ids(db, "latest") and other not in resolve_run_ids(db, "latest")
    t = score_table(db, run="latest", n_boot=20)
    row = t[(t["level"] == "l1")].iloc[0]
    assert row["episodes"] == 4 and row["spl"] == pytest.approx((0.1 + 0.2 + 0.3 + 0.4) / 4)
    assert describe_selection([a, b, c], "latest") == (
        f"--run latest: runs {a}, {b}, {c} (run {c} resumed {a}, {b}, which did not finish: one measurement)")
    assert describe_selection([c], "latest") is None and describe_selection([a, c], f"{a},{c}") is None


def test_a_finished_run_starts_a_new_measurement(db):
    _run(db, "interrupted", [0])
    first = _run(db, "done", [1, 2, 3])
    again = _run(db, "done", [])           # the same command after it finished: nothing resumed
    assert resume_chain(db.runs_frame(), again) == [again]
    assert resolve_run_ids(db, "latest") == resume_chain(db.runs_frame(), first)
    assert len(resume_chain(db.runs_frame(), first)) == 2


def test_runs_without_a_config_or_of_another_profile_or_command_are_not_chained(db):
    a = _run(db, "interrupted", [0], config={}, command="bench e2e", profile="bench")
    b = _run(db, "done", [1], config={}, command="bench e2e", profile="bench")
    assert resume_chain(db.runs_frame(), b) == [b]
    c = _run(db, "interrupted", [0], cell="c2")
    d = _run(db, "done", [1], profile="paper", cell="c2")
    e = _run(db, "done", [2], command="navbench all l1 --tasks 4", cell="c2")
    assert resume_chain(db.runs_frame(), d) == [d] and resume_chain(db.runs_frame(), e) == [e]
    assert resume_chain(db.runs_frame(), 999) == [999] and a < c


def test_bad_selections_are_database_errors(db):
    with pytest.raises(DatabaseError, match="no episodes stored"):
        resolve_run_ids(db, "latest")
    with pytest.raises(DatabaseError, match="no run in"):
        resolve_run_ids(db, "latest", latest="any")
    a = _run(db, "done", [0])
    with pytest.raises(DatabaseError, match="no run with id 7"):
        resolve_run_ids(db, f"{a},7")
    with pytest.raises(DatabaseError, match="comma-separated"):
        resolve_run_ids(db, "4,x")


def test_score_and_export_say_which_runs_latest_took(db, tmp_path):
    from navbench.cli.main import app

    a = _run(db, "interrupted", [0])
    b = _run(db, "done", [1, 2])
    res = CliRunner().invoke(app, ["score", "--db", db.url, "--boot", "20", "--run", "latest", "--format", "json"])
    assert res.exit_code == 0, res.output
    assert f"--run latest: runs {a}, {b} (run {b} resumed {a}, which did not finish" in res.stderr
    scores = json.loads(res.stdout)["scores"]
    assert {r["level"]: r["episodes"] for r in scores} == {"l1": 3, "all": 3}
    proc = subprocess.run([sys.executable, "-m", "navbench.cli.main", "export-trajectories", str(tmp_path / "x"),
                           "--db", db.url, "--run", "1,x"], capture_output=True, text=True, timeout=120)
    err = proc.stderr.strip()
    assert proc.returncode == 2 and err.startswith("error:") and "comma-separated" in err and len(err.splitlines()) == 1


def test_db_runs_lists_the_runs_each_resumed(db, monkeypatch):
    from navbench.cli import _common
    from navbench.cli.main import app

    monkeypatch.setattr(_common.console, "_width", 250)  # every column whole, whatever the terminal

    a = _run(db, "interrupted", [0])
    b = _run(db, "interrupted", [1])
    c = _run(db, "done", [2])
    res = CliRunner().invoke(app, ["db", "runs", "--db", db.url])
    assert res.exit_code == 0, res.output
    rows = {ln.split("│")[1].strip(): ln for ln in res.stdout.splitlines() if ln.startswith("│")}
    assert "resumes" in res.stdout
    assert f"│ {a}, {b} " in rows[str(c)] and f"│ {a} " in rows[str(b)]


def test_a_run_recorded_before_benchmark_versions_is_resumed_as_navbench_1(db):
    """A profile's recorded config holds its benchmark version since issue 36; an interrupted run
    recorded before (no such key) is the same measurement as its rerun under navbench-1, and
    not as one under another version."""
    old = _run(db, "interrupted", [0])
    new = _run(db, "done", [1], config={**CONFIG, "benchmark_version": "navbench-1"})
    assert resume_chain(db.runs_frame(), new) == [old, new]
    other = _run(db, "interrupted", [2], config={**CONFIG, "tasks": 5})
    later = _run(db, "done", [3], config={**CONFIG, "tasks": 5, "benchmark_version": "navbench-9"})
    assert resume_chain(db.runs_frame(), later) == [later] and other not in resume_chain(db.runs_frame(), later)
