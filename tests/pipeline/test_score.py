"""Offline scoring: exact point estimates on hand-made episodes, bootstrap intervals, the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from navbench.errors import DatabaseError
from navbench.results.db import ResultsDB
from navbench.results.score import bootstrap_ci, score_table, spl_matrix, summarise

from .test_db import episode


@pytest.fixture
def db(tmp_path):
    d = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    yield d
    d.close()


def _fill(db):
    """Two levels, 'ours' and 'dynamics' at low noise; hand-chosen values (see the asserts)."""
    r1 = db.start_run("quick", "run-navigation", {}, "a")
    rows = [
        # level l1, ours: success 1,1,0,1 ; spl .9,.8,0,.7 ; loc .01,.03,.5,.02 ; step 10,20,30,40
        episode("c1", 0, level="l1", success=True, spl_term=0.9, loc_rmse_m=0.01, rot_rmse_deg=1.0, step_ms=10.0),
        episode("c1", 1, level="l1", success=True, spl_term=0.8, loc_rmse_m=0.03, rot_rmse_deg=2.0, step_ms=20.0),
        episode("c1", 2, level="l1", success=False, spl_term=0.0, loc_rmse_m=0.5, rot_rmse_deg=9.0, step_ms=30.0),
        episode("c1", 3, level="l1", success=True, spl_term=0.7, loc_rmse_m=0.02, rot_rmse_deg=3.0, step_ms=40.0),
        # level l2, ours: success 1,0 ; spl .6, 0 ; loc .04, nan (no estimate recorded)
        episode("c2", 0, level="l2", success=True, spl_term=0.6, loc_rmse_m=0.04, rot_rmse_deg=4.0, step_ms=50.0),
        episode("c2", 1, level="l2", success=False, spl_term=0.0, loc_rmse_m=float("nan"), rot_rmse_deg=5.0, step_ms=60.0),
        # level l1, dynamics
        episode("c3", 0, level="l1", estimator="dynamics", success=False, spl_term=0.0, step_ms=1.0),
    ]
    db.add_episodes(r1, rows)
    r2 = db.start_run("quick", "run-navigation", {}, "b")
    db.add_episodes(r2, [episode("c4", 0, level="l1", noise="high", success=True, spl_term=0.5)])
    return r1, r2


def _row(table, level, estimator="ours", noise="low"):
    sel = table[(table["level"] == level) & (table["estimator"] == estimator) & (table["noise"] == noise)]
    assert len(sel) == 1
    return sel.iloc[0]


def test_point_estimates_exact(db):
    _fill(db)
    t = score_table(db, n_boot=200)
    l1 = _row(t, "l1")
    assert l1["episodes"] == 4
    assert l1["success_rate"] == pytest.approx(0.75)
    assert l1["spl"] == pytest.approx((0.9 + 0.8 + 0.0 + 0.7) / 4)
    assert l1["loc_rmse_m"] == pytest.approx(0.025)  # median of .01 .02 .03 .5
    assert l1["rot_rmse_deg"] == pytest.approx(2.5)
    assert l1["step_ms"] == pytest.approx(25.0) and l1["step_hz"] == pytest.approx(40.0)
    l2 = _row(t, "l2")
    assert l2["loc_rmse_m"] == pytest.approx(0.04)  # the NaN is left out
    pooled = _row(t, "all")
    assert pooled["episodes"] == 6
    assert pooled["success_rate"] == pytest.approx(4 / 6)
    assert pooled["spl"] == pytest.approx(3.0 / 6)
    assert pooled["loc_rmse_m"] == pytest.approx(0.03)  # median of .01 .02 .03 .04 .5
    assert pooled["step_ms"] == pytest.approx(35.0)
    assert _row(t, "all", "dynamics")["spl"] == 0.0
    # ordering: levels alphabetically, "all" last; within a level noise low before high
    assert list(t["level"]) == ["l1", "l1", "l1", "l2", "all", "all", "all"]
    assert list(t[t["level"] == "l1"]["noise"]) == ["low", "low", "high"]
    for _, r in t.iterrows():  # every interval contains its point estimate
        for m in ("success_rate", "spl", "step_ms"):
            assert r[f"{m}_ci_low"] <= r[m] + 1e-12 and r[m] <= r[f"{m}_ci_high"] + 1e-12


def test_run_and_level_selection(db):
    r1, r2 = _fill(db)
    assert set(score_table(db, run=r2, n_boot=50)["noise"]) == {"high"}
    assert set(score_table(db, run="latest", n_boot=50)["noise"]) == {"high"}
    assert score_table(db, run=str(r1), n_boot=50)["episodes"].max() == 6
    both = score_table(db, run=f"{r2},{r1}", n_boot=50)  # a measurement resumed over two runs
    every = score_table(db, run="all", n_boot=50)
    assert both[["level", "estimator", "noise", "episodes", "spl"]].equals(every[["level", "estimator", "noise",
                                                                              "episodes", "spl"]])
    assert set(both["noise"]) == {"low", "high"}
    with pytest.raises(DatabaseError, match="no run with id 999"):
        score_table(db, run=f"{r1},999")
    with pytest.raises(DatabaseError, match="comma-separated"):
        score_table(db, run=f"{r1},x")
    t = score_table(db, level="l2", n_boot=50)
    assert set(t["level"]) == {"l2", "all"} and _row(t, "all")["episodes"] == 2
    assert set(score_table(db, level=["l1", "l2"], n_boot=50)["level"]) == {"l1", "l2", "all"}
    with pytest.raises(DatabaseError):
        score_table(db, run=999)
    with pytest.raises(DatabaseError):
        score_table(db, run="yesterday")
    with pytest.raises(DatabaseError):
        score_table(db, level="nowhere")


def test_empty_database_is_a_user_error(db):
    with pytest.raises(DatabaseError, match="no episodes"):
        score_table(db)
    with pytest.raises(DatabaseError, match="no episodes"):
        score_table(db, run="latest")


def test_option_sets_become_variants(db):
    rid = db.start_run("quick", "run-navigation", {}, "a")
    db.add_episodes(rid, [episode("a", 0, estimator_options={"steps": 50}, spl_term=0.2),
                          episode("b", 0, estimator_options={"steps": 100}, spl_term=0.4),
                          episode("c", 0, estimator="dynamics", estimator_options={})])
    t = score_table(db, n_boot=20)
    assert set(t["estimator"]) == {"ours{steps=50}", "ours{steps=100}", "dynamics"}
    assert _row(t, "l1", "ours{steps=100}")["spl"] == pytest.approx(0.4)


def test_bootstrap_degenerate_and_two_point_cases():
    assert bootstrap_ci([0.7] * 10, np.mean, n=500, seed=1) == (pytest.approx(0.7), pytest.approx(0.7))
    assert bootstrap_ci([3.0], "median", n=100, seed=0) == (3.0, 3.0)
    # Two values {0, 1}: resampled means are 0, .5, 1 with probabilities 1/4, 1/2, 1/4, so the
    # 2.5 % and 97.5 % quantiles of 2000 resamples are exactly 0 and 1.
    assert bootstrap_ci([0.0, 1.0], np.mean, n=2000, seed=0) == (0.0, 1.0)
    low, high = bootstrap_ci([np.nan, np.nan], np.mean)
    assert np.isnan(low) and np.isnan(high)
    low, high = bootstrap_ci([], np.median)
    assert np.isnan(low) and np.isnan(high)


def test_bootstrap_contains_point_is_seeded_and_matches_a_reference_loop():
    rng = np.random.default_rng(5)
    x = rng.normal(size=37)
    for stat in (np.mean, np.median):
        low, high = bootstrap_ci(x, stat, n=1000, seed=3)
        assert low < stat(x) < high
        assert bootstrap_ci(x, stat, n=1000, seed=3) == (low, high)
        assert bootstrap_ci(x, stat, n=1000, seed=4) != (low, high)
    # the vectorised version equals a plain loop over the same index draws
    ref_rng = np.random.default_rng(11)
    idx = ref_rng.integers(0, x.size, size=(300, x.size))
    ref = np.quantile([np.mean(x[i]) for i in idx], [0.025, 0.975])
    assert bootstrap_ci(x, np.mean, n=300, seed=11) == (pytest.approx(ref[0]), pytest.approx(ref[1]))
    # a 90 % interval lies inside the 95 % one
    lo90, hi90 = bootstrap_ci(x, np.mean, n=1000, seed=3, level=0.90)
    lo95, hi95 = bootstrap_ci(x, np.mean, n=1000, seed=3)
    assert lo95 <= lo90 and hi90 <= hi95


def test_spl_matrix_layout(db):
    _fill(db)
    m = spl_matrix(score_table(db, n_boot=100))
    assert list(m.index) == ["high", "low"] and list(m.columns) == ["ours", "dynamics"]
    assert m.loc["low", "ours"].startswith("0.50 [")
    assert m.loc["high", "dynamics"] == ""


def test_summarise_empty_frame_has_columns():
    import pandas as pd

    t = summarise(pd.DataFrame())
    assert len(t) == 0 and {"spl_ci_low", "step_hz"} <= set(t.columns)


def test_cli_json_csv_table(db, tmp_path):
    from navbench.cli.main import app

    _fill(db)
    url = db.url
    runner = CliRunner()
    res = runner.invoke(app, ["score", "--format", "json", "--db", url, "--boot", "100"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert set(doc) == {"benchmark_version", "scores", "paired_differences"}
    assert doc["benchmark_version"] == "navbench-5"  # the rows of a run of the default version
    data = doc["scores"]
    assert isinstance(data, list) and len(data) == 7
    # ours and dynamics share l1 / low / task 0 / seed 0 (the helper's rows have no condition
    # key: they pair by level, map and noise): one pair, ours' other 3 + 2 episodes unpaired
    (claim,) = [d for d in doc["paired_differences"] if d["level"] == "all" and d["noise"] == "low"]
    assert claim["comparison"] == "ours - dynamics" and claim["pairs"] == 1
    assert claim["unpaired_reference"] == 5 and claim["spl_diff"] == pytest.approx(0.9)
    # at high noise only ours ran: no pair, its episode counted as unpaired, no difference
    (high,) = [d for d in doc["paired_differences"] if d["level"] == "all" and d["noise"] == "high"]
    assert high["pairs"] == 0 and high["unpaired_reference"] == 1 and high["spl_diff"] is None
    need = {"level", "estimator", "noise", "episodes", "success_rate", "spl", "spl_ci_low",
            "spl_ci_high", "loc_rmse_m", "rot_rmse_deg", "step_ms"}
    assert all(need <= set(d) for d in data)
    pooled = [d for d in data if d["level"] == "all" and d["estimator"] == "ours" and d["noise"] == "low"]
    assert pooled[0]["spl"] == pytest.approx(0.5) and pooled[0]["episodes"] == 6
    res = runner.invoke(app, ["score", "--format", "csv", "--db", url, "--level", "l2", "--boot", "50"])
    assert res.exit_code == 0
    lines = res.stdout.strip().splitlines()
    assert lines[0].startswith("level,estimator,noise,episodes,setups,success_rate") and len(lines) == 3
    res = runner.invoke(app, ["score", "--db", url, "--boot", "50", "--run", "latest"])
    assert res.exit_code == 0 and "high" in res.stdout and "SPL" in res.stdout


def test_cli_errors_are_one_line(tmp_path):
    from navbench.cli.main import main

    import subprocess
    import sys

    empty = f"sqlite:///{tmp_path / 'empty.db'}"
    for args in (["score", "--db", empty], ["score", "--db", "nosuch://x"]):
        proc = subprocess.run([sys.executable, "-m", "navbench.cli.main", *args],
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.strip().startswith("error:") and len(proc.stderr.strip().splitlines()) == 1
    assert callable(main)


def test_cli_db_info_and_runs(db):
    from navbench.cli.main import app

    _fill(db)
    runner = CliRunner()
    res = runner.invoke(app, ["db", "info", "--db", db.url])
    assert res.exit_code == 0 and "episodes" in res.stdout and "8" in res.stdout
    res = runner.invoke(app, ["db", "runs", "--db", db.url])
    assert res.exit_code == 0 and "quick" in res.stdout and "2 most recent runs" in res.stdout


def test_rows_that_pool_several_setups_are_counted_and_warned(db, tmp_path):
    """The same (level, estimator, noise) stored under two cells (say a quick run and a paper run
    with another map): the row says so, and the CLI warns on stderr."""
    from navbench.cli.main import app
    from navbench.results.score import mixed_setups, mixed_setups_warning

    _fill(db)
    table = score_table(db, n_boot=20)
    assert set(table["setups"]) == {1} and mixed_setups(table) == []
    assert mixed_setups_warning(table) is None
    r3 = db.start_run("paper", "run-navigation", {}, "c")
    db.add_episodes(r3, [episode("c9", 0, level="l1", success=True, spl_term=0.95)])  # l1/ours/low again
    table = score_table(db, n_boot=20)
    assert _row(table, "l1")["setups"] == 2 and _row(table, "all")["setups"] == 2
    assert _row(table, "l2")["setups"] == 1 and _row(table, "l1", "dynamics")["setups"] == 1
    assert mixed_setups(table) == ["l1/ours/low"]
    assert "l1/ours/low" in mixed_setups_warning(table)
    assert mixed_setups(score_table(db, run=str(r3), n_boot=20)) == []  # one run: one setup
    url = f"sqlite:///{tmp_path / 'r.db'}"
    res = CliRunner().invoke(app, ["score", "--db", url, "--boot", "20"])
    assert res.exit_code == 0 and "pool episodes of several setups" in res.stderr


def test_episodes_stored_before_condition_keys_still_score_and_pair(tmp_path):
    """A database whose episodes table predates ``condition_key`` opens, gains the column, and
    its rows score as before (one setup per cell) and pair by level, map and noise."""
    import sqlite3

    path = tmp_path / "old.db"
    ResultsDB(f"sqlite:///{path}").close()
    with sqlite3.connect(path) as con:
        con.execute("ALTER TABLE episodes DROP COLUMN condition_key")
    d = ResultsDB(f"sqlite:///{path}")
    rid = d.start_run("quick", "run-navigation", {}, "a")
    d.add_episodes(rid, [episode("c-ours", t, spl_term=0.9) for t in range(3)]
                   + [episode("c-dyn", t, estimator="dynamics", spl_term=0.3) for t in range(3)])
    assert d.episodes_frame()["condition_key"].isna().all()
    from navbench.results.score import score_tables

    table, paired = score_tables(d, n_boot=50)
    d.close()
    assert set(table["setups"]) == {1} and set(table["episodes"]) == {3}
    row = paired[paired["level"] == "all"].iloc[0]
    assert row["pairs"] == 3 and row["spl_diff"] == pytest.approx(0.6)


def test_a_runs_cells_keep_their_episodes_when_an_earlier_task_set_stored_some(db):
    """--tasks 2 then --tasks 4: the second run's cell holds tasks 0..3; selecting its cells
    keeps all four (the once-per-(setup, task, seed) rule applies after the selection), while
    every stored episode counts tasks 0 and 1 once."""
    from navbench.results.score import select_episodes

    from .test_db import FakeTask

    tasks = [FakeTask(i, (0.5, 0.5 + 0.4 * i, 0.0), (2.5, 2.5 - 0.4 * i), 2.6) for i in range(4)]
    db.record_task_set("l1", "ts2", tasks[:2])  # the first two tasks of the same stream
    db.record_task_set("l1", "ts4", tasks)
    r1 = db.start_run("quick", "run-navigation", {}, "a")
    db.add_episodes(r1, [episode("small", t, task_set_key="ts2", condition_key="cond") for t in range(2)])
    r2 = db.start_run("quick", "run-navigation", {}, "b")
    db.add_episodes(r2, [episode("large", t, task_set_key="ts4", condition_key="cond") for t in range(4)])
    assert len(select_episodes(db, cell_keys=["large"])) == 4
    every = select_episodes(db)
    assert len(every) == 4 and sorted(every["task_id"]) == [0, 1, 2, 3]
    assert list(every.sort_values("task_id")["cell_key"]) == ["small", "small", "large", "large"]
