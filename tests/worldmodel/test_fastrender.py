"""The numba renderer against analytic geometry."""

from __future__ import annotations

import numpy as np

from navbench.geometry import HALF_CAMERA, Intrinsics, camera_pose
from navbench.worldmodel.fastrender import FastRenderer, render_map, render_map_T
from navbench.worldmodel.grid import grid_for_level, voxelize_level


def test_room_depth_matches_true_geometry(room):
    vm = voxelize_level(room, grid_for_level(room, shape=(100, 100, 20)))
    fr = FastRenderer(vm, HALF_CAMERA, step=0.02)
    f = fr.render((0.5, 1.5, 0.0))
    assert f.valid.all()
    # straight ahead: the inner face of the wall at x = 3.9
    np.testing.assert_allclose(f.depth[60, 80], 3.4, atol=2e-3)
    # top row sees the ceiling (0.7 m above the camera), bottom row the floor (0.5 m below)
    up = (0 - HALF_CAMERA.cy) / HALF_CAMERA.fy
    down = (119 - HALF_CAMERA.cy) / HALF_CAMERA.fy
    np.testing.assert_allclose(f.depth[0, 40], 0.7 / -up, atol=2e-3)
    np.testing.assert_allclose(f.depth[119, 40], 0.5 / down, atol=2e-3)
    # left edge pixel: the wall at y = 2.9 (camera x axis points to -y at heading 0)
    left = (0 - HALF_CAMERA.cx) / HALF_CAMERA.fx
    np.testing.assert_allclose(f.depth[60, 0], 1.4 / -left, atol=2e-3)
    assert np.all((f.rgb >= 0) & (f.rgb <= 1))


def test_no_crossing_and_inside_camera_are_invalid(room):
    vm = voxelize_level(room, grid_for_level(room, shape=(60, 60, 20)))
    tiny = Intrinsics(8, 6, 4.0, 4.0, 4.0, 3.0)
    f = render_map(vm, (0.5, 1.5, 0.0), tiny, max_range=0.2, step=0.02)
    assert not f.valid.any() and np.isinf(f.depth).all()
    g = render_map(vm, (2.9, 1.9, 0.0), tiny, step=0.02)  # inside the tall box
    assert not g.valid.any()


def test_render_T_equals_planar_render(room):
    vm = voxelize_level(room, grid_for_level(room, shape=(60, 60, 20)))
    pose = (1.2, 2.0, 0.7)
    a = render_map(vm, pose, HALF_CAMERA)
    b = render_map_T(vm, camera_pose(pose), HALF_CAMERA)
    np.testing.assert_array_equal(a.depth, b.depth)
    np.testing.assert_array_equal(a.rgb, b.rgb)


def test_empty_space_skipping_finds_the_same_crossing(room):
    """Skipping by the distance table == marching every sample, on a noisy map."""
    vm = voxelize_level(room, grid_for_level(room, shape=(80, 60, 20)))
    rng = np.random.default_rng(0)
    vm.occ[:] = vm.occ + rng.normal(0, 0.15, vm.occ.shape).astype(np.float32)  # speckle
    for parallel in (False, True):
        fast = FastRenderer(vm, HALF_CAMERA, step=0.05, parallel=parallel)
        march = FastRenderer(vm, HALF_CAMERA, step=0.05, parallel=parallel)
        march.dist = np.zeros_like(march.dist)  # evaluate f at every sample
        march.dist2 = np.zeros_like(march.dist2)
        assert fast.dist.max() > 1 and fast.dist2.max() > fast.dist.max()
        for pose in [(0.5, 0.5, 0.3), (2.0, 1.0, 2.0), (3.5, 2.6, -2.5)]:
            a, b = fast.render(pose), march.render(pose)
            np.testing.assert_array_equal(a.depth, b.depth)
            np.testing.assert_array_equal(a.rgb, b.rgb)
            np.testing.assert_array_equal(a.valid, b.valid)


def test_render_map_cache_sees_in_place_edits(room):
    vm = voxelize_level(room, grid_for_level(room, shape=(60, 60, 20)))
    tiny = Intrinsics(8, 6, 4.0, 4.0, 4.0, 3.0)
    before = render_map(vm, (0.5, 1.5, 0.0), tiny, step=0.02)
    vm.occ[:] = 0.0  # nothing left to hit
    after = render_map(vm, (0.5, 1.5, 0.0), tiny, step=0.02)
    assert before.valid.all() and not after.valid.any()


def test_voxelized_level_renders_close_to_the_true_camera(room):
    from navbench.sim.camera import RaycastCamera

    vm = voxelize_level(room, grid_for_level(room, shape=(100, 100, 20)))
    cam = RaycastCamera(room, HALF_CAMERA)
    for pose in [(0.6, 0.6, 0.4), (2.2, 2.5, -1.2), (3.4, 0.5, 2.5)]:
        true, ours = cam.render(pose), render_map(vm, pose, HALF_CAMERA)
        both = true.valid & ours.valid
        assert both.mean() > 0.99
        err = np.abs(true.depth[both] - ours.depth[both])
        assert np.median(err) < 0.005 and np.percentile(err, 95) < 0.05
        assert np.median(np.abs(true.rgb[both] - ours.rgb[both])) < 0.05


def test_parallel_and_serial_kernels_have_separate_caches():
    """Two dispatchers of one Python function would share numba's on-disk cache entry, and the
    parallel one would then load the serial machine code (this happened: half speed)."""
    from navbench.worldmodel import fastrender

    par, ser = fastrender.render_kernel, fastrender.render_kernel_serial
    assert par.py_func.__qualname__ != ser.py_func.__qualname__
    assert par._cache._cache_file._index_name != ser._cache._cache_file._index_name
    assert par.targetoptions.get("parallel") and not ser.targetoptions.get("parallel")
