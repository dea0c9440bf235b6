"""Prediction-to-observation tracking (eq. 7): exact recovery, Jacobians, robustness, the shell."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.errors import TrackingError
from navbench.geometry import HALF_CAMERA, Frame, Intrinsics, camera_pose
from navbench.sim.dynamics import Control, predict
from navbench.track import eq7, ours
from navbench.track.lie import se3_exp
from navbench.track.registry import make_estimator

from .synth import flat_wall, render_box, small_level

Z0 = np.array([2.0, 1.5, 0.3])
U = Control(math.radians(5.0), 0.3, 0.12)
OFFSET = np.array([0.05 * 0.6, -0.05 * 0.8, math.radians(2.0)])  # 5 cm, 2 deg


def _errors(est, true):
    return math.hypot(*(est[:2] - true[:2])), abs(math.degrees((est[2] - true[2] + math.pi) % (2 * math.pi) - math.pi))


@pytest.mark.parametrize("optimizer", ["gauss-newton", "adam"])
@pytest.mark.parametrize("param", ["planar", "se3"])
@pytest.mark.parametrize("name", ["ours", "no-map"])
def test_recovers_a_known_offset_from_the_prediction(optimizer, param, name):
    true = predict(Z0, U) + OFFSET
    est = make_estimator(name, renderer=render_box, intrinsics=HALF_CAMERA, optimizer=optimizer,
                         param=param)
    est.reset(Z0, render_box(Z0))
    out = est.update(U, render_box(true))
    loc, rot = _errors(out, true)
    assert loc < 0.005 and rot < 0.2, (loc, rot)
    assert set(est.last_timing) == {"render", "estimate"}


def test_recovers_an_offset_with_the_exact_raycast_camera():
    from navbench.sim.camera import RaycastCamera

    cam = RaycastCamera(small_level(), HALF_CAMERA)
    z0 = np.array([1.2, 1.0, 0.5])
    true = predict(z0, U) + OFFSET
    for optimizer in ("gauss-newton", "adam"):
        est = make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, optimizer=optimizer)
        est.reset(z0, cam.render(z0))
        loc, rot = _errors(est.update(U, cam.render(true)), true)
        assert loc < 0.005 and rot < 0.2, (optimizer, loc, rot)


def test_ours_renders_the_reference_once_per_step_at_the_previous_estimate():
    calls = []

    def renderer(pose):
        calls.append(np.array(pose))
        return render_box(pose)

    est = make_estimator("ours", renderer=renderer, intrinsics=HALF_CAMERA)
    est.reset(Z0, render_box(Z0))
    z1 = est.update(U, render_box(predict(Z0, U)))
    est.update(U, render_box(predict(z1, U)))
    assert len(calls) == 2
    assert np.array_equal(calls[0], Z0) and np.array_equal(calls[1], z1)


def test_point_to_plane_is_blind_to_sliding_along_a_wall_but_not_across_it():
    pose = np.array([1.0, 0.0, 0.0])  # facing the wall x = 3 head-on
    frame = flat_wall(pose)
    ref = eq7.prepare_reference(frame, HALF_CAMERA, camera_pose(pose))
    idx = ours.gn_pixels(*HALF_CAMERA.shape, 2000)
    obs = eq7.sample_observation(frame, HALF_CAMERA, idx)
    cfg = ours.TrackerConfig()

    def res(state):
        q, dq = eq7.transform_and_jacobian("planar", state, ref.T_wc, obs.points, 0.5)
        return eq7.residuals(ref, obs, q, dq)

    slide = res(pose + [0.0, 0.03, 0.0])  # along the wall
    assert slide.geo_ok.sum() > 1000
    assert np.abs(slide.geo[slide.geo_ok]).max() < 1e-9
    assert np.abs(slide.photo[slide.photo_ok]).sum() > 1.0  # the texture still sees it
    across = res(pose + [0.03, 0.0, 0.0])  # towards the wall
    assert across.geo_ok.sum() > 1000
    assert np.allclose(np.abs(across.geo[across.geo_ok]), 0.03, atol=1e-9)
    assert cfg.geo_threshold == 5.0 and cfg.photo_threshold == 1.0


@pytest.mark.parametrize("param", ["planar", "se3"])
def test_analytic_jacobians_equal_finite_differences(param):
    z_ref = np.array([2.0, 1.4, 0.2])
    frame_ref = render_box(z_ref)
    ref = eq7.prepare_reference(frame_ref, HALF_CAMERA, camera_pose(z_ref))
    obs_frame = render_box(z_ref + [0.04, -0.03, 0.05])
    idx = ours.gn_pixels(*HALF_CAMERA.shape, 1500, seed=3)
    obs = eq7.sample_observation(obs_frame, HALF_CAMERA, idx)
    state = z_ref + np.array([0.05, -0.02, 0.04])
    if param == "se3":
        state = camera_pose(state, 0.5) @ se3_exp(np.array([0.01, 0.002, -0.01, 0.003, 0.02, -0.002]))
    q, dq = eq7.transform_and_jacobian(param, state, ref.T_wc, obs.points, 0.5)
    r0 = eq7.residuals(ref, obs, q, dq)
    P = dq.shape[-1]
    eps = 1e-6
    checked = 0
    for c in range(P):
        d = np.zeros(P)
        d[c] = eps
        qp, _ = eq7.transform_and_jacobian(param, eq7.retract(param, state, d), ref.T_wc, obs.points, 0.5)
        qm, _ = eq7.transform_and_jacobian(param, eq7.retract(param, state, -d), ref.T_wc, obs.points, 0.5)
        # dq itself
        assert np.allclose((qp - qm) / (2 * eps), dq[:, :, c], atol=1e-7)
        rp = eq7.residuals(ref, obs, qp, None)
        rm = eq7.residuals(ref, obs, qm, None)
        # compare where nothing discrete changed (same bilinear cell, same association)
        same = _cells(ref, qp) == _cells(ref, qm)
        keep = r0.geo_ok & rp.geo_ok & rm.geo_ok & same
        assert keep.sum() > 500
        fd_geo = (rp.geo - rm.geo) / (2 * eps)
        assert np.allclose(fd_geo[keep], r0.J_geo[keep, c], atol=1e-6)
        keep = r0.photo_ok & rp.photo_ok & rm.photo_ok & same
        fd_photo = (rp.photo - rm.photo) / (2 * eps)
        assert np.allclose(fd_photo[keep], r0.J_photo[keep, :, c], atol=1e-6)
        checked += keep.sum()
    assert checked > 1000


def _cells(ref, q):
    intr = ref.intr
    u = intr.fx * q[:, 0] / q[:, 2] + intr.cx
    v = intr.fy * q[:, 1] / q[:, 2] + intr.cy
    return (np.floor(u) * 1000 + np.floor(v)) * 10 + (np.floor(u + 0.5) - np.floor(u)) * 2 + (np.floor(v + 0.5) - np.floor(v))


@pytest.mark.parametrize("param", ["planar", "se3"])
def test_fast_kernel_equals_the_numpy_reference(param):
    z_ref = np.array([2.0, 1.4, 0.2])
    ref = eq7.prepare_reference(render_box(z_ref), HALF_CAMERA, camera_pose(z_ref))
    obs = eq7.sample_observation(render_box(z_ref + [0.03, 0.02, -0.04]), HALF_CAMERA,
                                  ours.gn_pixels(*HALF_CAMERA.shape, 2000, seed=1))
    cfg = ours.TrackerConfig(photo_threshold=0.3, geo_weight=7.0)  # some pixels over the threshold
    state = z_ref + np.array([0.01, 0.0, 0.0])
    if param == "se3":  # off the plane, so that no floor residual is a signed zero
        state = camera_pose(state, 0.5) @ se3_exp(np.array([0.0, 0.003, 0.0, 0.002, 0.0, 0.001]))
    pred = z_ref.copy()
    val, grad = eq7.objective(ref, obs, param, state, pred, cfg)
    Trel, B, b = eq7.linearization(param, state, ref.T_wc, 0.5)
    acc = eq7.accumulate(ref, obs, Trel, B, b, cfg)
    pv, pg, _ = eq7.prior_terms(param, state, pred, cfg, 0.5)
    scale = cfg.pixel_scale / len(obs.points)
    assert math.isclose(scale * acc.value + pv, val, rel_tol=1e-10)
    assert np.allclose(scale * acc.grad + pg, grad, rtol=1e-9, atol=1e-9), (scale * acc.grad + pg - grad)
    q, dq = eq7.transform_and_jacobian(param, state, ref.T_wc, obs.points, 0.5)
    r = eq7.residuals(ref, obs, q, dq, cfg.photo_threshold, cfg.geo_threshold)
    assert acc.counts[0] == r.photo_ok.sum() and acc.counts[1] == r.geo_ok.sum()
    assert 0 < r.photo_ok.sum() < r.geo_ok.sum()
    wp = cfg.photo_weight / np.maximum(np.abs(r.photo), cfg.irls_eps[0]) * r.photo_ok[:, None]
    wg = cfg.geo_weight / np.maximum(np.abs(r.geo), cfg.irls_eps[1]) * r.geo_ok
    H = np.einsum("kc,kcp,kcq->pq", wp, r.J_photo, r.J_photo) + np.einsum("k,kp,kq->pq", wg, r.J_geo, r.J_geo)
    assert np.allclose(acc.irls_H, H, rtol=1e-9)


def test_planar_prior_gradient_equals_finite_differences():
    cfg = ours.TrackerConfig()
    pred = np.array([1.0, 2.0, 3.1])
    z = np.array([1.01, 1.98, -3.1])  # heading difference wraps
    v, g, H = eq7.prior_terms("planar", z, pred, cfg, 0.5)
    for c in range(3):
        d = np.zeros(3)
        d[c] = 1e-7
        fd = (eq7.prior_terms("planar", z + d, pred, cfg, 0.5)[0]
              - eq7.prior_terms("planar", z - d, pred, cfg, 0.5)[0]) / 2e-7
        assert math.isclose(fd, g[c], rel_tol=1e-5)
    assert v > 0 and np.allclose(np.diag(H), [1 / 0.01**2, 1 / 0.01**2, 1 / math.radians(3) ** 2])


@pytest.mark.parametrize("optimizer", ["gauss-newton", "adam"])
def test_corrupted_pixels_barely_move_the_estimate(optimizer):
    true = predict(Z0, U) + OFFSET
    clean = render_box(true)
    rng = np.random.default_rng(7)
    bad = rng.random(clean.depth.shape) < 0.2
    depth = np.where(bad, rng.uniform(0.2, 6.0, clean.depth.shape), clean.depth).astype(np.float32)
    rgb = np.where(bad[..., None], rng.random(clean.rgb.shape), clean.rgb).astype(np.float32)
    corrupted = Frame(rgb, depth, clean.valid)
    outs = []
    for frame in (clean, corrupted):
        est = make_estimator("ours", renderer=render_box, intrinsics=HALF_CAMERA, optimizer=optimizer)
        est.reset(Z0, render_box(Z0))
        outs.append(est.update(U, frame))
    loc, rot = _errors(outs[0], outs[1])
    assert loc < 0.01, (loc, rot)


def test_any_image_size_and_determinism():
    intr = Intrinsics(64, 48, 40.0, 40.0, 32.0, 24.0)
    true = predict(Z0, U) + OFFSET
    outs = []
    for _ in range(2):
        est = make_estimator("ours", renderer=lambda p: render_box(p, intr), intrinsics=intr,
                             optimizer="adam", seed=4)
        est.reset(Z0, render_box(Z0, intr))
        outs.append(est.update(U, render_box(true, intr)))
    assert np.array_equal(outs[0], outs[1])
    loc, rot = _errors(outs[0], true)
    assert loc < 0.01 and rot < 0.5
    assert eq7.pixel_table(48, 64).shape == (100, 1000)
    assert eq7.pixel_table(48, 64).max() < 48 * 64


def test_misuse_raises_tracking_errors():
    with pytest.raises(TrackingError):
        make_estimator("ours", intrinsics=HALF_CAMERA)  # neither map nor renderer
    with pytest.raises(TrackingError):
        make_estimator("ours", renderer=render_box, optimizer="sgd")
    with pytest.raises(TrackingError):
        make_estimator("no-map", nonsense=1)
    est = make_estimator("no-map", intrinsics=HALF_CAMERA)
    with pytest.raises(TrackingError):
        est.update(U, render_box(Z0))
    est.reset(Z0, render_box(Z0))
    with pytest.raises(TrackingError):
        est.update(U, render_box(Z0, Intrinsics(64, 48, 40.0, 40.0, 32.0, 24.0)))


@pytest.mark.parametrize("optimizer", ["gauss-newton", "adam"])
def test_heading_search_recovers_a_large_turn_error(optimizer):
    """A turn in place at mid/high noise can be off by ~15-20 deg: the heading search finds it."""
    from navbench.sim.camera import RaycastCamera

    cam = RaycastCamera(small_level(), HALF_CAMERA)
    z0 = np.array([1.2, 1.0, 0.5])
    turn = Control(math.radians(11.5), 0.5, 0.0)
    true = predict(z0, turn) + np.array([0.0, 0.0, math.radians(15.0)])
    est = make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, optimizer=optimizer)
    est.reset(z0, cam.render(z0))
    loc, rot = _errors(est.update(turn, cam.render(true)), true)
    assert loc < 0.01 and rot < 0.3, (loc, rot)


def test_heading_search_picks_the_offset_with_the_lowest_data_term():
    from navbench.sim.camera import RaycastCamera

    cam = RaycastCamera(small_level(), HALF_CAMERA)
    z0 = np.array([1.2, 1.0, 0.5])
    true = z0 + np.array([0.0, 0.0, math.radians(-10.0)])
    cfg = ours.make_config({})
    ref = eq7.prepare_reference(cam.render(z0), HALF_CAMERA, camera_pose(z0))
    idx = ours.gn_pixels(*HALF_CAMERA.shape, cfg.gn_pixels, 0)
    start = ours.yaw_search(ref, cam.render(true), z0, cfg, idx)
    assert start[:2] == pytest.approx(z0[:2])
    assert math.degrees(start[2] - z0[2]) == pytest.approx(-10.0, abs=1e-9)
    off = ours.yaw_search(ref, cam.render(true), z0, ours.make_config({"yaw_search_deg": 0.0}), idx)
    np.testing.assert_array_equal(off, z0)


def test_heading_search_scores_the_top_rows_unless_spread():
    """The search scores the first ``yaw_search_pixels`` of the sorted Gauss-Newton sample: the
    image's top rows (navbench-1); ``yaw_search_spread`` spreads them over the whole image
    (issue 37: on the engine's frames the top rows, mostly ceiling, misled it)."""
    from navbench.sim.camera import RaycastCamera
    from navbench.track.heading import search_positions

    H, W = HALF_CAMERA.shape
    cfg, spread = ours.make_config({}), ours.make_config({"yaw_search_spread": True})
    idx = ours.gn_pixels(H, W, cfg.gn_pixels, 0)
    first, even = idx[search_positions(len(idx), cfg)], idx[search_positions(len(idx), spread)]
    assert len(first) == len(even) == cfg.yaw_search_pixels
    assert (first // W).max() <= 16 and (even // W).min() <= 1 and (even // W).max() >= H - 2
    assert np.all(np.diff(even) > 0)
    # a frame whose top 20 rows read nothing: the default search has no pixel to score and keeps
    # the prediction; spread over the image, it finds the 10 deg turn
    cam = RaycastCamera(small_level(), HALF_CAMERA)
    z0 = np.array([1.2, 1.0, 0.5])
    true = z0 + np.array([0.0, 0.0, math.radians(-10.0)])
    ref = eq7.prepare_reference(cam.render(z0), HALF_CAMERA, camera_pose(z0))
    f = cam.render(true)
    valid = f.valid.copy()
    valid[:20] = False
    blind = f._replace(valid=valid) if hasattr(f, "_replace") else type(f)(f.rgb, f.depth, valid)
    np.testing.assert_array_equal(ours.yaw_search(ref, blind, z0, cfg, idx), z0)
    start = ours.yaw_search(ref, blind, z0, spread, idx)
    assert math.degrees(start[2] - z0[2]) == pytest.approx(-10.0, abs=1e-9)
    # the search's choice with all rows readable is the same either way here
    assert ours.yaw_search(ref, f, z0, spread, idx)[2] == pytest.approx(true[2], abs=1e-9)
