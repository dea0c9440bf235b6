"""Tracking that stops when it has converged (issue 36): Gauss-Newton's early stop of the
point-to-plane phase (``gn_geo_tol``) and the heading search's gate (``yaw_search_gate``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.errors import TrackingError
from navbench.geometry import HALF_CAMERA, Frame, camera_pose
from navbench.track import eq7, ours
from navbench.track.lie import se3_inverse

from .synth import flat_wall, render_box

Z0 = np.array([2.0, 1.5, 0.3])
OFFSET = np.array([0.02, -0.015, math.radians(1.5)])


def _problem():
    """The box room seen from Z0 (the reference) and from Z0 + OFFSET (the observation)."""
    ref = eq7.prepare_reference(render_box(Z0), HALF_CAMERA, camera_pose(Z0))
    frame = render_box(Z0 + OFFSET)
    idx = ours.gn_pixels(*HALF_CAMERA.shape, 3000, 0)
    return ref, frame, idx


def _fixed_iterations(ref, frame, pred, cfg, idx):
    """Gauss-Newton of eq. 7 for exactly ``gn_iters`` iterations (no stop), written out here."""
    obs = eq7.sample_observation(frame, HALF_CAMERA, idx)
    state = np.asarray(ours.yaw_search(ref, frame, pred, cfg, idx), float)
    scale = cfg.pixel_scale / len(idx)
    Ti = se3_inverse(ref.T_wc)
    for it in range(cfg.gn_iters):
        Trel, B, b = eq7.linearization("planar", state, ref.T_wc, 0.5, Ti)
        acc = eq7.accumulate(ref, obs, Trel, B, b, cfg, photometric=it >= cfg.gn_geo_iters)
        _, pg, pH = eq7.prior_terms("planar", state, pred, cfg, 0.5)
        state = state - np.linalg.solve(scale * acc.irls_H + pH, scale * acc.irls_g + pg)
    return eq7.to_planar("planar", state)


def test_tolerance_zero_runs_every_iteration_and_gives_the_fixed_iteration_pose():
    ref, frame, idx = _problem()
    cfg = ours.make_config({"gn_tol": [0.0, 0.0], "gn_geo_tol": [0.0, 0.0]})
    info = {}
    got = ours.align_gauss_newton(ref, frame, Z0, cfg, idx, 0.5, info=info)
    assert info["gn_iters"] == cfg.gn_iters == 10
    np.testing.assert_array_equal(got, _fixed_iterations(ref, frame, Z0, cfg, idx))


def test_a_converged_problem_stops_early_with_the_tolerances():
    ref, frame, idx = _problem()
    true = Z0 + OFFSET
    full, early = {}, {}
    a = ours.align_gauss_newton(ref, frame, Z0, ours.make_config({}), idx, 0.5, info=full)
    cfg = ours.make_config({"gn_geo_tol": [1e-4, 1e-4], "gn_tol": [1e-4, 1e-4]})
    b = ours.align_gauss_newton(ref, frame, Z0, cfg, idx, 0.5, info=early)
    # default: the 5 point-to-plane iterations always run, then at least one of the full eq. 7
    assert full["gn_iters"] >= 6
    assert early["gn_iters"] < full["gn_iters"], (early, full)
    # an exact scene: both reach the true pose (the prior around Z0 pulls a little), and each
    # other within 0.1 mm and 0.005 deg
    for est in (a, b):
        assert np.abs(est[:2] - true[:2]).max() < 5e-3
        assert abs(math.degrees(est[2] - true[2])) < 0.2
    assert np.abs(a[:2] - b[:2]).max() < 1e-4 and abs(math.degrees(a[2] - b[2])) < 0.005


def test_the_geo_phase_ends_when_its_step_is_below_the_tolerance():
    """A huge gn_geo_tol ends the point-to-plane phase after its first iteration: iteration 2
    is then photometric. With gn_tol huge too, the first photometric iteration stops: 2 in all."""
    ref, frame, idx = _problem()
    info = {}
    ours.align_gauss_newton(ref, frame, Z0, ours.make_config({"gn_geo_tol": [1.0, 1.0], "gn_tol": [1.0, 1.0]}),
                            idx, 0.5, info=info)
    assert info["gn_iters"] == 2
    info = {}
    ours.align_gauss_newton(ref, frame, Z0, ours.make_config({"gn_tol": [1.0, 1.0]}), idx, 0.5, info=info)
    assert info["gn_iters"] == 6  # 5 point-to-plane iterations, then one that stops


# ------------------------------------------------------------------------------ heading gate

D = 2.0  # metres from the camera to the wall x = 3 (camera at x = 1, facing +x)


def _grey_wall(pose) -> Frame:
    """flat_wall with one uniform colour: the photometric residual is 0 wherever it is kept, so
    the search's score is the point-to-plane term alone."""
    f = flat_wall(pose)
    return Frame(np.full_like(f.rgb, 0.5), f.depth, f.valid)


def _interior_pixels():
    """The Gauss-Newton sample less the image's two outermost pixel rings (the point-to-plane
    term has no normal on the outermost one; the border columns sit on the image's edge)."""
    H, W = HALF_CAMERA.shape
    idx = ours.gn_pixels(H, W, 3000, 0)
    r, c = np.divmod(idx, W)
    return idx[(r >= 2) & (r <= H - 3) & (c >= 2) & (c <= W - 3)]


