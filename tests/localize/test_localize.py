"""The localiser (issue 14, section 6): lattice and off-lattice queries, exact circular
correlation, reported symmetric ambiguity, bad input. Exact renders through :class:`ExactWorld`."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.geometry import CAMERA_HEIGHT, HALF_CAMERA, wrap_angle
from navbench.localize import Localizer, LocalizerConfig
from navbench.localize import signature as sig
from navbench.localize.localizer import LocalizationError, candidates
from navbench.sim.camera import RaycastCamera
from tests.localize.worlds import ExactWorld, room, symmetric_room

CFG = LocalizerConfig(lattice_step=0.25)


@pytest.fixture(scope="module")
def loc():
    return Localizer.build(ExactWorld(room()), HALF_CAMERA, CAMERA_HEIGHT, CFG)


def _errors(h, pose):
    return float(np.hypot(*(h.pose[:2] - pose[:2]))), abs(math.degrees(float(wrap_angle(h.pose[2] - pose[2]))))


def test_lattice_is_free_and_regular(loc):
    pts = loc.bank.points
    assert len(pts) > 50
    # on multiples of the step
    np.testing.assert_allclose(pts / CFG.lattice_step, np.rint(pts / CFG.lattice_step), atol=1e-9)
    from navbench.level import distance_to_solids

    assert distance_to_solids(room(), pts).min() >= CFG.clearance - 1e-9


@pytest.mark.parametrize("offset", [(0.0, 0.0), (0.125, 0.125), (0.07, -0.11)])
def test_query_found_within_2cm_1deg(loc, offset):
    cam = RaycastCamera(room(), HALF_CAMERA)
    rng = np.random.default_rng(3)
    for _ in range(3):
        p = loc.bank.points[rng.integers(len(loc.bank.points))]
        pose = np.array([p[0] + offset[0], p[1] + offset[1], rng.uniform(-math.pi, math.pi)])
        from navbench.level import distance_to_solids

        if distance_to_solids(room(), pose[None, :2])[0] < 0.15:
            continue
        h = loc.localize(cam.render(pose))
        assert len(h) == 1
        e, a = _errors(h[0], pose)
        assert e < 0.02 and a < 1.0, (pose, h[0])
        assert 0.9 <= h[0].confidence <= 1.0
        assert set(loc.last_timing) >= {"signature", "correlate", "refine", "total"}


def test_fft_correlation_equals_direct_sums():
    rng = np.random.default_rng(0)
    pano = rng.random((5, 4, 64))
    Q = rng.random((4, 11))
    np.testing.assert_allclose(sig.circular_costs(pano, Q), sig.circular_costs_direct(pano, Q), atol=1e-4)


def test_best_shifts_are_the_row_minima_of_the_costs():
    """The fused float32 path (:meth:`Correlator.best`) gives each point's argmin and minimum of
    the direct sums (up to float32 rounding; random data has no near-ties at this tolerance)."""
    rng = np.random.default_rng(1)
    pano = rng.random((40, 8, 192)).astype(np.float32)
    Q = rng.random((8, 61))
    D = sig.circular_costs_direct(pano.astype(np.float64), Q)
    shift, cost = sig.Correlator(pano, 30).best(Q)
    np.testing.assert_array_equal(shift, np.argmin(D, axis=1))
    np.testing.assert_allclose(cost, D.min(axis=1), rtol=1e-4)


def test_best_does_not_depend_on_the_block_size():
    """:meth:`Correlator.best` works ``block`` points at a time; every block size (one, a
    divisor, not a divisor, all points at once) gives the same bits."""
    rng = np.random.default_rng(2)
    pano = rng.random((517, 8, 192)).astype(np.float32)
    Q = rng.random((8, 61))
    corr = sig.Correlator(pano, 30)
    want = corr.best(Q, block=len(pano))
    for block in (1, 47, 64, 512, 10_000):
        got = corr.best(Q, block=block)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1]), block


def test_heading_only_change_recovered_exactly(loc):
    """A window cut from a stored panorama at shift s is found at shift s with cost 0, and a
    rendered query at a lattice point with a heading on a bin gets that bin as its coarse heading."""
    bins, R = CFG.bins, sig.half_window(HALF_CAMERA, CFG.bins)
    pano = loc.bank.pano
    for i, s in ((3, 0), (17, 5), (40, bins - 1), (60, 123)):
        Q = pano[i][:, (s + np.arange(-R, R + 1)) % bins].astype(np.float64)
        D = sig.Correlator(pano, R).costs(Q)
        assert int(np.argmin(D[i])) == s
        assert D[i, s] == pytest.approx(0.0, abs=1e-3)
    cam = RaycastCamera(room(), HALF_CAMERA)
    ycs = sig.elevations(CFG.rows, CFG.row_top, CFG.row_step)
    i = len(loc.bank.points) // 2
    for s in (0, 37, 150):
        pose = np.array([*loc.bank.points[i], s * 2 * math.pi / bins])
        Q = sig.query_signature(cam.render(pose), HALF_CAMERA, ycs, CFG.grey_weight, bins,
                                CFG.depth_feature, CFG.feature_range)
        corr = sig.Correlator(pano, R)
        D = corr.costs(Q)
        assert int(np.argmin(D[i])) == s
        shift, cost = corr.best(Q)
        np.testing.assert_array_equal(shift[i], s)
        best = candidates(shift, cost, loc.bank.points, 1, CFG)[0]
        np.testing.assert_allclose(best, [*loc.bank.points[i], float(wrap_angle(pose[2]))], atol=1e-9)


def test_symmetric_ambiguity_is_reported():
    level = symmetric_room()
    loc = Localizer.build(ExactWorld(level), HALF_CAMERA, CAMERA_HEIGHT, CFG)
    pose = np.array([1.05, 2.1, 0.4])
    mirror = np.array([4.0 - pose[0], 3.0 - pose[1], float(wrap_angle(pose[2] + math.pi))])
    frame = RaycastCamera(level, HALF_CAMERA).render(pose)
    np.testing.assert_allclose(frame.depth, RaycastCamera(level, HALF_CAMERA).render(mirror).depth, atol=1e-4)
    hyps = loc.localize(frame, k=2)
    assert len(hyps) == 2
    found = sorted(min(_errors(h, p)[0] for h in hyps) for p in (pose, mirror))
    assert found[1] < 0.02
    assert abs(hyps[0].score - hyps[1].score) < 0.02
    assert min(h.confidence for h in hyps) > 0.9


def test_wrong_frame_size_is_one_line_error(loc):
    f = RaycastCamera(room(), HALF_CAMERA.scaled(0.5)).render(np.array([2.0, 1.5, 0.0]))
    with pytest.raises(LocalizationError, match=r"frame is \(60, 80\).*\(120, 160\)"):
        loc.localize(f)
    with pytest.raises(LocalizationError, match="k must be"):
        loc.localize(RaycastCamera(room(), HALF_CAMERA).render(np.array([2.0, 1.5, 0.0])), k=0)


def test_empty_map_is_one_line_error():
    from navbench.worldmodel.grid import GridSpec, VoxelMap

    spec = GridSpec((0.0, 0.0, 0.0), (3.0, 3.0, 1.2), (12, 12, 4))
    empty = VoxelMap(spec, np.zeros(spec.shape, np.float32), np.zeros((*spec.shape, 3), np.float32), 0.5, {})
    with pytest.raises(LocalizationError, match="empty map") as e:
        Localizer.build(empty, HALF_CAMERA, CAMERA_HEIGHT, LocalizerConfig(lattice_step=0.5))
    assert "\n" not in str(e.value)
    full = VoxelMap(spec, np.ones(spec.shape, np.float32), np.zeros((*spec.shape, 3), np.float32), 0.5, {})
    with pytest.raises(LocalizationError, match="no free lattice point"):
        Localizer.build(full, HALF_CAMERA, CAMERA_HEIGHT, LocalizerConfig(lattice_step=0.5))


def test_align_planar_is_ours_gauss_newton_without_yaw_search(loc):
    from navbench.geometry import camera_pose
    from navbench.localize.localizer import align_planar
    from navbench.track.eq7 import prepare_reference
    from navbench.track.ours import align_gauss_newton

    cam = RaycastCamera(room(), HALF_CAMERA)
    start = np.array([2.0, 1.5, 0.3])
    ref = prepare_reference(cam.render(start), HALF_CAMERA, camera_pose(start))
    frame = cam.render(np.array([2.06, 1.46, 0.33]))
    a = align_planar(ref, frame, start, loc._gn, loc._idx, CAMERA_HEIGHT)
    b = align_gauss_newton(ref, frame, start, loc._gn, loc._idx, CAMERA_HEIGHT)
    np.testing.assert_array_equal(a, b)
    assert np.hypot(*(a[:2] - [2.06, 1.46])) < 0.01


def test_truncated_costs_against_direct_sums():
    rng = np.random.default_rng(1)
    pano = rng.random((4, 3, 32)).astype(np.float32)
    Q = rng.random((3, 7))
    shifts = rng.integers(0, 32, (4, 2))
    got = sig.truncated_costs(pano, Q, shifts, 0.3)
    for n in range(4):
        for j in range(2):
            idx = (shifts[n, j] + np.arange(-3, 4)) % 32
            want = np.minimum(np.abs(Q - pano[n][:, idx]), 0.3).sum()
            assert got[n, j] == pytest.approx(want, rel=1e-6)


def _candidates_numpy(best_s, best, points, k, cfg):
    """The non-maximum suppression as first written (numpy, one vector pass per kept point): the
    reference of the compiled :func:`navbench.localize.localizer._suppress`."""
    idx = np.flatnonzero(np.isfinite(best))
    idx = idx[np.argsort(best[idx], kind="stable")]
    heads = best_s[idx] * (2 * math.pi / cfg.bins)
    xy = points[idx]
    alive = np.ones(len(idx), bool)
    out, pos = [], 0
    while len(out) < k:
        while pos < len(idx) and not alive[pos]:
            pos += 1
        if pos >= len(idx):
            break
        out.append(np.array([xy[pos, 0], xy[pos, 1], float(wrap_angle(heads[pos]))]))
        near = (np.hypot(xy[:, 0] - xy[pos, 0], xy[:, 1] - xy[pos, 1]) < cfg.nms_radius) & \
            (np.abs(wrap_angle(heads - heads[pos])) < math.radians(cfg.nms_deg))
        alive &= ~near
        pos += 1
    return out


@pytest.mark.parametrize("seed", range(6))
def test_compiled_suppression_equals_the_numpy_loop_bit_for_bit(seed):
    # lattice points 0.125 m apart (distances exactly at the 0.5 m radius) and heading bins 1.875
    # degrees apart (differences exactly at the 30 degree limit), ties in cost, unusable points
    rng = np.random.default_rng(seed)
    cfg = LocalizerConfig()
    n = 600
    points = rng.integers(0, 24, size=(n, 2)) * 0.125
    best_s = rng.integers(0, cfg.bins, size=n)
    best = rng.integers(0, 40, size=n).astype(np.float64)
    best[rng.random(n) < 0.1] = np.inf
    for k in (1, 5, 24, n):
        want = _candidates_numpy(best_s, best, points, k, cfg)
        got = candidates(best_s, best, points, k, cfg)
        assert len(got) == len(want) and len(got) >= min(k, 1)
        for a, b in zip(got, want):
            assert np.array_equal(a, b)
    assert candidates(best_s, np.full(n, np.inf), points, 5, cfg) == []
