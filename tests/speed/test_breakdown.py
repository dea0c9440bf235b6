"""The per-stage and per-component breakdown of a run (issue 17): computed, stored with the run
in the results database's ``run_timings`` and printed at the end of ``navbench all``."""

from __future__ import annotations

import pytest

from navbench.nav.timing import TIMING_KEYS
from navbench.results.breakdown import breakdown_rows, format_breakdown, stage_rows
from navbench.results.db import ResultsDB
from navbench.pipeline.stages import NavigationSummary
from tests.bad_input.conftest import project  # noqa: F401  (the scratch-project fixture)


def test_stage_rows_sum_calls_by_stage_in_first_seen_order():
    rows = stage_rows([("views", 1.0, False), ("fit", 2.0, False), ("views", 0.5, True)])
    assert rows == [{"kind": "stage", "name": "views", "seconds": 1.5, "count": 2, "cached": 1},
                    {"kind": "stage", "name": "fit", "seconds": 2.0, "count": 1, "cached": 0}]


def test_components_and_other_are_hand_computed():
    nav = NavigationSummary(cells=[], total=4, already_done=1, ran=3,
                            component_s={"sim": 1.0, "render": 2.0, "estimate": 0.5}, steps=100, store_s=0.25,
                            estimator_s={"ours": [3.25, 60], "dynamics": [0.25, 40]})
    rows = breakdown_rows([("fit-map", 3.0, False)], nav, navigation_s=2.5, workers=2)
    by = {(r["kind"], r["name"]): r for r in rows}
    assert by["stage", "run-navigation"] == {"kind": "stage", "name": "run-navigation", "seconds": 2.5,
                                             "count": 3, "cached": 1}
    assert [r["name"] for r in rows if r["kind"] == "component"] == [*TIMING_KEYS, "store", "other"]
    assert by["component", "plan"]["seconds"] == 0.0 and by["component", "render"]["count"] == 100
    assert by["component", "other"]["seconds"] == 2.5 * 2 - 3.5  # worker time outside the components
    assert by["estimator", "ours"] == {"kind": "estimator", "name": "ours", "seconds": 3.25, "count": 60,
                                       "cached": 0}
    text = format_breakdown(rows)
    assert "render" in text and "20.00 ms/step" in text and "fit-map" in text
    assert "54.17 ms/step" in text  # ours: 3.25 s over 60 steps


#: The tiny level on its voxelized true geometry (a tiny fit plans nothing): episodes with steps.
TRUE_MAP = """
name = "tinytrue"
levels = ["tiny"]
[views]
camera = "half"
count = 12
eval_count = 4
[tasks]
count = 2
[navigation]
estimators = ["dynamics", "ours"]
noise = ["low"]
workers = 1
map = "true"
"""


def test_run_profile_stores_and_returns_the_breakdown(project):
    from navbench.pipeline.run import run_profile

    (project / "true.toml").write_text(TRUE_MAP)
    url = f"sqlite:///{project / 'lib.db'}"
    result = run_profile("true.toml", db=url, until="score")
    names = {(r["kind"], r["name"]) for r in result.breakdown}
    assert {("stage", s) for s in ("true-map", "sample-tasks", "run-navigation", "score")} <= names
    assert {("component", k) for k in TIMING_KEYS} <= names
    nav = {r["name"]: r for r in result.breakdown if r["kind"] == "component"}
    assert nav["sim"]["count"] == result.navigation.steps > 0
    assert nav["render"]["seconds"] > 0 and nav["estimate"]["seconds"] > 0  # ours renders and tracks
    est = {r["name"]: r for r in result.breakdown if r["kind"] == "estimator"}
    assert set(est) == {"dynamics", "ours"}
    assert est["ours"]["count"] + est["dynamics"]["count"] == result.navigation.steps
    assert est["ours"]["seconds"] + est["dynamics"]["seconds"] == pytest.approx(
        sum(nav[k]["seconds"] for k in TIMING_KEYS))
    with ResultsDB(url) as db:
        stored = db.run_timings_frame(result.run_id)
    assert len(stored) == len(result.breakdown)
    assert list(stored["name"]) == [r["name"] for r in result.breakdown]
    assert stored["seconds"].tolist() == pytest.approx([r["seconds"] for r in result.breakdown])


def test_navbench_all_prints_the_breakdown(project):
    from typer.testing import CliRunner

    from navbench.cli.main import app

    (project / "true.toml").write_text(TRUE_MAP)
    res = CliRunner().invoke(app, ["all", "--profile", "true.toml", "--report", "out"])
    assert res.exit_code == 0, res.output
    assert "where the time went" in res.output
    for word in ("true-map", "run-navigation", "episode component", "render", "ms/step"):
        assert word in res.output
