"""The camera's texture modes (issue 36, "textures as tables"): texel tables exact at texel
centres and within their stated bound elsewhere, whole frames against the procedural ones on a
committed level (depth identical), render_reference alike, and the setting opt-in: a bad value
is one line, and its default leaves every key as it was."""

import math
from pathlib import Path

import numpy as np
import pytest

from navbench.errors import ConfigError, NavbenchError
from navbench.geometry import HALF_CAMERA, PAPER_CAMERA, Intrinsics
from navbench.level import prisms, surface_colour
from navbench.sim.camera import RaycastCamera, render_reference
from navbench.sim.texels import (MAX_TABLE_BYTES, TABLE_TOLERANCE, build_texel_tables, colour_bound,
                                 pattern_curvature, surface_pattern, texel_tables)

from .fixtures import rooms

ROOT = Path(__file__).resolve().parents[2]


def _house():
    from navbench.levelio import load_level

    path = ROOT / "levels" / "house-1.json"
    if not path.is_file():
        pytest.skip("levels/house-1.json not generated yet")
    return load_level(path)


def _poses(level, n, seed):
    from navbench.sim.bench import bench_poses

    return bench_poses(level, n, seed)


def _centres(tb, s, rng, n):
    """``n`` random texel centres ``(u, v)`` of surface ``s`` (inner texels)."""
    _, nu, nv = tb.shape[s]
    i = rng.integers(0, nu - 1, n)
    j = rng.integers(0, nv - 1, n)
    return tb.origin[s, 0] + i * tb.h, tb.origin[s, 1] + j * tb.h


def _surfaces(tb):
    return [s for s in range(len(tb.texture)) if tb.shape[s, 1] > 1 and tb.shape[s, 2] > 1]


@pytest.mark.parametrize("make", [rooms, _house])
def test_table_is_the_procedural_pattern_exactly_at_texel_centres(make):
    level = make()
    tb = texel_tables(level)
    rng = np.random.default_rng(0)
    surfaces = _surfaces(tb)
    assert len(surfaces) > 2 + len(prisms(level))  # floor, ceiling, low tops, side faces
    for s in surfaces:
        u, v = _centres(tb, s, rng, 50)
        tex = np.full(len(u), tb.texture[s])
        got = surface_pattern(level, "table", np.full(len(u), s), tex, u, v)
        want = surface_pattern(level, "procedural", None, tex, u, v)
        assert np.array_equal(got, want), s


@pytest.mark.parametrize("make", [rooms, _house])
def test_table_is_within_its_bound_between_texel_centres(make):
    """Off the centres: |table - procedural| of P <= h^2/8 (2 pi)^2 sum_k w_k (fu_k^2 + fv_k^2) per
    texture, and the colour bound (times amp) within the tolerance the texel was chosen by."""
    level = make()
    tb = texel_tables(level)
    assert tb.bound <= TABLE_TOLERANCE and tb.bound == colour_bound(level, tb.h)
    assert colour_bound(level, 2 * tb.h) > TABLE_TOLERANCE  # the largest power of two that fits
    p_bound = tb.h ** 2 / 8 * (2 * math.pi) ** 2 * pattern_curvature(level)
    rng = np.random.default_rng(1)
    worst = 0.0
    for s in _surfaces(tb):
        _, nu, nv = tb.shape[s]
        u = tb.origin[s, 0] + rng.uniform(0, nu - 1, 200) * tb.h
        v = tb.origin[s, 1] + rng.uniform(0, nv - 1, 200) * tb.h
        tex = np.full(len(u), tb.texture[s])
        err = np.abs(surface_pattern(level, "table", np.full(len(u), s), tex, u, v)
                     - surface_pattern(level, "procedural", None, tex, u, v))
        assert err.max() <= p_bound[tb.texture[s]] * (1 + 1e-9) + 1e-15, s
        worst = max(worst, float(err.max() / p_bound[tb.texture[s]]))
    assert worst > 0.05  # the points did fall between centres: the bound is not vacuous here


