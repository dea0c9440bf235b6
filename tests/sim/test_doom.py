"""The ViZDoom backend (issue 37 §1, §2, §5): the level read back from the engine, depth against
a wall at a known distance, determinism, warp quantisation, and the simulator contract of
tests/sim/test_sim_world.py run on :class:`DoomSimulator`."""

import math

import numpy as np
import pytest

pytest.importorskip("vizdoom", reason="the vizdoom package (the optional 'vizdoom' extra) is not installed")

from navbench.geometry import AGENT_RADIUS, PAPER_CAMERA  # noqa: E402
from navbench.level import prisms  # noqa: E402
from navbench.sim.doom.engine import (ANGLE_UNITS, DEPTH_LINEAR, DoomEngine,  # noqa: E402
                                      saturation_value)
from navbench.errors import ConfigError  # noqa: E402
from navbench.sim.doom.simulator import DoomSimulator, buffer_to_metres  # noqa: E402
from navbench.sim.doom.wad import UNITS_PER_METRE, level_to_map, read_wad  # noqa: E402
from navbench.sim.dynamics import Control  # noqa: E402
from navbench.sim.world import sample_free_points  # noqa: E402

from . import test_sim_world as contract  # noqa: E402
from .fixtures import rooms, single_wall  # noqa: E402

#: The engine's quanta: 1 cm positions (so a rounded coordinate is off by <= 0.5 cm), headings
#: in 1/65536 turns.
POS_TOL = 0.5 / UNITS_PER_METRE + 1e-9
ANGLE_TOL = math.pi / ANGLE_UNITS + 1e-9


@pytest.fixture
def make_sim():
    """A DoomSimulator factory with Simulator's signature; stops every engine it started."""
    made = []

    def make(*args, **kwargs):
        made.append(DoomSimulator(*args, **kwargs))
        return made[-1]

    yield make
    for sim in made:
        sim.close()


# ------------------------------------------------------------------------- §1 levels as maps

def _height_at(level, pts):
    """Height (m) of the tallest solid covering each point ``(N, 2)`` (0: floor; points outside
    the box: the level height, as a wall). Solids are closed: a point on the seam of two
    touching pieces (a HouseExpo import's exterior fill) is under both, not on the floor."""
    pr = prisms(level)
    h = np.zeros(len(pts))
    for p in range(len(pr)):
        poly = pr.polygon(p)
        e = np.roll(poly, -1, axis=0) - poly
        rel = pts[:, None, :] - poly[None]
        inside = np.all(e[None, :, 0] * rel[..., 1] - e[None, :, 1] * rel[..., 0] >= 0, axis=1)
        h = np.where(inside, np.maximum(h, pr.height[p]), h)
    outside = (pts[:, 0] <= 0) | (pts[:, 0] >= level.width) | (pts[:, 1] <= 0) | (pts[:, 1] >= level.depth)
    return np.where(outside, level.height, np.minimum(h, level.height))


def _point_segment_distance(pts, segs):
    """Distance ``(N, S)`` from points ``(N, 2)`` to segments ``(S, 4)``."""
    a, b = segs[:, :2], segs[:, 2:]
    d = b - a
    rel = pts[:, None, :] - a[None]
    t = np.clip((rel * d[None]).sum(-1) / np.maximum((d * d).sum(-1), 1e-30)[None], 0, 1)
    return np.linalg.norm(rel - t[..., None] * d[None], axis=-1)


@pytest.mark.parametrize("name", ["rooms", "house-1"])
def test_level_round_trip_through_the_engine(name):
    check_round_trip(contract._level(name))


def test_houseexpo_import_round_trip_through_the_engine():
    # an imported HouseExpo plan (tests/fixtures/houseexpo_small.json, as tests/levels/
    # test_houseexpo.py imports it): a diagonal outline edge, the outside filled with
    # full-height pieces that overlap the outline's walls, and six pieces of furniture
    import json
    from pathlib import Path

    from navbench.levelgen import level_from_houseexpo

    doc = json.loads((Path(__file__).resolve().parents[1] / "fixtures" / "houseexpo_small.json").read_text())
    level = level_from_houseexpo(doc, "hx", 4, size=11.4, obstacles=6)
    assert level.meta["exterior_obstacles"] and any(
        abs(w.a[0] - w.b[0]) > 1e-6 and abs(w.a[1] - w.b[1]) > 1e-6 for w in level.walls)  # a diagonal wall
    check_round_trip(level)


