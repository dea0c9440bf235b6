"""The localiser's change-tolerant parts (issue 14, changed rooms): the one-sided verification
against hand-counted pixels, the trimmed re-ranking cost against its written-out sums, the
refinement that never reports a pose worse than where it started, screening, and a query in a
room whose furniture changed."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from navbench.geometry import CAMERA_HEIGHT, HALF_CAMERA, wrap_angle
from navbench.localize import Localizer, LocalizerConfig
from navbench.localize import signature as sig
from navbench.localize.localizer import one_sided_confidence
from navbench.sim.camera import RaycastCamera
from tests.localize.worlds import ExactWorld, _box, room

CFG = LocalizerConfig(lattice_step=0.25)


@pytest.fixture(scope="module")
def loc():
    return Localizer.build(ExactWorld(room()), HALF_CAMERA, CAMERA_HEIGHT, CFG)


def test_one_sided_confidence_hand_counted():
    """11 pixels, tolerance 0.05 + 0.1 * depth, colour 0.1: 4 inliers, 2 in front (added
    furniture), 1 beyond (removed furniture), 1 wrong colour and 1 without a prediction
    (contradictions), 1 invalid query pixel (ignored), 1 inlier at the tolerance's edge."""
    dq = np.array([1.0, 2.0, 1.0, 1.0, 1.0, 0.5, 3.0, 1.0, 1.0, 9.9, 1.0])
    dp = np.array([1.0, 2.1, 1.02, 3.0, 2.0, 0.5, 2.0, 1.0, np.nan, 1.0, 1.0 + 0.15])
    vq = np.array([1, 1, 1, 1, 1, 1, 1, 1, 1, 0, 1], bool)
    vp = np.array([1, 1, 1, 1, 1, 1, 1, 1, 0, 1, 1], bool)
    dc = np.array([0.0, 0.05, 0.1, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0])
    # pixel: 0 in, 1 in (|-0.1| <= 0.25), 2 in (colour at the limit), 3 front, 4 front,
    # 5 in, 6 beyond, 7 wrong colour, 8 no prediction, 9 invalid, 10 in (|-0.15| <= 0.15)
    conf, weighted, ok = one_sided_confidence(dq, vq, dp, vp, dc, 0.05, 0.1, 0.1, 0.25, 0.5)
    np.testing.assert_array_equal(ok, [1, 1, 1, 0, 0, 1, 0, 0, 0, 0, 1])
    assert conf == pytest.approx(5 / 10)
    assert weighted == pytest.approx(5 / (5 + 2 + 0.25 * 2 + 0.5 * 1))
    conf1, same, _ = one_sided_confidence(dq, vq, dp, vp, dc, 0.05, 0.1, 0.1, 1.0, 1.0)
    assert conf1 == same == pytest.approx(5 / 10)
    assert one_sided_confidence(dq, np.zeros(11, bool), dp, vp, dc, 0.05, 0.1, 0.1)[:2] == (0.0, 0.0)


def test_trimmed_costs_equal_written_out_sums():
    rng = np.random.default_rng(2)
    pano = rng.random((6, 4, 32))
    Q = rng.random((4, 9))
    shifts = rng.integers(0, 32, (6, 3))
    tau, keep = 0.3, 6
    out = sig.trimmed_costs(pano, Q, shifts, tau, keep)
    for n in range(6):
        for j in range(3):
            idx = (shifts[n, j] + np.arange(-4, 5)) % 32
            col = np.minimum(np.abs(Q - pano[n][:, idx]), tau).sum(axis=0)
            assert out[n, j] == pytest.approx(np.sort(col)[:keep].sum())
    np.testing.assert_allclose(sig.trimmed_costs(pano, Q, shifts, tau, 9), sig.truncated_costs(pano, Q, shifts, tau))


def changed_room():
    """:func:`room` with a box added in front of the north wall and the first box removed."""
    base = room()
    obs = (base.obstacles[1], _box(1.6, 2.2, 2.2, 2.7, 1.0, 3))
    return replace(base, obstacles=obs)


def test_refinement_never_reports_worse_than_its_start(loc):
    cam = RaycastCamera(changed_room(), HALF_CAMERA)
    rng = np.random.default_rng(5)
    for _ in range(4):
        pose = np.array([rng.uniform(0.6, 3.4), rng.uniform(0.4, 1.6), rng.uniform(-math.pi, math.pi)])
        frame = cam.render(pose)
        for start in (pose, pose + [0.08, -0.06, 0.02]):
            assert loc.refine(frame, start).score >= loc.verify_at(frame, start).score - 1e-12


