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


def _refused(res, *names: str) -> None:
    assert res.code == 2, f"exit {res.code}, expected 2:\n{res.output}"
    assert_clean_error(res, *names)


def _short(project, fit_line: str) -> str:
    """A copy of tiny.toml named ``short`` with ``fit_line`` added to its [fit] table."""
    (project / "short.toml").write_text((project / "tiny.toml").read_text()
                                        .replace('name = "tinytest"', 'name = "short"')
                                        .replace("[fit]\n", f"[fit]\n{fit_line}\n"))
    return "short.toml"


def test_a_max_range_shorter_than_any_camera_sees_is_refused_before_work(project, seq):
    """``max_range = 0.001`` (a slip for 10) sees no pixel of any view: refused by the profile
    check, by ``--set`` and by a library FitConfig, before a view is collected or imported."""
    from navbench.errors import ConfigError
    from navbench.worldmodel.fit import FitConfig

    for mr in ("0.001", "0.01", "0.0999"):
        res = nb("fit-map", "tiny", "--profile", _short(project, f"max_range = {mr}"), "--device", "cpu")
        _refused(res, "short.toml", "[fit] max_range", ">= 0.1", mr)
        res = nb("fit-map", "tiny", "--profile", "tiny.toml", "--set", f"fit.max_range={mr}",
                 "--device", "cpu")
        _refused(res, "--set fit.max_range", ">= 0.1")
        res = nb("fit-map", "--views", seq, "--profile", "tiny.toml", "--set", f"fit.max_range={mr}",
                 "--device", "cpu")
        _refused(res, "--set fit.max_range", ">= 0.1")
        with pytest.raises(ConfigError, match=r"max_range must be >= 0\.1 m"):
            FitConfig(max_range=float(mr))
    with pytest.raises(ConfigError, match="max_range"):
        FitConfig(max_range=math.nan)
    assert not any((project / "results" / "cache").glob("*/*")), "work was done before the refusal"


def test_views_with_no_valid_depth_within_max_range_are_refused(project, seq):
    """A max_range the views' nearest valid depth lies beyond: nothing to fit or score. Refused
    (naming the views and the nearest depth) for --views, the held-out part of the split, a
    given --heldout, and the profile pipeline's own views; no map is cached, no row stored."""
    from navbench.worldmodel.views import load_views, save_views
    from tests.bad_input.conftest import db_row_counts

    assert nb("import-views", seq, "--out", "v.npz").code == 0
    v = load_views(project / "v.npz", mmap=False)
    thr = float(np.median(v.depth[v.valid]))
    assert thr > 0.3
    mr = f"{thr * 0.8:.3f}"
    far = load_views(project / "v.npz", mmap=False)
    far.valid = far.valid & (far.depth > thr)
    save_views(far, project / "far.npz")
    res = nb("fit-map", "--views", "far.npz", "--profile", _short(project, f"max_range = {mr}"),
             "--device", "cpu")
    _refused(res, "--views (the fitted part", f"within max_range = {float(mr):g} m",
                       "the nearest is", "raise [fit] max_range")
    half = load_views(project / "v.npz", mmap=False)
    half.valid = half.valid.copy()
    half.valid[3::4] &= half.depth[3::4] > thr  # the views every --heldout-every 4 holds out
    save_views(half, project / "far-heldout.npz")
    res = nb("fit-map", "--views", "far-heldout.npz", "--heldout-every", "4", "--profile", "short.toml",
             "--device", "cpu")
    _refused(res, "--views (the held-out part", "within max_range")
    save_views(v.subset([0, 1, 2, 4, 5, 6]), project / "train.npz")
    save_views(far.subset([3, 7]), project / "held.npz")
    res = nb("fit-map", "--views", "train.npz", "--heldout", "held.npz", "--profile", "short.toml",
             "--device", "cpu")
    _refused(res, "--heldout", "within max_range")
    # the profile pipeline (collected views): 0.1 m is above the floor but nearer than any view
    res = nb("fit-map", "tiny", "--profile", _short(project, "max_range = 0.1"), "--device", "cpu")
    _refused(res, "fit-map tiny", "within max_range = 0.1 m")
    assert not any((project / "results" / "cache" / "fit-map").glob("*"))
    assert db_row_counts(project).get("results/navbench.db:maps", 0) == 0


def test_a_map_that_renders_nothing_stores_no_score(project, seq):
    """A map that never renders a crossing (pure eq. 3 from an empty grid: no gradient ever
    reaches an occupancy) over views it can see: depth MAE and RGB L1 are undefined (None /
    NULL, marked in the table), not 0.0."""
    from navbench.results.db import ResultsDB

    _short(project, 'init = "empty"\nfree_space_weight = 0.0')
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


@pytest.mark.parametrize("options, shown", [
    (["emission.max_range=0.01"], "emission.max_range: expected a number >= 0.1"),
    (["emission.step=5", "emission.max_range=1"], "step must be in [0.001, max_range = 1]"),
])
def test_an_emission_tracker_whose_rays_have_no_sample_is_refused(tmp_path, monkeypatch, options, shown):
    """The same class for the emission tracker's renderer: a ``max_range`` below the floor, or
    a ``step`` longer than ``max_range`` (``round(1 / 5) = 0`` samples per ray), tracked with
    an empty render and stored ATE 0.0000; refused before a level is built."""
    monkeypatch.chdir(tmp_path)
    args = [a for o in options for a in ("-o", o)]
    res = nb("track-eval", "house-1", "--estimators", "emission", "--steps", "3",
             "--trajectories", "1", "--no-store", *args)
    _refused(res, "--option", shown)
    assert not (tmp_path / "results").exists()


