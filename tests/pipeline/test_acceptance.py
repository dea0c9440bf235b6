"""The acceptance test of a version change (``navbench compare --acceptance``; issue 36 §3) on
hand-made databases whose every difference is constant across tasks, so each 95 % interval is
its point and each verdict is worked out by hand below."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from navbench.cli.main import app
from navbench.errors import ConfigError
from navbench.results.acceptance import acceptance, cell_verdict, markdown
from navbench.results.db import ResultsDB

from .test_db import episode

TASKS = range(6)


def _grid(path, version, spl):
    """One run of ``version``: every (estimator, noise) of ``spl`` on tasks 0..5 of level l1,
    every episode a success whose SPL term is ``spl[(estimator, noise)]``."""
    db = ResultsDB(f"sqlite:///{path}")
    run = db.start_run("acceptance", "run-navigation", {}, version, benchmark_version=version)
    db.add_episodes(run, [episode(f"{est}-{noise}", t, estimator=est, noise=noise, spl_term=s,
                                  traj_key=f"{est}-{noise}-{t}")
                          for (est, noise), s in spl.items() for t in TASKS])
    db.close()
    return f"sqlite:///{path}"


OLD = {("ours", "low"): 0.8, ("ours", "mid"): 0.8, ("no-map", "low"): 0.5, ("no-map", "mid"): 0.5,
       ("dynamics", "low"): 0.3, ("dynamics", "mid"): 0.3}


def _new(**changes):
    spl = {("ours", "low"): 0.805, ("ours", "mid"): 0.795,  # +0.005 and -0.005: within ±0.01
           ("no-map", "low"): 0.5, ("no-map", "mid"): 0.5,  # 0: within
           ("dynamics", "low"): 0.35, ("dynamics", "mid"): 0.3}  # +0.05 (better), 0
    spl.update({tuple(k.split("_")): v for k, v in changes.items()})
    return spl


def test_cell_verdicts_by_hand():
    assert cell_verdict(0.01, -0.2) == "within"
    assert cell_verdict(-0.01, -0.2) == "within"
    assert cell_verdict(0.0101, 0.001) == "better"
    assert cell_verdict(0.05, -0.001) == "worse"
    assert cell_verdict(-0.05, -0.1) == "worse"


def test_accepted_grid(tmp_path):
    old = _grid(tmp_path / "1.db", "navbench-1", OLD)
    new = _grid(tmp_path / "2.db", "navbench-2", _new())
    r = acceptance(old, new)
    assert (r.old, r.new, r.accepted, r.failures) == ("navbench-1", "navbench-2", True, [])
    cells = {(c.estimator, c.noise): c for c in r.cells.itertuples()}
    assert len(cells) == 6 and all(c.pairs == len(TASKS) for c in cells.values())
    assert cells["ours", "low"].spl_diff == pytest.approx(0.005)
    assert cells["ours", "mid"].spl_diff == pytest.approx(-0.005)
    assert cells["dynamics", "low"].spl_diff == pytest.approx(0.05)
    assert cells["dynamics", "low"].spl_diff_ci_low == pytest.approx(0.05)
    assert {k: c.verdict for k, c in cells.items()} == {
        ("ours", "low"): "within", ("ours", "mid"): "within", ("no-map", "low"): "within",
        ("no-map", "mid"): "within", ("dynamics", "low"): "better", ("dynamics", "mid"): "within"}
    # the claim under both versions: ours - no-map and ours - dynamics at both noise levels
    claim = {(c.version, c.ablation, c.noise): c for c in r.claim.itertuples()}
    assert len(claim) == 8 and all(c.holds for c in claim.values())
    assert claim["navbench-1", "no-map", "low"].spl_diff == pytest.approx(0.3)
    assert claim["navbench-2", "dynamics", "low"].spl_diff == pytest.approx(0.455)
    text = markdown(r)
    assert "navbench-2 against navbench-1: accepted" in text and "Why not" not in text


def test_a_worse_cell_and_a_failed_claim_reject(tmp_path):
    old = _grid(tmp_path / "1.db", "navbench-1", OLD)
    # no-map at mid: 0.5 -> 0.4 (worse by 0.1); no-map at low: 0.5 -> 0.805 (better, but now
    # ours - no-map = 0 at low under navbench-2: the claim fails there)
    new = _grid(tmp_path / "2.db", "navbench-2", _new(**{"no-map_mid": 0.4, "no-map_low": 0.805}))
    r = acceptance(old, new)
    assert not r.accepted
    verdicts = {(c.estimator, c.noise): c.verdict for c in r.cells.itertuples()}
    assert verdicts["no-map", "mid"] == "worse" and verdicts["no-map", "low"] == "better"
    assert len(r.failures) == 2
    assert r.failures[0].startswith("no-map at mid noise: SPL navbench-2 - navbench-1 -0.100")
    assert r.failures[1].startswith("the claim fails under navbench-2 at low noise: ours - no-map SPL +0.000")
    fails = r.claim[~r.claim["holds"]]
    assert list(zip(fails["version"], fails["ablation"], fails["noise"])) == [("navbench-2", "no-map", "low")]


def test_same_version_on_both_sides_is_refused(tmp_path):
    old = _grid(tmp_path / "1.db", "navbench-1", OLD)
    again = _grid(tmp_path / "1b.db", "navbench-1", _new())
    with pytest.raises(ConfigError, match="both databases hold navbench-1"):
        acceptance(old, again)


def test_cli_exit_codes_and_formats(tmp_path):
    old = _grid(tmp_path / "1.db", "navbench-1", OLD)
    good = _grid(tmp_path / "2.db", "navbench-2", _new())
    bad = _grid(tmp_path / "3.db", "navbench-2", _new(**{"no-map_mid": 0.4}))
    runner = CliRunner()
    r = runner.invoke(app, ["compare", "--db", old, "--b-db", good, "--acceptance", "--format", "markdown"])
    assert r.exit_code == 0, r.output
    assert "| `dynamics` | low | 6 | 0.300 | 0.350 |" in r.output and "| better |" in r.output
    r = runner.invoke(app, ["compare", "--db", old, "--b-db", bad, "--acceptance", "--format", "json"])
    assert r.exit_code == 1
    doc = json.loads(r.stdout)
    assert doc["accepted"] is False and len(doc["failures"]) == 1 and len(doc["cells"]) == 6
    r = runner.invoke(app, ["compare", "--db", old, "--b-db", bad, "--acceptance"])
    assert r.exit_code == 1 and "not accepted" in r.output


@pytest.mark.parametrize("args, message", [
    (["--acceptance"], "--b-db"),
    (["--acceptance", "--b-db", "B", "--pair", "no-map:ours"], "leave out --pair"),
    (["--acceptance", "--b-db", "B", "--format", "csv"], "two tables"),
])
def test_cli_usage_errors_are_one_line(tmp_path, args, message, capsys):
    from navbench.cli.main import main

    old = _grid(tmp_path / "1.db", "navbench-1", OLD)
    args = [old if a == "B" else a for a in args]
    with pytest.raises(SystemExit) as e:
        main(["compare", "--db", old, *args])
    err = capsys.readouterr().err
    assert e.value.code == 2
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
