"""Issue 35 §2, §4, §5: the researcher's loop from the command line. One case per friction point
(each failed before its change): --set on every command that takes a profile, -o on
run-navigation, errors that name what the user typed, "did you mean", no run row for a usage
error, whole tables when piped, db runs --format, NAVBENCH_CACHE and export-trajectories --cache."""

from __future__ import annotations

import csv
import io
import json
import sqlite3

import pytest

from .conftest import assert_clean_error, nb, tree_snapshot, written_outside


def _run_rows(project) -> list[tuple]:
    db = project / "results" / "navbench.db"
    if not db.exists():
        return []
    with sqlite3.connect(db) as con:
        return con.execute("SELECT id, status, command FROM runs").fetchall()


PROFILE_COMMANDS = [["all"], ["run-navigation"], ["fit-map", "tiny"], ["collect-views", "tiny"],
                    ["collect-5000-views", "tiny"], ["track-eval", "tiny"], ["localize-eval", "tiny"]]


@pytest.mark.parametrize("cmd", PROFILE_COMMANDS, ids=lambda c: c[0])
def test_set_on_every_command_that_takes_a_profile(project, tmp_path, cmd):
    before = tree_snapshot(tmp_path)
    res = nb(*cmd, "--profile", "tiny.toml", "--set", "taks.count=3")
    assert_clean_error(res, "--set taks.count", "did you mean 'tasks.count'", "fit.steps")
    res = nb(*cmd, "--profile", "tiny.toml", "--set", "fit.lr=nan")
    assert_clean_error(res, "--set fit.lr=nan", "got nan")
    assert not written_outside(before, tree_snapshot(tmp_path), ("levels/",))
    assert _run_rows(project) == []


def test_set_is_stored_in_the_runs_resolved_config(project):
    res = nb("run-navigation", "--profile", "tiny.toml", "--set", "tasks.count=1",
             "--set", "navigation.estimators=gt", "--set", "fit.steps=2")
    assert res.code == 0, res.output
    assert "stored 1 new episodes" in res.out
    with sqlite3.connect(project / "results" / "navbench.db") as con:
        (config,), = con.execute("SELECT config FROM runs").fetchall()
    config = json.loads(config)
    assert (config["tasks"], config["estimators"], config["fit_steps"]) == (1, ["gt"], 2)


def test_minimal_profile_extends_quick(project):
    (project / "mini.toml").write_text('extends = "tiny.toml"\n[tasks]\ncount = 1\n[navigation]\n'
                                       'estimators = ["gt"]\n')
    res = nb("run-navigation", "--profile", "mini.toml", "--set", "fit.steps=2")
    assert res.code == 0, res.output
    assert "1/1 of the grid" in res.out
    assert [r[1] for r in _run_rows(project)] == ["done"]


@pytest.mark.parametrize("args,names", [
    (["-o", "gt.foo=1"], ["--option gt", "takes no options"]),
    (["-o", "ours.optimizer=adam"], ["--option ours.optimizer", "not among the run's estimators"]),
    (["-o", "ours=1"], ["--option", "ESTIMATOR.KEY=VALUE"]),
    (["--estimators", "ours", "-o", "ours.optimiser=adam"], ["--option", "optimiser"]),
])
def test_run_navigation_takes_estimator_options(project, args, names):
    res = nb("run-navigation", "--profile", "tiny.toml", *args)
    assert_clean_error(res, *names)
    assert _run_rows(project) == []


def test_run_navigation_option_reaches_the_resolved_config(project):
    from navbench.cli.commands.run_navigation import _with_options
    from navbench.pipeline.profiles import load_profile, override

    prof = override(load_profile("tiny.toml"), estimators=["ours", "gt"],
                    estimator_options={"ours": {"prior_sigma": [0.05, 0.1]}})
    out = _with_options(prof, {"ours": {"optimizer": "adam"}})
    assert out.estimator_options == {"ours": {"prior_sigma": [0.05, 0.1], "optimizer": "adam"}}


def test_errors_name_what_the_user_typed(project):
    res = nb("fit-map", "tiny", "--profile", "tiny.toml", "--device", "gpu")
    assert_clean_error(res, "--device gpu", "unknown device 'gpu'")
    assert "profile" not in res.err
    res = nb("run-navigation", "--profile", "/missing/file.toml")
    assert_clean_error(res, "--profile /missing/file.toml: no such file")
    assert "unknown profile" not in res.err


