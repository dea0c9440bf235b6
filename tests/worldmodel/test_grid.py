"""Grid convention, map files, slices and the voxelised true geometry."""

from __future__ import annotations

import numpy as np
import pytest

from navbench.errors import ArtifactError, ConfigError
from navbench.worldmodel.grid import (
    GridSpec, VoxelMap, cell_tolerance_scores, grid_for_level, load_map, occupancy_slice,
    save_map, slice_scores, trilinear, voxelize_level,
)


def _affine_map(spec, a, b0):
    """occ = a . p + b0 evaluated at cell centres (trilinear reproduces it exactly inside)."""
    X, Y, Z = np.meshgrid(spec.centres(0), spec.centres(1), spec.centres(2), indexing="ij")
    occ = a[0] * X + a[1] * Y + a[2] * Z + b0
    col = np.stack([X, Y, Z], -1) * 0.1
    return VoxelMap(spec, occ, col, 0.5)


def test_cell_centres_and_index():
    spec = GridSpec((0, 0, -1), (2, 4, 1), (4, 8, 2))
    np.testing.assert_allclose(spec.size, [0.5, 0.5, 1.0])
    np.testing.assert_allclose(spec.centres(0), [0.25, 0.75, 1.25, 1.75])
    np.testing.assert_allclose(spec.to_index([[0.25, 0.25, -0.5]]), [[0, 0, 0]])


def test_trilinear_exact_for_affine_and_clamped_outside():
    spec = GridSpec((0, 0, 0), (1, 1, 1), (5, 6, 7))
    vm = _affine_map(spec, np.array([0.3, -0.7, 1.1]), 0.2)
    rng = np.random.default_rng(0)
    lo = [spec.centres(a)[0] for a in range(3)]
    hi = [spec.centres(a)[-1] for a in range(3)]
    p = rng.uniform(lo, hi, (100, 3))  # inside the hull of the cell centres
    np.testing.assert_allclose(trilinear(vm.occ, spec, p), p @ [0.3, -0.7, 1.1] + 0.2, atol=1e-6)
    np.testing.assert_allclose(trilinear(vm.col, spec, p), p * 0.1, atol=1e-6)
    # outside: the border cell centre's value
    q = np.array([[-5.0, 0.5, 0.5]])
    qc = np.array([[spec.centres(0)[0], 0.5, 0.5]])
    np.testing.assert_allclose(trilinear(vm.occ, spec, q), trilinear(vm.occ, spec, qc))


def test_map_roundtrip_and_validation(tmp_path):
    spec = GridSpec((0, 0, 0), (1, 1, 1), (3, 4, 5))
    rng = np.random.default_rng(1)
    vm = VoxelMap(spec, rng.random((3, 4, 5)), rng.random((3, 4, 5, 3)), 0.5, {"step": 0.1})
    path = save_map(vm, tmp_path / "m.npz")
    back = load_map(path)
    assert back.spec == spec and back.tau == 0.5 and back.meta == {"step": 0.1}
    np.testing.assert_array_equal(back.occ, vm.occ)
    np.testing.assert_allclose(back.col, vm.col, atol=1e-3)  # float16 colour
    with pytest.raises(ArtifactError, match="no such map"):
        load_map(tmp_path / "missing.npz")
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(ArtifactError, match="unreadable"):
        load_map(tmp_path / "bad.npz")
    np.savez(tmp_path / "wrong.npz", occ=np.zeros((2, 2, 2), np.float32), col=vm.col,
             header=np.array('{"format_version": 1, "spec": {"lo": [0,0,0], "hi": [1,1,1], '
                             '"shape": [3,4,5]}, "tau": 0.5, "meta": {}}'))
    with pytest.raises(ArtifactError, match="occ has shape"):
        load_map(tmp_path / "wrong.npz")
    with pytest.raises(ArtifactError, match="shape"):
        VoxelMap(spec, np.zeros((3, 4, 5)), np.zeros((3, 4, 5)))


