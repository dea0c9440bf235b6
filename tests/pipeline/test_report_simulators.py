"""The report's Simulators section (issue 37 §4): one benchmark version on two backends side by
side, from one database holding both (``navbench-1`` and ``navbench-1+vizdoom``) or from
``report --b-db``; its numbers are ``navbench compare --b-db``'s on the same pairs, never pooled."""

from __future__ import annotations

import html
import re

import pandas as pd
import pytest

from navbench.report.build import build_report
from navbench.results.compare import compare
from navbench.results.db import ResultsDB

from .test_db import episode

ESTIMATORS = ("ours", "no-map")
NOISES = ("low", "mid")
TASKS = range(5)


def _spl(sim: str, est: str, noise: str, level: str, task: int) -> float:
    """Distinct per episode (so the bootstrap intervals have a spread), and clearly apart between
    the backends: pymunk's no-map near 0.8, vizdoom's near 0.3 (a pooled mean would be near 0.55)."""
    base = {("pymunk", "ours"): 0.85, ("pymunk", "no-map"): 0.8, ("vizdoom", "ours"): 0.7,
            ("vizdoom", "no-map"): 0.3}[sim, est]
    return round(base - 0.02 * task - (0.05 if noise == "mid" else 0.0) - (0.01 if level == "l2" else 0.0), 4)


def _store(db: ResultsDB, sim: str, levels=("l1", "l2"), seeds=(0,), failures=()) -> None:
    """One run of every (estimator, noise, level, task, seed) on ``sim``, stored under its benchmark
    version; ``failures``: (estimator, noise, task) stored as failures (success 0, SPL 0)."""
    version = "navbench-1" if sim == "pymunk" else f"navbench-1+{sim}"
    run = db.start_run("six", "run-navigation", {}, f"{sim}-{seeds}", benchmark_version=version)
    rows = []
    for est in ESTIMATORS:
        for noise in NOISES:
            for level in levels:
                for t in TASKS:
                    for s in seeds:
                        ok = (est, noise, t) not in failures
                        rows.append(episode(f"{sim}-{est}-{noise}-{level}", t, seed=s, level=level, estimator=est,
                                            noise=noise, success=ok, spl_term=_spl(sim, est, noise, level, t) if ok else 0.0,
                                            traj_key=f"{sim}-{est}-{noise}-{level}-{t}-{s}"))
    db.add_episodes(run, rows)
    db.finish_run(run)


def _db(path, *sims, **kw) -> str:
    db = ResultsDB(f"sqlite:///{path}")
    for sim in sims:
        _store(db, sim, **kw)
    db.close()
    return f"sqlite:///{path}"


def _section(text: str) -> str:
    assert 'id="simulators"' in text
    return text.split('id="simulators"', 1)[1].split("<h2", 1)[0]


def _cells(section: str) -> list[list[str]]:
    rows = re.findall(r"<tr[^>]*>(.*?)</tr>", section, re.S)
    return [[html.unescape(re.sub("<[^>]+>", "", c)).strip().replace("\u00a0", " ")
             for c in re.findall(r"<t[dh][^>]*>(.*?)</t[dh]>", r, re.S)] for r in rows]


COLS = ["estimator_a", "level", "noise", "pairs", "unpaired_a", "unpaired_b", "success_a", "success_b",
        "success_diff", "success_diff_ci_low", "success_diff_ci_high", "spl_a", "spl_b", "spl_diff",
        "spl_diff_ci_low", "spl_diff_ci_high"]


