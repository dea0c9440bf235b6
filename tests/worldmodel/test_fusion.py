"""Online fusion (issue 15 section 3): analytic geometry, the numpy reference, a level walk."""

from __future__ import annotations

import numpy as np
import pytest

from navbench.errors import ConfigError
from navbench.geometry import HALF_CAMERA, Frame
from navbench.worldmodel.fastrender import FastRenderer, skip_distance, SLAB
from navbench.worldmodel.fusion import (
    FusedMap,
    FusionConfig,
    fuse_frame_reference,
    seen_slice,
    slice_heights,
)
from navbench.worldmodel.fusion_render import FusedRenderer, block_skip_tables
from navbench.worldmodel.grid import cell_tolerance_scores, grid_for_level, occupancy_slice
from navbench.worldmodel.gridspec import GridSpec

# a 4 m x 4 m x 1.2 m box of 0.1 m cells; the camera at (0.55, 2.05) looks along +x at a wall
# (a plane perpendicular to the optical axis) at x = 2.33: z-depth 1.78 m at every pixel
SPEC = GridSpec((0.0, 0.0, 0.0), (4.0, 4.0, 1.2), (40, 40, 12))
POSE = np.array([0.55, 2.05, 0.0])
WALL_X = 2.33
COLOUR = np.array([0.25, 0.5, 0.75], np.float32)


def wall_frame(intr=HALF_CAMERA) -> Frame:
    H, W = intr.shape
    depth = np.full((H, W), WALL_X - POSE[0], np.float32)
    rgb = np.broadcast_to(COLOUR, (H, W, 3)).copy()
    return Frame(rgb, depth, np.ones((H, W), bool))