@pytest.mark.parametrize("args,names", [
    (["show-level", "tinny"], ["did you mean 'tiny'"]),
    (["run-navigation", "housee-1", "--profile", "quick"], ["housee-1", "did you mean 'house-1'"]),
    (["run-navigation", "--profile", "quik"], ["unknown profile 'quik'", "did you mean 'quick'"]),
    (["run-navigation", "--profile", "tiny.toml", "--estimators", "ourss"], ["did you mean 'ours'"]),
    (["run-navigation", "--profile", "tiny.toml", "--set", "scoring.preset=nrs"], ["did you mean 'nrns'"]),
    (["score", "--preset", "nrs"], ["unknown scoring preset 'nrs'", "did you mean 'nrns'"]),
])
def test_did_you_mean(project, args, names):
    res = nb(*args)
    assert_clean_error(res, *names)
    assert _run_rows(project) == []  # nothing ran, nothing was generated
    assert not (project / "results" / "cache" / "make-level").exists()


def test_a_usage_error_creates_no_run_row(project):
    """Refused inside the run (a map file that is not there): the run stored nothing, so it is
    not a run; before issue 35 it stayed in db runs as 'failed'."""
    res = nb("run-navigation", "--profile", "tiny.toml", "--map", "nothere.npz")
    assert_clean_error(res, "--map", "nothere.npz")
    assert _run_rows(project) == []


def _fill_runs(project):
    from navbench.results.db import ResultsDB

    (project / "results").mkdir(exist_ok=True)
    db = ResultsDB(f"sqlite:///{project / 'results' / 'navbench.db'}")
    long = "navbench run-navigation house-1 --estimators ours,ours-every-k --set fit.steps=300 " * 2
    for prof in ("ours-every-k", "ours"):
        db.finish_run(db.start_run(prof, long.strip(), {}, "h" * 64), "done")
    db.close()
    return long.strip()


def test_tables_print_whole_when_piped(project, monkeypatch):
    monkeypatch.delenv("COLUMNS", raising=False)  # an exported $COLUMNS is a width asked for
    long = _fill_runs(project)
    res = nb("db", "runs")
    assert res.code == 0, res.output
    assert "…" not in res.out
    assert long in res.out and "ours-every-k" in res.out
    header = next(ln for ln in res.out.splitlines() if "profile" in ln)
    assert "command" in header and "episodes" in header
    assert "2 most recent runs" in res.out


def test_db_runs_formats(project):
    long = _fill_runs(project)
    rows = list(csv.DictReader(io.StringIO(nb("db", "runs", "--format", "csv").out)))
    assert [r["profile"] for r in rows] == ["ours-every-k", "ours"] and rows[0]["command"] == long
    data = json.loads(nb("db", "runs", "--format", "json").out)
    assert [d["profile"] for d in data] == ["ours-every-k", "ours"] and data[0]["status"] == "done"
    md = nb("db", "runs", "--format", "markdown").out.splitlines()
    assert md[0].startswith("| id | profile | command |") and md[1].startswith("|---|")
    assert len(md) == 4 and long in md[2]
    assert_clean_error(nb("db", "runs", "--format", "jsn"), "--format jsn", "did you mean 'json'")


def test_navbench_cache_is_shared_and_export_names_the_cache(project, tmp_path, monkeypatch):
    shared = tmp_path / "shared-cache"
    monkeypatch.setenv("NAVBENCH_CACHE", str(shared))
    res = nb("run-navigation", "--profile", "tiny.toml", "--estimators", "gt", "--tasks", "1",
             "--set", "fit.steps=2")
    assert res.code == 0, res.output
    assert (shared / "fit-map").is_dir() and (shared / "episode").is_dir()
    assert not (project / "results" / "cache").exists()
    # another folder, this project's database: the trajectories are in the shared cache only
    other = tmp_path / "elsewhere"
    other.mkdir()
    monkeypatch.chdir(other)
    monkeypatch.delenv("NAVBENCH_CACHE")
    url = f"sqlite:///{project / 'results' / 'navbench.db'}"
    res = nb("export-trajectories", "out", "--db", url)
    assert_clean_error(res, "not in the cache results/cache", str(project / "results" / "cache"), "--cache")
    res = nb("export-trajectories", "out", "--db", url, "--cache", str(shared))
    assert res.code == 0, res.output
    assert "exported 1 trajectory pairs" in res.out
    assert_clean_error(nb("export-trajectories", "out2", "--db", url, "--cache", "nope"), "--cache nope")


def test_a_narrow_terminal_folds_cells_instead_of_cutting_them(project, monkeypatch):
    _fill_runs(project)
    monkeypatch.setenv("COLUMNS", "70")
    res = nb("db", "runs")
    assert res.code == 0, res.output
    assert "…" not in res.out
    assert max(len(ln) for ln in res.out.splitlines()) <= 70
