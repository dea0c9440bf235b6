"""A larger --tasks or --seeds after a smaller one extends the same cell (issue 16): the score
counts each (task, seed) once, whatever task sets stored it."""

from __future__ import annotations

import json
import os
import sqlite3

import pytest
from typer.testing import CliRunner

from .test_run_navigation import workdir

BASE = ["run-navigation", "tiny", "--estimators", "gt,dynamics", "--noise", "low", "--map", "true",
        "--workers", "1"]


@pytest.mark.slow
def test_more_tasks_and_seeds_extend_the_cell_without_double_counting(tmp_path):
    from navbench.cli.main import app

    root = workdir(tmp_path)
    url = f"sqlite:///{root / 'nb.db'}"
    cwd = os.getcwd()
    os.chdir(root)
    try:
        runner = CliRunner()
        for extra in (["--tasks", "2"], ["--tasks", "4", "--seeds", "2"]):
            res = runner.invoke(app, [*BASE, *extra, "--db", url])
            assert res.exit_code == 0, res.output
        res = runner.invoke(app, ["score", "--format", "json", "--db", url, "--boot", "50"])
    finally:
        os.chdir(cwd)
    assert res.exit_code == 0, res.output
    with sqlite3.connect(root / "nb.db") as con:
        rows = con.execute("SELECT task_set_key, estimator, task_id, seed, spl_term, path_length, "
                           "condition_key FROM episodes").fetchall()
    # the two runs stored tasks 0 and 1 (seed 0) under two task sets, hence two cells:
    # 2 x 2 episodes, then 4 tasks x 2 seeds x 2 estimators
    assert len(rows) == 4 + 16 and len({r[0] for r in rows}) == 2
    # ... as the same episodes (same seeds): identical outcomes, and one condition per noise
    firsts = {}
    for ts, est, tid, seed, spl, path, cond in rows:
        firsts.setdefault((est, tid, seed), set()).add((spl, path, cond))
    assert all(len(v) == 1 for v in firsts.values())
    scores = json.loads(res.stdout)["scores"]
    for est in ("gt", "dynamics"):
        for level in ("tiny", "all"):
            (row,) = [r for r in scores if r["estimator"] == est and r["level"] == level]
            assert row["episodes"] == 8 and row["setups"] == 1, row
    # the pairs: gt is not part of the claim; nothing to compare
    assert json.loads(res.stdout)["paired_differences"] == []
