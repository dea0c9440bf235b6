"""Procedural levels: determinism, the committed benchmark levels, validation."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from navbench.errors import ConfigError, LevelError
from navbench.geometry import CAMERA_HEIGHT
from navbench.level import Obstacle, Wall, distance_to_solids, prisms, _is_convex
from navbench.levelio import dumps_level, level_from_dict, load_level
from navbench import levelgen
from navbench.levelgen import (BENCHMARK_LEVELS, CLEARANCE, clearance_mask, generate_level,
                               generate_maze, make_benchmark_level, make_level, validate_level)

LEVELS_DIR = Path(__file__).resolve().parents[2] / "levels"


@pytest.fixture(scope="module")
def committed():
    return {name: load_level(LEVELS_DIR / f"{name}.json") for name in BENCHMARK_LEVELS}


def test_same_seed_gives_identical_level_and_bytes():
    a = generate_level("t", 5, rooms=5, obstacles=8)
    b = generate_level("t", 5, rooms=5, obstacles=8)
    assert a == b
    assert a.meta == b.meta
    assert dumps_level(a) == dumps_level(b)
    c = generate_level("t", 6, rooms=5, obstacles=8)
    assert dumps_level(c) != dumps_level(a)


def test_file_round_trip_is_exact():
    lv = generate_level("t", 11, rooms=6, obstacles=10)
    back = level_from_dict(json.loads(dumps_level(lv)))
    assert back == lv
    assert back.meta == lv.meta
    assert dumps_level(back) == dumps_level(lv)


@pytest.mark.parametrize("name", list(BENCHMARK_LEVELS))
def test_committed_level_regenerates_byte_identical(name):
    path = LEVELS_DIR / f"{name}.json"
    assert dumps_level(make_benchmark_level(name)) == path.read_text()


def test_benchmark_table_has_the_papers_levels():
    assert sorted(BENCHMARK_LEVELS) == sorted([f"house-{k}" for k in range(1, 7)] + ["maze"]
                                              + [f"dense-{k}" for k in range(1, 7)])
    assert len({o["seed"] for o in BENCHMARK_LEVELS.values()}) == len(BENCHMARK_LEVELS)


@pytest.mark.parametrize("name", [n for n in BENCHMARK_LEVELS if n.startswith("dense")])
def test_dense_levels_have_the_styles_floor_plan(committed, name):
    """The dense style (issue 16): 8-12 rooms with a corridor among them, a non-rectangular
    outline (cut-away corners), doors 0.8-0.95 m that pass the agent, smaller free space than
    the house style's largest house."""
    lv = committed[name]
    m = lv.meta
    assert m["kind"] == "dense"
    assert 8 <= len(m["rooms"]) <= 12
    assert m["corridor"] is not None
    ext = m["exterior_obstacles"]
    assert 1 <= len(ext) <= 2
    cut = sum(levelgen._poly_area(np.asarray(lv.obstacles[i].polygon)) for i in ext)
    assert 0 < cut <= levelgen.MAX_CUTAWAY * lv.width * lv.depth + 1e-6
    for d in m["doors"]:
        assert 0.8 - 1e-9 <= d["width"] <= 0.95 + 1e-9
        n = np.array([1.0, 0.0]) if d["axis"] == "x" else np.array([0.0, 1.0])
        pts = np.array(d["center"]) + np.array([-0.4, 0.0, 0.4])[:, None] * n
        assert np.all(distance_to_solids(lv, pts) > CLEARANCE)
    sizes = [min(r[2] - r[0], r[3] - r[1]) for i, r in enumerate(m["rooms"]) if i != m["corridor"]]
    assert min(sizes) >= 1.5 - 1e-9  # wall centre lines; the corridor is 1.2-1.5 m wide


