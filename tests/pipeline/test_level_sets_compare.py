"""docs/data/level-sets/level_sets_compare.py: the unpaired comparison of two level sets (issue 16)."""

from __future__ import annotations

import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.scripts import load_script

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def compare():
    return load_script("docs/data/level-sets/level_sets_compare.py")


def test_resampling_is_stratified_by_level(compare):
    """Each level constant: resampling tasks within levels keeps every level's count, so every
    bootstrap mean is the pooled mean exactly (3 x 1.0 and 7 x 0.0: 0.3)."""
    df = pd.DataFrame({"level": ["a"] * 3 + ["b"] * 7, "spl_term": [1.0] * 3 + [0.0] * 7})
    means = compare.stratified_means(df, np.random.default_rng(0), 200)
    assert np.allclose(means, 0.3)
    mixed = pd.DataFrame({"level": ["a"] * 10, "spl_term": [1.0] * 3 + [0.0] * 7})
    spread = compare.stratified_means(mixed, np.random.default_rng(0), 200)
    assert spread.min() < 0.3 < spread.max()


def _db(path: Path, rows: list[tuple]) -> None:
    con = sqlite3.connect(path)
    con.execute("CREATE TABLE episodes (id INTEGER PRIMARY KEY, run_id INT, level TEXT, task_id INT, "
                "seed INT, noise TEXT, estimator TEXT, spl_term REAL, success INT)")
    con.executemany("INSERT INTO episodes (run_id, level, task_id, seed, noise, estimator, spl_term, "
                    "success) VALUES (?, ?, ?, ?, ?, ?, ?, ?)", rows)
    con.commit()
    con.close()


def test_prints_both_sets_and_their_difference(tmp_path):
    """Hand-computed: set A (house-x) SPL 0.8 on both tasks, its duplicate row of task 0 counts
    once (the last, not the 0.1); set B (dense-x) 0.5; B - A = -0.300, constant levels so the
    interval is the point. --tasks 2 drops task 2."""
    a = [(1, "house-x", 0, 0, "low", "no-map", 0.1, 0), (1, "house-x", 0, 0, "low", "no-map", 0.8, 1),
         (1, "house-x", 1, 0, "low", "no-map", 0.8, 1), (1, "house-x", 2, 0, "low", "no-map", 0.0, 0)]
    b = [(4, "dense-x", 0, 0, "low", "no-map", 0.5, 1), (4, "dense-x", 1, 0, "low", "no-map", 0.5, 1)]
    _db(tmp_path / "a.db", a)
    _db(tmp_path / "b.db", b)
    out = subprocess.run([sys.executable, str(ROOT / "docs" / "data" / "level-sets" / "level_sets_compare.py"), "--a-db",
                          str(tmp_path / "a.db"), "--a-runs", "1", "--b-db", str(tmp_path / "b.db"),
                          "--b-runs", "4", "--tasks", "2"], capture_output=True, text=True, check=True).stdout
    row = [ln for ln in out.splitlines() if ln.startswith("| no-map | low")][0]
    assert "| 2 / 2 | 0.800 | 0.500 | -0.300 [-0.300, -0.300] | 1.000 | 1.000 |" in row
    assert "| dense-x | 0.500 |" in out and "| house-x | 0.800 |" in out
    missing = subprocess.run([sys.executable, str(ROOT / "docs" / "data" / "level-sets" / "level_sets_compare.py"), "--a-db",
                              str(tmp_path / "none.db"), "--a-runs", "1", "--b-runs", "4"],
                             capture_output=True, text=True)
    assert missing.returncode != 0 and "no such database file" in missing.stderr
    assert not (tmp_path / "none.db").exists()