def test_an_emission_objective_on_a_map_whose_step_exceeds_max_range_is_refused():
    """The map's own ray step (``meta['step']``) longer than the tracker's max_range: no
    sample per ray, refused when the objective is built (not tracked blind)."""
    from navbench.errors import TrackingError
    from navbench.geometry import Intrinsics
    from navbench.track import emission
    from navbench.worldmodel.grid import grid_for_level, voxelize_level
    from tests.track.synth import small_level

    vmap = voxelize_level(small_level(), grid_for_level(small_level(), shape=(20, 16, 6)))
    vmap.meta["step"] = 2.0
    small = Intrinsics(16, 12, 7.5, 7.5, 8.0, 6.0)
    with pytest.raises(TrackingError, match="shorter than the map's ray step"):
        emission.EmissionObjective(vmap, small, 0.5, emission.EmissionConfig(max_range=1.0))
    assert emission.EmissionObjective(vmap, small, 0.5, emission.EmissionConfig(max_range=2.0)).n == 1


def _with_header(src, dst, **changes):
    """A copy of map file ``src`` whose JSON header has ``changes`` (``meta_KEY`` for meta)."""
    z = dict(np.load(src))
    h = json.loads(str(z["header"]))
    for k, v in changes.items():
        if k.startswith("meta_"):
            h["meta"][k[5:]] = v
        else:
            h[k] = v
    z["header"] = np.array(json.dumps(h))
    np.savez(dst, **z)
    return dst


@pytest.mark.parametrize("change, shown", [
    ({"meta_step": 1e-9}, "meta.step = 1e-09"),       # P-004: 2e10 samples per ray, a hang
    ({"meta_step": "x"}, "meta.step = 'x'"),
    ({"meta_max_range": 0}, "meta.max_range = 0"),    # P-010: a render range of nothing
    ({"meta_max_range": math.nan}, "meta.max_range = nan"),
    ({"meta_sigma2": -1.0}, "meta.sigma2 = -1.0"),
    ({"tau": 5.0}, "tau 5.0: must be in (0, 1)"),      # occupancy in [0, 1] never crosses 5
    ({"tau": 0.0}, "tau 0.0"),
])
def test_a_map_header_out_of_range_is_refused_on_load(project, change, shown):
    """The header numbers navbench renders a map with are range-checked when the file is read,
    for every command that reads a map file (track-sequence hung on meta.step = 1e-9)."""
    from tests.bad_input.conftest import deadline
    from navbench.errors import ArtifactError
    from navbench.levelio import load_level
    from navbench.worldmodel.grid import grid_for_level, load_map, voxelize_level

    lv = load_level(project / "levels" / "tiny.json")
    voxelize_level(lv, grid_for_level(lv, shape=(16, 12, 6))).save(project / "map.npz")
    assert load_map(project / "map.npz").meta["step"] > 0  # the good file loads
    bad = _with_header(project / "map.npz", project / "bad.npz", **change)
    with pytest.raises(ArtifactError, match=r"bad\.npz: bad map header"):
        load_map(bad)
    (project / "seq").mkdir()
    with deadline(60):
        res = nb("track-sequence", "seq", "--map", "bad.npz", "--no-store", "--out", "e.txt")
    _refused(res, "bad.npz", "bad map header", shown)
    assert not (project / "e.txt").exists()


def test_a_fit_whose_ray_step_is_below_the_floor_is_refused():
    """max_range / n_samples is the fitted map's meta['step']: below 1 mm the file would not
    load back (and its rays would take 20 000+ samples), so the fit refuses it first."""
    from navbench.errors import ConfigError
    from navbench.worldmodel.fit import FitConfig

    with pytest.raises(ConfigError, match=r"ray step\) must be >= 0\.001"):
        FitConfig(max_range=0.5, n_samples=1000)
    assert FitConfig(max_range=0.5, n_samples=500).step == 0.001


def test_a_map_with_absurd_occupancy_is_refused_on_load(project):
    """P-013: occupancy 1e30 was loaded; localize-eval then built and cached a bank for it and
    failed with a message not naming the file. Values beyond 1e6 are refused on load."""
    from navbench.errors import ArtifactError
    from navbench.levelio import load_level
    from navbench.worldmodel.grid import grid_for_level, load_map, voxelize_level

    lv = load_level(project / "levels" / "tiny.json")
    voxelize_level(lv, grid_for_level(lv, shape=(16, 12, 6))).save(project / "map.npz")
    z = dict(np.load(project / "map.npz"))
    z["occ"] = np.full_like(z["occ"], 1e30)
    np.savez(project / "bad.npz", **z)
    with pytest.raises(ArtifactError, match=r"bad\.npz: occ has values beyond 1e\+06"):
        load_map(project / "bad.npz")
    res = nb("localize-eval", "tiny", "--map", "bad.npz", "--no-store")
    _refused(res, "bad.npz", "occ has values beyond")
    assert not (project / "results" / "cache" / "localize-bank").exists()