def test_screened_candidate_is_returned_unrefined(loc):
    pose = np.array([2.0, 1.5, 0.3])
    frame = RaycastCamera(room(), HALF_CAMERA).render(pose)
    start = pose + [0.07, 0.05, 0.02]
    h = loc._refine(loc.strided(frame), start, floor=np.inf)
    np.testing.assert_array_equal(h.pose, start)
    assert np.hypot(*(loc.refine(frame, start).pose[:2] - pose[:2])) < 0.02


def test_query_in_a_changed_room_is_found(loc):
    """Views of the changed room (a box added, one removed; 8-28 % of their pixels changed)
    localised in the original's map: found within 2 cm and 1 degree. (A view whose changed part
    leaves only a wall and a corner can slide along the wall at equal score: not one of these.)"""
    cam = RaycastCamera(changed_room(), HALF_CAMERA)
    for pose in (np.array([2.0, 1.2, math.pi / 2]), np.array([1.0, 2.0, -0.6]), np.array([1.5, 1.5, 1.2]),
                 np.array([3.0, 1.0, 2.2])):
        frame = cam.render(pose)
        h = loc.localize(frame)[0]
        assert np.hypot(*(h.pose[:2] - pose[:2])) < 0.02, (pose, h)
        assert abs(math.degrees(float(wrap_angle(h.pose[2] - pose[2])))) < 1.0


def test_exhaustive_truncated_is_the_minimum_over_every_shift():
    """The robust search's cost at every shift written out (weights, per-channel truncation,
    a weight-0 channel that must not count), its minimum and first argmin per point; the
    same bits on one thread as on two."""
    import numba

    rng = np.random.default_rng(7)
    pano = rng.random((9, 4, 32)).astype(np.float32)
    Q = rng.random((4, 9)).astype(np.float32)
    pano[3, :, 5:14] = Q  # point 3 sees the window exactly at shift 9
    weight = np.array([0.3, 0.0, 1.0, 1.0], np.float32)
    tau = np.array([0.05, 0.2, 0.1, 0.3], np.float32)
    shift, cost = sig.exhaustive_truncated(pano, Q, weight, tau)
    for n in range(9):
        full = np.array([sum(weight[c] * np.minimum(np.abs(Q[c] - pano[n, c, (s + np.arange(-4, 5)) % 32]),
                                                     tau[c]).sum() for c in range(4)) for s in range(32)])
        assert cost[n] == pytest.approx(full.min(), rel=1e-5, abs=1e-6)
        assert full[shift[n]] == pytest.approx(full.min(), rel=1e-5, abs=1e-6)
    assert shift[3] == 9 and cost[3] == 0.0
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = sig.exhaustive_truncated(pano, Q, weight, tau)
    finally:
        numba.set_num_threads(old)
    np.testing.assert_array_equal(one[0], shift)
    np.testing.assert_array_equal(one[1], cost)


def test_robust_search_takes_over_when_nothing_verifies():
    """With ``accept`` out of reach nothing verifies: after ``robust_after`` refined candidates
    the robust search's candidates follow (none of them a candidate already tried), and a view of
    the changed room is still found; with ``robust_after = 0`` the search never runs (the scan
    matching off: its moved starts are tested below)."""
    world = ExactWorld(room())
    on = Localizer.build(world, HALF_CAMERA, CAMERA_HEIGHT, replace(CFG, accept=1.01, robust_after=2,
                                                                   max_candidates=6, scan_radius=0.0))
    off = Localizer(world, HALF_CAMERA, CAMERA_HEIGHT, replace(on.config, robust_after=0), on.bank)
    pose = np.array([2.0, 1.2, math.pi / 2])
    frame = RaycastCamera(changed_room(), HALF_CAMERA).render(pose)
    h = on.localize(frame)[0]
    assert on.last_timing["robust"] > 0 and len(on.last_refined) == 6
    assert np.hypot(*(h.pose[:2] - pose[:2])) < 0.02
    from navbench.localize.localizer import _same_candidate

    tried = on.last_candidates[:6]
    assert not any(_same_candidate(a, b, on.config) for i, a in enumerate(tried[:2]) for b in tried[2:])
    off.localize(frame)
    assert off.last_timing["robust"] == 0.0


def test_robust_candidates_rank_a_changed_view_first():
    """A view whose lower part new furniture fills: the robust search puts its true place and
    heading first."""
    world = ExactWorld(room())
    loc = Localizer.build(world, HALF_CAMERA, CAMERA_HEIGHT, CFG)
    pose = np.array([2.0, 1.2, math.pi / 2])
    frame = RaycastCamera(changed_room(), HALF_CAMERA).render(pose)
    best = loc.robust_candidates(loc.query_signature(frame), 3)[0]
    assert np.hypot(*(best[:2] - pose[:2])) <= CFG.lattice_step
    assert abs(math.degrees(float(wrap_angle(best[2] - pose[2])))) <= 360 / CFG.bins


