"""Every score table states the simulator conditions its episodes ran under, and episodes of
different conditions never pool into one row or pair with each other (issue 16)."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from navbench.results.db import ResultsDB
from navbench.results.score import (
    UNRECORDED_CONDITIONS,
    conditions_in,
    conditions_label,
    score_tables,
    short_conditions,
    spl_matrix,
)

from .test_db import episode

DEFAULTS = "pose_quantisation=off, direction_limit=believed, collision_check=swept"
PAPER = "pose_quantisation=round, direction_limit=true, collision_check=endpoint"
PAPER_EPISODE = {"pose_quantisation": "round", "body_fixed_drive": True, "collision_check": "endpoint"}


def test_labels_name_every_condition():
    assert conditions_label({}) == DEFAULTS
    assert conditions_label({"max_steps": 300}) == DEFAULTS  # not a condition
    assert conditions_label(PAPER_EPISODE) == PAPER
    assert conditions_label({"body_fixed_drive": True}) == (
        "pose_quantisation=off, direction_limit=true, collision_check=swept")
    assert conditions_label(None) == UNRECORDED_CONDITIONS
    assert short_conditions(DEFAULTS) == "defaults"
    assert short_conditions(PAPER) == PAPER
    assert short_conditions("pose_quantisation=off, direction_limit=true, collision_check=swept") == \
        "direction_limit=true"
    assert short_conditions(UNRECORDED_CONDITIONS) == UNRECORDED_CONDITIONS


@pytest.fixture
def two_conditions(tmp_path):
    """One level, ``ours`` and ``dynamics`` at low noise on tasks 0..2, once under the defaults
    (run 1) and once under the paper's conditions (run 2), with hand-chosen SPL terms. The two
    runs' rows share level, map, noise, task set, tasks and seeds; only the conditions (and so
    the condition and cell keys) differ."""
    d = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    r1 = d.start_run("six", "navbench all", {"episode": {}}, "a")
    d.add_episodes(r1, [episode("d-ours", t, spl_term=s, condition_key="cond-default")
                        for t, s in enumerate((0.9, 0.8, 0.7))]
                   + [episode("d-dyn", t, estimator="dynamics", spl_term=s, condition_key="cond-default",
                              success=s > 0) for t, s in enumerate((0.6, 0.0, 0.3))])
    r2 = d.start_run("six", "navbench all --condition ...", {"episode": PAPER_EPISODE}, "b")
    d.add_episodes(r2, [episode("p-ours", t, spl_term=s, condition_key="cond-paper")
                        for t, s in enumerate((0.95, 0.85, 0.75))]
                   + [episode("p-dyn", t, estimator="dynamics", spl_term=s, condition_key="cond-paper",
                              success=s > 0) for t, s in enumerate((0.1, 0.0, 0.2))])
    yield d
    d.close()


def _one(frame, **eq):
    sel = frame
    for k, v in eq.items():
        sel = sel[sel[k] == v]
    assert len(sel) == 1, sel
    return sel.iloc[0]


def test_different_conditions_are_separate_rows_and_never_pair(two_conditions):
    table, paired = score_tables(two_conditions, n_boot=200)
    assert conditions_in(table) == [DEFAULTS, PAPER] and conditions_in(paired) == [DEFAULTS, PAPER]
    for level in ("l1", "all"):
        a = _one(table, level=level, estimator="ours", conditions=DEFAULTS)
        b = _one(table, level=level, estimator="ours", conditions=PAPER)
        assert a["episodes"] == b["episodes"] == 3 and a["setups"] == b["setups"] == 1
        assert a["spl"] == pytest.approx(0.8) and b["spl"] == pytest.approx(0.85)
        assert _one(table, level=level, estimator="dynamics", conditions=DEFAULTS)["spl"] == pytest.approx(0.3)
        assert _one(table, level=level, estimator="dynamics", conditions=PAPER)["spl"] == pytest.approx(0.1)
        assert _one(table, level=level, estimator="dynamics", conditions=PAPER)["success_rate"] == \
            pytest.approx(2 / 3)
    assert len(table) == 8  # (l1, all) x (ours, dynamics) x two conditions
    # pairs only within one set of conditions: ours - dynamics = mean of the per-task differences
    pa = _one(paired, level="all", conditions=DEFAULTS)
    pb = _one(paired, level="all", conditions=PAPER)
    assert pa["pairs"] == pb["pairs"] == 3
    assert pa["unpaired_reference"] == pa["unpaired_other"] == 0
    assert pa["spl_diff"] == pytest.approx(((0.9 - 0.6) + (0.8 - 0.0) + (0.7 - 0.3)) / 3)
    assert pb["spl_diff"] == pytest.approx(((0.95 - 0.1) + (0.85 - 0.0) + (0.75 - 0.2)) / 3)
    # the Fig. 5a matrix of one conditions set holds that set's value only
    m = spl_matrix(table, "all", conditions=PAPER)
    assert m.loc["low", "ours"].startswith("0.85 [")


def test_rows_without_condition_keys_still_split_by_their_runs_conditions(two_conditions, tmp_path):
    """Rows stored before condition keys existed pair by level, map and noise; the conditions
    their runs recorded still keep them apart."""
    d = ResultsDB(f"sqlite:///{tmp_path / 'legacy.db'}")
    r1 = d.start_run("six", "a", {"episode": {}}, "a")
    d.add_episodes(r1, [episode("o1", 0, spl_term=0.9), episode("y1", 0, estimator="dynamics", spl_term=0.5)])
    r2 = d.start_run("six", "b", {"episode": {"body_fixed_drive": True}}, "b")
    d.add_episodes(r2, [episode("o2", 0, spl_term=0.8), episode("y2", 0, estimator="dynamics", spl_term=0.0)])
    table, paired = score_tables(d, n_boot=50)
    d.close()
    assert set(table["episodes"]) == {1} and len(table) == 8
    diffs = {r.conditions: r.spl_diff for r in paired[paired["level"] == "all"].itertuples()}
    assert diffs == {DEFAULTS: pytest.approx(0.4),
                     "pose_quantisation=off, direction_limit=true, collision_check=swept": pytest.approx(0.8)}


def test_a_run_without_a_recorded_episode_config_is_labelled_unrecorded(tmp_path):
    d = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    rid = d.start_run("x", "y", {}, "a")
    d.add_episodes(rid, [episode("c", 0)])
    table, _ = score_tables(d, n_boot=20)
    d.close()
    assert set(table["conditions"]) == {UNRECORDED_CONDITIONS}


def test_score_cli_states_the_conditions(two_conditions, tmp_path, monkeypatch):
    from navbench.cli._common import console
    from navbench.cli.main import app

    # The CLI's console is built once, at import, and reads COLUMNS then: whichever test imports
    # it first fixes its width. Widen it here so the conditions label is never wrapped.
    monkeypatch.setattr(console, "_width", 250)

    url = two_conditions.url
    runner = CliRunner()
    res = runner.invoke(app, ["score", "--db", url, "--boot", "50", "--format", "json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert {d["conditions"] for d in doc["scores"]} == {DEFAULTS, PAPER}
    assert {d["conditions"] for d in doc["paired_differences"]} == {DEFAULTS, PAPER}
    res = runner.invoke(app, ["score", "--db", url, "--boot", "50", "--format", "csv"])
    header = res.stdout.splitlines()[0].split(",")
    assert "conditions" in header and len(res.stdout.strip().splitlines()) == 9
    res = runner.invoke(app, ["score", "--db", url, "--boot", "50"])
    assert res.exit_code == 0 and "never pooled" in res.stdout and PAPER in res.stdout
    assert "defaults" in res.stdout  # the conditions column of the default rows
    res = runner.invoke(app, ["score", "--db", url, "--boot", "50", "--run", "1"])
    assert res.exit_code == 0 and f"conditions: {DEFAULTS}" in res.stdout
    assert "never pooled" not in res.stdout


def test_all_prints_the_conditions_of_its_score_csv(two_conditions, tmp_path, capsys):
    """`navbench all`'s tables come from the score stage's CSV files: they carry the conditions."""
    from navbench.cli._common import console
    from navbench.cli.commands.all import _print_claim, _print_scores
    from navbench.results.score import paired_differences, select_episodes, summarise

    frame = select_episodes(two_conditions, run=2)
    summarise(frame, n_boot=20).to_csv(tmp_path / "score.csv", index=False)
    paired_differences(frame, n_boot=20).to_csv(tmp_path / "paired.csv", index=False)
    with console.capture() as cap:
        _print_scores(tmp_path / "score.csv")
        _print_claim(tmp_path / "paired.csv")
    out = " ".join(cap.get().split())  # captions wrap at the table's width
    assert out.count(f"conditions: {PAPER}") == 2  # under each of the two tables


def test_report_states_the_conditions_and_never_pools_them(two_conditions, tmp_path):
    """The report of a database with two sets of conditions: one Fig. 5a matrix, claim table
    and claim figure per set, each captioned with its conditions; the per-level table and the
    failure counts carry a conditions column; Fig. 4c names the camera, workers and CPU."""
    import pandas as pd

    from navbench.report.build import build_report

    d = two_conditions
    r3 = d.start_run("six", "c", {"episode": PAPER_EPISODE, "camera": "half", "workers": 2}, "c")
    d.add_episodes(r3, [episode("p-ours", 3, spl_term=0.5, condition_key="cond-paper")])
    index = build_report(d, tmp_path / "rep", levels_dir=tmp_path / "nolevels", n_boot=50)
    page = " ".join(index.read_text().split())
    for conds in (DEFAULTS, PAPER):
        assert f"Fig. 5a SPL beside navbench&#x27;s; scoring preset &#x27;paper&#x27;; conditions: {conds}" in page
        assert f"Noise low: ours − ablation on the same (task, seed); conditions: {conds}" in page
        assert f"margin; conditions: {conds}" in page  # the claim figure's caption
    assert "2 sets of simulator conditions, never pooled" in page
    first = pd.read_csv(tmp_path / "rep" / "spl_table.csv", index_col=0)
    second = pd.read_csv(tmp_path / "rep" / "spl_table_2.csv", index_col=0)
    assert first.loc["low", "ours"].startswith("0.80 [") and second.loc["low", "ours"].startswith("0.76 [")
    # (paper conditions: 0.95, 0.85, 0.75 and task 3's 0.5 -> 0.7625; shown to two digits)
    scores = pd.read_csv(tmp_path / "rep" / "scores.csv")
    paper_ours = scores[(scores["level"] == "all") & (scores["estimator"] == "ours")
                        & (scores["conditions"] == PAPER)]
    assert paper_ours["spl"].iloc[0] == pytest.approx(0.7625) and paper_ours["episodes"].iloc[0] == 4
    reasons = pd.read_csv(tmp_path / "rep" / "end_reasons.csv")
    assert sorted(reasons["conditions"]) == sorted(["defaults", "defaults", PAPER, PAPER])
    eps = pd.read_csv(tmp_path / "rep" / "episodes.csv")
    assert (eps["conditions"] == PAPER).sum() == 7 and (eps["conditions"] == DEFAULTS).sum() == 6
    paired = pd.read_csv(tmp_path / "rep" / "paired_differences.csv")
    row = paired[(paired["level"] == "all") & (paired["conditions"] == PAPER)].iloc[0]
    assert row["pairs"] == 3 and row["unpaired_reference"] == 1  # task 3 has no dynamics partner
    assert "camera half (160 x 120); 2 worker processes" in page


def test_markdown_results_table(two_conditions):
    """`score --format markdown`: per conditions, the pooled SPL beside the paper's Fig. 5a and
    the paired difference beside the paper's margin; success with its exact interval."""
    from navbench.cli.main import app
    from navbench.nav.metrics import clopper_pearson

    res = CliRunner().invoke(app, ["score", "--db", two_conditions.url, "--boot", "200", "--format", "markdown"])
    assert res.exit_code == 0, res.output
    out = res.stdout
    blocks = out.split("Conditions: ")[1:]
    assert [b.split(".")[0] for b in blocks] == [DEFAULTS, PAPER]
    low_default = next(ln for ln in blocks[0].splitlines() if ln.startswith("| low | 0."))
    low_paper = next(ln for ln in blocks[1].splitlines() if ln.startswith("| low | 0."))
    cells = [c.strip() for c in low_paper.strip("|").split("|")]
    assert cells[1].startswith("0.850 [") and cells[1].endswith("(0.92)")   # ours, paper 0.92
    assert cells[2].startswith("0.100 [") and cells[2].endswith("(0.61)")   # dynamics
    assert cells[3].startswith("+0.750 [") and cells[3].endswith("(+0.31)")  # ours - dynamics
    assert "+0.500 [" in low_default and "0.800 [" in low_default
    lo, hi = clopper_pearson(2, 3, 0.95)
    success = next(ln for ln in blocks[1].splitlines() if ln.startswith("| low | 1.000"))
    assert f"0.667 [{lo:.3f}, {hi:.3f}]" in success and "| 3 / 3 | 3 |" in success
