"""Benchmark versions: stored with every run and episode, never pooled, selectable; an old database
(no version column) opens and scores as navbench-1."""

from __future__ import annotations

import json
import sqlite3

import pytest
from typer.testing import CliRunner

from navbench import benchmark
from navbench.errors import DatabaseError
from navbench.results.db import ResultsDB
from navbench.results.score import score_table, select_versioned

from .test_db import episode


@pytest.fixture
def db(tmp_path):
    d = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    yield d
    d.close()


def test_versions_module():
    assert benchmark.BENCHMARK_VERSION in benchmark.VERSIONS
    assert benchmark.check_version("navbench-1") == "navbench-1"
    with pytest.raises(benchmark.UnknownVersion, match="known: navbench-1"):
        benchmark.check_version("navbench-0")
    # a version written by a newer navbench ranks after every known one
    assert benchmark.newest(["navbench-1", "navbench-9"]) == "navbench-9"
    assert benchmark.key_part("navbench-1") == {}          # keys made before versions are unchanged
    assert benchmark.key_part("navbench-9") == {"benchmark": "navbench-9"}
    assert benchmark.GYM_IDS[benchmark.BENCHMARK_VERSION]


def test_runs_and_episodes_store_their_version(db):
    r = db.start_run("quick", "run-navigation", {}, "h")
    db.add_episodes(r, [episode("c1", 0)])
    assert db.runs_frame()["benchmark_version"].tolist() == [benchmark.BENCHMARK_VERSION]
    assert db.episodes_frame()["benchmark_version"].tolist() == [benchmark.BENCHMARK_VERSION]
    r2 = db.start_run("quick", "run-navigation", {}, "h", benchmark_version="navbench-9")
    db.add_episodes(r2, [episode("c2", 0)])
    assert db.episodes_frame()["benchmark_version"].tolist() == [benchmark.BENCHMARK_VERSION, "navbench-9"]


def _two_versions(db):
    """navbench-1: ours succeeds on tasks 0, 1 (SPL .8, .6); 'navbench-9' (a later version): fails both."""
    r1 = db.start_run("quick", "run-navigation", {}, "a", benchmark_version="navbench-1")
    db.add_episodes(r1, [episode("c1", 0, spl_term=0.8), episode("c1", 1, spl_term=0.6)])
    r9 = db.start_run("quick", "run-navigation", {}, "a", benchmark_version="navbench-9")
    db.add_episodes(r9, [episode("c9", 0, success=False, spl_term=0.0),
                         episode("c9", 1, success=False, spl_term=0.0)])


def test_two_versions_are_never_pooled(db):
    _two_versions(db)
    frame, version, note = select_versioned(db)
    assert version == "navbench-9" and len(frame) == 2          # the newest, alone
    assert "navbench-1, navbench-9" in note and "2 row(s) of navbench-1 left out" in note
    t = score_table(db, n_boot=50)
    assert t[t["level"] == "all"]["episodes"].tolist() == [2]
    assert t[t["level"] == "all"]["spl"].tolist() == [0.0]
    old = score_table(db, n_boot=50, benchmark_version="navbench-1")
    assert old[old["level"] == "all"]["spl"].tolist() == [pytest.approx(0.7)]
    assert select_versioned(db, benchmark_version="navbench-1")[2] is not None


def test_one_version_gives_no_note(db):
    r = db.start_run("quick", "run-navigation", {}, "a")
    db.add_episodes(r, [episode("c1", 0)])
    assert select_versioned(db)[1:] == (benchmark.BENCHMARK_VERSION, None)  # the current one


def test_asking_for_a_version_absent_or_unknown(db):
    r = db.start_run("quick", "run-navigation", {}, "a")
    db.add_episodes(r, [episode("c1", 0)])
    with pytest.raises(DatabaseError, match="unknown 'navbench-7'; known: navbench-1"):
        select_versioned(db, benchmark_version="navbench-7")


def test_an_old_database_opens_and_scores_as_navbench_1(tmp_path):
    path = tmp_path / "old.db"
    with ResultsDB(f"sqlite:///{path}") as d:
        r = d.start_run("quick", "run-navigation", {}, "a")
        d.add_episodes(r, [episode("c1", 0, spl_term=0.8), episode("c1", 1, spl_term=0.6)])
    con = sqlite3.connect(path)  # the layout before versions: no such columns
    con.execute("ALTER TABLE episodes DROP COLUMN benchmark_version")
    con.execute("ALTER TABLE runs DROP COLUMN benchmark_version")
    con.commit()
    con.close()
    with ResultsDB(f"sqlite:///{path}") as d:
        frame, version, note = select_versioned(d)
        assert version == "navbench-1" and note is None and len(frame) == 2
        t = score_table(d, n_boot=50)
        assert t[t["level"] == "all"]["spl"].tolist() == [pytest.approx(0.7)]
        assert d.run_version(1) == "navbench-1"


