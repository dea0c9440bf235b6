"""``navbench compare`` (issue 35): paired differences B - A on hand-made databases whose every
number is worked out by hand below, in both interval methods; the CLI's formats and errors.

These cases replaced ``scripts/paired_runs.py``: while the script existed, it printed the same
points and intervals on :func:`_table4_like` (``--a 1,3 --b 2 --preset nrns``), and on random
databases ``--interval percentile`` matched it to the last printed digit (the draws are the
script's: ``navbench.results.paired.percentile_ci``)."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from navbench.cli.main import app
from navbench.results.db import ResultsDB
from navbench.results.compare import compare, parse_pair
from navbench.results.paired import mcnemar_exact_p, percentile_ci

from .test_db import episode

L = 4.0  # every task's shortest path (m): an nrns success's SPL term is L / path


def _ep(cell, task, level, *, stop=True, dist=0.5, path=4.0, estimator="gt", **kw):
    """An episode whose nrns score is set by ``stop`` (end_reason reached), ``dist`` (final
    Euclidean distance, success at <= 1 m) and ``path`` (SPL term L / path on success). The
    stored (paper) success and SPL are deliberately the opposite of nrns's, so a test passes
    only when the preset is applied."""
    ok = stop and dist <= 1.0
    return episode(cell, task, level=level, estimator=estimator, noise="mid", success=not ok,
                   spl_term=0.0 if ok else 0.9, optimal_length=L, path_length=path, final_dist_m=dist,
                   final_geo_m=dist, end_reason="reached" if stop else "stuck", steps=100, **kw)


def _table4_like(path, b_path=None):
    """Six pairs of estimator gt at noise mid: side A = runs 1 and 3, side B = run 2.

    ==========  =====================  =====================  ======  =======
    level/task  A (nrns success, SPL)  B (nrns success, SPL)  SPL B-A  SR B-A
    ==========  =====================  =====================  ======  =======
    l1/0        1, 4/5   = 0.8         1, 4/4   = 1.0         +0.2     0
    l1/1        1, 4/8   = 0.5         1, 4/5.714 = 0.7       +0.2     0
    l1/2        1, 4/10  = 0.4         1, 4/6.667 = 0.6       +0.2     0
    l1/3        1, 4/6.667 = 0.6       1, 4/5   = 0.8         +0.2     0
    l2/0        0 (no stop)            1, 4/8   = 0.5         +0.5    +1
    l2/1        0 (1.5 m away)         1, 4/8   = 0.5         +0.5    +1
    ==========  =====================  =====================  ======  =======

    Plus: A's l1/4 and B's l2/2 have no partner (unpaired 1 and 1); run 1 stored l1/0 as a
    failure that run 3 stored again as the success above (the last stored row counts).
    Differences are constant within each level, so a bootstrap stratified by level has no
    spread: every interval is its point (an unstratified one would not be).
    """
    db = ResultsDB(f"sqlite:///{path}")
    r1 = db.start_run("quick", "run-navigation", {}, "a")
    db.add_episodes(r1, [_ep("a1", 0, "l1", dist=3.0),  # superseded by run 3's row
                         _ep("a1", 1, "l1", path=8.0), _ep("a1", 2, "l1", path=10.0),
                         _ep("a1", 3, "l1", path=L / 0.6), _ep("a1", 4, "l1"),
                         _ep("a2", 0, "l2", stop=False, dist=0.3), _ep("a2", 1, "l2", dist=1.5)])
    bdb = db if b_path is None else ResultsDB(f"sqlite:///{b_path}")
    r2 = bdb.start_run("quick", "run-navigation", {}, "b")
    bdb.add_episodes(r2, [_ep("b1", 0, "l1", path=4.0), _ep("b1", 1, "l1", path=L / 0.7),
                          _ep("b1", 2, "l1", path=L / 0.6), _ep("b1", 3, "l1", path=5.0),
                          _ep("b2", 0, "l2", path=8.0), _ep("b2", 1, "l2", path=8.0), _ep("b2", 2, "l2")])
    r3 = db.start_run("quick", "run-navigation", {}, "a, resumed")
    db.add_episodes(r3, [_ep("a3", 0, "l1", path=5.0)])
    if bdb is not db:
        bdb.close()
    db.close()
    return r1, r2, r3


def _row(table, level):
    rows = table[table["level"] == level]
    assert len(rows) == 1
    return rows.iloc[0]


@pytest.mark.parametrize("method", ["bca", "percentile"])
def test_two_sets_of_runs_hand_computed(tmp_path, method):
    _table4_like(tmp_path / "r.db")
    res = compare(f"sqlite:///{tmp_path / 'r.db'}", a="1,3", b="2", preset="nrns", method=method, n_boot=500)
    t = res.table
    assert res.preset == "nrns" and (t["preset"] == "nrns").all()
    assert list(t["level"]) == ["l1", "l2", "all"] and set(t["comparison"]) == {"gt (B) - gt (A)"}
    assert any("1 episode(s) share" in w for w in res.warnings)  # run 1's l1/0, superseded by run 3
    l1, l2, pooled = _row(t, "l1"), _row(t, "l2"), _row(t, "all")
    assert (l1.pairs, l1.unpaired_a, l1.unpaired_b) == (4, 1, 0)
    assert (l2.pairs, l2.unpaired_a, l2.unpaired_b) == (2, 0, 1)
    assert (pooled.pairs, pooled.unpaired_a, pooled.unpaired_b) == (6, 1, 1)
    assert pooled.spl_a == pytest.approx((0.8 + 0.5 + 0.4 + 0.6) / 6)
    assert pooled.spl_b == pytest.approx((1.0 + 0.7 + 0.6 + 0.8 + 0.5 + 0.5) / 6)
    assert pooled.success_a == pytest.approx(4 / 6) and pooled.success_b == 1.0
    assert (pooled.only_a, pooled.only_b) == (0, 2)
    assert pooled.mcnemar_p == pytest.approx(0.5)  # 2 discordant pairs, both B's: 2 * (1/2)^2
    for row, spl, sr in ((l1, 0.2, 0.0), (l2, 0.5, 1.0), (pooled, (4 * 0.2 + 2 * 0.5) / 6, 2 / 6)):
        assert row.spl_diff == pytest.approx(spl)
        assert (row.spl_diff_ci_low, row.spl_diff_ci_high) == pytest.approx((spl, spl))
        assert row.success_diff == pytest.approx(sr)
        assert (row.success_diff_ci_low, row.success_diff_ci_high) == pytest.approx((sr, sr))
    # SoftSPL (geodesic 0.5 m of 4 m left: 7/8 of the SPL ratio) and RMSE (0.05 on both sides)
    assert l2.soft_spl_b == pytest.approx(0.875 * 0.5)
    assert pooled.loc_rmse_diff == pytest.approx(0.0) and pooled.loc_rmse_pairs == 6
    assert "BCa" in res.interval if method == "bca" else "percentile" in res.interval


def test_a_second_database_gives_the_same_numbers(tmp_path):
    _table4_like(tmp_path / "a.db", b_path=tmp_path / "b.db")
    _table4_like(tmp_path / "one.db")
    # a.db's run 2 is the resumed one (run 3 of one.db)
    two = compare(f"sqlite:///{tmp_path / 'a.db'}", a="1,2", b="1", b_db=f"sqlite:///{tmp_path / 'b.db'}",
                  preset="nrns", n_boot=200).table
    one = compare(f"sqlite:///{tmp_path / 'one.db'}", a="1,3", b="2", preset="nrns", n_boot=200).table
    cols = ["level", "pairs", "unpaired_a", "unpaired_b", "spl_diff", "success_diff", "only_b", "mcnemar_p"]
    assert two[cols].equals(one[cols])


def test_percentile_draws_are_the_scripts():
    """scripts/paired_runs.py's stratified_ci, written out: 4000 means of every level's values
    drawn with replacement from one generator, then the 2.5 and 97.5 percentiles."""
    groups = [np.array([0.0, 1.0, 0.5]), np.array([0.2, 0.9])]
    rng = np.random.default_rng(0)
    boots = [np.mean(np.concatenate([rng.choice(g, len(g)) for g in groups])) for _ in range(4000)]
    assert percentile_ci(groups, np.random.default_rng(0)) == tuple(np.percentile(boots, [2.5, 97.5]))


def test_mcnemar_exact_by_hand():
    assert mcnemar_exact_p(0, 0) == 1.0
    assert mcnemar_exact_p(0, 3) == pytest.approx(2 / 8)
    assert mcnemar_exact_p(1, 4) == pytest.approx(2 * (1 + 5) / 32)
    assert mcnemar_exact_p(3, 3) == 1.0


@pytest.fixture
def two_estimators(tmp_path):
    """One run: ours and ours-every-k on the same two tasks of l1 (and ours alone on task 2).
    ours: SPL terms 0.8, 0.5, 0.9; ours-every-k: 0.4, 0.5 (nrns: 4/10, 4/8)."""
    db = ResultsDB(f"sqlite:///{tmp_path / 'e.db'}")
    r = db.start_run("quick", "run-navigation", {}, "x")
    db.add_episodes(r, [_ep("o", 0, "l1", estimator="ours", path=5.0), _ep("o", 1, "l1", estimator="ours", path=8.0),
                        _ep("o", 2, "l1", estimator="ours", path=L / 0.9),
                        _ep("k", 0, "l1", estimator="ours-every-k", path=10.0),
                        _ep("k", 1, "l1", estimator="ours-every-k", path=8.0)])
    db.close()
    return f"sqlite:///{tmp_path / 'e.db'}"


def test_two_estimators_of_one_selection(two_estimators):
    t = compare(two_estimators, pairs=["ours-every-k:ours"], preset="nrns", n_boot=200).table
    assert list(t["level"]) == ["l1", "all"]
    r = _row(t, "l1")
    assert r.comparison == "ours - ours-every-k"
    assert (r.pairs, r.unpaired_a, r.unpaired_b) == (2, 0, 1)
    assert r.spl_a == pytest.approx(0.45) and r.spl_b == pytest.approx(0.65)
    assert r.spl_diff == pytest.approx(0.2)  # (0.8 - 0.4 + 0.5 - 0.5) / 2


def test_cli_formats(two_estimators):
    runner = CliRunner()
    base = ["compare", "--db", two_estimators, "--pair", "ours-every-k:ours", "--preset", "nrns", "--boot", "100"]
    res = runner.invoke(app, base + ["--format", "json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["difference"] == "B - A" and doc["preset"] == "nrns" and "McNemar" in doc["interval"]
    assert doc["comparisons"][0]["spl_diff"] == pytest.approx(0.2)
    rows = list(csv.DictReader(io.StringIO(runner.invoke(app, base + ["--format", "csv"]).stdout)))
    assert float(rows[0]["spl_diff"]) == pytest.approx(0.2) and rows[0]["estimator_a"] == "ours-every-k"
    md = runner.invoke(app, base + ["--format", "markdown"]).stdout
    assert "| ours - ours-every-k | l1 | mid | 2 (0 / 1) | 1.000 / 1.000 |" in md
    table = runner.invoke(app, base).stdout
    assert "ours - ours-every-k  (B - A)" in table and "+0.200" in table
    assert not [ln for ln in table.splitlines() if ln.split()[:1] == ["all"]]  # one level: no pooled rows
    assert "0.450" in table and "0.650" in table


@pytest.mark.parametrize("args, message", [
    (["--pair", "nope:ours"], "no estimator 'nope'"),
    (["--pair", "ours"], "give two estimators as A:B"),
    (["--pair", "ours:ours"], "with itself"),
    (["--pair", "ours-every-k:ours", "--a", "7"], "--a: no run with id 7"),
    (["--pair", "ours-every-k:ours", "--preset", "nrnss"], "unknown scoring preset 'nrnss'"),
    (["--a", "1", "--b-db", "sqlite:////nonexistent/dir/b.db"], "--b-db: no results database at /nonexistent/dir/b.db"),
    ([], "name what to compare"),
])
def test_cli_errors_are_one_line(two_estimators, args, message, capsys):
    from navbench.cli.main import main

    with pytest.raises(SystemExit) as e:
        main(["compare", "--db", two_estimators] + args)
    err = capsys.readouterr().err
    assert e.value.code == 2
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_parse_pair():
    assert parse_pair("ours-every-k:ours") == ("ours-every-k", "ours")
