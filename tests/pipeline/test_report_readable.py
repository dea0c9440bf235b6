"""The report read as a person reads it (issue 35 §1 and §6): long commands wrap instead of widening
the page, numbers at consistent decimals per column, labels instead of column names, counts with
their plurals, the paper's SPL beside navbench's in one table, a leaderboard of every estimator,
and the comparisons named with ``--pair``."""

from __future__ import annotations

import html
import re

import pytest

from navbench.results.db import ResultsDB
from navbench.report.build import build_report

from .test_report import CHROMIUM, fake_loader, fill_db, run_chromium, write_level

LONG = ("/work/main/.venv/bin/navbench run-navigation house-1 --profile imagenav-unknown-quick --tasks 100 "
        "--db sqlite:////home/someone/experiments/2026-11-26/table4-six-houses-with-a-long-name/results/"
        "table4-ablations-nrns-preset-all-six-houses.db --estimators ours,no-map,dynamics")


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("readable")
    db = ResultsDB(f"sqlite:///{tmp / 'r.db'}")
    trajs = fill_db(db)
    rid = db.start_run("quick", LONG, {}, "d" * 64)  # a second run, with a long command
    db.finish_run(rid)
    write_level(tmp / "levels", "lvA")
    index = build_report(db, tmp / "report", load_trajectory=fake_loader(trajs), levels_dir=tmp / "levels",
                         n_boot=100, pairs=[("no-map", "ours"), ("dynamics", "no-map")])
    db.close()
    return tmp, index.read_text()


def _table(text: str, csv_name: str) -> str:
    """The HTML of the table whose caption links ``csv_name``."""
    m = re.search(r'<figure class="table"><figcaption>(?:(?!</figure>).)*?href="' + re.escape(csv_name)
                  + r'"(?:(?!</figure>).)*</figure>', text, re.S)
    assert m, csv_name
    return m.group(0)


def _cells(table_html: str) -> list[list[str]]:
    rows = re.findall(r"<tr[^>]*>(.*?)</tr>", table_html, re.S)
    return [[html.unescape(re.sub("<[^>]+>", "", c)).strip() for c in re.findall(r"<t[dh][^>]*>(.*?)</t[dh]>", r, re.S)]
            for r in rows]


def test_counts_have_their_plural_and_no_zero_tracking_rows_above_episode_cdfs(tmp_path):
    db = ResultsDB(f"sqlite:///{tmp_path / 'one.db'}")
    rid = db.start_run("quick", "all", {}, "e" * 64)
    from .test_db import episode

    db.add_episodes(rid, [episode("c", 0)])
    db.finish_run(rid)
    text = build_report(db, tmp_path / "rep", levels_dir=tmp_path / "levels", n_boot=20).read_text()
    db.close()
    meta = re.search(r'<p class="meta">Generated(.*?)</p>', text, re.S).group(1)
    assert "1 run," in meta and "1 runs" not in meta and "1 episode" in meta and "1 episodes" not in meta
    assert "0 tracking" not in meta  # the tracking CDFs below come from the navigation episodes


def test_long_commands_wrap_instead_of_widening_the_page(report):
    tmp, text = report
    assert LONG.split()[-3][:40] in text  # the long command is on the page
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium)")
    probe = tmp / "report" / "width.html"
    probe.write_text(text.replace("</body>", """<script>
window.addEventListener('load', function () {
  var m = document.createElement('pre');
  m.textContent = 'NBWIDTH scroll=' + document.documentElement.scrollWidth + ' view=' +
                  document.documentElement.clientWidth + ' END';
  document.body.appendChild(m);
});
</script></body>"""))
    proc = run_chromium(["--window-size=1000,800", "--dump-dom", probe.as_uri()], tmp)
    found = re.search(r"NBWIDTH scroll=(\d+) view=(\d+) END", proc.stdout)
    assert found, proc.stderr[-500:]
    assert int(found.group(1)) <= int(found.group(2))  # no horizontal scroll bar


