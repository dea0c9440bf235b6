"""Ray-cast camera: depths against analytic geometry, colours against the level textures,
and the compiled renderer against the pure-numpy reference."""

import math

import numpy as np
import pytest

from navbench.geometry import HALF_CAMERA, PAPER_CAMERA, Intrinsics, world_points
from navbench.level import Level, Wall, distance_to_solids, prisms, surface_colour
from navbench.sim.camera import RaycastCamera, render_reference

from .fixtures import TEXTURES, box_before_wall, rooms, single_wall

CH = 0.5  # camera height
LH = 1.2  # level height
YC_HALF = (np.arange(HALF_CAMERA.height) - HALF_CAMERA.cy) / HALF_CAMERA.fy
XC_HALF = (np.arange(HALF_CAMERA.width) - HALF_CAMERA.cx) / HALF_CAMERA.fx


def _expected_with_wall(t_wall):
    """Depth per row (H,) of a column whose ray meets a full-height wall at z-depth ``t_wall``."""
    yc = YC_HALF
    z = CH - yc * t_wall
    with np.errstate(divide="ignore"):
        floor = CH / yc
        ceil = (CH - LH) / yc
    return np.where((z >= 0) & (z <= LH), t_wall, np.where(yc > 0, floor, ceil))


def test_facing_single_wall_depth_and_backprojection():
    level = single_wall()  # face at x = 2.95
    pose = (1.0, 5.0, 0.0)
    f = RaycastCamera(level, HALF_CAMERA).render(pose)
    assert f.valid.all()
    wall = np.abs(f.depth - 1.95) < 1e-3
    rows_wall = (CH - YC_HALF * 1.95 >= 0) & (CH - YC_HALF * 1.95 <= LH)
    assert np.array_equal(wall.any(axis=1), rows_wall)
    np.testing.assert_allclose(f.depth, np.tile(_expected_with_wall(1.95)[:, None], (1, 160)), atol=1e-5)
    P = world_points(pose, f.depth, HALF_CAMERA)
    np.testing.assert_allclose(P[rows_wall, :, 0], 2.95, atol=1e-5)
    floor = YC_HALF * 1.95 > CH
    np.testing.assert_allclose(P[floor, :, 2], 0.0, atol=1e-5)
    ceil = CH - YC_HALF * 1.95 > LH
    np.testing.assert_allclose(P[ceil, :, 2], LH, atol=1e-5)


def test_oblique_wall_per_column():
    level = single_wall()
    pose = (1.0, 5.0, 0.4)
    f = RaycastCamera(level, HALF_CAMERA).render(pose)
    c, s = math.cos(0.4), math.sin(0.4)
    dx = c + XC_HALF * s  # world x/y components of each column's ray (z-depth parameter)
    dy = s - XC_HALF * c
    checked = 0
    for i in range(160):
        t_wall = 1.95 / dx[i]
        if not 0.0 < 5.0 + t_wall * dy[i] < 10.0:  # the ray passes the wall's end
            assert np.isinf(f.depth[60, i]) and not f.valid[60, i]
            continue
        np.testing.assert_allclose(f.depth[:, i], _expected_with_wall(t_wall), atol=1e-5)
        checked += 1
    assert checked > 100


def test_corner_two_walls():
    walls = [Wall((3.0, 0.0), (3.0, 10.0), 0.1, 0), Wall((0.0, 8.0), (10.0, 8.0), 0.1, 2)]
    level = Level("corner", 10.0, 10.0, tuple(walls), (), TEXTURES, 1, 2)
    pose = (1.0, 6.0, math.pi / 4)
    f = RaycastCamera(level, HALF_CAMERA).render(pose)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    dx = c + XC_HALF * s
    dy = s - XC_HALF * c
    with np.errstate(divide="ignore"):
        tx = np.where(dx > 0, 1.95 / dx, np.inf)  # plane x = 2.95
        ty = np.where(dy > 0, 1.95 / dy, np.inf)  # plane y = 7.95
    t = np.minimum(tx, ty)
    assert np.isfinite(t).all() and (tx < ty).any() and (ty < tx).any()
    for i in range(160):
        np.testing.assert_allclose(f.depth[:, i], _expected_with_wall(t[i]), atol=1e-5)
    # the horizon row (y_c = 0) sees only walls; its points lie on the nearer plane
    P = world_points(pose, f.depth, HALF_CAMERA)[60]
    on_x = tx < ty
    np.testing.assert_allclose(P[on_x, 0], 2.95, atol=1e-5)
    np.testing.assert_allclose(P[~on_x, 1], 7.95, atol=1e-5)
    np.testing.assert_allclose(P[:, 2], CH, atol=1e-6)