def in_view(spec, pose, intr=HALF_CAMERA):
    """Cells whose centre projects into the image (independent of the kernel: rotation matrix)."""
    from navbench.geometry import camera_pose

    X, Y, Z = np.meshgrid(spec.centres(0), spec.centres(1), spec.centres(2), indexing="ij")
    T = camera_pose(pose, 0.5)
    p = np.stack([X, Y, Z], -1) - T[:3, 3]
    pc = p @ T[:3, :3]  # world -> camera: R^T p
    z = pc[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.rint(intr.fx * pc[..., 0] / z + intr.cx)
        v = np.rint(intr.fy * pc[..., 1] / z + intr.cy)
    return (z > 0) & (u >= 0) & (u < intr.width) & (v >= 0) & (v < intr.height), X


def test_wall_at_known_distance_occupied_there_free_before():
    fused = FusedMap.empty(SPEC)
    fused.fuse(wall_frame(), POSE, HALF_CAMERA)
    trunc = 0.1  # the grid's largest cell size
    view, X = in_view(SPEC, POSE)
    s = WALL_X - X  # exact signed distance to the wall (positive in front)
    seen = fused.seen
    # seen: exactly the cells in view up to trunc behind the wall
    assert np.array_equal(seen, view & (s >= -trunc))
    occ = fused.vmap.occ
    # occupied exactly at the wall (centres behind it within trunc: the shell x = 2.35),
    # free before it, on the ramp in between
    assert np.array_equal(seen & (occ > 0.5), view & (s < 0) & (s >= -trunc))
    assert set(np.unique(X[seen & (occ > 0.5)]).round(3)) == {2.35}
    assert np.all(occ[view & (s > trunc)] == 0.0)
    ramp = view & (np.abs(s) <= trunc)
    np.testing.assert_allclose(occ[ramp], 0.5 - 0.5 * s[ramp] / trunc, atol=1e-6)
    assert np.all(occ[~seen] == np.float32(0.5 - 2.0 ** -20))  # unseen: neutral, never occupied
    # colour at the hit: the cells within the colour band (2 trunc) take the wall's colour,
    # behind the surface too (beyond trunc they stay unseen for the occupancy)
    band = view & (np.abs(s) <= 2 * trunc)
    assert (band & ~seen).sum() > 0
    assert np.all(fused.vmap.col[band] == COLOUR) and np.all(fused.col_weight[band] == 1)
    assert np.all(fused.vmap.col[np.abs(s) > 2 * trunc] == 0)
    # just outside the image: a provisional colour (weight 0) where the stencil may reach
    margin = ~view & (np.abs(s) <= 2 * trunc) & np.any(fused.vmap.col != 0, axis=-1)
    assert margin.sum() > 0 and np.all(fused.col_weight[margin] == 0)
    assert np.all(fused.vmap.col[margin] == COLOUR) and not fused.seen[margin].any()


def test_wall_slice_and_rendered_depth_are_exact():
    fused = FusedMap.empty(SPEC)
    fused.fuse(wall_frame(), POSE, HALF_CAMERA)
    occ2d, xs, ys = occupancy_slice(fused.vmap, "slice")
    # f is constant in y and z: the slice at the camera height is the cell centres' value
    assert set(xs[np.nonzero(occ2d)[0]].round(3)) == {2.35}
    view2d = in_view(SPEC, POSE)[0][:, :, 6]
    assert np.array_equal(occ2d, view2d & np.isclose(xs, 2.35)[:, None])
    # rendering: f is linear in x between the centres 2.25 (0.1) and 2.35 (0.6) and no sample
    # pair straddles a centre, so eq. 1's interpolated crossing is the wall itself
    r = FastRenderer(fused.vmap, HALF_CAMERA).render(POSE)
    assert r.valid[60, 80]
    assert abs(float(r.depth[60, 80]) - (WALL_X - POSE[0])) < 1e-5
    np.testing.assert_allclose(r.rgb[60, 80], COLOUR, atol=1e-6)


def test_known_and_occupied_planning_cells():
    fused = FusedMap.empty(SPEC)
    fused.fuse(wall_frame(), POSE, HALF_CAMERA)
    known, occupied = seen_slice(fused)
    occ2d, _, _ = occupancy_slice(fused.vmap)
    assert known.shape == occupied.shape == occ2d.shape and np.array_equal(occupied, occ2d)
    assert np.all(known[occupied])
    ks = slice_heights(SPEC)
    full = fused.seen[:, :, ks].all(axis=2)
    assert np.array_equal(known, full | occupied | fused.visited)
    # the cells under the agent (radius 0.1 m) are visited, hence known
    i, j = int(POSE[0] / 0.1), int(POSE[1] / 0.1)
    assert fused.visited[i, j] and known[i, j]
    # behind the wall nothing is known; before it the view cone is known free
    assert not known[30:].any()
    assert known[15, 20] and not occupied[15, 20]
    with pytest.raises(ConfigError, match="min_seen"):
        seen_slice(fused, min_seen=0.0)


def walk(level, steps, seed=0, noise="tracking"):
    from navbench.sim.camera import RaycastCamera
    from navbench.track.study import record_trajectories

    traj = record_trajectories(level, 1, steps, noise=noise, seed=seed)[0]
    cam = RaycastCamera(level, HALF_CAMERA)
    return traj, [(p, cam.render(p)) for p in traj.true_poses]


def test_kernel_equals_numpy_reference_bit_for_bit(room):
    spec = grid_for_level(room, (40, 30, 16))
    a, b = FusedMap.empty(spec), FusedMap.empty(spec)
    _, frames = walk(room, 12)
    for pose, frame in frames:
        na = a.fuse(frame, pose, HALF_CAMERA)
        nb = fuse_frame_reference(b, frame, pose, HALF_CAMERA)
        assert na == nb > 0
    for name in ("sdf", "weight", "col_weight", "visited"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert np.array_equal(a.vmap.occ, b.vmap.occ) and np.array_equal(a.vmap.col, b.vmap.col)


@pytest.fixture(scope="module")
def house_walk():
    from pathlib import Path

    from navbench.levelio import load_level

    level = load_level(Path(__file__).resolve().parents[2] / "levels" / "house-1.json")
    _, frames = walk(level, 200, seed=0)
    return level, frames


def test_exact_frames_reproduce_the_level_slice(house_walk):
    """Issue 15 section 7: fusing exact frames along a walk gives the level's occupancy slice on
    the seen part (precision and recall >= 0.95, one-cell tolerance as slice_scores)."""
    from navbench.level import occupancy_raster

    level, frames = house_walk
    spec = grid_for_level(level)
    fused = FusedMap.empty(spec)
    for pose, frame in frames:
        fused.fuse(frame, pose, HALF_CAMERA)
    known, occupied = seen_slice(fused)
    true, _, _ = occupancy_raster(level, float(spec.size[0]), z_low=0.05, z_high=1.0)
    nx, ny = min(true.shape[0], known.shape[0]), min(true.shape[1], known.shape[1])
    k, o, t = known[:nx, :ny], occupied[:nx, :ny], true[:nx, :ny]
    assert k.mean() > 0.15  # the walk saw a good part of the house
    precision, recall = cell_tolerance_scores(o & k, t & k)
    assert precision >= 0.95 and recall >= 0.95, (precision, recall)


def test_column_slice_equals_occupancy_slice_on_a_fused_map(house_walk):
    from navbench.worldmodel.fusion import column_slice

    level, frames = house_walk
    fused = FusedMap.empty(grid_for_level(level))
    for pose, frame in frames[:80]:
        fused.fuse(frame, pose, HALF_CAMERA)
    for mode in ("band", "slice"):
        occ2d, _, _ = occupancy_slice(fused.vmap, mode)
        assert occ2d.any() and np.array_equal(column_slice(fused.vmap, mode), occ2d), mode
    assert np.array_equal(seen_slice(fused)[1], occupancy_slice(fused.vmap)[0])


def test_fusion_is_deterministic(house_walk):
    level, frames = house_walk
    spec = grid_for_level(level)
    maps = [FusedMap.empty(spec) for _ in range(2)]
    for m in maps:
        for pose, frame in frames[:60]:
            m.fuse(frame, pose, HALF_CAMERA)
    a, b = maps
    assert a.vmap.content_hash() == b.vmap.content_hash()
    assert np.array_equal(a.sdf, b.sdf) and np.array_equal(a.weight, b.weight)


def test_block_skip_tables_are_lower_bounds_and_render_identically(house_walk):
    level, frames = house_walk
    fused = FusedMap.empty(grid_for_level(level))
    for pose, frame in frames[:40]:
        fused.fuse(frame, pose, HALF_CAMERA)
    occ = fused.vmap.occ
    d, d2 = block_skip_tables(occ, 0.5)
    e, e2 = skip_distance(occ, 0.5), skip_distance(occ, 0.5, slab=SLAB)
    assert d.shape == e.shape and np.all(d <= e) and np.all(d2 <= e2) and d.max() > 1
    exact = FastRenderer(fused.vmap, HALF_CAMERA, parallel=False)
    online = FusedRenderer(fused, HALF_CAMERA, parallel=False)
    for pose, _ in frames[:40:8]:
        A, B = exact.render(pose), online.render(pose)
        assert np.array_equal(A.depth, B.depth) and np.array_equal(A.rgb, B.rgb)


def test_incremental_skip_tables_equal_the_whole_rebuild_frame_by_frame(house_walk):
    """FusedRenderer updates its block tables around what each fusion wrote (FusedMap.dirty):
    after every frame they equal block_skip_tables of the whole map, and the dirty box holds
    every cell whose occupancy changed."""
    level, frames = house_walk
    fused = FusedMap.empty(grid_for_level(level))
    r = FusedRenderer(fused, HALF_CAMERA, parallel=False)
    r.renderer()
    skip = r._skip
    for n, (pose, frame) in enumerate(frames[:60]):
        before = fused.vmap.occ.copy()
        fused.fuse(frame, pose, HALF_CAMERA)
        i0, i1, j0, j1, k0, k1 = fused.dirty
        changed = np.argwhere(before != fused.vmap.occ)
        if len(changed):
            assert (changed.min(axis=0) >= [i0, j0, k0]).all() and (changed.max(axis=0) <= [i1, j1, k1]).all()
        fr = r.renderer()
        assert r._skip is skip  # the incremental path, not a rebuild
        d, d2 = block_skip_tables(fused.vmap.occ, fused.vmap.tau)
        assert np.array_equal(fr.dist, d) and np.array_equal(fr.dist2, d2), f"frame {n}"
    fused.fuse(frames[60][1], frames[60][0], HALF_CAMERA)
    fused.fuse(frames[61][1], frames[61][0], HALF_CAMERA)  # two fusions since: a whole rebuild
    fr = r.renderer()
    assert r._skip is not skip and np.array_equal(fr.dist, block_skip_tables(fused.vmap.occ, fused.vmap.tau)[0])
    fused.clear()
    assert fused.dirty is None and not r.render(frames[0][0]).valid.any()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_block_flags_of_a_region_equal_the_whole_scan(seed):
    from navbench.worldmodel.fusion_render import _block_flags, _block_flags_region

    rng = np.random.default_rng(seed)
    shape = (23, 18, 9)  # not multiples of the block: partial blocks at the far faces
    occ = np.where(rng.random(shape) < 0.02, 0.9, 0.1).astype(np.float32)
    for b in (2, 4):
        whole = _block_flags(occ, 0.5, b)
        for _ in range(20):
            lo = np.array([rng.integers(0, n) for n in whole.shape], np.int64)
            hi = np.array([rng.integers(l, n) for l, n in zip(lo, whole.shape)], np.int64)
            flags = rng.random(whole.shape) < 0.5  # garbage inside the region, kept outside
            outside = flags.copy()
            _block_flags_region(occ, 0.5, b, flags, lo, hi)
            inside = np.zeros(whole.shape, bool)
            inside[lo[0]:hi[0] + 1, lo[1]:hi[1] + 1, lo[2]:hi[2] + 1] = True
            assert np.array_equal(flags[inside], whole[inside]) and np.array_equal(flags[~inside], outside[~inside])


def test_fused_renderer_follows_the_map_and_clear_empties_it(house_walk):
    level, frames = house_walk
    fused = FusedMap.empty(grid_for_level(level))
    r = FusedRenderer(fused, HALF_CAMERA, parallel=False)
    pose, frame = frames[0]
    assert not r.render(pose).valid.any()  # empty map: nothing to see
    fused.fuse(frame, pose, HALF_CAMERA)
    seen = r.render(pose)
    assert seen.valid.mean() > 0.9
    both = seen.valid & frame.valid
    assert np.median(np.abs(seen.depth[both] - frame.depth[both])) < 0.01
    fused.clear()
    assert not fused.seen.any() and not fused.visited.any() and fused.frames == 0
    assert not r.render(pose).valid.any()


def test_bad_fusion_settings_are_refused():
    for kw in ({"trunc": 0.0}, {"colour_band": -1.0}, {"max_weight": 0.5},
               {"max_depth": float("nan")}, {"body_radius": -0.1}):
        with pytest.raises(ConfigError):
            FusionConfig(**kw)
    fused = FusedMap.empty(SPEC)
    with pytest.raises(ConfigError, match="intrinsics"):
        fused.fuse(wall_frame(HALF_CAMERA.scaled(0.5)), POSE, HALF_CAMERA)


def test_distance_scale_fast_equals_reference_and_is_exact_on_planes(house_walk):
    from navbench.geometry import pixel_rays
    from navbench.worldmodel.fusion import distance_scale, distance_scale_reference

    _, frames = house_walk
    for _, frame in frames[:30:10]:
        g = distance_scale(frame.depth, frame.valid, HALF_CAMERA)
        np.testing.assert_allclose(g, distance_scale_reference(frame.depth, frame.valid, HALF_CAMERA),
                                   rtol=1e-9, atol=1e-12)
        assert np.all((g >= 0.3) & (g <= np.linalg.norm(pixel_rays(HALF_CAMERA), axis=-1) + 1e-12))
    # a plane perpendicular to the optical axis: |ray| cos = 1, the z-depth difference is exact
    g = distance_scale(wall_frame().depth, wall_frame().valid, HALF_CAMERA)
    np.testing.assert_allclose(g, 1.0, atol=1e-12)
    # the floor seen from 0.5 m: the scale turns z-depth differences into heights above it
    rays = pixel_rays(HALF_CAMERA)
    H, W = HALF_CAMERA.shape
    yc = rays[..., 1]
    depth = np.where(yc > 0, 0.5 / np.where(yc > 0, yc, 1), np.inf).astype(np.float32)
    valid = (yc > 0) & (depth < 20)
    g = distance_scale(depth, valid, HALF_CAMERA)
    # a point 1 cm above the floor on the ray of pixel (v, u): z-depth difference 0.01 / yc
    inner = valid.copy()
    inner[:, [0, -1]] = False
    inner[[0, -1], :] = False
    inner[:-1] &= valid[1:]
    v, u = np.nonzero(inner)
    want = np.clip(yc, 0.3, np.linalg.norm(rays, axis=-1))  # height difference = yc * z-depth difference
    np.testing.assert_allclose(g[v, u], want[v, u], rtol=1e-4)
    assert (want[v, u] > 0.3).mean() > 0.3


def test_seen_slice_single_height_reads_the_two_cells_around_it():
    fused = FusedMap.empty(SPEC)
    fused.fuse(wall_frame(), POSE, HALF_CAMERA)
    # cell centres 0.05, 0.15, ...: the camera height 0.5 lies between the centres 0.45 and 0.55
    assert list(slice_heights(SPEC, "slice", height=0.5)) == [4, 5]
    known, occupied = seen_slice(fused, "slice")
    occ2d, _, _ = occupancy_slice(fused.vmap, "slice")
    assert np.array_equal(occupied, occ2d)
    assert np.array_equal(known, fused.seen[:, :, [4, 5]].all(axis=2) | occupied | fused.visited)
    # the single height sees more of the floor-level blind zone than the body band
    assert known.sum() > seen_slice(fused)[0].sum()
    with pytest.raises(ConfigError, match="mode"):
        seen_slice(fused, "cube")
