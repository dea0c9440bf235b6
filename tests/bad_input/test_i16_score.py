"""Probe cases of issue 16's score and report: odd bootstrap sizes, odd stored rows (a single
episode, an estimator without its pair, episodes with NULL timings) never make a traceback."""

from __future__ import annotations

import json

import pytest

from tests.bad_input.conftest import assert_usage_error, nb, project  # noqa: F401
from tests.pipeline.test_db import episode


def _store(rows):
    from navbench.results.db import ResultsDB

    db = ResultsDB("sqlite:///results/navbench.db")
    run = db.start_run("probe", "navbench probe", {}, "k")
    db.add_episodes(run, rows)
    db.finish_run(run)
    db.close()


@pytest.mark.parametrize("boot", ["0", "-3", "100001"])
def test_bootstrap_sizes_outside_the_range_are_usage_errors(project, boot):
    _store([episode("c", 0)])
    assert_usage_error(nb("score", "--boot", boot), "--boot")


@pytest.mark.parametrize("rows", [
    [episode("c", 0)],                                                       # one episode
    [episode("c", 0, estimator="no-map"), episode("d", 1, estimator="no-map")],  # no reference
    [episode("c", t, sim_ms=None, render_ms=None, estimate_ms=None, step_ms=None) for t in range(3)],
    [episode("c", 0, spl_term=0.5), episode("d", 0, estimator="dynamics", noise="high")],  # no pair
], ids=["one-episode", "no-ours", "no-timings", "unpaired"])
@pytest.mark.parametrize("boot", ["1", "3"])
def test_odd_stored_rows_score_and_report_without_a_traceback(project, rows, boot):
    _store(rows)
    res = nb("score", "--boot", boot, "--format", "json")
    assert res.code == 0, res.output
    doc = json.loads(res.out)
    assert doc["scores"] and isinstance(doc["paired_differences"], list)
    assert nb("score", "--boot", boot).code == 0
    res = nb("report", "--boot", boot, "--out", "results/report")
    assert res.code == 0 and "Traceback" not in res.output, res.output