def check_round_trip(level):
    """The level's map read back from the engine (sectors with floor and ceiling heights,
    blocking lines) agrees with the level's segments within one map unit (issue 37 §5)."""
    with DoomEngine(level, (160, 120), sectors_info=True) as eng:
        sectors = eng.sectors()
    s = UNITS_PER_METRE
    # floors and ceilings: the floor, and one raised floor per low obstacle, all under the ceiling
    got = sorted((round(sec.floor_height), round(sec.ceiling_height)) for sec in sectors)
    want = sorted([(0, round(level.height * s))] + [(round(o.height * s), round(level.height * s))
                                                    for o in level.obstacles if o.height < level.height])
    assert got == want
    lines = {}
    for sec in sectors:
        for ln in sec.lines:
            lines[(ln.x1, ln.y1, ln.x2, ln.y2)] = ln.is_blocking
    assert lines and all(lines.values())  # every wall and furniture edge blocks
    eng_segs = np.array(list(lines)) / s  # metres
    # every engine line lies on the level's segments (footprint edges or the box) within 1 unit
    pr = prisms(level)
    lvl = [np.concatenate([pr.polygon(p), np.roll(pr.polygon(p), -1, axis=0)], axis=1) for p in range(len(pr))]
    w, d = level.width, level.depth
    lvl = np.concatenate(lvl + [np.array([[0, 0, w, 0], [w, 0, w, d], [w, d, 0, d], [0, d, 0, 0]], float)])
    for f in np.linspace(0, 1, 5):
        pts = eng_segs[:, :2] + f * (eng_segs[:, 2:] - eng_segs[:, :2])
        assert _point_segment_distance(pts, lvl).min(axis=1).max() <= 1 / s
    # every stretch of a level segment where the height changes across it has an engine line
    # within 1 unit (sampled every 2 cm)
    n_checked = 0
    for a0, a1, b0, b1 in lvl:
        a, b = np.array([a0, a1]), np.array([b0, b1])
        length = np.linalg.norm(b - a)
        t = (np.arange(int(length / 0.02)) + 0.5) * 0.02 / length
        pts = a + t[:, None] * (b - a)
        nrm = np.array([-(b - a)[1], (b - a)[0]]) / length * 0.003
        changes = _height_at(level, pts + nrm) != _height_at(level, pts - nrm)
        if changes.any():
            dist = _point_segment_distance(pts[changes], eng_segs).min(axis=1)
            assert dist.max() <= 1 / s
            n_checked += int(changes.sum())
    assert n_checked > 1000


def test_wad_holds_a_udmf_map():
    m = level_to_map(single_wall())
    assert [name for name, _ in read_wad(m.wad)] == ["MAP01", "TEXTMAP", "ENDMAP"]
    text = dict(read_wad(m.wad))["TEXTMAP"].decode()
    assert text.startswith('namespace = "zdoom";') and "type = 1;" in text  # the player start