def test_dense_style_draws_more_and_smaller_rooms_than_house():
    """Over the same seeds the dense style has more rooms, a smaller mean room and more doors
    per square metre than the house style (the statistics it was defined by)."""
    def stats(style):
        rooms, area = [], []
        for seed in range(8):
            lv = generate_level("t", seed, style=style)
            rooms.append(len(lv.meta["rooms"]))
            area += [(r[2] - r[0]) * (r[3] - r[1]) for r in lv.meta["rooms"]]
        return np.mean(rooms), np.mean(area)
    (rh, ah), (rd, ad) = stats("house"), stats("dense")
    assert rd >= 8 > rh
    assert ad < 0.7 * ah
    with pytest.raises(ConfigError, match="unknown house style 'flat'"):
        generate_level("t", 1, style="flat")
    assert make_level("t", 3, kind="dense").meta["kind"] == "dense"


@pytest.mark.parametrize("name", list(BENCHMARK_LEVELS))
def test_committed_level_is_connected_and_well_formed(committed, name):
    lv = committed[name]
    validate_level(lv)  # one free component at 1.2 L, rooms and doors passable
    assert max(lv.width, lv.depth) <= 11.4 + 1e-9
    assert len(lv.walls) <= 60
    ext = set(lv.meta["exterior_obstacles"])
    assert len(lv.obstacles) - len(ext) <= 25
    pr = prisms(lv)
    tol = 1e-9  # wall corners are computed from centre lines in float64
    assert pr.verts.min() >= -tol
    assert pr.verts[:, 0].max() <= lv.width + tol and pr.verts[:, 1].max() <= lv.depth + tol
    for o in lv.obstacles:
        assert _is_convex(np.asarray(o.polygon))
        assert 0 < o.height <= lv.height
    free, _, _ = clearance_mask(lv)
    assert free.sum() * 0.05 ** 2 > 0.3 * levelgen.house_area(lv)


@pytest.mark.parametrize("name", [n for n in BENCHMARK_LEVELS if n.startswith("house")])
def test_committed_houses_have_rooms_doors_and_mixed_furniture(committed, name):
    lv = committed[name]
    assert 4 <= len(lv.meta["rooms"]) <= 8
    assert len(lv.meta["doors"]) >= len(lv.meta["rooms"]) - 1
    ext = set(lv.meta["exterior_obstacles"])
    heights = [o.height for i, o in enumerate(lv.obstacles) if i not in ext]
    assert min(heights) < CAMERA_HEIGHT < max(heights)  # some seen from above, some tall
    # doors pass the agent: exact distance to solids at the door and 0.4 m to either side
    for d in lv.meta["doors"]:
        assert 0.8 - 1e-9 <= d["width"] <= 2.2 + 1e-9
        n = np.array([1.0, 0.0]) if d["axis"] == "x" else np.array([0.0, 1.0])
        pts = np.array(d["center"]) + np.array([-0.4, 0.0, 0.4])[:, None] * n
        assert np.all(distance_to_solids(lv, pts) > CLEARANCE)


@pytest.mark.parametrize("name", list(BENCHMARK_LEVELS))
def test_textures_are_modelable_and_neighbours_differ(committed, name):
    lv = committed[name]
    used = {w.texture for w in lv.walls} | {lv.floor_texture, lv.ceiling_texture}
    used |= {o.texture for i, o in enumerate(lv.obstacles) if i not in lv.meta["exterior_obstacles"]}
    for t in used:
        tex = lv.textures[t]
        freqs = [math.hypot(fu, fv) for fu, fv, _ in tex.waves]
        assert max(freqs) <= 3.0 and min(freqs) >= 0.5
        assert all(0.15 <= a <= 0.3 for a in tex.amp)
    assert lv.textures[lv.floor_texture].kind == "tiles"
    assert lv.textures[lv.floor_texture].waves[0][0] == pytest.approx(1 / 0.6, abs=1e-4)
    segs = [(w.a, w.b) for w in lv.walls]
    nbr = levelgen._touching_walls(segs, tol=0.051)
    for i, js in enumerate(nbr):
        for j in js:
            assert lv.walls[i].texture != lv.walls[j].texture


