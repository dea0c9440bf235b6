"""Smoke test of docs/data/claim/nav_eval.py on the committed house-1 level and task set."""

from __future__ import annotations

from pathlib import Path

from tests.scripts import load_script

ROOT = Path(__file__).resolve().parents[2]


def test_nav_eval_prints_success_and_spl(capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    mod = load_script("docs/data/claim/nav_eval.py")
    mod.main(["house-1", "--estimators", "gt", "--noise", "none", "--tasks", "3"])
    out = capsys.readouterr().out
    assert "TRUE occupancy raster" in out and "3 tasks (task file)" in out
    row = [line for line in out.splitlines() if line.startswith("gt")][0].split()
    assert row[1] == "none" and float(row[2]) == 1.0 and 0.8 < float(row[3]) <= 1.0
