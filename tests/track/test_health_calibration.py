"""The health test's threshold per map (``health_min_inliers = "auto"``, issue 14 section 3):
:func:`navbench.track.health.calibrated_threshold` by hand, the calibration's fractions on an
exact and on a deliberately wrong map, the estimator's use of the threshold, and the
health-calibration stage (held-out views of a fit-map artifact, cache, keys)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.errors import TrackingError
from navbench.geometry import HALF_CAMERA, Frame
from navbench.track.health import HealthCalibration, calibrated_threshold, view_inlier_fractions

from .synth import small_level


@pytest.fixture(scope="module")
def level():
    return small_level()


@pytest.fixture(scope="module")
def views(level):
    """Eight exact views of the small room at seeded free poses."""
    from navbench.worldmodel.views import collect_views

    return collect_views(level, 8, HALF_CAMERA, seed=3)


def _frames(views):
    from navbench.track.sequence import frame_at

    return [frame_at(views, i) for i in range(len(views))]


def test_threshold_by_hand():
    cal = HealthCalibration(quantile=0.1, factor=0.6, clamp=(0.15, 0.5))
    # quantile 0.1 of 0.80, 0.81, ..., 0.99 (linear interpolation): 0.80 + 0.1 * 19 * 0.01
    f = np.linspace(0.80, 0.99, 20)
    assert calibrated_threshold(f, cal) == pytest.approx(0.6 * 0.819)
    # nan (no evidence) is left out; the clamp holds at both ends
    assert calibrated_threshold(np.r_[f, np.nan, np.nan], cal) == pytest.approx(0.6 * 0.819)
    assert calibrated_threshold(np.full(10, 0.1), cal) == 0.15
    assert calibrated_threshold(np.full(10, 1.0), cal) == 0.5
    assert calibrated_threshold(np.full(3, np.nan), cal) == 0.5  # no evidence: the ceiling
    with pytest.raises(TrackingError, match="quantile"):
        HealthCalibration(quantile=1.5)


def test_exact_map_agrees_fully_and_a_wrong_map_lowers_the_threshold(level, views):
    """On the exact world every evidence pixel agrees (fraction 1 at the true pose, and after
    one tracking step from a perturbed pose nearly so). A map whose colour is wrong at a random
    40 % of the pixels (iid) agrees on about 60 % of them: the calibrated threshold
    follows it down (0.6 x ~0.6) instead of raising alarms at every step."""
    from navbench.sim.camera import RaycastCamera
    from navbench.track.eq7 import TrackerConfig
    from navbench.track.ours import align, gn_pixels

    cam = RaycastCamera(level, HALF_CAMERA)
    idx = gn_pixels(HALF_CAMERA.height, HALF_CAMERA.width, 1000, 1)
    frames = _frames(views)
    exact = view_inlier_fractions(cam.render, frames, views.poses, HALF_CAMERA, idx,
                                  HealthCalibration(perturb=(0.0, 0.0)))
    np.testing.assert_allclose(exact, 1.0, atol=0.02)  # float32 depth at the 5 % edge only
    stepped = view_inlier_fractions(cam.render, frames, views.poses, HALF_CAMERA, idx,
                                    HealthCalibration(), align=align, tracker=TrackerConfig())
    assert np.nanmin(stepped) > 0.9

    bad = np.random.default_rng(0).random(HALF_CAMERA.shape) < 0.4

    def wrong(pose):
        fr = cam.render(pose)
        rgb = fr.rgb.copy()
        c = rgb[bad]
        rgb[bad] = np.where(c < 0.5, c + 0.5, c - 0.5)  # L1 error 1.5 over RGB > photo_tol
        return Frame(rgb, fr.depth, fr.valid)

    f = view_inlier_fractions(wrong, frames, views.poses, HALF_CAMERA, idx,
                              HealthCalibration(perturb=(0.0, 0.0)))
    cal = HealthCalibration()
    assert np.nanmax(np.abs(f - 0.6)) < 0.08  # binomial noise over hundreds of pixels
    assert calibrated_threshold(f, cal) < calibrated_threshold(exact, cal) - 0.1
    assert calibrated_threshold(exact, cal) == cal.clamp[1]


def test_auto_threshold_is_given_to_the_estimator(level):
    from navbench.sim.camera import RaycastCamera
    from navbench.track.registry import make_estimator

    cam = RaycastCamera(level, HALF_CAMERA)
    est = make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, health=True,
                         health_min_inliers="auto", health_threshold=0.3)
    assert est.health_threshold == 0.3
    assert make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, health=True,
                          health_threshold=0.3).health_threshold == 0.5  # a number wins
    with pytest.raises(TrackingError, match="auto.*calibrated"):
        make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, health=True,
                       health_min_inliers="auto")
    for bad in ("sometimes", 1.5, True):
        with pytest.raises(TrackingError, match="health_min_inliers"):
            make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, health=True,
                           health_min_inliers=bad)
    # without health or recover "auto" is never read and needs nothing
    assert math.isnan(make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA,
                                     health_min_inliers="auto").health_threshold)


def test_calibration_stage_uses_the_maps_held_out_views_and_is_cached(tmp_path, level):
    """A fit-map artifact's held-out views (its ``eval_views`` input) are the calibration's
    views, also when the map is given as its map.npz path; the artifact is a cache hit the
    second time and its key follows the tracker's options and the calibration."""
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.stages.context import Ref, StageContext
    from navbench.pipeline.stages.health import (HealthCalibrationConfig, calibration_views,
                                                 health_calibration_stage)
    from navbench.pipeline.stages.views import ViewsConfig, collect_views_stage
    from tests.localize.worlds import ExactWorld

    ctx = StageContext(ArtifactStore(tmp_path / "cache"))
    lvl = Ref("make-level", "0" * 64, tmp_path / "level.json", True, level.name)
    from navbench.levelio import save_level

    save_level(level, lvl.path)
    train = collect_views_stage(ctx, lvl, ViewsConfig(6, "half", 1))
    held = collect_views_stage(ctx, lvl, ViewsConfig(5, "half", 2))

    def fake_fit(d):
        np.savez(d / "map.npz", unread=np.zeros(1))  # not read by this test (the cache checks it is an npz)

    path, key, _ = ctx.run("fit-map", {"fake": 1}, {"level": lvl.key, "views": train.key,
                                                     "eval_views": held.key}, fake_fit)
    for spec in ("fit", str(path / "map.npz")):
        v = calibration_views(ctx, spec, key, lvl)
        assert (v.stage, v.key) == ("collect-views", held.key)
    assert calibration_views(ctx, key[:10], "content-hash", lvl).key == held.key  # a key prefix
    # imported data (no level): a fit of import-views without held-out ones calibrates on them
    from navbench.pipeline.stages.imported import store_views_stage
    from navbench.worldmodel.views import load_views

    imp = store_views_stage(ctx, load_views(train.path))
    p2, k2, _ = ctx.run("fit-map", {"fake": 2}, {"views": imp.key}, fake_fit)
    v = calibration_views(ctx, str(p2 / "map.npz"), "content-hash", None)
    assert (v.stage, v.key) == ("import-views", imp.key)
    with pytest.raises(Exception, match="no views of its own"):
        calibration_views(ctx, str(tmp_path / "level.json"), "content-hash", None)
    # a map with no artifact behind it: views rendered from the level (seeded, its own stream)
    v = calibration_views(ctx, "true", "true", lvl, count=4)
    assert v.key not in (train.key, held.key)

    world = ExactWorld(level)
    a = health_calibration_stage(ctx, held, "map-a", lambda: world)
    b = health_calibration_stage(ctx, held, "map-a", lambda: world)
    assert not a.cached and b.cached and a.key == b.key
    assert a.meta["threshold"] == 0.5 and a.meta["views"] == 5  # exact map: the ceiling
    c = health_calibration_stage(ctx, held, "map-a", lambda: world,
                                 HealthCalibrationConfig({}, {"health_tol": 0.02}))
    d = health_calibration_stage(ctx, held, "map-a", lambda: world,
                                 HealthCalibrationConfig({}, {"health_min_inliers": "auto"}))
    e = health_calibration_stage(ctx, held, "map-b", lambda: world)
    assert c.key != a.key and d.key == a.key and e.key != a.key


