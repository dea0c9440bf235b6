"""The world-model interface: VoxelMap implements it, its methods are the grid functions, a toy
model that is no grid serves the planner and the trackers, and load_world_model refuses bad
files with one line naming them."""

from __future__ import annotations

import io
import json
import zipfile
from importlib.metadata import EntryPoint

import numpy as np
import pytest

import navbench.worldmodel.base as wmbase
from navbench.errors import ArtifactError, TrackingError
from navbench.geometry import Intrinsics
from navbench.worldmodel.base import DifferentiableWorldModel, WorldModel, load_world_model
from navbench.worldmodel.grid import (
    GridSpec,
    VoxelMap,
    grid_for_level,
    load_map,
    occupancy_slice,
    save_map,
    slice_scores,
    voxelize_level,
)
from toy_world import DiscWorld

TINY = Intrinsics(16, 12, 8.0, 8.0, 8.0, 6.0)


def _random_map(seed: int = 1) -> VoxelMap:
    rng = np.random.default_rng(seed)
    spec = GridSpec((0, 0, 0), (1, 1, 1), (3, 4, 5))
    meta = {"step": np.float32(0.1), "level": "r", "nested": {"b": [1, 2.5], "a": None}}
    return VoxelMap(spec, rng.random((3, 4, 5)), rng.random((3, 4, 5, 3)), 0.5, meta)


@pytest.fixture(scope="module")
def room_map(room):
    return voxelize_level(room, grid_for_level(room, shape=(40, 30, 16)))


def test_voxel_map_is_a_world_model():
    vm = _random_map()
    assert isinstance(vm, WorldModel) and isinstance(vm, DifferentiableWorldModel)
    assert vm.kind == "voxel"
    assert not isinstance(object(), WorldModel)


def test_save_load_round_trip_keeps_content_hash(tmp_path):
    vm = _random_map()
    h = vm.content_hash()
    assert len(h) == 64 and int(h, 16) >= 0
    path = vm.save(tmp_path / "m.npz")
    for back in (VoxelMap.load(path), load_world_model(path)):
        assert type(back) is VoxelMap and back.content_hash() == h
        np.testing.assert_array_equal(back.occ, vm.occ)
    # the same content built again hashes the same (no ids, times or file bytes in the hash)
    assert _random_map().content_hash() == h
    # and a second file of the loaded map too
    assert VoxelMap.load(VoxelMap.load(path).save(tmp_path / "m2.npz")).content_hash() == h


def test_content_hash_changes_with_one_voxel_tau_or_meta():
    vm = _random_map()
    h = vm.content_hash()
    occ = vm.occ.copy()
    occ[1, 2, 3] += 0.25
    assert VoxelMap(vm.spec, occ, vm.col, vm.tau, vm.meta).content_hash() != h
    col = vm.col.copy()
    col[0, 0, 0, 2] += 0.1
    assert VoxelMap(vm.spec, vm.occ, col, vm.tau, vm.meta).content_hash() != h
    assert VoxelMap(vm.spec, vm.occ, vm.col, 0.4, vm.meta).content_hash() != h
    assert VoxelMap(vm.spec, vm.occ, vm.col, vm.tau, {**vm.meta, "step": 0.2}).content_hash() != h
    # the hash is of what a file stores: colour below float16 resolution is not stored
    col = vm.col.copy()
    col[0, 0, 0, 0] = np.float32(np.float16(col[0, 0, 0, 0]))
    assert VoxelMap(vm.spec, vm.occ, col, vm.tau, vm.meta).content_hash() == h


def test_methods_equal_the_functions_they_delegate_to(room_map, tmp_path):
    for mode in ("band", "slice"):
        got, want = room_map.occupancy_slice(mode), occupancy_slice(room_map, mode)
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g, w)
    got = room_map.occupancy_slice("band", 0.1, 0.4)
    np.testing.assert_array_equal(got[0], occupancy_slice(room_map, "band", 0.1, 0.4)[0])

    from navbench.worldmodel.fastrender import FastRenderer, render_map

    pose = (0.6, 1.4, 0.3)
    a = room_map.renderer(TINY, 0.5).render(pose)
    for b in (render_map(room_map, pose, TINY, 0.5), FastRenderer(room_map, TINY, 0.5).render(pose)):
        np.testing.assert_array_equal(a.depth, b.depth)
        np.testing.assert_array_equal(a.rgb, b.rgb)
        np.testing.assert_array_equal(a.valid, b.valid)
    c = room_map.renderer(TINY, 0.5, max_range=3.0, step=0.05).render(pose)
    np.testing.assert_array_equal(c.depth, render_map(room_map, pose, TINY, 0.5, 3.0, 0.05).depth)

    p1, p2 = room_map.save(tmp_path / "a.npz"), save_map(room_map, tmp_path / "b.npz")
    assert load_map(p1).content_hash() == VoxelMap.load(p2).content_hash() == room_map.content_hash()


