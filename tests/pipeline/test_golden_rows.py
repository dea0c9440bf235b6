"""The refactoring guard (issue 12): a small grid run through the CLI stores exactly the rows the
code stored before the pipeline-layer refactor (tests/fixtures/golden_rows.json, recorded by
scripts/golden_rows.py from commit a972844, under navbench-1), and since navbench-5 became the
default version, that version's rows too (tests/fixtures/golden_rows_navbench-5.json): keys, outcomes and step counts exactly, every float
bit for bit on a machine like the recording one and within :data:`FLOAT_RTOL` across processors.
The tracker's compiled kernels (fastmath, vectorised to the CPU's SIMD width) and the BLAS
kernels of its Gauss-Newton solves round differently on other processors: on an AMD EPYC with
AVX-512 (2026-11-26) the tracked estimators' floats differed by 1e-16 to 4e-12 relative, every
key, outcome and step count equal. A change of behaviour moves them by far more."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.scripts import load_script

ROOT = Path(__file__).resolve().parents[2]
#: Relative agreement of the stored floats (``repr`` strings) across processors.
FLOAT_RTOL = 1e-9
#: The stored columns holding floats.
FLOATS = ("spl_term", "path_length", "optimal_length", "loc_rmse_m", "rot_rmse_deg")


def _same(got: dict, want: dict) -> bool:
    """Every column equal, the float columns within :data:`FLOAT_RTOL`."""
    if set(got) != set(want):
        return False
    for k, w in want.items():
        g = got[k]
        if k in FLOATS and g is not None and w is not None:
            if float(g) != pytest.approx(float(w), rel=FLOAT_RTOL, abs=1e-15):
                return False
        elif g != w:
            return False
    return True


@pytest.mark.slow
@pytest.mark.parametrize("version", ["navbench-1", "navbench-5"])
def test_small_grid_rows_are_bit_identical_to_the_recorded_ones(version):
    """navbench-1's rows (recorded before the pipeline-layer refactor) and the default version's
    (navbench-5, recorded 2026-11-27 when it became the default), each grid under its own
    version whatever the default is."""
    mod = load_script("golden_rows")
    want = json.loads((ROOT / "tests" / "fixtures" / mod.fixture_name(version)).read_text())
    got = mod.grid_rows(ROOT, version)
    assert len(got) == len(want) == 24
    assert {r["end_reason"] for r in want} == {"reached"}   # the grid exercises driving and tracking
    for g, w in zip(got, want):
        assert _same(g, w), f"{w['estimator']} {w['noise']} task {w['task_id']}: {g} != {w}"


def test_same_rows_tolerates_only_float_rounding():
    """The comparison itself: a float 4e-12 off passes, 1e-6 off fails, any other column must
    match exactly."""
    row = {"task_id": 0, "steps": 29, "end_reason": "reached", "path_length": "1.436097547818515",
           "loc_rmse_m": "0.0044489291928231055", "spl_term": "0.9", "optimal_length": "1.3",
           "rot_rmse_deg": "0.26"}
    assert _same(dict(row, loc_rmse_m=repr(0.0044489291928231055 * (1 + 4e-12))), row)
    assert not _same(dict(row, path_length=repr(1.436097547818515 * (1 + 1e-6))), row)
    assert not _same(dict(row, steps=30), row)
    assert not _same(dict(row, end_reason="collided"), row)