def _walk_frames(level, steps=6, seed=1):
    from navbench.sim.camera import RaycastCamera
    from navbench.sim.dynamics import Control
    from navbench.track.study import record_trajectories

    tr = record_trajectories(level, 1, steps, noise="none", seed=seed)[0]
    cam = RaycastCamera(level, HALF_CAMERA)
    return tr.true_poses, [Control(*u) for u in tr.controls], cam


@pytest.mark.parametrize("runner_is_true", [True, False])
def test_runner_up_hypotheses_are_kept_until_the_residuals_decide(level, runner_is_true):
    """Option ``relocalize_keep``: after a relocalisation the verified runner-up is tracked
    beside the chosen track for K steps; the track with the larger summed inlier fraction wins
    (here the threshold is 0, so neither track ever raises an alarm). The true track beats a
    look-alike 0.8 m away whichever of the two was chosen."""
    from navbench.track.registry import make_estimator

    poses, controls, cam = _walk_frames(level)
    est = make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, recover=True,
                         health_min_inliers=0.0, relocalize_keep=2)
    wrong = poses[1] + np.array([0.0, 0.0, 0.0])
    wrong[:2] += 0.8 * np.array([-np.sin(poses[1, 2]), np.cos(poses[1, 2])])  # 0.8 m to the side
    est.reset(poses[0], cam.render(poses[0]))
    est.update(controls[0], cam.render(poses[1]))
    main, runner = (wrong, poses[1]) if runner_is_true else (poses[1], wrong)
    est.pose = main.copy()
    est._runners = {"poses": [runner.copy()], "sums": [0.9], "main": 0.9, "left": 2}
    out = [est.update(controls[t], cam.render(poses[t + 1])) for t in (1, 2, 3)]
    assert est._runners is None  # decided after two steps
    err = np.hypot(*(np.array(out)[1:, :2] - poses[3:5, :2]).T)
    assert err.max() < 0.03
    assert est.last_health["relocalized"] is False


