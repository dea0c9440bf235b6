"""Issue 17, part 2: the lazy reference's two-step fill (serial and threaded) against the full
render, the ``reference_scale`` option of ``ours`` (the eq. 7 kernel against its numpy reference
with a reference of another resolution than the observation; tracking along a walk), and views
stored compressed (read back bit for bit)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.errors import ArtifactError, TrackingError
from navbench.geometry import HALF_CAMERA, PAPER_CAMERA, camera_pose
from navbench.track import eq7, ours
from tests.track.synth import small_level


@pytest.fixture(scope="module")
def room():
    from navbench.worldmodel.grid import grid_for_level, voxelize_level

    level = small_level()
    return level, voxelize_level(level, grid_for_level(level, shape=(60, 45, 16)))


@pytest.mark.parametrize("parallel", [False, True])
def test_lazy_fill_renders_the_full_frames_pixels_on_one_or_more_threads(room, parallel):
    """LazyFrame.fill (collect the pixels, then render them; threaded with a parallel renderer)
    gives every pixel it renders exactly the value of the full frame, and renders each once."""
    from navbench.worldmodel.fastrender import FastRenderer, LazyFrame

    _, vm = room
    fr = FastRenderer(vm, PAPER_CAMERA, parallel=parallel)
    pose = np.array([1.2, 1.0, 0.5])
    T = camera_pose(pose, fr.camera_height)
    ref = eq7.prepare_reference(FastRenderer(vm, PAPER_CAMERA, parallel=False).render(pose),
                                PAPER_CAMERA, T)
    lazy = LazyFrame(fr, T)
    idx = ours.gn_pixels(*PAPER_CAMERA.shape, 3000, 0)
    obs = eq7.sample_observation(fr.render(pose + [0.02, 0.0, 0.05]), PAPER_CAMERA, idx)
    Trels = [eq7.linearization("planar", pose + [0.02, 0.0, d], T, fr.camera_height)[0]
             for d in (0.0, 0.05, 0.1)]
    lazy.fill(obs.points, obs.ok, np.stack(Trels[:2]))
    first = lazy.rendered
    lazy.fill(obs.points, obs.ok, np.stack(Trels[1:]))  # overlaps the first call
    m = lazy.done
    assert lazy.rendered == m.sum() and 0 < first < lazy.rendered  # no pixel twice
    assert 0.05 < m.mean() < 0.9
    np.testing.assert_array_equal(lazy.rgb[m], ref.rgb[m])
    np.testing.assert_array_equal(lazy.depth[m], ref.depth[m])
    np.testing.assert_array_equal(lazy.valid[m], ref.valid[m])
    assert not lazy.rgb[~m].any() and not lazy.depth[~m].any()


def test_reference_of_another_resolution_matches_the_numpy_objective(room):
    """With ``obs_intr`` the observation is back-projected with its own camera and projected into
    the reference's: the numba kernel equals the numpy reference (value, subgradient, counts)."""
    from navbench.worldmodel.fastrender import FastRenderer

    _, vm = room
    small = PAPER_CAMERA.scaled(0.5)
    assert small == HALF_CAMERA
    pose = np.array([1.2, 1.0, 0.5])
    T = camera_pose(pose, 0.5)
    ref = eq7.prepare_reference(FastRenderer(vm, small).render(pose), small, T)._replace(obs_intr=PAPER_CAMERA)
    assert ref.observed == PAPER_CAMERA and ref.intr == small
    idx = ours.gn_pixels(*PAPER_CAMERA.shape, 2000, 0)
    moved = pose + [0.01, -0.01, 0.02]
    obs = eq7.sample_observation(FastRenderer(vm, PAPER_CAMERA).render(moved), ref.observed, idx)
    cfg = eq7.TrackerConfig()
    state = moved + [0.003, 0.0, -0.004]
    val, grad = eq7.objective(ref, obs, "planar", state, moved, cfg, 0.5)
    Trel, B, b = eq7.linearization("planar", state, T, 0.5)
    acc = eq7.accumulate(ref, obs, Trel, B, b, cfg)
    pv, pg, _ = eq7.prior_terms("planar", state, moved, cfg, 0.5)
    scale = cfg.pixel_scale / len(obs.points)
    assert math.isclose(scale * acc.value + pv, val, rel_tol=1e-10)
    assert np.allclose(scale * acc.grad + pg, grad, rtol=1e-9, atol=1e-9)
    q, dq = eq7.transform_and_jacobian("planar", state, T, obs.points, 0.5)
    r = eq7.residuals(ref, obs, q, dq, cfg.photo_threshold, cfg.geo_threshold)
    assert acc.counts[0] == r.photo_ok.sum() > 500 and acc.counts[1] == r.geo_ok.sum() > 500


