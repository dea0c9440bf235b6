"""The bank's compiled panoramas (:mod:`navbench.localize.bankrender`) against the reference
loop of :func:`~navbench.localize.signature.panorama`, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from navbench.localize import signature as sig
from navbench.localize.bankrender import panoramas
from navbench.localize.localizer import LocalizerConfig, build_bank
from navbench.nav.imagenav import SeenMap
from navbench.worldmodel.fastrender import FastRenderer
from navbench.worldmodel.grid import voxelize_level
from tests.localize.worlds import ExactWorld, room

CFG = LocalizerConfig(lattice_step=0.25)


@pytest.fixture(scope="module")
def full():
    return voxelize_level(room())


def _setup(cfg=CFG):
    ycs = sig.elevations(cfg.rows, cfg.row_top, cfg.row_step)
    quad = sig.quadrant_intrinsics(cfg.bins, cfg.rows, cfg.row_top, cfg.row_step)
    return ycs, quad


def _reference(render, points, ycs, quad, kind, cfg=CFG):
    out = np.empty((len(points), 2 * cfg.rows, cfg.bins), np.float32)
    for i, xy in enumerate(points):
        out[i] = sig.panorama(render.render, xy, cfg.bins, ycs, cfg.grey_weight, quad, kind, cfg.feature_range)
    return out


def _seen(full):
    occ, xs, ys = full.occupancy_slice("band")
    known = np.zeros(occ.shape, bool)
    known[: occ.shape[0] // 2] = True  # the half x < 2 m: rays into the other half see nothing
    return SeenMap(full, known)


@pytest.mark.parametrize("kind", ["range", "inverse"])
@pytest.mark.parametrize("which", ["true", "seen"])
def test_compiled_panoramas_equal_the_reference_loop_bit_for_bit(full, kind, which):
    model = full if which == "true" else _seen(full)
    occ, xs, ys = model.occupancy_slice("band")
    points = sig.lattice_points(occ, xs, ys, 0.25, CFG.clearance)
    points = np.vstack([points, points[:5] + [0.0371, -0.0123]])  # off-lattice positions too
    ycs, quad = _setup()
    render = model.renderer(quad, 0.5)
    assert isinstance(render, FastRenderer) and len(points) > 20
    ref = _reference(render, points, ycs, quad, kind)
    fast = panoramas(render, points, CFG.bins, ycs, CFG.grey_weight, quad, kind, CFG.feature_range)
    assert fast.dtype == np.float32 and fast.shape == ref.shape
    np.testing.assert_array_equal(fast.view(np.uint32), ref.view(np.uint32))
    if which == "seen":  # the unseen half renders nothing: some columns are "no hit" (range 1)
        assert (fast[:, 0] == 1.0).any() and (fast[:, 0] < 1.0).any()


def test_other_renderers_take_the_reference_loop():
    world = ExactWorld(room())  # the level's own ray caster: not a FastRenderer
    ycs, quad = _setup()
    render = world.renderer(quad, 0.5)
    points = np.array([[1.0, 1.5], [2.2, 0.8], [3.4, 1.2]])
    ref = _reference(render, points, ycs, quad, "range")
    fast = panoramas(render, points, CFG.bins, ycs, CFG.grey_weight, quad, "range", CFG.feature_range)
    np.testing.assert_array_equal(fast, ref)
    assert panoramas(render, np.zeros((0, 2)), CFG.bins, ycs, CFG.grey_weight, quad).shape == (0, 2 * CFG.rows, CFG.bins)


def test_build_bank_uses_the_compiled_pass_and_equals_the_loop(full):
    bank = build_bank(full, 0.5, CFG)
    ycs, quad = _setup()
    ref = _reference(full.renderer(quad, 0.5), bank.points, ycs, quad, CFG.depth_feature)
    np.testing.assert_array_equal(bank.pano.view(np.uint32), ref.view(np.uint32))


def test_seen_map_renderers_share_exact_skip_tables(full):
    seen = _seen(full)
    ycs, quad = _setup()
    a, b = seen.renderer(quad, 0.5), seen.renderer(quad, 0.5)
    assert a.dist is b.dist and a.dist2 is b.dist2  # built once per view
    exact = seen.vmap.renderer(quad, 0.5, 20.0)  # the map's own renderer: tables of its own
    np.testing.assert_array_equal(a.dist, exact.dist)
    np.testing.assert_array_equal(a.dist2, exact.dist2)
    pose = np.array([1.0, 1.5, 0.3])
    fa, fe = a.render(pose), exact.render(pose)
    np.testing.assert_array_equal(fa.depth, fe.depth)
    np.testing.assert_array_equal(fa.rgb, fe.rgb)