def test_score_cli_names_the_version_and_selects_another(tmp_path):
    from navbench.cli.main import app

    url = f"sqlite:///{tmp_path / 'r.db'}"
    with ResultsDB(url) as d:
        _two_versions(d)
    runner = CliRunner()
    res = runner.invoke(app, ["score", "--db", url, "--format", "json", "--boot", "50"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["benchmark_version"] == "navbench-9"
    assert "never pooled" in res.stderr
    res = runner.invoke(app, ["score", "--db", url, "--format", "json", "--boot", "50",
                              "--benchmark-version", "navbench-1"])
    assert res.exit_code == 0 and json.loads(res.stdout)["benchmark_version"] == "navbench-1"
    from tests.bad_input.conftest import assert_clean_error, nb

    assert_clean_error(nb("score", "--db", url, "--benchmark-version", "navbench-0"), "navbench-0", "navbench-1")


def test_report_names_its_version_and_leaves_the_other_out(db, tmp_path):
    from navbench.report.build import build_report

    _two_versions(db)
    index = build_report(db, tmp_path / "rep", n_boot=50)
    text = index.read_text()
    assert "Benchmark version navbench-9" in text and "never pooled" in text
    old = build_report(db, tmp_path / "rep1", n_boot=50, benchmark_version="navbench-1").read_text()
    assert "Benchmark version navbench-1" in old


def _tracking(db, version, study, locs):
    r = db.start_run("track-eval", "track-eval", {}, study, benchmark_version=version)
    db.add_tracking_rows(r, [dict(study_key=study, level="l1", estimator="dynamics", estimator_options={},
                                  noise="tracking", trajectory_id=i, seed=0, loc_rmse_m=v, rot_rmse_deg=1.0,
                                  step_ms_median=0.01) for i, v in enumerate(locs)])


def test_tracking_rows_store_their_version_and_the_report_never_pools_them(db, tmp_path):
    """track-eval's rows copy their run's version (as episodes do); the report's Fig. 4 rows are
    of one version: the episodes', else the newest the tracking rows hold."""
    import pandas as pd

    from navbench.report.build import build_report

    _tracking(db, "navbench-1", "s1", [0.1, 0.1])
    _tracking(db, "navbench-9", "s9", [0.5, 0.5, 0.5])
    assert db.tracking_frame()["benchmark_version"].tolist() == ["navbench-1"] * 2 + ["navbench-9"] * 3
    index = build_report(db, tmp_path / "rep", n_boot=50)
    summary = pd.read_csv(tmp_path / "rep" / "tracking_summary.csv")
    assert summary["trajectories"].tolist() == [3] and summary["loc_rmse_median_m"].tolist() == [0.5]
    assert "Benchmark version navbench-9" in index.read_text() and "never pooled" in index.read_text()
    _two_versions(db)  # episodes of navbench-1 and navbench-9: the report of navbench-1
    old = build_report(db, tmp_path / "rep1", n_boot=50, benchmark_version="navbench-1").read_text()
    summary = pd.read_csv(tmp_path / "rep1" / "tracking_summary.csv")
    assert summary["trajectories"].tolist() == [2] and summary["loc_rmse_median_m"].tolist() == [0.1]
    assert "3 tracking-study row(s) of another version left out" in old


def test_compare_names_each_sides_version_and_warns_across_versions(db):
    from navbench.results.compare import compare

    _two_versions(db)
    # the same version both sides: run 1 vs run 1 as two sides is navbench-1 on both
    res = compare(db=db.url, a="1", b="2", pairs=[("ours", "ours")], n_boot=50)
    assert res.side_a.endswith("navbench-1") and res.side_b.endswith("navbench-9")
    assert any("across benchmark versions" in w for w in res.warnings)
    pooled = res.table[res.table["level"] == "all"].iloc[0]
    assert pooled["pairs"] == 2 and pooled["spl_diff"] == pytest.approx(-0.7)  # B - A: 0 - (.8+.6)/2
    one = compare(db=db.url, pairs=[("ours", "ours")], a="all", b="all", n_boot=50,
                  benchmark_version="navbench-1")
    assert one.side_a.endswith("navbench-1") and one.side_b.endswith("navbench-1")
    assert not any("across benchmark versions" in w for w in one.warnings)
    assert any("never pooled" in w for w in one.warnings)  # each side left navbench-9 out