def _walk(level, steps=10):
    from navbench.sim.camera import RaycastCamera
    from navbench.sim.dynamics import Control, apply_dynamics

    cam = RaycastCamera(level, PAPER_CAMERA)
    rng = np.random.default_rng(5)
    poses, controls = [np.array([1.2, 1.0, 0.5])], []
    for t in range(steps):
        u = Control(math.radians(6.0 * (-1) ** (t // 3)), poses[-1][2], 0.06 * (t % 3))
        controls.append(u)
        poses.append(apply_dynamics(poses[-1], u, rng.normal(0, 0.05), rng.normal(0, 0.01)))
    return poses, controls, [cam.render(p) for p in poses]


def test_reference_scale_tracks_a_walk_and_renders_the_smaller_image(room):
    """``ours`` with ``reference_scale=0.5`` renders its reference at 160 x 120 for the paper
    camera and tracks a noisy walk on the voxelised true map about as well as at full scale."""
    from navbench.track.registry import make_estimator

    level, vm = room
    poses, controls, frames = _walk(level)
    errs = {}
    for scale in (1.0, 0.5):
        est = make_estimator("ours", vmap=vm, intrinsics=PAPER_CAMERA, reference_scale=scale)
        est.reset(poses[0], frames[0])
        out = np.array([est.update(u, f) for u, f in zip(controls, frames[1:])])
        assert est._ref.intr == PAPER_CAMERA.scaled(scale)
        d = out - np.array(poses[1:])
        errs[scale] = (np.hypot(d[:, 0], d[:, 1]).max(), np.degrees(np.abs(d[:, 2])).max())
    assert errs[0.5][0] < 0.03 and errs[0.5][1] < 1.0, errs
    assert errs[0.5][0] < 3 * errs[1.0][0] + 0.005, errs


@pytest.mark.parametrize("name,options,match", [
    ("ours", {"reference_scale": 0.0}, "reference_scale"),
    ("ours", {"reference_scale": 1.5}, "reference_scale"),
    ("ours", {"reference_scale": 0.5, "health": True}, "health"),
    ("no-map", {"reference_scale": 0.5}, "map-based"),
])
def test_reference_scale_refused_where_it_cannot_apply(room, name, options, match):
    from navbench.track.registry import make_estimator

    with pytest.raises(TrackingError, match=match):
        make_estimator(name, vmap=room[1], intrinsics=PAPER_CAMERA, **options)


def test_reference_scale_refuses_a_custom_renderer(room):
    from navbench.track.registry import make_estimator

    with pytest.raises(TrackingError, match="renderer"):
        make_estimator("ours", vmap=room[1], intrinsics=PAPER_CAMERA, renderer=lambda pose: None,
                       reference_scale=0.5)


# ------------------------------------------------------------------------------ views storage

@pytest.fixture(scope="module")
def views():
    from navbench.worldmodel.views import collect_views

    return collect_views(small_level(), 12, HALF_CAMERA, seed=3)


def test_compressed_views_read_back_bit_identically(views, tmp_path):
    from navbench.worldmodel.views import (COMPRESSED_FILE, load_views, save_views,
                                           views_content_hash)

    plain, packed = tmp_path / "plain", tmp_path / "packed"
    save_views(views, plain)
    save_views(views, packed, compress=True)
    assert not (packed / "depth.npy").exists() and not (packed / "valid.npy").exists()
    assert (packed / COMPRESSED_FILE).is_file() and (packed / "rgb.npy").is_file()
    size = {p: sum(f.stat().st_size for f in p.iterdir()) for p in (plain, packed)}
    assert size[packed] < 0.7 * size[plain]
    a, b = load_views(plain), load_views(packed)
    for name in ("poses", "rgb", "depth", "valid"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape
        np.testing.assert_array_equal(x, y)
    assert views_content_hash(b) == views_content_hash(views) == views_content_hash(a)


def test_a_damaged_compressed_views_file_is_named(views, tmp_path):
    from navbench.worldmodel.views import COMPRESSED_FILE, load_views, save_views

    d = save_views(views, tmp_path / "v", compress=True)
    f = d / COMPRESSED_FILE
    f.write_bytes(f.read_bytes()[:200])
    with pytest.raises(ArtifactError, match=COMPRESSED_FILE):
        load_views(d)
    f.unlink()
    with pytest.raises(ArtifactError, match="depth.npy"):
        load_views(d)


def test_collect_views_stage_stores_views_compressed(tmp_path):
    """The collect-views stage writes depth and valid compressed; the cached views load."""
    from navbench.levelio import save_level
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.stages import LevelConfig, ViewsConfig, collect_views_stage, make_level_stage
    from navbench.pipeline.stages.context import StageContext
    from navbench.worldmodel.views import COMPRESSED_FILE, load_views
    from tests.pipeline.test_stages import tiny_level

    (tmp_path / "levels").mkdir()
    save_level(tiny_level(), tmp_path / "levels" / "tiny.json")
    ctx = StageContext(ArtifactStore(tmp_path / "cache"), None, log=lambda m: None,
                       levels_dir=tmp_path / "levels", tasks_dir=tmp_path / "tasks")
    ref = collect_views_stage(ctx, make_level_stage(ctx, LevelConfig("tiny")), ViewsConfig(count=4))
    assert (ref.path / COMPRESSED_FILE).is_file()
    assert len(load_views(ref.path)) == 4
