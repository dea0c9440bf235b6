"""Views: collection, artifact validation, TUM RGB-D round trip."""

from __future__ import annotations

import json

import numpy as np
import pytest

from navbench.errors import ArtifactError
from navbench.geometry import AGENT_RADIUS, Intrinsics, camera_pose
from navbench.level import distance_to_solids
from navbench.worldmodel.tum import export_views, import_views, planar_height_tilt
from navbench.worldmodel.views import Views, collect_views, load_views, save_views

SMALL = Intrinsics(16, 12, 7.5, 7.5, 8.0, 6.0)


@pytest.fixture(scope="module")
def views(room):
    return collect_views(room, 6, SMALL, seed=3)


def test_collect_views_is_seeded_and_in_free_space(room, views):
    again = collect_views(room, 6, SMALL, seed=3)
    np.testing.assert_array_equal(views.poses, again.poses)
    np.testing.assert_array_equal(views.rgb, again.rgb)
    assert not np.array_equal(collect_views(room, 6, SMALL, seed=4).poses, views.poses)
    assert np.all(distance_to_solids(room, views.poses[:, :2]) >= AGENT_RADIUS + 0.05)
    assert views.valid.all() and views.rgb.dtype == np.uint8 and views.depth.dtype == np.float32
    assert views.box == ((0, 0, 0), (room.width, room.depth, room.height))


@pytest.mark.parametrize("name", ["v", "v.npz"])
def test_save_load_roundtrip(tmp_path, views, name):
    back = load_views(save_views(views, tmp_path / name))
    for k in ("poses", "rgb", "depth", "valid"):
        np.testing.assert_array_equal(np.asarray(getattr(back, k)), getattr(views, k))
    assert (back.intrinsics, back.camera_height, back.level, back.seed, back.box) == \
        (views.intrinsics, views.camera_height, views.level, views.seed, views.box)


def test_malformed_artifacts_raise(tmp_path, views):
    d = save_views(views, tmp_path / "v")
    np.save(d / "depth.npy", views.depth[:, :5])
    with pytest.raises(ArtifactError, match="depth has shape"):
        load_views(d)
    bad = views.depth.copy()
    bad[2, 3, 4] = np.nan
    np.save(d / "depth.npy", bad)
    with pytest.raises(ArtifactError, match="view 2 has NaN"):
        load_views(d)
    np.save(d / "depth.npy", views.depth)
    h = json.loads((d / "views.json").read_text())
    del h["intrinsics"]
    (d / "views.json").write_text(json.dumps(h))
    with pytest.raises(ArtifactError, match="missing or malformed intrinsics"):
        load_views(d)
    save_views(views, d)
    np.save(d / "poses.npy", views.poses[:4])
    with pytest.raises(ArtifactError, match="header says 6 views, poses has 4"):
        load_views(d)
    (d / "poses.npy").unlink()
    with pytest.raises(ArtifactError, match="missing poses.npy"):
        load_views(d)
    with pytest.raises(ArtifactError, match="no such"):
        load_views(tmp_path / "nothing")
    with pytest.raises(ArtifactError, match="rgb has shape"):
        Views(views.poses, views.intrinsics, 0.5, views.rgb[:, :, :3], views.depth, views.valid,
              "x", 0, views.box)


def test_tum_roundtrip_is_lossless_up_to_depth_quantisation(tmp_path, views):
    v = views.subset(range(6))
    v.valid[0, 0, 0] = False
    v.depth[0, 0, 0] = np.inf
    out = export_views(v, tmp_path / "tum")
    assert (out / "rgb.txt").is_file() and len(list((out / "depth").glob("*.png"))) == 6
    back = import_views(out)
    np.testing.assert_array_equal(back.rgb, v.rgb)
    np.testing.assert_array_equal(back.valid, v.valid)
    np.testing.assert_allclose(back.depth[v.valid], v.depth[v.valid], atol=0.5 / 5000 + 1e-6)
    np.testing.assert_allclose(back.poses, v.poses, atol=1e-7)
    assert back.intrinsics == v.intrinsics and back.camera_height == v.camera_height
    assert back.meta["max_tilt_deg"] < 1e-5
    # explicit intrinsics and no json: the box comes from the observed points
    (out / "intrinsics.json").unlink()
    b2 = import_views(out, intrinsics=SMALL, camera_height=0.5)
    assert np.all(np.asarray(b2.box[0]) <= [0.1, 0.1, 0.0]) and b2.box[1][2] >= 1.2
    with pytest.raises(ArtifactError, match="no intrinsics"):
        import_views(out)


def test_groundtruth_is_camera_to_world(tmp_path, views):
    out = export_views(views.subset([0]), tmp_path / "tum")
    line = [ln for ln in (out / "groundtruth.txt").read_text().splitlines() if not ln.startswith("#")][0]
    t = np.array(line.split()[1:4], float)
    T = camera_pose(views.poses[0], views.camera_height)
    np.testing.assert_allclose(t, T[:3, 3], atol=1e-8)
    pose, h, tilt = planar_height_tilt(T)
    np.testing.assert_allclose(pose, views.poses[0], atol=1e-12)
    assert h == pytest.approx(0.5) and tilt == pytest.approx(0.0, abs=1e-6)


# ------------------------------------------------------------------ sizes against memory (issue 11)