def test_horizon_scan_lies_on_the_level_and_scan_matching_recovers_an_offset():
    """The horizon row's points at the true pose lie on the level's walls and boxes at camera
    height (likelihood-field cost within the 5 cm raster's half cell); from 0.3 m and 12 degrees
    off, the correlative scan matching returns within a grid step (2.5 cm, 1 degree) of the
    truth, coarse-to-fine as the full grid does here."""
    from navbench.localize import scan

    level = room()
    occ, xs, ys = ExactWorld(level).occupancy_slice("slice", height=CAMERA_HEIGHT)
    field = scan.likelihood_field(occ, xs, ys, 0.2)
    cam = RaycastCamera(level, HALF_CAMERA)
    for pose in (np.array([2.0, 1.5, 0.7]), np.array([1.0, 2.2, -2.0]), np.array([3.0, 0.8, 2.5])):
        pts = scan.horizon_scan(cam.render(pose), HALF_CAMERA, CAMERA_HEIGHT)
        assert len(pts) > 100
        assert scan.field_cost(field, xs, ys, 0.2, pts, pose) <= 0.026
        start = pose + np.array([0.2, -0.2, math.radians(12)])
        assert scan.field_cost(field, xs, ys, 0.2, pts, start) > 0.05
        for coarse in (1, 2):
            got, cost = scan.match_scan(field, xs, ys, 0.2, pts, start, radius=0.3, max_deg=15, coarse=coarse)
            assert np.hypot(*(got[:2] - pose[:2])) <= 0.026 * math.sqrt(2) + 1e-9, (coarse, got, pose)
            assert abs(math.degrees(float(wrap_angle(got[2] - pose[2])))) <= 1.0 + 1e-9
            assert cost <= 0.026


def test_likelihood_field_by_hand():
    """A 5-cell row of 0.1 m cells, the middle one occupied: each centre's distance to the
    boundary, which lies half a cell from the occupied centre (the occupied centre itself: 0.05),
    truncated at 0.12."""
    from navbench.localize import scan

    occ = np.array([[0], [0], [1], [0], [0]], bool)
    xs, ys = np.arange(5) * 0.1, np.array([0.0, 0.1])
    f = scan.likelihood_field(np.repeat(occ, 2, axis=1), xs, ys, 0.12)
    np.testing.assert_allclose(f[:, 0], [0.12, 0.05, 0.05, 0.05, 0.12], atol=1e-6)
    assert (scan.likelihood_field(np.zeros((3, 3), bool), xs[:3], ys, 0.2) == np.float32(0.2)).all()


def test_scan_matched_starts_are_refined_beside_the_candidates():
    """With the scan matching on, each robust candidate the matching moves is refined from the
    moved pose and from its own (``scan_both``): the changed room's view is found either way."""
    world = ExactWorld(room())
    on = Localizer.build(world, HALF_CAMERA, CAMERA_HEIGHT, replace(CFG, accept=1.01, robust_after=2,
                                                                   max_candidates=6))
    pose = np.array([2.0, 1.2, math.pi / 2])
    h = on.localize(RaycastCamera(changed_room(), HALF_CAMERA).render(pose))[0]
    assert np.hypot(*(h.pose[:2] - pose[:2])) < 0.02
    assert len(on.last_refined) == 6


def test_bad_scan_settings_are_one_line_errors():
    from navbench.localize.localizer import LocalizationError

    for bad in ({"scan_radius": -1.0}, {"scan_trunc": 0.0}, {"scan_coarse": 0}):
        with pytest.raises(LocalizationError, match="scan_"):
            Localizer.build(ExactWorld(room()), HALF_CAMERA, CAMERA_HEIGHT, replace(CFG, **bad))
    with pytest.raises(LocalizationError, match="reverify must be >= 0"):
        Localizer.build(ExactWorld(room()), HALF_CAMERA, CAMERA_HEIGHT, replace(CFG, reverify=-1.0))


