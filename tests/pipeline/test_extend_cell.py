"""A larger --tasks or --seeds after a smaller one extends the same cell (issue 16): the score
counts each (task, seed) once, whatever task sets stored it, and the episodes already stored
under the smaller task set are scored from their trajectories, not simulated again."""

from __future__ import annotations

import json
import os
import sqlite3

import pytest
from typer.testing import CliRunner

from tests.bad_input.conftest import project  # noqa: F401  (fixture)

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
        outputs = []
        for extra in (["--tasks", "2"], ["--tasks", "4", "--seeds", "2"]):
            res = runner.invoke(app, [*BASE, *extra, "--db", url])
            assert res.exit_code == 0, res.output
            outputs.append(" ".join(res.output.split()))
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
    # the larger run did not simulate tasks 0 and 1 (seed 0) again: it scored the smaller run's
    # trajectories (2 tasks x 2 estimators) and simulated the other 12 episodes
    assert "0 already stored, 4 from stored trajectories, 12 run now" in outputs[1], outputs[1]
    with sqlite3.connect(root / "nb.db") as con:
        shared = con.execute("SELECT estimator, task_id, COUNT(DISTINCT task_set_key), "
                             "COUNT(DISTINCT traj_key) FROM episodes WHERE seed = 0 AND task_id < 2 "
                             "GROUP BY estimator, task_id").fetchall()
    assert len(shared) == 4 and all(n_sets == 2 and n_traj == 1 for _, _, n_sets, n_traj in shared), shared
    scores = json.loads(res.stdout)["scores"]
    for est in ("gt", "dynamics"):
        for level in ("tiny", "all"):
            (row,) = [r for r in scores if r["estimator"] == est and r["level"] == level]
            assert row["episodes"] == 8 and row["setups"] == 1, row
    # the pairs: gt is not part of the claim; nothing to compare
    assert json.loads(res.stdout)["paired_differences"] == []


def test_a_task_set_with_other_tasks_under_the_same_ids_reuses_nothing(project):
    """Reuse needs the same task (start and target), not only the same id: task seed 7 gives
    other tasks 0 and 1, which are simulated; a rerun of either set simulates nothing."""
    from tests.bad_input.conftest import TINY_PROFILE, nb

    (project / "seed7.toml").write_text(TINY_PROFILE.replace("[tasks]\n", "[tasks]\nseed = 7\n"))
    args = ("--tasks", "2", "--map", "true")
    runs = [nb("run-navigation", "--profile", p, *args) for p in ("tiny.toml", "seed7.toml", "tiny.toml")]
    assert all(r.code == 0 for r in runs), [r.output for r in runs]
    said = [" ".join(r.output.split()) for r in runs]
    assert "0 from stored trajectories, 4 run now" in said[0], said[0]
    assert "0 already stored, 0 from stored trajectories, 4 run now" in said[1], said[1]
    assert "4 already stored, 0 from stored trajectories, 0 run now" in said[2], said[2]
    with sqlite3.connect(project / "results" / "navbench.db") as con:
        sets = con.execute("SELECT task_set_key, COUNT(*), COUNT(DISTINCT traj_key) FROM episodes "
                           "GROUP BY task_set_key").fetchall()
    assert len(sets) == 2 and all(n == 4 and n_traj == 4 for _, n, n_traj in sets), sets
