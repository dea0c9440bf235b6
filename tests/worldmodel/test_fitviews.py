"""Views from outside (issue 13): the content key, the held-out split, the planar-pose check of
a TUM import, and the round trip export -> import -> fit against the direct fit."""

from __future__ import annotations

import numpy as np
import pytest

from navbench.errors import ArtifactError, ConfigError
from navbench.geometry import Intrinsics, camera_pose
from navbench.worldmodel.fit import FitConfig
from navbench.worldmodel.fitviews import fit_views
from navbench.worldmodel.tum import _rot_to_quat, export_views, import_views
from navbench.worldmodel.views import (TUM_DEPTH_SCALE, Views, collect_views, heldout_split, load_views,
                                       save_views, views_content_hash)
from tests.pipeline.test_stages import tiny_level

INTR = Intrinsics(16, 12, 7.5, 7.5, 8.0, 6.0)
FIT = FitConfig(steps=30, grid_shape=(16, 12, 8), n_samples=40, images_per_batch=4,
                pixels_per_image=50, device="cpu")


@pytest.fixture(scope="module")
def views():
    return collect_views(tiny_level(), 12, INTR, seed=0)


def tum_quantised(v: Views) -> Views:
    """``v`` with its depth on the TUM grid (1/5000 m; beyond 13.1 m: no reading), i.e. what an
    export keeps of it: the only loss of a round trip besides the poses' 9 printed decimals."""
    q = np.rint(np.where(v.valid, v.depth, 0).astype(np.float64) * TUM_DEPTH_SCALE)
    valid = v.valid & (q <= 65535) & (q > 0)
    depth = np.where(valid, q / TUM_DEPTH_SCALE, np.inf).astype(np.float32)
    return Views(v.poses.copy(), v.intrinsics, v.camera_height, v.rgb.copy(), depth, valid,
                 v.level, v.seed, v.box, dict(v.meta))


def test_content_hash_is_of_the_content_not_the_path_or_label(views, tmp_path):
    h = views_content_hash(views)
    assert views_content_hash(load_views(save_views(views, tmp_path / "a.npz"))) == h
    assert views_content_hash(load_views(save_views(views, tmp_path / "dir"))) == h  # memory-mapped
    relabelled = Views(views.poses, views.intrinsics, views.camera_height, views.rgb, views.depth,
                       views.valid, "another-name", None, views.box, {"source": "elsewhere"})
    assert views_content_hash(relabelled) == h
    rgb = views.rgb.copy()
    rgb[3, 2, 1, 0] ^= 1
    changed = Views(views.poses, views.intrinsics, views.camera_height, rgb, views.depth,
                    views.valid, views.level, views.seed, views.box)
    assert views_content_hash(changed) != h


def test_heldout_split_every_kth():
    train, held = heldout_split(25, 10)
    assert held.tolist() == [9, 19] and sorted(train.tolist() + held.tolist()) == list(range(25))
    for count, every in ((5, 10), (3, 1), (4, True)):
        with pytest.raises(ConfigError):
            heldout_split(count, every)


def test_round_trip_export_import_fit_equals_the_direct_fit(views, tmp_path):
    """Views on the TUM depth grid -> export -> import -> fit: the same map and quality as the
    direct fit: quality within 1e-6 (the poses pass through 9-decimal text; rgb and depth are
    exact), not bit for bit."""
    v = tum_quantised(views)
    export_views(v, tmp_path / "tum")
    back = import_views(tmp_path / "tum")
    np.testing.assert_array_equal(back.rgb, v.rgb)
    np.testing.assert_array_equal(back.valid, v.valid)
    np.testing.assert_array_equal(back.depth, v.depth)
    np.testing.assert_allclose(back.poses, v.poses, atol=1e-8)
    m1, q1 = fit_views(v, FIT, heldout_every=4, level=tiny_level())
    m2, q2 = fit_views(back, FIT, heldout_every=4, level=tiny_level())
    assert q1["train_views"] == q2["train_views"] == 9 and q1["heldout_views"] == 3
    for k in ("depth_mae_m", "rgb_l1", "coverage", "final_loss", "slice_precision", "slice_recall"):
        assert q2[k] == pytest.approx(q1[k], abs=1e-6), k
    # the float32 grids after 30 Adam steps from rays 1e-9 apart: within 1e-5 cell by cell
    np.testing.assert_allclose(m2.occ, m1.occ, atol=1e-5)
    np.testing.assert_allclose(m2.col, m1.col, atol=1e-5)