def _hand_score(turn: float, idx) -> float:
    """The score of the prediction (heading 0, the reference's own pose, so every observed point
    is compared at its own pixel) when the truth is turned by ``turn`` rad: an observed wall
    point ``w = (3, y)`` placed with the predicted pose lands at ``x' = 1 + D cos(turn) +
    y sin(turn)`` (the camera at x = 1 rotated back by ``turn`` about its centre),
    ``|3 - x'| = |D (1 - cos turn) - y sin turn|`` from the wall, times ``geo_weight`` 3,
    averaged (one uniform colour: every pixel's photometric term is kept, at 0)."""
    f = flat_wall(np.array([1.0, 0.0, turn]))
    T = camera_pose(np.array([1.0, 0.0, turn]))
    assert f.valid.reshape(-1)[idx].all()
    p = eq7.sample_observation(f, HALF_CAMERA, idx).points
    y = (p @ T[:3, :3].T + T[:3, 3])[:, 1]
    return float(np.mean(3.0 * np.abs(D * (1 - math.cos(turn)) - y * math.sin(turn))))


@pytest.mark.parametrize("turn_deg, searched", [(0.5, False), (10.0, True)])
def test_the_gate_searches_after_a_large_turn_and_not_after_a_small_one(turn_deg, searched):
    pred = np.array([1.0, 0.0, 0.0])
    ref = eq7.prepare_reference(_grey_wall(pred), HALF_CAMERA, camera_pose(pred))
    idx = _interior_pixels()
    turn = math.radians(turn_deg)
    frame = _grey_wall(np.array([1.0, 0.0, turn]))
    small, large = _hand_score(math.radians(0.5), idx[:400]), _hand_score(math.radians(10.0), idx[:400])
    # by hand: y spans about +-2.1 m (93.7 deg field of view at 2 m), so the mean |y| sin(turn)
    # is ~1 m x sin(turn): ~0.03 after 0.5 deg, ~0.5 after 10 deg (x 3 for geo_weight)
    assert 0.01 < small < 0.1 < 0.3 < large < 1.5
    gate = math.sqrt(small * large)
    info = {}
    start = ours.yaw_search(ref, frame, pred, ours.make_config({"yaw_search_gate": gate}), idx, info=info)
    assert info["yaw_score"] == pytest.approx(_hand_score(turn, idx[:400]), rel=1e-4)
    assert info["yaw_searched"] is searched
    if searched:  # the search itself ran: it finds the turn (a multiple of its 2 deg step)
        assert math.degrees(start[2]) == pytest.approx(turn_deg, abs=1e-9)
    else:
        np.testing.assert_array_equal(start, pred)


def test_a_gate_that_always_opens_gives_the_ungated_search():
    """The gated search scores the prediction first, then the others: the same choice."""
    ref, _, idx = _problem()
    for off in (-7.0, 3.0, 9.0):  # not 0: the exact scene then scores ~0, below any gate
        frame = render_box(Z0 + np.array([0.0, 0.0, math.radians(off)]))
        a = ours.yaw_search(ref, frame, Z0, ours.make_config({}), idx)
        info = {}
        b = ours.yaw_search(ref, frame, Z0, ours.make_config({"yaw_search_gate": 1e-12}), idx, info=info)
        assert info["yaw_searched"] is True
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("opts", [{"yaw_search_gate": -0.1}, {"gn_geo_tol": [-1e-4, 0.0]},
                                  {"yaw_search_gate": float("nan")}])
def test_negative_tolerances_are_refused(opts):
    with pytest.raises(TrackingError):
        ours.make_config(opts)


def test_the_turn_rule_searches_after_a_turn_and_not_after_a_straight_step():
    """yaw_search_turn_deg: the controller turns in place (>= 5 deg) or steps straight, and the
    dynamics' heading noise acts only on a turn; a straight step starts from the prediction."""
    from navbench.sim.dynamics import Control

    ref, _, idx = _problem()
    frame = render_box(Z0 + np.array([0.0, 0.0, math.radians(8.0)]))
    cfg = ours.make_config({"yaw_search_turn_deg": 1.0})
    for turn, searched in ((math.radians(0.5), False), (math.radians(-5.0), True), (None, True)):
        info = {}
        start = ours.yaw_search(ref, frame, Z0, cfg, idx, info=info, turn=turn)
        assert info["yaw_searched"] is searched
        if searched:
            assert math.degrees(start[2] - Z0[2]) == pytest.approx(8.0, abs=1e-9)
        else:
            np.testing.assert_array_equal(start, Z0)
    # through the estimator: the predicted turn is the control's
    est = ours.PredictionToObservationTracker(renderer=render_box, intrinsics=HALF_CAMERA,
                                              yaw_search_turn_deg=1.0)
    est.reset(Z0, render_box(Z0))
    est.update(Control(0.0, 0.3, 0.1), render_box(Z0 + np.array([0.1 * math.cos(0.3), 0.1 * math.sin(0.3), 0.0])))
    assert est.last_info["yaw_searched"] is False
    est.update(Control(math.radians(6.0), 0.3, 0.0), render_box(est.pose + np.array([0.0, 0.0, math.radians(6.0)])))
    assert est.last_info["yaw_searched"] is True


def test_the_turn_rule_with_the_residual_gate_scores_only_the_straight_steps():
    ref, _, idx = _problem()
    frame = render_box(Z0 + np.array([0.0, 0.0, math.radians(8.0)]))
    cfg = ours.make_config({"yaw_search_turn_deg": 1.0, "yaw_search_gate": 1e-12})
    info = {}
    ours.yaw_search(ref, frame, Z0, cfg, idx, info=info, turn=0.0)  # straight: the residual decides
    assert info["yaw_searched"] is True and info["yaw_score"] > 1e-12
    info = {}
    ours.yaw_search(ref, frame, Z0, cfg, idx, info=info, turn=math.radians(6.0))  # a turn: no score needed
    assert info["yaw_searched"] is True and "yaw_score" not in info