def test_ray_renderer_equals_render_rays(room_map):
    torch = pytest.importorskip("torch")
    from navbench.worldmodel.diffrender import render_rays
    from navbench.worldmodel.fastrender import map_step

    rr = room_map.ray_renderer(None, 20.0)
    assert rr.step == map_step(room_map, None) and rr.n == int(round(20.0 / rr.step))
    rng = np.random.default_rng(0)
    origins = torch.tensor(np.tile([[0.6, 1.4, 0.5]], (50, 1)), dtype=torch.float32)
    d = rng.normal(size=(50, 3))
    dirs = torch.tensor(d / np.linalg.norm(d, axis=1, keepdims=True), dtype=torch.float32)
    got = rr(origins, dirs, colour_moves_surface=True)
    want = render_rays(torch.from_numpy(room_map.occ), torch.from_numpy(room_map.col), room_map.spec,
                       room_map.tau, origins, dirs, rr.step, rr.n, colour_moves_surface=True)
    assert torch.equal(got.depth, want.depth) and torch.equal(got.rgb, want.rgb)
    assert torch.equal(got.hit, want.hit) and bool(got.hit.any())


# ------------------------------------------------------------------------------ a toy model

def test_toy_world_model_serves_the_planner_and_the_tracker(room):
    from navbench.plan.astar import make_planner_map, plan_on_map
    from navbench.track.registry import make_estimator
    from navbench.track.ours import default_renderer

    toy = DiscWorld()
    assert isinstance(toy, WorldModel) and not isinstance(toy, DifferentiableWorldModel)
    occ2d, xs, ys = toy.occupancy_slice("band")
    plan = plan_on_map(make_planner_map(occ2d, xs, ys), (0.7, 1.5), (3.3, 1.5))
    assert plan.ok and plan.status == "astar"  # the straight line crosses the pillar
    w = np.asarray(plan.waypoints)
    t = np.linspace(0, 1, 50)[:, None]
    dense = np.concatenate([a + t * (b - a) for a, b in zip(w[:-1], w[1:])])
    assert np.all(np.hypot(dense[:, 0] - 2.0, dense[:, 1] - 1.5) > toy.radius)  # around it
    frame = default_renderer(toy, TINY, 0.5)((1.0, 1.0, 0.0))
    assert frame.depth.shape == TINY.shape
    est = make_estimator("ours", vmap=toy, intrinsics=TINY, camera_height=0.5)
    assert est._render((1.0, 1.0, 0.0)).rgb.shape == (12, 16, 3)
    with pytest.raises(TrackingError, match="differentiable world model"):
        make_estimator("emission", vmap=toy, intrinsics=TINY, camera_height=0.5)
    # map quality's slice scores read the interface too: the toy's walls are the room's, its
    # pillar is not the room's two boxes, so both scores are strictly between 0 and 1
    prec, rec = slice_scores(toy, room)
    assert 0.5 < prec < 1 and 0.5 < rec < 1


def _plugins(monkeypatch, **targets):
    eps = [EntryPoint(name, value, wmbase.ENTRY_POINT_GROUP) for name, value in targets.items()]
    monkeypatch.setattr(wmbase, "entry_points", lambda group: [e for e in eps if e.group == group])


def test_plugin_kind_loads_through_the_entry_point_group(tmp_path, monkeypatch):
    _plugins(monkeypatch, **{"toy-disc": "toy_world:DiscWorld"})
    toy = DiscWorld(radius=0.7, meta={"level": "x"})
    back = load_world_model(toy.save(tmp_path / "toy.npz"))
    assert isinstance(back, DiscWorld) and back.content_hash() == toy.content_hash()
    assert wmbase.world_model_kinds() == ["toy-disc", "voxel"]
    # voxel maps still load beside the plugin
    assert isinstance(load_world_model(_random_map().save(tmp_path / "v.npz")), VoxelMap)


# ------------------------------------------------------------------------------ bad files

def _npz(path, **arrays):
    np.savez(path, **arrays)
    return path


def _header(shape=(3, 4, 5), **extra) -> np.ndarray:
    h = {"format_version": 1, "spec": {"lo": [0, 0, 0], "hi": [1, 1, 1], "shape": list(shape)},
         "tau": 0.5, "meta": {}, **extra}
    return np.array(json.dumps(h))