def test_runner_ups_off_by_default_and_validated(level):
    from navbench.track.registry import make_estimator

    poses, controls, cam = _walk_frames(level)
    est = make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, recover=True)
    assert est.config.relocalize_keep == 0
    for bad in (-1, True, "abc", 1.5):
        with pytest.raises(TrackingError, match="relocalize_keep"):
            make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, relocalize_keep=bad)


def test_imported_sequence_tracks_with_the_auto_threshold(tmp_path):
    """track-sequence (imported data, no level): ``health_min_inliers=auto`` is calibrated on
    the views of the map's fit-map artifact; a bare map file has none and is refused in one
    line."""
    import shutil

    from navbench.errors import ConfigError
    from navbench.geometry import HALF_CAMERA
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.stages.imported import store_views_stage
    from navbench.pipeline.stages.context import StageContext
    from navbench.pipeline.tracking import track_sequence
    from navbench.track.sequence import render_walk
    from navbench.worldmodel.grid import voxelize_level
    from navbench.worldmodel.tum import export_views
    from tests.pipeline.test_stages import tiny_level

    lv = tiny_level()
    views = render_walk(lv, 6, HALF_CAMERA, seed=2)
    seq = export_views(views, tmp_path / "seq")
    voxelize_level(lv).save(tmp_path / "map.npz")
    store = ArtifactStore(tmp_path / "cache")
    imp = store_views_stage(StageContext(store), views)
    path = store.write("fit-map", "ab" * 32, lambda d: shutil.copy(tmp_path / "map.npz", d / "map.npz"),
                       config={}, inputs={"views": imp.key}, version=1)
    opts = {"health": True, "health_min_inliers": "auto"}
    res = track_sequence(seq, map=path / "map.npz", store=store, options=opts)
    assert np.isfinite(res.ate_m) and res.ate_m < 0.05
    (cal,) = store.ls("health-calibration")
    with pytest.raises(ConfigError, match="no views of its own"):
        track_sequence(seq, map=tmp_path / "map.npz", store=store, options=opts)


def test_collisions_stop_instead_of_freezing_the_recording(level):
    """``collisions="stop"``: a colliding step leaves the robot where it was and the recording
    goes on; under appendix D's ``freeze`` (the default, keys unchanged) the robot stands still
    for the rest of the trajectory. Trajectories without a collision are identical."""
    from navbench.pipeline.stages.track_eval import study_key_config
    from navbench.sim.world import CollisionWorld
    from navbench.track.study import TrackingStudyConfig, record_trajectories

    def still(tr):
        d = np.diff(tr.true_poses, axis=0)
        return int(np.sum((np.hypot(d[:, 0], d[:, 1]) == 0) & (d[:, 2] == 0)))

    freeze = record_trajectories(level, 4, 1000, noise="mid", seed=1)
    stop = record_trajectories(level, 4, 1000, noise="mid", seed=1, collisions="stop")
    assert [t.collided for t in freeze] == [False, False, False, True]
    for a, b in zip(freeze[:3], stop[:3]):
        np.testing.assert_array_equal(a.true_poses, b.true_poses)
    a, b = freeze[3], stop[3]
    assert b.collided and still(a) > 200 and still(b) < 60
    k = int(np.flatnonzero(~np.all(a.true_poses == b.true_poses, axis=1))[0])
    np.testing.assert_array_equal(b.true_poses[k], b.true_poses[k - 1])  # stopped where it was
    assert b.controls[k - 1][0] == 0.0 and b.controls[k - 1][2] == 0.0  # and read no motion
    world = CollisionWorld(level)
    assert min(world.clearance(p[:2]) for p in b.true_poses) >= world.radius - 1e-9
    assert "collisions" not in study_key_config(TrackingStudyConfig())
    assert study_key_config(TrackingStudyConfig(collisions="stop"))["collisions"] == "stop"
    with pytest.raises(Exception, match="--collisions"):
        TrackingStudyConfig(collisions="bounce")


@pytest.mark.parametrize("keep, asked", [(0, None), (2, 3)])
def test_runner_ups_ask_the_relocaliser_for_its_ambiguity(level, keep, asked):
    """With runner-ups the relocaliser is asked for ``relocalize_top`` hypotheses (the localiser
    returns one by default); without them the call is as before."""
    from navbench.track.registry import make_estimator

    poses, controls, cam = _walk_frames(level)
    calls = []

    class Fake:
        def localize(self, frame, k=None):
            calls.append(k)
            return []

    est = make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, recover=True,
                         relocalizer=Fake(), relocalize_keep=keep)
    est.reset(poses[0], cam.render(poses[0]))
    est.update(controls[0], cam.render(poses[3] + np.array([1.0, 0.0, 2.0])))  # far off: alarm
    assert est.last_health["alarm"] and calls == [asked]