def test_a_level_is_converted_once_per_process_with_identical_frames(monkeypatch):
    # the pipeline starts an engine per episode; the conversion (~0.1 s of a ~0.3 s start on
    # house-1, docs/data/vizdoom/episode_time.py) runs once per level content and light level
    import dataclasses

    import navbench.sim.doom.engine as engine
    import navbench.sim.doom.wad as wad

    level = contract._level("house-1")
    real = wad.level_to_map
    calls = []
    monkeypatch.setattr(wad, "level_to_map", lambda *a: calls.append(a) or real(*a))
    monkeypatch.setattr(wad, "_MAP_CACHE", type(wad._MAP_CACHE)())
    poses = [(1.0, 1.0, 0.3), (3.2, 2.1, -2.0), (5.5, 4.0, 1.7)]

    def frames():
        with DoomSimulator(level, "none", seed=3, intrinsics=PAPER_CAMERA) as sim:
            return sim.engine.map, [sim.reset(p) for p in poses]

    m1, cold = frames()
    m2, warm = frames()
    assert len(calls) == 1 and m2 is m1  # the second engine took the converted map
    with pytest.raises(ValueError):
        m1.lines[0, 0] = 0.0  # shared between engines: read-only
    # the frames of a map converted afresh for the engine (as before the cache), bit for bit
    monkeypatch.setattr(engine, "cached_level_map", lambda lv, light: real(lv, light))
    m3, fresh = frames()
    assert m3 is not m1 and m3.wad == m1.wad
    for a, b, c in zip(cold, warm, fresh):
        for k in range(3):
            np.testing.assert_array_equal(a[k], b[k])
            np.testing.assert_array_equal(a[k], c[k])
    # the key is the level's content: meta is not read; a moved obstacle or another light is
    # another map
    assert wad.cached_level_map(dataclasses.replace(level, meta={"note": 1})) is m1
    o = level.obstacles[0]
    moved = dataclasses.replace(level, obstacles=(dataclasses.replace(
        o, polygon=tuple((x + 0.05, y) for x, y in o.polygon)),) + level.obstacles[1:])
    assert wad.cached_level_map(moved).textmap == real(moved).textmap != m1.textmap
    assert wad.cached_level_map(level, 255).textmap == real(level, 255).textmap != m1.textmap
    assert wad.cached_level_map(level) is m1


@pytest.mark.parametrize("res", [(160, 120), (320, 240)])
def test_a_closed_engine_is_reused_with_frames_identical_to_a_fresh_one(res):
    # the pipeline starts an engine per episode (~0.2-0.4 s: docs/data/vizdoom/episode_time.py);
    # inside reuse_engines a closed one stays running and the next engine on the same WAD
    # starts a new episode in it
    import navbench.sim.doom.engine as engine

    level = contract._level("house-1")
    rng = np.random.default_rng(5)
    pts = sample_free_points(level, rng, 40, 0.2)
    poses = [(x, y, rng.uniform(-math.pi, math.pi)) for x, y in pts]
    outside = DoomEngine(level, res, seed=3)
    game = outside.game
    outside.close()
    assert not engine._PARKED and not game.is_running()  # outside the block: stopped
    fresh = DoomEngine(level, res, seed=11)
    try:
        with engine.reuse_engines():
            first = DoomEngine(level, res, seed=3)
            for p in poses[:20]:  # an earlier episode: the engine moved, turned, ran tics
                first.set_pose(p)
            game = first.game
            first.close()
            assert engine._PARKED and engine._PARKED[0][1].game is game and game.is_running()
            reused = DoomEngine(level, res, seed=11)
            assert reused.game is game and not engine._PARKED
            for eng in (reused, fresh):
                assert np.array_equal(eng.variables()[:2], first.map.start)  # both at the map's start
            for p in poses[20:]:
                np.testing.assert_array_equal(reused.set_pose(p), fresh.set_pose(p))
                for a, b in zip(reused.buffers(), fresh.buffers()):
                    np.testing.assert_array_equal(a, b)
                np.testing.assert_array_equal(reused.variables(), fresh.variables())
            reused.close()
            # another light (another WAD) is another engine; parking it stops the one waiting
            other = DoomEngine(level, res, seed=3, light_level=255)
            assert other.game is not game and engine._PARKED[0][1].game is game
            other_game = other.game
            other.close()
            assert len(engine._PARKED) == 1 and engine._PARKED[0][1].game is other_game
            assert not game.is_running() and other_game.is_running()
        assert not engine._PARKED and not other_game.is_running()  # the block's end stops it
    finally:
        fresh.close()


