"""Probe (issue 12, item 5): a bad map file given as ``--map PATH``.

A map file is read by :func:`navbench.worldmodel.base.load_world_model` (and
:func:`navbench.worldmodel.grid.load_map` for voxel maps); whatever is wrong with it (not an npz,
wrong or missing arrays, NaN, a grid of absurd size, an unknown world-model kind) is one
``error:`` line naming the file, before anything is recorded or written. Runs ``track-eval``,
the command that takes ``--map PATH`` today.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.bad_input.conftest import assert_clean_error, nb, tree_snapshot, written_outside


def _header(shape=(3, 4, 5), **extra) -> np.ndarray:
    h = {"format_version": 1, "spec": {"lo": [0, 0, 0], "hi": [1, 1, 1], "shape": list(shape)},
         "tau": 0.5, "meta": {}, **extra}
    return np.array(json.dumps(h))


def _write(case: str, path):
    occ, col = np.zeros((3, 4, 5), np.float32), np.zeros((3, 4, 5, 3), np.float16)
    if case == "not-npz":
        path.write_text("occ,col\n1,2\n")
    elif case == "wrong-arrays":
        np.savez(path, occ=np.zeros((4, 4), np.float32), col=col, header=_header())
    elif case == "nan":
        occ[0, 1, 2] = np.nan
        np.savez(path, occ=occ, col=col, header=_header())
    elif case == "absurd-size":
        np.savez_compressed(path, occ=occ, col=col, header=_header((50_000, 50_000, 1_000)))
    elif case == "unknown-kind":
        np.savez(path, header=np.array(json.dumps({"kind": "no-such-kind"})))
    return path


@pytest.mark.parametrize("case", ["not-npz", "wrong-arrays", "nan", "absurd-size", "unknown-kind"])
def test_bad_map_file_is_one_line_naming_it(project, tmp_path, case):
    bad = _write(case, tmp_path / f"{case}.npz")
    before = tree_snapshot(project)
    res = nb("track-eval", "tiny", "--map", bad, "--estimators", "ours", "--trajectories", "1",
             "--steps", "2", "--no-store")
    assert_clean_error(res, bad.name)
    assert written_outside(before, tree_snapshot(project)) == []
    assert not (project / "results").exists() or not any((project / "results").rglob("*.db"))
