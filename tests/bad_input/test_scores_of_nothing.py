"""Scores of nothing (issue 34): a metric over zero valid pixels is never stored as 0; views
without depth are refused in one line; held-out views that are the training views are refused."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from tests.bad_input.conftest import assert_clean_error, nb
from tests.bad_input.test_own_views import seq  # noqa: F401 - a fixture


def _zero_depth(tum):
    """Overwrite every depth PNG of a TUM directory with 0 (= no reading)."""
    from PIL import Image

    for p in sorted((tum / "depth").glob("*.png")):
        h, w = np.asarray(Image.open(p)).shape
        Image.fromarray(np.zeros((h, w), np.uint16)).save(p)


def test_a_sequence_without_valid_depth_is_refused_by_import_and_fit(project, seq):
    _zero_depth(seq)
    res = nb("import-views", seq, "--out", "v.npz", "--store")
    assert_clean_error(res, "depth.txt", "no depth pixel", "12")
    assert not (project / "v.npz").exists()
    res = nb("fit-map", "--views", seq, "--profile", "tiny.toml", "--device", "cpu")
    assert_clean_error(res, "depth.txt", "no depth pixel")
    assert not (project / "results" / "cache" / "fit-map").exists()


def test_views_whose_depth_is_all_invalid_are_not_fitted_or_scored(project, seq):
    """A views file (not TUM) with no valid depth, and one whose held-out part has none."""
    from navbench.worldmodel.views import load_views, save_views

    assert nb("import-views", seq, "--out", "v.npz").code == 0
    v = load_views(project / "v.npz", mmap=False)
    v.valid = np.zeros_like(v.valid)
    save_views(v, project / "blind.npz")
    res = nb("fit-map", "--views", "blind.npz", "--profile", "tiny.toml", "--device", "cpu")
    assert_clean_error(res, "--views", "valid depth pixel")
    v = load_views(project / "v.npz", mmap=False)
    v.valid = v.valid.copy()
    v.valid[3::4] = False  # the views every --heldout-every 4 holds out
    save_views(v, project / "blind-heldout.npz")
    res = nb("fit-map", "--views", "blind-heldout.npz", "--heldout-every", "4", "--profile",
             "tiny.toml", "--device", "cpu")
    assert_clean_error(res, "--views (the held-out part", "valid depth pixel")
    assert not (project / "results" / "cache" / "fit-map").exists()


def test_a_max_range_that_leaves_no_pixel_stores_no_score(project, seq):
    """Nothing rendered within max_range: depth MAE and RGB L1 are undefined (None / NULL, marked
    in the table), not 0.0."""
    from navbench.results.db import ResultsDB

    (project / "short.toml").write_text((project / "tiny.toml").read_text()
                                        .replace('name = "tinytest"', 'name = "short"')
                                        .replace("[fit]\n", "[fit]\nmax_range = 0.01\n"))
    assert nb("import-views", seq, "--out", "v.npz").code == 0
    res = nb("fit-map", "--views", "v.npz", "--heldout-every", "4", "--profile", "short.toml",
             "--device", "cpu", "--json")
    assert res.code == 0, res.output
    out = json.loads(res.out[res.out.index("{"):])
    assert out["depth_mae_m"] is None and out["rgb_l1"] is None and out["coverage"] == 0.0
    table = nb("fit-map", "--views", "v.npz", "--heldout-every", "4", "--profile", "short.toml",
               "--device", "cpu")
    assert table.code == 0 and "undefined (-), not 0" in table.out, table.output
    maps = ResultsDB(f"sqlite:///{project / 'results' / 'navbench.db'}").maps_frame()
    row = maps[maps.map_key == out["map_key"]].iloc[0]
    assert math.isnan(row.depth_mae_m) and math.isnan(row.rgb_l1)


def test_heldout_views_that_are_the_training_views_are_refused(project, seq):
    from navbench.worldmodel.views import load_views, save_views

    assert nb("import-views", seq, "--out", "v.npz", "--store").code == 0
    v = load_views(project / "v.npz", mmap=False)
    save_views(v.subset([0, 5, 7]), project / "part.npz")
    for held, names in (("v.npz", ["--heldout", "the same views as --views"]),
                        (str(seq), ["--heldout", "the same views as --views"]),  # same content, TUM
                        ("part.npz", ["--heldout", "3 of its 3 views are also in --views"])):
        res = nb("fit-map", "--views", "v.npz", "--heldout", held, "--profile", "tiny.toml",
                 "--device", "cpu")
        assert_clean_error(res, *names)
    assert not (project / "results" / "cache" / "fit-map").exists()


def test_slice_scores_of_an_empty_raster_are_undefined_not_perfect():
    from navbench.worldmodel.grid import cell_tolerance_scores

    true = np.zeros((6, 6), bool)
    true[2, 2] = True
    prec, rec = cell_tolerance_scores(np.zeros((6, 6), bool), true, 1)
    assert math.isnan(prec) and rec == 0.0
    prec, rec = cell_tolerance_scores(true, np.zeros((6, 6), bool), 1)
    assert prec == 0.0 and math.isnan(rec)