def test_clearance_mask_matches_exact_distance():
    lv = make_benchmark_level("maze")
    free, xs, ys = clearance_mask(lv, resolution=0.1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    ref = distance_to_solids(lv, np.stack([X.ravel(), Y.ravel()], 1)) > CLEARANCE
    assert np.array_equal(free.ravel(), ref)


def test_requested_rooms_and_obstacles_are_honoured():
    lv = generate_level("t", 3, size=10.0, rooms=5, obstacles=9)
    assert len(lv.meta["rooms"]) == 5
    assert len(lv.obstacles) - len(lv.meta["exterior_obstacles"]) == 9
    assert max(lv.width, lv.depth) == pytest.approx(10.0)
    assert lv.meta["generator"] == "navbench.levelgen.house"
    assert lv.meta["rooms_requested"] == 5 and lv.meta["obstacles_requested"] == 9
    assert lv.seed == 3


def test_validation_rejects_a_split_level():
    lv = make_benchmark_level("maze")
    cut = Wall((lv.width / 2 + 0.6, 0.0), (lv.width / 2 + 0.6, lv.depth), 0.1, 3)
    bad = type(lv)(**{**lv.__dict__, "walls": lv.walls + (cut,)})
    with pytest.raises(LevelError, match="connected components"):
        validate_level(bad)


def test_validation_rejects_a_blocked_door(committed):
    lv = committed["house-1"]
    d = lv.meta["doors"][0]
    cx, cy = d["center"]
    block = Obstacle(((cx - 0.2, cy - 0.2), (cx + 0.2, cy - 0.2), (cx + 0.2, cy + 0.2), (cx - 0.2, cy + 0.2)),
                     0.3, 3)
    bad = type(lv)(**{**lv.__dict__, "obstacles": lv.obstacles + (block,)})
    with pytest.raises(LevelError):
        validate_level(bad)


def test_validation_rejects_solids_outside_the_box():
    lv = make_benchmark_level("maze")
    out = Obstacle(((-0.5, 1.0), (0.2, 1.0), (0.2, 1.5)), 0.3, 3)
    bad = type(lv)(**{**lv.__dict__, "obstacles": (out,)})
    with pytest.raises(LevelError, match="outside the level box"):
        validate_level(bad)


def test_maze_is_a_grid_of_corridors():
    lv = generate_maze("m", 1, size=6.1)
    assert lv.obstacles == ()
    assert lv.meta["cells"] == 5
    pitch = 1.2
    for w in lv.walls:  # every wall lies on a grid line of the maze or on the outer boundary
        for c in (w.a[0], w.a[1], w.b[0], w.b[1]):
            k = (c - 0.05) / pitch
            assert abs(k - round(k)) < 1e-9 or c in (0.0, lv.width)
    validate_level(lv)


def test_impossible_requests_fail_clearly():
    with pytest.raises(LevelError, match="3 attempts"):
        generate_level("t", 0, size=5.0, rooms=12, max_attempts=3)
    with pytest.raises(ConfigError, match="seed"):
        generate_level("t", -1)
    with pytest.raises(ConfigError, match="size"):
        generate_level("t", 1, size=100.0)
    with pytest.raises(ConfigError, match="rooms"):
        make_level("m", 1, kind="maze", rooms=3)
    with pytest.raises(ConfigError, match="kind"):
        make_level("m", 1, kind="castle")
    with pytest.raises(ConfigError, match="unknown benchmark level"):
        make_benchmark_level("house-9")


def test_validation_names_malformed_meta(committed):
    lv = committed["house-2"]
    bad = type(lv)(**{**lv.__dict__, "meta": {**lv.meta, "doors": [{"center": [1.0], "axis": "x"}]}})
    with pytest.raises(LevelError, match=r"meta.doors\[0\]"):
        validate_level(bad)
    bad = type(lv)(**{**lv.__dict__, "meta": {**lv.meta, "rooms": [[0, 0, "a", 1]]}})
    with pytest.raises(LevelError, match=r"meta.rooms\[0\]"):
        validate_level(bad)