@pytest.mark.parametrize("hb", [0.3, 0.45])
def test_low_box_in_front_of_wall(hb):
    level = box_before_wall(hb)  # box x in [2, 2.5], y in [4, 6]; wall face x = 4
    pose = (1.0, 5.0, 0.0)
    f = RaycastCamera(level, HALF_CAMERA).render(pose)
    col = f.depth[:, 80]  # x_c = 0: the ray runs along y = 5
    yc = YC_HALF
    expected = np.empty(len(yc))
    for j, y in enumerate(yc):
        cands = [_expected_with_wall(3.0)[j]]
        if 0 <= CH - y * 1.0 <= hb:
            cands.append(1.0)  # box front face
        if y > 0 and 1.0 <= (CH - hb) / y <= 1.5:
            cands.append((CH - hb) / y)  # box top
        expected[j] = min(cands)
    np.testing.assert_allclose(col, expected, atol=1e-5)
    kinds = {"face": np.isclose(expected, 1.0), "wall": np.isclose(expected, 3.0)}
    top = (yc > 0) & ((CH - hb) / np.where(yc > 0, yc, 1) >= 1) & ((CH - hb) / np.where(yc > 0, yc, 1) <= 1.5)
    assert kinds["face"].any() and kinds["wall"].any() and top.any()
    # the wall is visible right above the box: the rows just above the top see depth 3
    first_top = np.flatnonzero(top)[0]
    assert col[first_top - 1] == pytest.approx(3.0, abs=1e-5)
    # back-projected top pixels lie on the plane z = hb inside the box footprint
    P = world_points(pose, f.depth, HALF_CAMERA)[:, 80]
    np.testing.assert_allclose(P[top, 2], hb, atol=1e-5)
    assert np.all((P[top, 0] >= 2.0 - 1e-6) & (P[top, 0] <= 2.5 + 1e-6))


def test_colours_equal_surface_colour():
    level = box_before_wall(0.3)
    pose = (1.0, 5.0, 0.0)
    f = RaycastCamera(level, HALF_CAMERA).render(pose)
    P = world_points(pose, f.depth, HALF_CAMERA)
    pr = prisms(level)
    # wall pixel (row 60: horizon, column 20): u = distance along the face edge from its first vertex
    wall_poly = pr.polygon(0)
    k = next(k for k in range(4) if np.allclose(wall_poly[[k, (k + 1) % 4], 0], 4.0))
    a = wall_poly[k]
    i, j = 20, 60
    u = np.linalg.norm(P[j, i, :2] - a)
    np.testing.assert_allclose(f.rgb[j, i], surface_colour(TEXTURES[0], u, P[j, i, 2]), atol=1e-5)
    # floor pixel and ceiling pixel: u = x, v = y
    np.testing.assert_allclose(f.rgb[119, 3], surface_colour(TEXTURES[1], P[119, 3, 0], P[119, 3, 1]), atol=1e-5)
    np.testing.assert_allclose(f.rgb[0, 3], surface_colour(TEXTURES[2], P[0, 3, 0], P[0, 3, 1]), atol=1e-5)
    # box front face (edge x = 2 from (2, 6) to (2, 4) in CCW order) and top (u = x, v = y)
    j = int(np.flatnonzero(np.isclose(f.depth[:, 80], 1.0))[0])
    box = pr.polygon(1)
    k = next(k for k in range(4) if np.allclose(box[[k, (k + 1) % 4], 0], 2.0))
    u = np.linalg.norm(P[j, 80, :2] - box[k])
    np.testing.assert_allclose(f.rgb[j, 80], surface_colour(TEXTURES[3], u, P[j, 80, 2]), atol=1e-5)
    j = j - 1 if np.isclose(P[j - 1, 80, 2], 0.3, atol=1e-5) else j - 2
    assert P[j, 80, 2] == pytest.approx(0.3, abs=1e-5)
    np.testing.assert_allclose(f.rgb[j, 80], surface_colour(TEXTURES[3], P[j, 80, 0], P[j, 80, 1]), atol=1e-5)


def test_max_range_marks_invalid():
    level = single_wall()
    f = RaycastCamera(level, HALF_CAMERA, max_range=1.5).render((1.0, 5.0, 0.0))
    assert not f.valid.all() and f.valid.any()
    assert np.all(np.isinf(f.depth[~f.valid])) and np.all(f.rgb[~f.valid] == 0)
    assert np.all(f.depth[f.valid] <= 1.5)