def test_available_memory_is_read_and_checked(monkeypatch):
    import navbench.worldmodel.memory as mem
    from navbench.errors import ConfigError

    avail = mem.available_memory()
    assert avail is None or (isinstance(avail, int) and avail > 0)
    monkeypatch.setattr(mem, "available_memory", lambda: 3 << 30)
    mem.check_memory(3 << 30, "fits exactly")
    with pytest.raises(ConfigError, match=r"^big: x need 4\.0 GiB of memory, only 3\.0 GiB is available$"):
        mem.check_memory(4 << 30, "big: x")
    monkeypatch.setattr(mem, "available_memory", lambda: None)  # unknown: nothing is refused
    mem.check_memory(1 << 60, "unknown")


def test_views_memory_is_count_x_pixels_x_8_plus_overhead():
    from navbench.worldmodel.views import VIEW_OVERHEAD_BYTES, VIEWS_BASE_BYTES, views_memory_bytes

    assert views_memory_bytes(10, SMALL) == 10 * (16 * 12 * 8 + VIEW_OVERHEAD_BYTES) + VIEWS_BASE_BYTES


def test_collect_and_fit_refuse_before_allocating(monkeypatch, room, views):
    """The checks run before the first allocation: with 1 MiB 'available' nothing is sampled,
    rendered or allocated (the sampler and the grid init would fail the test if reached)."""
    import navbench.worldmodel.fit as fit_mod
    import navbench.worldmodel.memory as mem
    import navbench.worldmodel.views as views_mod
    from navbench.errors import ConfigError
    from navbench.worldmodel.grid import voxelize_level

    def reached(*a, **k):
        raise AssertionError("allocated before the memory check")

    monkeypatch.setattr(mem, "available_memory", lambda: 1 << 20)
    monkeypatch.setattr(views_mod, "sample_free_poses", reached)
    monkeypatch.setattr(fit_mod, "initial_grids", reached)
    with pytest.raises(ConfigError, match="collect-views: 100 views of 16x12 .* only 1.0 MiB"):
        collect_views(room, 100, SMALL, seed=0)
    with pytest.raises(ConfigError, match=r"fit: grid_shape \[200, 200, 20\] \(800000 cells"):
        fit_mod.fit_map(views, fit_mod.FitConfig(steps=1, device="cpu"))
    with pytest.raises(ConfigError, match="voxelize wm-room: grid"):
        voxelize_level(room)


@pytest.mark.parametrize("shape", [(16, 12), (16, 12, 1), ("a", 2, 2), (2.5, 2, 2), "abc", (True, 2, 2)])
def test_fit_config_refuses_malformed_grid_shape(shape):
    from navbench.errors import ConfigError
    from navbench.worldmodel.fit import FitConfig

    with pytest.raises(ConfigError, match="grid_shape"):
        FitConfig(grid_shape=shape)


def test_intrinsics_are_checked():
    from navbench.worldmodel.views import check_intrinsics

    assert check_intrinsics(SMALL, "x") is SMALL
    for bad, field in ((Intrinsics(16, 12, -7.5, 7.5, 8, 6), "fx"), (Intrinsics(16, 12, 7.5, float("nan"), 8, 6), "fy"),
                       (Intrinsics(16, 12, 7.5, 7.5, 17, 6), "cx"), (Intrinsics(16, 12, 7.5, 7.5, 8, -1), "cy"),
                       (Intrinsics(0, 12, 7.5, 7.5, 0, 6), "width")):
        with pytest.raises(ArtifactError, match=f"^cam: .*{field}"):
            check_intrinsics(bad, "cam")


def test_export_never_overwrites(tmp_path, views):
    (tmp_path / "seq").mkdir()
    (tmp_path / "seq" / "rgb.txt").write_text("another sequence\n")
    with pytest.raises(ArtifactError, match="not empty"):
        export_views(views, tmp_path / "seq")
    assert (tmp_path / "seq" / "rgb.txt").read_text() == "another sequence\n"
    (tmp_path / "file").write_text("x")
    with pytest.raises(ArtifactError, match="not a directory"):
        export_views(views, tmp_path / "file")
    export_views(views.subset([0]), tmp_path / "empty-dir-is-fine")


def test_save_views_failure_is_an_artifact_error_and_leaves_nothing(tmp_path, views):
    (tmp_path / "f").write_text("x")
    for target in (tmp_path / "f" / "v", tmp_path / "f" / "v.npz"):
        with pytest.raises(ArtifactError, match="cannot write views"):
            save_views(views, target)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]


def test_import_accepts_16bit_depth_in_both_pil_modes(tmp_path, views):
    """TUM depth opens as I;16 (Pillow >= 10) or I (older Pillows, int32 holding the 16-bit
    values): both are 16-bit depth. Pillow no longer writes mode I PNGs, so a TIFF stands in."""
    from PIL import Image

    out = export_views(views.subset([0, 1]), tmp_path / "tum")
    f = sorted((out / "depth").glob("*.png"))[0]
    arr = np.asarray(Image.open(f)).astype(np.int32)
    Image.fromarray(arr, mode="I").save(f.with_suffix(".tiff"))
    assert Image.open(f.with_suffix(".tiff")).mode == "I"
    lst = out / "depth.txt"
    lst.write_text(lst.read_text().replace(f.name, f.with_suffix(".tiff").name))
    back = import_views(out)
    np.testing.assert_allclose(back.depth[0][back.valid[0]], views.depth[0][views.valid[0]], atol=1e-4)