def _huge_declared(path, shape):
    """An npz whose arrays declare ``shape`` in their .npy headers but hold no data."""
    with zipfile.ZipFile(path, "w") as zf:
        for name, shp in (("occ", shape), ("col", shape + (3,))):
            buf = io.BytesIO()
            np.lib.format.write_array_header_1_0(buf, {"descr": "<f4", "fortran_order": False,
                                                       "shape": shp})
            zf.writestr(name + ".npy", buf.getvalue())
        buf = io.BytesIO()
        np.save(buf, _header(shape))
        zf.writestr("header.npy", buf.getvalue())
    return path


def _bad_files(d):
    ok_occ, ok_col = np.zeros((3, 4, 5), np.float32), np.zeros((3, 4, 5, 3), np.float16)
    nan = ok_occ.copy()
    nan[1, 1, 1] = np.nan
    (d / "text.npz").write_text("not a zip file\n")
    return {
        "missing": (d / "nope.npz", "no such map file"),
        "not npz": (d / "text.npz", "unreadable map file"),
        "no header": (_npz(d / "nohead.npz", occ=ok_occ, col=ok_col), "missing \\['header'\\]"),
        "header not JSON": (_npz(d / "badjson.npz", header=np.array("{oops")), "unreadable"),
        "header a list": (_npz(d / "list.npz", header=np.array("[1, 2]")), "JSON object"),
        "kind not a name": (_npz(d / "k.npz", header=_header(kind=3)), "kind 3 is not a name"),
        "unknown kind": (_npz(d / "u.npz", header=_header(kind="octree")), "unknown world-model kind 'octree'"),
        "missing occ": (_npz(d / "noocc.npz", col=ok_col, header=_header()), "missing \\['occ'\\]"),
        "wrong shape": (_npz(d / "shape.npz", occ=np.zeros((2, 2, 2), np.float32), col=ok_col,
                             header=_header()), "occ has shape"),
        "string array": (_npz(d / "str.npz", occ=np.full((3, 4, 5), "x"), col=ok_col,
                              header=_header()), "dtype"),
        "NaN": (_npz(d / "nan.npz", occ=nan, col=ok_col, header=_header()), "NaN"),
        "NaN tau": (_npz(d / "nantau.npz", occ=ok_occ, col=ok_col, header=_header(tau=float("nan"))),
                    "finite"),
        "bad version": (_npz(d / "v.npz", occ=ok_occ, col=ok_col, header=_header(format_version=9)),
                        "format version 9"),
        "absurd header": (_npz(d / "absurd.npz", occ=ok_occ, col=ok_col,
                               header=_header((100_000, 100_000, 1000))), "more than"),
        "truncated arrays": (_huge_declared(d / "trunc.npz", (30, 40, 50)), "unreadable"),
    }


BAD_CASES = ["missing", "not npz", "no header", "header not JSON", "header a list",
             "kind not a name", "unknown kind", "missing occ", "wrong shape", "string array", "NaN",
             "NaN tau", "bad version", "absurd header", "truncated arrays"]


@pytest.mark.parametrize("case", BAD_CASES)
def test_load_world_model_refuses_bad_files(case, tmp_path):
    path, pattern = _bad_files(tmp_path)[case]
    with pytest.raises(ArtifactError, match=pattern) as e:
        load_world_model(path)
    msg = str(e.value)
    assert str(path) in msg and "\n" not in msg


def test_a_declared_grid_beyond_the_memory_is_refused_before_reading(tmp_path, monkeypatch):
    import navbench.worldmodel.memory as memory

    monkeypatch.setattr(memory, "available_memory", lambda: 1 << 30)
    path = _huge_declared(tmp_path / "huge.npz", (1000, 1000, 1000))
    with pytest.raises(ArtifactError, match="of memory") as e:
        load_world_model(path)
    assert str(path) in str(e.value)


def test_broken_or_wrong_plugins_are_one_line(tmp_path, monkeypatch):
    _plugins(monkeypatch, broken="no_such_module_xyz:Thing", wrong="toy_world:NotAWorld")
    for kind, pattern in (("broken", "does not load"), ("wrong", "not a WorldModel")):
        path = _npz(tmp_path / f"{kind}.npz", header=np.array(json.dumps({"kind": kind})))
        with pytest.raises(ArtifactError, match=pattern) as e:
            load_world_model(path)
        assert str(path) in str(e.value) and "\n" not in str(e.value)