def test_b_db_section_equals_compare_on_the_same_pairs(tmp_path):
    """``report --b-db`` (through the CLI): the CSV's every number is ``compare(--b-db)``'s, and the
    page shows the pooled rows with both SPLs, the paper's, and the difference with its interval."""
    from typer.testing import CliRunner

    from navbench.cli.main import app

    failures = {("no-map", "low", 1), ("ours", "mid", 3)}
    a = _db(tmp_path / "p.db", "pymunk")
    # vizdoom: one level only (l2's pymunk episodes are unpaired), a few failures
    b = _db(tmp_path / "v.db", "vizdoom", levels=("l1",), failures=failures)
    res = CliRunner().invoke(app, ["report", "--db", a, "--b-db", b, "--out", str(tmp_path / "rep"), "--boot", "300",
                                   "--levels", str(tmp_path / "levels"), "--cache", str(tmp_path / "cache")])
    assert res.exit_code == 0, res.output
    got = pd.read_csv(tmp_path / "rep" / "simulators.csv")
    want = compare(a, b_db=b, n_boot=300, seed=0).table
    assert len(got) == len(want) == len(ESTIMATORS) * len(NOISES) * 3  # levels l1, l2 (no pair) and pooled
    for c in COLS:
        if got[c].dtype.kind == "f":
            assert got[c].to_numpy() == pytest.approx(want[c].to_numpy(), rel=1e-6, nan_ok=True), c
        else:
            assert list(got[c].astype(str)) == list(want[c].astype(str)), c
    assert set(got["backend_a"]) == {"pymunk: navbench-1"} and set(got["backend_b"]) == {"vizdoom: navbench-1+vizdoom"}
    assert (got["unpaired_a"][got["level"] == "all"] == len(TASKS)).all()  # l2 is pymunk's only

    text = (tmp_path / "rep" / "index.html").read_text()
    cells = _cells(_section(text))
    assert cells[0] == ["estimator", "noise", "pairs (unpaired pymunk / vizdoom)", "success pymunk",
                        "success vizdoom", "success vizdoom − pymunk [95 %]", "SPL pymunk", "SPL vizdoom",
                        "SPL paper (Fig. 5a)", "SPL − paper, pymunk / vizdoom", "SPL vizdoom − pymunk [95 %]"]
    row = next(r for r in cells[1:] if r[:2] == ["no-map", "low"])
    w = want[(want["level"] == "all") & (want["estimator_a"] == "no-map") & (want["noise"] == "low")].iloc[0]
    assert row[2] == "5 (5 / 0)" and row[8] == "0.61"  # Fig. 5a: no-map at low noise
    assert row[6:8] == [f"{w.spl_a:.3f}", f"{w.spl_b:.3f}"]
    assert row[9] == f"{w.spl_a - 0.61:+.3f} / {w.spl_b - 0.61:+.3f}"
    assert row[10] == f"{w.spl_diff:+.3f} [{w.spl_diff_ci_low:+.3f}, {w.spl_diff_ci_high:+.3f}]"
    assert w.spl_diff_ci_low < w.spl_diff < w.spl_diff_ci_high  # a real interval, not a point
    assert row[5].startswith(f"{w.success_diff:+.3f} [")
    assert 'href="#simulators"' in text