def test_numbers_at_consistent_decimals_and_labels_for_column_names(report):
    _, text = report
    tracking = _cells(_table(text, "tracking_summary.csv"))
    head, rows = tracking[0], tracking[1:]
    assert not [h for h in head if "_" in h], head  # labels, not frac_loc_rmse_below_0.1m
    assert "frac_loc_rmse_below_0.1m" not in text.split("tracking_summary.csv", 1)[1].split("</figure>", 1)[0]
    for j in range(1, len(head)):
        decimals = {len(r[j].split(".")[1]) if "." in r[j] else 0 for r in rows if r[j] not in ("–", "")}
        assert len(decimals) <= 1, (head[j], [r[j] for r in rows])
    runtime = _cells(_table(text, "runtime.csv"))
    for j in range(1, len(runtime[0])):
        col = [r[j] for r in runtime[1:] if len(r) > j and r[j] not in ("–", "")]
        assert len({len(v.split(".")[1]) if "." in v else 0 for v in col}) <= 1, (runtime[0][j], col)
    for raw in ("step_ms", "step_hz", "config_hash", "navbench_version", "depth_mae_m"):
        assert f"<th>{raw}</th>" not in text, raw


def test_leaderboard_every_estimator_once_with_the_papers_spl_beside(report):
    _, text = report
    board = _cells(_table(text, "leaderboard.csv"))
    head, rows = board[0:2], board[2:]
    flat = " ".join(" ".join(h) for h in head)
    assert "SR" in flat and "SPL" in flat and "paper" in flat
    assert sorted(r[0] for r in rows) == ["dynamics", "no-map", "ours"]  # one row per estimator
    assert "spl_paper.csv" not in text.split('id="spl"', 1)[1].split('id="scores"', 1)[0]  # no separate paper table
    # the paper's SPL sits right after navbench's SPL of the same noise, in the same order
    sub = head[-1]
    for i, h in enumerate(sub):
        if h.startswith("paper"):
            assert sub[i - 1].startswith("SPL")
    ours = next(r for r in rows if r[0] == "ours")
    assert "0.46" in ours and "0.92" in ours  # Fig. 5a: ours high 0.46, low 0.92


def test_report_pair_shows_the_compare_table(report):
    _, text = report
    section = text.split('id="compare"', 1)[1].split("<h2", 1)[0]
    assert "ours - no-map" in section and "no-map - dynamics" in section
    cells = _cells(_table(text, "comparisons.csv"))
    assert cells[0][:3] == ["B - A", "level", "noise"]
    assert {r[0] for r in cells[1:]} == {"ours - no-map", "no-map - dynamics"}


def test_report_cli_pair(tmp_path):
    from typer.testing import CliRunner

    from navbench.cli.main import app

    db = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    fill_db(db)
    db.close()
    url = f"sqlite:///{tmp_path / 'r.db'}"
    res = CliRunner().invoke(app, ["report", "--db", url, "--out", str(tmp_path / "rep"), "--boot", "20",
                                   "--levels", str(tmp_path / "levels"), "--cache", str(tmp_path / "cache"),
                                   "--pair", "dynamics:ours"])
    assert res.exit_code == 0, res.output
    assert "ours - dynamics" in (tmp_path / "rep" / "index.html").read_text()


def test_report_unknown_pair_is_one_line_and_writes_nothing(tmp_path, capsys):
    from navbench.cli.main import main

    db = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    fill_db(db)
    db.close()
    with pytest.raises(SystemExit) as e:
        main(["report", "--db", f"sqlite:///{tmp_path / 'r.db'}", "--out", str(tmp_path / "rep"),
              "--levels", str(tmp_path / "levels"), "--cache", str(tmp_path / "cache"), "--pair", "nope:ours"])
    err = capsys.readouterr().err
    assert e.value.code == 2 and "no estimator 'nope'" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "rep").exists()


def test_decimals_and_plurals_by_hand():
    from navbench.report.display import decimals, plural, shown

    assert decimals([31.0, 4.2]) == 1  # 3 significant figures of 31.0
    assert decimals([31.0, 0.0123]) == 3  # and 2 of the smallest non-zero value
    assert decimals([0.0295, 0.0508]) == 4
    assert decimals([20.0, 0.1]) == 1 and decimals([500.0, 12.0]) == 0  # already round: no trailing zeros
    assert decimals([0.0, float("nan")]) == 0
    assert (plural(0, "run"), plural(1, "run"), plural(2, "entry", "entries")) == ("0 runs", "1 run", "2 entries")
    import pandas as pd

    page = shown(pd.DataFrame({"loc_rmse_median_m": [0.06026, 0.1], "steps": [3, 4]}))
    assert list(page.columns) == ["median location RMSE (m)", "steps"]
    assert list(page.iloc[:, 0]) == ["0.060", "0.100"]  # 3 figures of 0.1, 2 of 0.06026: 3 decimals and list(page["steps"]) == [3, 4]