def test_the_compiled_pattern_is_the_level_s_texture():
    level = rooms()
    rng = np.random.default_rng(2)
    u, v = rng.uniform(-3, 12, 500), rng.uniform(-1, 8, 500)
    for t, tex in enumerate(level.textures):
        p = surface_pattern(level, "procedural", None, np.full(500, t), u, v)
        col = np.clip(np.asarray(tex.base) + np.asarray(tex.amp) * p[:, None], 0, 1)
        np.testing.assert_allclose(col, surface_colour(tex, u, v), atol=1e-12, rtol=0)
        poly = surface_pattern(level, "polynomial", None, np.full(500, t), u, v)
        np.testing.assert_allclose(poly, p, atol=1.7 * math.pi ** 19 / math.factorial(19), rtol=0)


def test_a_hit_outside_its_table_is_procedural():
    level = rooms()
    u, v = np.array([-7.3, 40.0, 3.0]), np.array([2.0, 3.0, -9.5])  # the floor beyond the box
    tex = np.full(3, level.floor_texture)
    assert np.array_equal(surface_pattern(level, "table", np.zeros(3, np.int64), tex, u, v),
                          surface_pattern(level, "procedural", None, tex, u, v))


def test_whole_frames_table_vs_procedural_on_a_committed_level():
    """house-1, paper camera: colour within the tables' bound (mean far below), depth and
    validity bit for bit; the polynomial sine within one float32 step."""
    level = _house()
    cams = {m: RaycastCamera(level, PAPER_CAMERA, texture=m) for m in ("procedural", "table", "polynomial")}
    bound = texel_tables(level).bound
    means = []
    for pose in _poses(level, 4, seed=5):
        f = {m: c.render(pose) for m, c in cams.items()}
        for m in ("table", "polynomial"):
            assert np.array_equal(f[m].depth, f["procedural"].depth)
            assert np.array_equal(f[m].valid, f["procedural"].valid)
        d = np.abs(f["table"].rgb.astype(np.float64) - f["procedural"].rgb)
        assert d.max() <= bound + 1e-7  # + float32 rounding of the stored colour
        means.append(d.mean())
        assert np.abs(f["polynomial"].rgb.astype(np.float64) - f["procedural"].rgb).max() <= 1.2e-7
    assert 0 < np.mean(means) < bound / 2


@pytest.mark.parametrize("texture", ["table", "polynomial"])
def test_reference_renderer_follows_the_mode(texture):
    level = rooms()
    intr = Intrinsics(64, 48, 40.0, 40.0, 31.5, 23.7)
    for parallel in (False, True):
        cam = RaycastCamera(level, intr, parallel=parallel, texture=texture)
        for pose in [(1.0, 1.0, 0.3), (5.0, 3.0, 2.5), (6.0, 2.5, -1.9)]:
            a = cam.render(pose)
            b = render_reference(level, intr, pose, texture=texture)
            assert np.array_equal(a.valid, b.valid)
            np.testing.assert_allclose(a.rgb, b.rgb, atol=1e-6, rtol=0)
    a = RaycastCamera(level, HALF_CAMERA, texture=texture).render((5.0, 3.0, 2.5))
    b = render_reference(level, HALF_CAMERA, (5.0, 3.0, 2.5), texture=texture)
    np.testing.assert_allclose(a.rgb, b.rgb, atol=1e-6, rtol=0)


def test_pixels_render_in_table_mode_is_the_full_render_there():
    from navbench.track.ours import gn_pixels

    level = rooms()
    H, W = HALF_CAMERA.shape
    pixels = gn_pixels(H, W, 500, 0)
    cam = RaycastCamera(level, HALF_CAMERA, texture="table")
    full, part = cam.render((2.0, 3.0, 0.4)), cam.render((2.0, 3.0, 0.4), pixels)
    picked = np.zeros(H * W, bool)
    picked[pixels] = True
    picked = picked.reshape(H, W)
    assert np.array_equal(part.rgb[picked], full.rgb[picked])