def test_grid_for_level_puts_floor_and_ceiling_between_centres(room):
    spec = grid_for_level(room)
    zs = spec.centres(2)
    assert spec.shape == (200, 200, 20)
    np.testing.assert_allclose(zs[1:3].mean(), 0.0, atol=1e-12)
    np.testing.assert_allclose(zs[17:19].mean(), room.height, atol=1e-12)
    assert spec.hi[0] >= room.width and spec.hi[1] >= room.depth
    np.testing.assert_allclose(spec.size[0], spec.size[1])


def test_voxelize_level_occupancy_and_slice(room):
    spec = grid_for_level(room, shape=(100, 100, 20))
    vm = voxelize_level(room, spec)
    # inside the tall box, in free space, below the floor
    f = trilinear(vm.occ, spec, np.array([[2.9, 1.9, 0.5], [2.0, 2.0, 0.5], [2.0, 2.0, -0.1]]))
    assert f[0] > vm.tau and f[1] < vm.tau and f[2] > vm.tau
    # the crossing lies on the true floor: f(z=0) == tau
    np.testing.assert_allclose(trilinear(vm.occ, spec, np.array([[2.0, 2.0, 0.0]])), vm.tau, atol=1e-6)
    band, xs, ys = occupancy_slice(vm, "band")
    high, _, _ = occupancy_slice(vm, "slice", height=0.5)
    ix, iy = np.searchsorted(xs, 1.25), np.searchsorted(ys, 1.0)
    assert band[ix, iy] and not high[ix, iy]  # the low box counts in the band only
    prec, rec = slice_scores(vm, room)
    assert prec >= 0.99 and rec >= 0.99
    with pytest.raises(ConfigError):
        occupancy_slice(vm, "cube")


def test_cell_tolerance_scores_hand_made():
    true = np.zeros((6, 6), bool)
    true[2, 2] = True
    pred = np.zeros((6, 6), bool)
    pred[3, 3] = True  # one cell off: within tolerance
    pred[5, 0] = True  # far: a false positive
    prec, rec = cell_tolerance_scores(pred, true, 1)
    assert prec == 0.5 and rec == 1.0
    assert cell_tolerance_scores(pred, true, 0) == (0.0, 0.0)


@pytest.mark.parametrize("seed", [0, 1])
def test_compiled_slice_values_equal_the_numpy_reference_bit_for_bit(seed, room):
    """occupancy_slice thresholds _slice_max, the compiled max over heights of trilinear f: the
    same floats as slice_values_reference (numpy trilinear) on a random grid (values on both
    sides of tau, heights below the first and above the last cell centre: clipped) and on a
    voxelized level, for the band and the slice."""
    from navbench.worldmodel._slice import _slice_max
    from navbench.worldmodel.grid import band_heights, slice_values_reference
    from navbench.worldmodel.gridspec import GridSpec

    rng = np.random.default_rng(seed)
    spec = GridSpec((-0.3, 0.2, 0.0), (2.1, 3.0, 1.2), (17, 23, 9))
    occ = np.where(rng.random(spec.shape) < 0.03, 0.9, 0.1) + 0.05 * rng.random(spec.shape)  # sparse obstacles
    rand = VoxelMap(spec, occ.astype(np.float32), np.zeros(spec.shape + (3,), np.float32), 0.5)
    for vmap in (rand, voxelize_level(room)):
        for mode, lo, hi, h in (("band", 0.05, 1.0, 0.5), ("band", -0.2, 1.5, 0.5), ("slice", 0.0, 0.0, 0.5),
                                ("slice", 0.0, 0.0, 1.4)):
            heights = band_heights(vmap.spec, mode, lo, hi, h)
            ref = slice_values_reference(vmap, heights)
            got = _slice_max(vmap.occ, np.asarray(vmap.spec.lo, np.float64), vmap.spec.size,
                             vmap.spec.centres(0), vmap.spec.centres(1), np.asarray(heights, np.float64))
            assert np.array_equal(got.view(np.uint64), ref.view(np.uint64))
            occ2d, xs, ys = occupancy_slice(vmap, mode, lo, hi, h)
            assert np.array_equal(occ2d, ref > vmap.tau)
            if (lo, hi, h) in ((0.05, 1.0, 0.5), (0.0, 0.0, 0.5)):  # the body band and the camera slice
                assert 0 < occ2d.mean() < 1  # obstacles and free space (the others may hit floor or ceiling)