def test_simulators_on_a_reused_engine_give_the_rows_of_fresh_ones():
    # episodes as the worker runs them (a simulator per episode, closed after it): the same
    # trajectories and frames whether the engine was reused or started afresh
    import navbench.sim.doom.engine as engine

    level = contract._level("house-1")
    rng = np.random.default_rng(2)
    controls = [Control(rng.uniform(-0.2, 0.2), 0.0, rng.uniform(0, 0.16)) for _ in range(15)]
    starts = [(1.0, 1.0, 0.3), (3.2, 2.1, -2.0), (5.5, 4.0, 1.7)]

    def episodes():
        out = []
        for k, start in enumerate(starts):
            with DoomSimulator(level, "mid", seed=100 + k, intrinsics=PAPER_CAMERA.scaled(0.5)) as sim:
                out.append([sim.reset(start)] + [sim.step(u) for u in controls])
                games.append(sim.engine.game)
        return out

    games = []
    fresh = episodes()
    with engine.reuse_engines():
        reused = episodes()
    assert len(set(map(id, games[:3]))) == 3 and games[3] is games[4] is games[5]
    for ea, eb in zip(fresh, reused):
        for a, b in zip(ea, eb):
            fa, fb = (a, b) if not hasattr(a, "frame") else (a.frame, b.frame)
            if hasattr(a, "frame"):
                np.testing.assert_array_equal(a.pose, b.pose)
                assert a.collided == b.collided
            for k in range(3):
                np.testing.assert_array_equal(fa[k], fb[k])


# ------------------------------------------------------------------------- §2 the engine