def _free_poses(level, n, seed):
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        p = rng.uniform([0.2, 0.2], [level.width - 0.2, level.depth - 0.2])
        if distance_to_solids(level, p[None])[0] > 0.1:
            out.append((p[0], p[1], rng.uniform(-math.pi, math.pi)))
    return out


@pytest.mark.parametrize("intr", [HALF_CAMERA, Intrinsics(64, 48, 40.0, 40.0, 31.5, 23.7)])
def test_fast_equals_reference(intr):
    level = rooms()
    for parallel in (False, True):
        cam = RaycastCamera(level, intr, parallel=parallel)
        for pose in _free_poses(level, 6, seed=1):
            a = cam.render(pose)
            b = render_reference(level, intr, pose)
            assert a.rgb.dtype == np.float32 and a.depth.dtype == np.float32 and a.valid.dtype == bool
            assert np.array_equal(a.valid, b.valid)
            np.testing.assert_allclose(a.depth[a.valid], b.depth[b.valid], atol=1e-5, rtol=0)
            np.testing.assert_allclose(a.rgb, b.rgb, atol=1e-5, rtol=0)


def test_paper_camera_matches_reference_once():
    level = rooms()
    pose = (5.0, 3.0, 2.5)
    a = RaycastCamera(level, PAPER_CAMERA).render(pose)
    b = render_reference(level, PAPER_CAMERA, pose)
    assert a.valid.all()  # a closed house: every pixel sees a surface
    np.testing.assert_allclose(a.depth, b.depth, atol=1e-5, rtol=0)
    np.testing.assert_allclose(a.rgb, b.rgb, atol=1e-5, rtol=0)


def test_house_1_matches_reference():
    from pathlib import Path

    from navbench.levelio import load_level

    path = Path(__file__).resolve().parents[2] / "levels" / "house-1.json"
    if not path.is_file():
        pytest.skip("levels/house-1.json not generated yet")
    level = load_level(path)
    cam = RaycastCamera(level, HALF_CAMERA)
    for pose in _free_poses(level, 4, seed=2):
        a = cam.render(pose)
        b = render_reference(level, HALF_CAMERA, pose)
        assert np.array_equal(a.valid, b.valid)
        np.testing.assert_allclose(a.depth[a.valid], b.depth[b.valid], atol=1e-5, rtol=0)
        np.testing.assert_allclose(a.rgb, b.rgb, atol=1e-5, rtol=0)


# ------------------------------------------------------------------ only the pixels an estimator reads

@pytest.mark.parametrize("intr", [HALF_CAMERA, PAPER_CAMERA, Intrinsics(64, 48, 40.0, 40.0, 31.5, 23.7)])
def test_pixels_render_is_the_full_render_there_and_unseen_elsewhere(intr):
    """``render(pose, pixels)`` gives each listed pixel the full render's exact bits (serial and
    parallel full renders alike) and marks every other pixel unseen (NaN, not valid)."""
    from navbench.track.ours import gn_pixels

    level = rooms()
    H, W = intr.shape
    rng = np.random.default_rng(3)
    for pixels in (gn_pixels(H, W, 3000, 0),
                   rng.choice(H * W, size=37, replace=False),          # unsorted
                   np.array([0, W - 1, H * W - 1, (H - 1) * W, 5, 5]),  # corners, a duplicate
                   np.arange(H * W)):                                    # every pixel
        picked = np.zeros(H * W, bool)
        picked[pixels] = True
        picked = picked.reshape(H, W)
        for pose in _free_poses(level, 3, seed=4):
            for parallel in (False, True):
                full = RaycastCamera(level, intr, parallel=parallel).render(pose)
                part = RaycastCamera(level, intr, parallel=parallel).render(pose, pixels)
                assert np.array_equal(part.depth[picked], full.depth[picked])  # inf included
                assert np.array_equal(part.valid[picked], full.valid[picked])
                assert np.array_equal(part.rgb[picked], full.rgb[picked])
                assert np.isnan(part.depth[~picked]).all() and np.isnan(part.rgb[~picked]).all()
                assert not part.valid[~picked].any()


def test_pixel_columns_groups_by_column_and_refuses_out_of_range():
    from navbench.sim.camera import pixel_columns

    col_ptr, rows = pixel_columns([7, 0, 4, 5, 4], 2, 4)  # (row, col): (1,3) (0,0) (1,0) (1,1)
    assert col_ptr.tolist() == [0, 2, 3, 3, 4] and rows.tolist() == [0, 1, 1, 1]
    with pytest.raises(ValueError, match=r"\[0, 8\)"):
        pixel_columns([8], 2, 4)
    with pytest.raises(ValueError):
        pixel_columns([-1], 2, 4)