def test_fit_without_a_level_uses_the_imported_views_box(views, tmp_path):
    """No level anywhere: the box of an import without one in intrinsics.json is the bounds of
    the camera centres and observed points; the map's grid is built on it; no slice scores."""
    import json

    export_views(views, tmp_path / "tum")
    info = json.loads((tmp_path / "tum" / "intrinsics.json").read_text())
    del info["box"], info["level"]
    (tmp_path / "tum" / "intrinsics.json").write_text(json.dumps(info))
    v = import_views(tmp_path / "tum")
    lo, hi = np.asarray(v.box[0]), np.asarray(v.box[1])
    assert np.all(lo[:2] >= -0.1 - 1e-9) and lo[2] < 0.0 and hi[2] > views.camera_height  # floor and walls seen
    vmap, q = fit_views(v, FIT, heldout_every=4)
    assert "slice_precision" not in q and q["split"] == "every 4"
    assert q["heldout_views"] == 3 and q["train_views"] == 9 and 0 < q["coverage"] <= 1
    np.testing.assert_allclose(vmap.spec.lo, (lo[0], lo[1], lo[2] - FIT.margin_z))
    assert np.all(np.asarray(vmap.spec.hi) >= hi - 1e-9)
    _, held = heldout_split(len(v), 4)
    _, q2 = fit_views(v, FIT, heldout=v.subset(held))
    assert q2["split"] == "given" and q2["train_views"] == len(v) and q2["heldout_views"] == 3


# --- tilted and off-height poses: refused, never flattened ------------------------------------

def _tilted(T: np.ndarray, deg: float) -> np.ndarray:
    """``T`` pitched by ``deg`` about the camera's own x axis."""
    a = np.radians(deg)
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    out = T.copy()
    out[:3, :3] = T[:3, :3] @ Rx
    return out


def _set_pose(tum, lineno: int, T: np.ndarray) -> None:
    lines = (tum / "groundtruth.txt").read_text().splitlines()
    ts = lines[lineno - 1].split()[0]
    lines[lineno - 1] = f"{ts} " + " ".join(f"{x:.9f}" for x in (*T[:3, 3], *_rot_to_quat(T[:3, :3])))
    (tum / "groundtruth.txt").write_text("\n".join(lines) + "\n")


@pytest.fixture
def tum(views, tmp_path):
    return export_views(views.subset(np.arange(4)), tmp_path / "tum")


def test_tilted_pose_is_refused_naming_the_line_and_tolerance(views, tum):
    T = camera_pose(views.poses[2], views.camera_height)
    _set_pose(tum, 5, _tilted(T, 3.0))  # data lines start at line 3: line 5 is the third view
    with pytest.raises(ArtifactError) as e:
        import_views(tum)
    msg = str(e.value)
    assert "groundtruth.txt:5" in msg and "tilted 3 deg" in msg and "tolerance 0.5 deg" in msg
    assert len(import_views(tum, max_tilt_deg=5.0)) == 4  # a stated, larger tolerance accepts it


def test_small_tilt_within_tolerance_is_accepted_and_reported(views, tum):
    T = camera_pose(views.poses[1], views.camera_height)
    _set_pose(tum, 4, _tilted(T, 0.2))
    v = import_views(tum)
    assert v.meta["max_tilt_deg"] == pytest.approx(0.2, abs=1e-6)


def test_off_height_pose_is_refused(views, tum):
    T = camera_pose(views.poses[0], views.camera_height)
    T[2, 3] += 0.3
    _set_pose(tum, 3, T)
    with pytest.raises(ArtifactError) as e:
        import_views(tum)
    assert "groundtruth.txt:3" in str(e.value) and "0.3 m from the camera height" in str(e.value)