@pytest.mark.parametrize("res", [(320, 240), (160, 120)])
def test_depth_of_a_wall_at_known_distances(res):
    level = single_wall(9.0)  # face at x = 8.95 m, 10 m long
    a, b = DEPTH_LINEAR[res]
    step = a / UNITS_PER_METRE
    reach = (a * (saturation_value(res[1]) - 1) + b) / UNITS_PER_METRE  # 9.1 m, 4.5 m
    W, H = res
    seen = unseen = 0
    with DoomSimulator(level, "none", intrinsics=PAPER_CAMERA.scaled(W / 320)) as sim:
        for dist in (0.3, 0.8, 1.5, 2.5, 4.0, 6.0, 8.5):
            f = sim.reset((round(8.95 - dist, 2), 5.0, 0.0))
            centre = f.depth[H // 2 - 2: H // 2 + 2, W // 2 - 20: W // 2 + 20]
            valid = f.valid[H // 2 - 2: H // 2 + 2, W // 2 - 20: W // 2 + 20]
            if dist < reach - step:
                assert valid.all()
                assert np.abs(centre - dist).max() <= step, (res, dist, centre.min(), centre.max())
                seen += 1
            elif dist > reach + step:  # beyond the buffer's reach: saturated, invalid
                assert not valid.any() and np.isinf(centre).all()
                unseen += 1
    assert seen >= 5 and (unseen >= 2 or res == (320, 240))


def _wall_patch_brightness(sim, dist, jitter):
    """Mean intensity (0..1, RGB averaged) of the 0.5 m x 0.5 m patch of ``single_wall(9.0)``'s
    face centred at (y 5 m, eye height), seen straight on from ``dist`` m, averaged over the
    ``jitter`` (k, 2) position offsets (m): the engine point-samples one texel per pixel, so a
    single pose's patch mean moves with the sub-texel phase."""
    K = sim.intrinsics
    i, j = np.meshgrid(np.arange(K.width), np.arange(K.height))
    out = []
    for jx, jy in jitter:
        f = sim.reset((8.95 - dist + jx, 5.0 + jy, 0.0))
        x, y = sim.pose[:2]
        t = 8.95 - x  # heading 0: the ray of column i meets the face at y - t (i - cx) / fx
        patch = (np.abs(y - t * (i - K.cx) / K.fx - 5.0) <= 0.25) & (np.abs(t * (j - K.cy) / K.fy) <= 0.25)
        out.append(f.rgb[patch].mean())
    return float(np.mean(out))


def test_sector_light_255_gives_a_surface_one_colour_at_every_distance(make_sim):
    """Doom's diminishing light: at the default sector light 192 a wall patch seen from 4 m is
    16 % darker than from 1 m (measured, docs/data/vizdoom/lighting.txt); at 255 the two agree.
    Tolerance 3 %: at 255 the patch means (16 jittered poses, 320 x 240) stay within 0.6 % from
    0.5 to 4 m and within 2.7 % out to 8 m, the same as with the fade switched off in the
    engine (``r_visibility 0``): that is point sampling, not light; 3 % is five times below the
    fade it must show at 192."""
    level = single_wall(9.0)
    jitter = np.random.default_rng(0).uniform(-0.05, 0.05, (8, 2))
    ratio = {}
    for light in (255, 192):
        sim = make_sim(level, "none", intrinsics=PAPER_CAMERA, light_level=light)
        near, far = (_wall_patch_brightness(sim, d, jitter) for d in (1.0, 4.0))
        ratio[light] = far / near
    assert abs(ratio[255] - 1) <= 0.03, ratio
    assert ratio[192] < 1 - 3 * 0.03, ratio  # the fade the option removes is there by default
    assert "lightlevel = 255;" in level_to_map(level, 255).textmap


def test_light_level_outside_0_255_is_one_line():
    for bad in (256, -1, 1.5, True):
        with pytest.raises(ConfigError, match=r"^light_level must be a whole number in 0\.\.255, got "):
            DoomEngine(single_wall(), (160, 120), light_level=bad)


def test_warp_reads_back_the_pose_quantised():
    level = rooms()
    rng = np.random.default_rng(4)
    with DoomEngine(level, (160, 120)) as eng:
        for xy in sample_free_points(level, rng, 40, AGENT_RADIUS):
            pose = np.array([*xy, rng.uniform(-math.pi, math.pi)])
            got = eng.set_pose(pose)
            want_xy = np.round(pose[:2] * UNITS_PER_METRE) / UNITS_PER_METRE
            np.testing.assert_allclose(got[:2], want_xy, rtol=0, atol=1e-9)
            units = round(math.degrees(pose[2]) % 360 * ANGLE_UNITS / 360)
            want_th = math.radians(units * 360 / ANGLE_UNITS)
            assert abs((got[2] - want_th + math.pi) % (2 * math.pi) - math.pi) < 1e-7
            assert abs((got[2] - pose[2] + math.pi) % (2 * math.pi) - math.pi) <= ANGLE_TOL
            assert eng.variables()[3] == 50.0  # the eye at the camera height after settling


def test_the_warp_tic_alone_renders_from_the_floor():
    # why settle_tics defaults to 2: the frame of the warp's own tic has the eye 4 units up
    with DoomEngine(rooms(), (160, 120), settle_tics=1) as eng:
        eng.set_pose((1.0, 3.0, 0.0))
        assert eng.variables()[3] == 4.0
        first = eng.buffers()[0].copy()
        eng.game.advance_action(1, True)
        eng._state = eng.game.get_state()
        assert eng.variables()[3] == 50.0 and not np.array_equal(first, eng.buffers()[0])


def test_same_seed_gives_identical_frames(make_sim):
    rng = np.random.default_rng(0)
    controls = [Control(rng.uniform(-0.2, 0.2), 0.0, rng.uniform(0, 0.16)) for _ in range(20)]
    runs = []
    for _ in range(2):
        sim = make_sim(rooms(), "mid", seed=7, intrinsics=PAPER_CAMERA.scaled(0.5))
        frames = [sim.reset((1.0, 3.0, 0.2))] + [sim.step(u).frame for u in controls]
        runs.append((frames, sim.pose.copy()))
    (fa, pa), (fb, pb) = runs
    assert np.array_equal(pa, pb)
    for x, y in zip(fa, fb):
        assert np.array_equal(x.rgb, y.rgb) and np.array_equal(x.depth, y.depth) and np.array_equal(x.valid, y.valid)
    assert not np.array_equal(fa[0].rgb, fa[-1].rgb)  # the agent moved and the view changed


def test_exact_depth_option_and_pixel_subsets(make_sim):
    level = single_wall()
    sim = make_sim(level, "none", intrinsics=PAPER_CAMERA, depth="exact")
    assert sim.intrinsics.fx == 160.0 and sim.intrinsics.fy > sim.intrinsics.fx  # Doom's projection
    f = sim.reset((1.0, 5.0, 0.0))
    H, W = f.depth.shape
    assert f.depth[H // 2, W // 2] == pytest.approx(1.95, abs=1e-5)
    pixels = np.array([H // 2 * W + W // 2, 10])
    g = sim.observe(pixels)
    assert g.valid.sum() == 2 and g.depth[H // 2, W // 2] == f.depth[H // 2, W // 2]
    assert np.isnan(g.depth[0, 11]) and np.array_equal(g.rgb[H // 2, W // 2], f.rgb[H // 2, W // 2])


def test_buffer_to_metres_marks_saturation_and_discontinuities():
    a, b = DEPTH_LINEAR[(160, 120)]
    buf = np.full((120, 160), 20, np.uint8)
    buf[:, 80:] = 24  # a 4-step jump between columns 79 and 80
    buf[:10, :10] = saturation_value(120)  # saturated corner
    buf[110:, 150:] = 255  # values the engine writes above saturation on far flats
    depth, valid = buffer_to_metres(buf, (160, 120), edge_steps=None)
    assert depth[50, 40] == pytest.approx((a * 20 + b) / 100) and depth[50, 120] == pytest.approx((a * 24 + b) / 100)
    assert not valid[:10, :10].any() and not valid[110:, 150:].any() and np.isinf(depth[:10, :10]).all()
    assert valid[20:100, 79:81].all()  # no discontinuity test without edge_steps
    depth, valid = buffer_to_metres(buf, (160, 120), edge_steps=3)
    assert not valid[20:100, 79:81].any() and valid[20:100, 78].all() and valid[20:100, 81].all()
    depth, valid = buffer_to_metres(buf, (160, 120), edge_steps=4)
    assert valid[20:100, 79:81].all()
    with pytest.raises(ConfigError):
        DoomSimulator(rooms(), intrinsics=None, edge_steps=-1)


# ------------------------------------------------------------------------- the simulator contract

def test_contract_walk_into_wall(make_sim):
    contract.check_walk_into_wall_stops_at_contact(make_sim, tol=POS_TOL)


def test_contract_low_box(make_sim):
    contract.check_low_box_blocks_the_agent(make_sim, tol=POS_TOL)


def test_contract_random_walk(make_sim):
    contract.check_random_walk_never_overlaps(make_sim, rooms(), steps=1500, min_collisions=3, tol=POS_TOL)


def test_contract_same_seed(make_sim):
    contract.check_same_seed_same_trajectory_and_aligned_stream(make_sim, start_tol=ANGLE_TOL)


def test_contract_controls(make_sim):
    contract.check_controls_are_clipped(make_sim, tol=POS_TOL, angle_tol=ANGLE_TOL)
    contract.check_direction_is_the_commanded_world_angle(make_sim, tol=POS_TOL, angle_tol=ANGLE_TOL)


def test_contract_frames_and_errors(make_sim):
    # the 160 x 120 depth buffer reaches about 4.5 m: from this pose some pixels see farther
    contract.check_simulator_frames_and_errors(make_sim, all_valid=False)


def test_rounded_position_overlapping_a_solid_collides(make_sim):
    # the wall's face at x = 2.958: contact at 2.858; a free move ending at 2.856 is rounded by
    # the engine to 2.86, 0.2 cm into the wall's reach: the true pose, and a collision
    sim = make_sim(single_wall(3.008), "none", intrinsics=None)
    sim.reset((2.70, 5.0, 0.0))
    res = sim.step(Control(0.0, 0.0, 0.156))
    assert res.pose[0] == pytest.approx(2.86, abs=1e-9) and res.collided
    # the same move in navbench's exact world does not collide
    exact = contract.Simulator(single_wall(3.008), "none", intrinsics=None)
    exact.reset((2.70, 5.0, 0.0))
    assert not exact.step(Control(0.0, 0.0, 0.156)).collided


def test_pieces_shorter_than_the_vertex_precision_are_dropped():
    # box B's left edge lies 3 micrometres inside box A: the pieces of B's edges between A's
    # edge and B's corner are 3 um long, below the 10 um the vertices are written with
    from navbench.level import Obstacle

    base = single_wall(9.0)
    a = Obstacle(((1.0, 1.0), (2.0, 1.0), (2.0, 2.0), (1.0, 2.0)), 0.3, 1)
    b = Obstacle(((1.999997, 1.5), (3.0, 1.5), (3.0, 1.8), (1.999997, 1.8)), 0.5, 3)
    level = type(base)(base.name, base.width, base.depth, base.walls, (a, b), base.textures,
                       base.floor_texture, base.ceiling_texture)
    m = level_to_map(level)
    assert np.all(np.any(m.lines[:, :2] != m.lines[:, 2:], axis=1))
    with DoomEngine(level, (160, 120), sectors_info=True) as eng:
        floors = sorted(round(sec.floor_height) for sec in eng.sectors())
    assert floors == [0, 30, 50]