def test_tables_over_the_memory_cap_coarsen_and_say_their_bound():
    level = rooms()
    fine = build_texel_tables(level)
    small = build_texel_tables(level, max_bytes=fine.nbytes // 3)
    assert small.h == 2 * fine.h and small.nbytes <= fine.nbytes // 3
    assert small.bound == colour_bound(level, small.h) > fine.bound
    assert fine.nbytes <= MAX_TABLE_BYTES


# ------------------------------------------------------------------ the setting: opt-in, checked

def test_a_bad_texture_is_one_line():
    from navbench.pipeline.stages.grid import build_episode_config
    from navbench.pipeline.stages.views import ViewsConfig
    from navbench.sim.world import Simulator

    for make in (lambda: RaycastCamera(rooms(), HALF_CAMERA, texture="tabel"),
                 lambda: render_reference(rooms(), HALF_CAMERA, (1, 1, 0), texture="tabel"),
                 lambda: Simulator(rooms(), texture="tabel"),
                 lambda: build_episode_config({"texture": "tabel"}),
                 lambda: ViewsConfig(10, texture="tabel")):
        with pytest.raises(ConfigError, match="expected one of procedural, table, polynomial") as e:
            make()
        assert "\n" not in str(e.value)


def test_profile_sets_the_texture_and_refuses_a_bad_one():
    from navbench.pipeline.overrides import apply_sets
    from navbench.pipeline.profiles import load_profile

    prof = apply_sets(load_profile("quick"), ["navigation.episode.texture=table", "views.texture=table"])
    assert prof.episode["texture"] == "table" and prof.views_texture == "table"
    for bad in ("navigation.episode.texture=tabel", "views.texture=tabel"):
        with pytest.raises(NavbenchError) as e:
            apply_sets(load_profile("quick"), [bad])
        assert "texture" in str(e.value) and "\n" not in str(e.value)


def test_the_default_texture_leaves_the_keys_as_they_were():
    """Episode and views keys of configs that never name the texture are the keys stored before
    the setting existed; naming the default changes nothing; ``table`` is a new key."""
    from navbench.config import config_hash
    from navbench.pipeline.stages.grid import NavigationConfig, resolved_episode_config
    from navbench.pipeline.stages.views import ViewsConfig, views_key_config

    old = {"camera": "half", "count": 1000, "seed": 0}  # the key config of views before the field
    assert views_key_config(ViewsConfig(1000)) == old
    assert views_key_config(ViewsConfig(1000, texture="procedural")) == old
    assert views_key_config(ViewsConfig(1000, texture="table")) == {**old, "texture": "table"}
    plain = resolved_episode_config(NavigationConfig())
    assert "texture" not in plain
    assert resolved_episode_config(NavigationConfig(episode={"texture": "procedural"})) == plain
    table = resolved_episode_config(NavigationConfig(episode={"texture": "table"}))
    assert table == {**plain, "texture": "table"} and config_hash(table) != config_hash(plain)


def test_the_simulator_and_the_episode_agree_on_the_texture():
    from navbench.nav.episode import EpisodeConfig, run_episode
    from navbench.sim.world import Simulator

    sim = Simulator(rooms(), intrinsics=None, texture="table")
    assert sim.texture == "table"
    with pytest.raises(ConfigError, match="texture"):
        run_episode(rooms(), None, None, None, None, None, sim, EpisodeConfig())


def test_the_gym_env_passes_the_texture_to_its_camera():
    from navbench.sim.env import PointNavEnv

    env = PointNavEnv(rooms(), texture="table")
    assert env.sim.texture == env.sim.camera.texture == "table"
    assert PointNavEnv(rooms()).sim.camera.texture == "procedural"


def test_scores_never_pool_texture_modes():
    """A run whose episodes used texture tables gets its own conditions label (score and the
    report group and pair by it); the default keeps the label stored runs have."""
    from navbench.results.score import conditions_label, short_conditions

    plain = conditions_label({})
    assert conditions_label({"texture": "procedural"}) == plain and "texture" not in plain
    table = conditions_label({"texture": "table"})
    assert table == plain + ", texture=table"
    assert short_conditions(table) == "texture=table" and short_conditions(plain) == "defaults"