def test_a_refined_pose_is_scored_by_its_own_render(loc, monkeypatch):
    """A last Gauss-Newton round that jumps 0.5 m (what a changed room's furniture can do) does
    not carry the score of the render it started from: the jumped pose is rendered and verified
    again (``reverify``), and the better of the two is kept. With ``reverify = 0`` (the
    behaviour before 2026-11-26) the jumped pose was reported with its start's score."""
    import navbench.localize.localizer as L

    calls = []

    def stay_then_jump(ref, fr, p, *a):  # round 1 converged, round 2 jumps 0.5 m
        calls.append(1)
        return np.asarray(p, np.float64) + ([0.0, 0.0, 0.0] if len(calls) % 2 else [0.5, 0.0, 0.0])

    pose = np.array([2.0, 1.2, 0.4])
    frame = RaycastCamera(room(), HALF_CAMERA).render(pose)
    monkeypatch.setattr(L, "align_planar", stay_then_jump)
    h = loc.refine(frame, pose)
    np.testing.assert_allclose(h.pose, pose, atol=1e-12)  # the jump scored worse and was undone
    assert h.score == loc.verify_at(frame, h.pose).score > loc.verify_at(frame, pose + [0.5, 0, 0]).score
    for start in (pose + [0.3, 0.2, 0.1], pose + [-0.6, 0.1, -0.3]):
        h = loc.refine(frame, start)
        assert h.score == loc.verify_at(frame, h.pose).score
    old = Localizer(loc.world_model, loc.intrinsics, loc.camera_height, replace(CFG, reverify=0.0), loc.bank)
    h = old.refine(frame, pose)
    np.testing.assert_allclose(h.pose, pose + [0.5, 0.0, 0.0], atol=1e-12)
    assert h.score == loc.verify_at(frame, pose).score > loc.verify_at(frame, h.pose).score


def test_near_tied_candidates_are_refined_past_the_first_verified(loc, monkeypatch):
    """``close_margin``: once ``k`` hypotheses are verified, the next coarse candidates whose
    coarse cost exceeds the best one's by at most ``close_margin`` are refined too (at most
    ``close_max`` in all), so a view whose signatures nearly tie is decided by verifying each;
    a clearly worse coarse cost ends the search as before, and ``close_margin = 0`` is the search
    before 2026-11-26 (``min_candidates`` refined, then stop)."""
    from navbench.localize.localizer import Hypothesis

    poses = [np.array([x, 1.0, 0.0]) for x in (1.0, 1.5, 2.0, 2.5)]
    costs = [3.0, 3.2, 3.4, 4.0]  # coarse costs, best first (a ratio rule would read 1.07 / 1.13 / 1.33)
    scores = {1.0: 0.90, 1.5: 0.88, 2.0: 0.99, 2.5: 1.0}  # verified scores: the third is right

    def coarse(self, Q, count, out=None):
        out.extend(costs)
        return [p.copy() for p in poses]

    def refine(self, frame, pose, floor=-np.inf):
        return Hypothesis(pose.copy(), scores[float(pose[0])], 0.95)

    monkeypatch.setattr(Localizer, "coarse_candidates", coarse)
    monkeypatch.setattr(Localizer, "_refine", refine)
    frame = RaycastCamera(room(), HALF_CAMERA).render(np.array([2.0, 1.0, 0.0]))

    def run(**kw):
        one = Localizer(loc.world_model, loc.intrinsics, loc.camera_height, replace(CFG, **kw), loc.bank)
        h = one.localize(frame)[0]
        return float(h.pose[0]), len(one.last_refined)

    assert run(close_margin=0.0) == (1.0, 2)        # min_candidates, then stop: the wrong place
    assert run(close_margin=0.5) == (2.0, 3)        # 3.4 - 3.0 <= 0.5 refined, 4.0 - 3.0 > 0.5 not
    assert run(close_margin=0.5, close_max=2) == (1.0, 2)
    assert run(close_margin=1.0) == (2.5, 4)        # 4.0 - 3.0 <= 1.0: every candidate
    assert run(close_margin=0.3) == (1.0, 2)        # 3.4 - 3.0 > 0.3: stop at two
    from navbench.localize.localizer import LocalizationError

    with pytest.raises(LocalizationError, match="close_margin must be >= 0"):
        run(close_margin=-0.1)


def test_one_sided_confidence_is_silent_on_infinite_invalid_depths():
    """The engine's frames (``--sim vizdoom``) mark invalid pixels with depth +inf: where both
    the query and the prediction are inf the check printed numpy's "invalid value encountered in
    subtract" on every localised query; the counts were right, the warning was noise."""
    import warnings

    dq = np.array([1.0, np.inf, 2.0, np.inf])
    dp = np.array([1.0, np.inf, np.inf, 2.0])
    vq = np.array([1, 0, 1, 0], bool)
    vp = np.array([1, 0, 0, 1], bool)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        conf, weighted, ok = one_sided_confidence(dq, vq, dp, vp, np.zeros(4), 0.05, 0.1, 0.1)
    np.testing.assert_array_equal(ok, [1, 0, 0, 0])
    assert conf == pytest.approx(1 / 2) and weighted == pytest.approx(1 / 2)
