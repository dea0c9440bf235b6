"""The refactoring guard (issue 12): a small grid run through the CLI stores exactly the rows the
code stored before the pipeline-layer refactor (tests/fixtures/golden_rows.json, recorded by
scripts/golden_rows.py from commit a972844), bit for bit: keys, outcomes and every float."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.scripts import load_script

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_small_grid_rows_are_bit_identical_to_the_recorded_ones():
    mod = load_script("golden_rows")
    want = json.loads((ROOT / "tests" / "fixtures" / "golden_rows.json").read_text())
    got = mod.grid_rows(ROOT)
    assert len(got) == len(want) == 24
    assert {r["end_reason"] for r in want} == {"reached"}   # the grid exercises driving and tracking
    for g, w in zip(got, want):
        assert g == w, f"{w['estimator']} {w['noise']} task {w['task_id']}: {g} != {w}"