def test_one_database_two_simulators_each_shown_never_pooled(tmp_path):
    url = _db(tmp_path / "r.db", "pymunk", "vizdoom")
    with ResultsDB(url) as db:
        index = build_report(db, tmp_path / "rep", levels_dir=tmp_path / "levels", n_boot=200)
        text = index.read_text()
        # the main sections stay one version (pymunk's, the reference); --benchmark-version the other
        lead = pd.read_csv(tmp_path / "rep" / "leaderboard.csv")
        spl = lead.set_index(["estimator", "noise"])["spl"]
        assert spl["no-map", "low"] == pytest.approx(sum(_spl("pymunk", "no-map", "low", lv, t)
                                                         for lv in ("l1", "l2") for t in TASKS) / 10)
        cells = _cells(_section(text))
        row = next(r for r in cells[1:] if r[:2] == ["no-map", "low"])
        p = [_spl("pymunk", "no-map", "low", lv, t) for lv in ("l1", "l2") for t in TASKS]
        v = [_spl("vizdoom", "no-map", "low", lv, t) for lv in ("l1", "l2") for t in TASKS]
        assert row[6:8] == ["0.755", "0.255"] == [f"{sum(p) / 10:.3f}", f"{sum(v) / 10:.3f}"]  # not 0.505
        assert row[8:10] == ["0.61", "+0.145 / -0.355"]  # the paper's no-map at low, and each gap to it
        assert row[10].startswith("-0.500 [")  # every pair differs by 0.5
        # the claim on each backend: pymunk's rows are the main claim section's, vizdoom's its own
        claim = pd.read_csv(tmp_path / "rep" / "simulators_claim.csv")
        main = pd.read_csv(tmp_path / "rep" / "paired_differences.csv")
        mine = claim[claim["backend"] == "pymunk"].drop(columns=["backend", "paper_diff"]).reset_index(drop=True)
        pd.testing.assert_frame_equal(mine, main, check_dtype=False)
        viz = claim[(claim["backend"] == "vizdoom") & (claim["level"] == "all")]
        assert viz["spl_diff"].to_numpy() == pytest.approx([0.4, 0.4])  # ours 0.7 - no-map 0.3 per task
        assert list(viz["paper_diff"]) == pytest.approx([0.92 - 0.61, 0.79 - 0.51])
        ctab = _cells(_section(text).split("simulators_claim.csv", 1)[1])
        assert ctab[0] == ["comparison", "noise", "SPL pymunk [95 %] (pairs)", "SPL vizdoom [95 %] (pairs)",
                           "paper (Fig. 5a)"]
        assert ctab[1][:2] == ["ours − no-map", "low"] and ctab[1][3].startswith("+0.400 [") and ctab[1][4] == "+0.31"
        # read at the other version, vizdoom's sections, and still vizdoom - pymunk beside them
        build_report(db, tmp_path / "rep2", levels_dir=tmp_path / "levels", n_boot=200,
                     benchmark_version="navbench-1+vizdoom")
    text2 = (tmp_path / "rep2" / "index.html").read_text()
    assert "Benchmark version navbench-1+vizdoom" in text2
    row2 = next(r for r in _cells(_section(text2))[1:] if r[:2] == ["no-map", "low"])
    assert row2 == row


def test_no_paired_episodes_is_one_line(tmp_path):
    a = _db(tmp_path / "p.db", "pymunk")
    b = _db(tmp_path / "v.db", "vizdoom", seeds=(7,))  # other seeds: no pair
    with ResultsDB(a) as db, ResultsDB(b, create=False) as bdb:
        index = build_report(db, tmp_path / "rep", levels_dir=tmp_path / "levels", n_boot=50, b_db=bdb)
    section = _section(index.read_text())
    assert "share no paired episodes" in section and 'href="simulators.csv"' not in section
    assert not (tmp_path / "rep" / "simulators.csv").exists()


@pytest.mark.parametrize("which, message", [
    ("missing", "--b-db: no results database at /nonexistent/dir/b.db"),
    ("empty", "no navigation episodes to set beside the report's"),
])
def test_cli_bad_b_db_is_one_line_and_writes_nothing(tmp_path, capsys, which, message):
    from navbench.cli.main import main

    a = _db(tmp_path / "p.db", "pymunk")
    if which == "missing":
        b = "sqlite:////nonexistent/dir/b.db"
    else:
        b = _db(tmp_path / "empty.db")  # a results database with no episode
    with pytest.raises(SystemExit) as e:
        main(["report", "--db", a, "--b-db", b, "--out", str(tmp_path / "rep"),
              "--levels", str(tmp_path / "levels"), "--cache", str(tmp_path / "cache")])
    err = capsys.readouterr().err
    assert e.value.code == 2 and message in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "rep").exists()


def test_b_db_on_the_same_simulator_is_named_by_database(tmp_path):
    """Two databases of one backend (a rerun of the grid): the sides are named by where they come
    from, the title says so, and equal episodes differ by exactly 0."""
    a = _db(tmp_path / "p.db", "pymunk")
    b = _db(tmp_path / "p2.db", "pymunk")
    with ResultsDB(a) as db, ResultsDB(b, create=False) as bdb:
        text = build_report(db, tmp_path / "rep", levels_dir=tmp_path / "levels", n_boot=50, b_db=bdb).read_text()
    assert 'id="simulators">Two databases on one simulator, side by side (report --b-db)</h2>' in text
    cells = _cells(_section(text))
    assert cells[0][6:8] == ["SPL pymunk (this database)", "SPL pymunk (--b-db)"]
    assert all(r[10] == "+0.000 [+0.000, +0.000]" for r in cells[1:1 + len(ESTIMATORS) * len(NOISES)])
