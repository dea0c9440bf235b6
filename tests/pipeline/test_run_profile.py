"""The library entry point: run_profile -> RunResult, and recorded_run's run bookkeeping."""

from __future__ import annotations

import pytest

from navbench.results.db import ResultsDB
from navbench.pipeline.profiles import load_profile
from navbench.pipeline.run import RunResult, recorded_run, run_profile
from tests.bad_input.conftest import project  # noqa: F401  (the scratch-project fixture)


def test_run_profile_returns_the_run_its_scores_and_report(project):
    url = f"sqlite:///{project / 'lib.db'}"
    result = run_profile("tiny.toml", db=url, report_dir="out/report")
    assert isinstance(result, RunResult)
    nav = result.navigation
    assert nav.total == 2 * 3 and nav.stored == nav.total and nav.already_done == 0  # 2 estimators x 3 tasks
    scores = result.scores  # per level, and pooled over levels ("all")
    assert sorted(zip(scores["level"], scores["estimator"])) == [
        ("all", "dynamics"), ("all", "gt"), ("tiny", "dynamics"), ("tiny", "gt")]
    assert (scores["episodes"] == 3).all()
    assert result.report_path.resolve() == project / "out" / "report" / "index.html"
    assert result.report_path.is_file()
    assert {s for s, _ in result.refs} >= {"collect-views", "fit-map", "sample-tasks", "score", "report"}
    db = ResultsDB(url)
    runs = db.runs_frame()
    assert list(runs["status"]) == ["done"] and int(runs["id"].iloc[0]) == result.run_id
    # the page the finished run published says so (issue 16): its runs table shows it done
    page = result.report_path.read_text()
    assert "had not finished" not in page
    runs_html = page.split('id="runs"')[1].split("<h2")[0]
    assert "<td>done</td>" in runs_html and "<td>running</td>" not in runs_html
    import pandas as pd

    published = pd.read_csv(result.report_path.parent / "runs.csv")
    assert list(published["status"]) == ["done"] and list(published["id"]) == [result.run_id]
    assert len(db.episodes_frame()) == nav.total
    # a rerun resumes: nothing new, the same table
    again = run_profile(load_profile("tiny.toml"), db=db, until="score")
    assert again.navigation.stored == 0 and again.navigation.already_done == nav.total
    assert again.scores.equals(scores) and again.report is None
    db.close()


def test_recorded_run_marks_failures_and_interruptions(tmp_path):
    db = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    with pytest.raises(ValueError):
        with recorded_run(db, "p", "cmd", {"a": 1}):
            raise ValueError("boom")
    with pytest.raises(KeyboardInterrupt):
        with recorded_run(db, "p", "cmd", {"a": 1}):
            raise KeyboardInterrupt
    with recorded_run(db, "p", "cmd", {"a": 1}) as run_id:
        pass
    runs = db.runs_frame().sort_values("id")
    assert list(runs["status"]) == ["failed", "interrupted", "done"]
    assert int(runs["id"].iloc[-1]) == run_id
    db.close()


def test_run_profile_refuses_a_bad_stage_name_and_report_folder_before_any_work(project):
    from navbench.errors import ConfigError

    with pytest.raises(ConfigError, match="until"):
        run_profile("tiny.toml", until="scores")
    (project / "mine").mkdir()
    (project / "mine" / "notes.txt").write_text("keep me")
    with pytest.raises(ConfigError, match="not empty"):
        run_profile("tiny.toml", report_dir="mine")
    assert not (project / "results" / "cache").exists()
    assert (project / "mine" / "notes.txt").read_text() == "keep me"
