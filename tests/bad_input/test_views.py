"""Probe (issue 11): import-views, export-views, collect-views and the fit's grid size.

Every case runs the real CLI in a scratch project and expects one ``error:`` line naming the
file (and line, for the TUM lists) or option, a non-zero exit, and nothing written. The TUM
directories are built here with numpy + PIL (16 x 12 images, three frames), outside the project.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.bad_input.conftest import assert_clean_error, nb, tree_snapshot

W, H = 16, 12
TS = ["0.000000", "0.100000", "0.200000"]  # list data lines 2, 3, 4 (line 1 is a comment)


def make_tum(root: Path, intrinsics_json: bool = True) -> Path:
    """A valid TUM RGB-D directory: 3 frames of random colour, depth 1.5 m (16-bit PNG, 7500),
    planar camera-to-world poses 0.5 m above the floor."""
    from navbench.geometry import camera_pose
    from navbench.worldmodel.tum import _rot_to_quat

    rng = np.random.default_rng(0)
    (root / "rgb").mkdir(parents=True)
    (root / "depth").mkdir()
    rgb_l, dep_l, gt_l = ["# color images"], ["# depth maps"], ["# timestamp tx ty tz qx qy qz qw"]
    for k, ts in enumerate(TS):
        Image.fromarray(rng.integers(0, 256, (H, W, 3), dtype=np.uint8)).save(root / "rgb" / f"{ts}.png")
        Image.fromarray(np.full((H, W), 7500, np.uint16)).save(root / "depth" / f"{ts}.png")
        T = camera_pose((1.0 + 0.2 * k, 1.0, 0.3 * k), 0.5)
        q = _rot_to_quat(T[:3, :3])
        rgb_l.append(f"{ts} rgb/{ts}.png")
        dep_l.append(f"{ts} depth/{ts}.png")
        gt_l.append(f"{ts} " + " ".join(f"{v:.9f}" for v in (*T[:3, 3], *q)))
    for name, lines in (("rgb.txt", rgb_l), ("depth.txt", dep_l), ("groundtruth.txt", gt_l)):
        (root / name).write_text("\n".join(lines) + "\n")
    if intrinsics_json:
        (root / "intrinsics.json").write_text(
            f'{{"width": {W}, "height": {H}, "fx": 7.5, "fy": 7.5, "cx": 8.0, "cy": 6.0, '
            f'"camera_height": 0.5}}\n')
    return root


def set_line(path: Path, lineno: int, text: str) -> None:
    lines = path.read_text().splitlines()
    lines[lineno - 1] = text
    path.write_text("\n".join(lines) + "\n")


def gt_fields(tum: Path, lineno: int) -> list[str]:
    return (tum / "groundtruth.txt").read_text().splitlines()[lineno - 1].split()


@pytest.fixture
def tum(project):
    return make_tum(project.parent / "tum")


def import_refused(project, tum, *names, args=()):
    """Run import-views into a new --out and check the contract: one clean line naming
    ``names``, no --out, nothing changed in the project or the TUM directory."""
    before, tum_before = tree_snapshot(project), tree_snapshot(tum)
    res = nb("import-views", tum, "--out", "imported.npz", *args)
    assert_clean_error(res, *names)
    assert not (project / "imported.npz").exists()
    assert tree_snapshot(project) == before and tree_snapshot(tum) == tum_before
    return res


def test_valid_tum_imports(project, tum):
    """The builder's directory is valid: the cases below fail for their one defect only."""
    res = nb("import-views", tum, "--out", "ok.npz")
    assert res.code == 0, res.output
    from navbench.worldmodel.views import load_views

    v = load_views(project / "ok.npz")
    assert len(v) == 3 and np.allclose(v.depth, 1.5)


# --- failure 1: TUM layout -------------------------------------------------------------------

def test_8bit_depth_png_is_refused(project, tum):
    """An 8-bit depth PNG became depths of 1-51 mm; TUM depth is 16-bit (metres x 5000)."""
    Image.fromarray(np.full((H, W), 7, np.uint8), mode="L").save(tum / "depth" / f"{TS[1]}.png")
    import_refused(project, tum, f"depth/{TS[1]}.png", "mode L", "uint8", "16-bit", "depth.txt:3")


@pytest.mark.parametrize("args, option", [
    (["--fx", "-75"], "--fx"), (["--fx", "0"], "--fx"), (["--fx", "nan"], "--fx"),
    (["--fx", "inf"], "--fx"), (["--fx", "7.5", "--fy", "-1"], "--fy"),
    (["--fx", "7.5", "--cx", "99"], "--cx"), (["--fx", "7.5", "--cy", "-0.5"], "--cy"),
    (["--fx", "7.5", "--cx", "nan"], "--cx"), (["--cx", "3"], "--cx"),
    (["--depth-scale", "0"], "--depth-scale"), (["--depth-scale", "-5000"], "--depth-scale"),
    (["--camera-height", "-1"], "--camera-height"), (["--camera-height", "nan"], "--camera-height"),
    (["--max-dt", "-1"], "--max-dt"), (["--max-dt", "nan"], "--max-dt"),
])
def test_bad_intrinsics_options_are_refused(project, tum, args, option):
    """``--fx -75`` was accepted; every intrinsics (and scale) option is checked."""
    import_refused(project, tum, option, args=args)


def test_non_numeric_pose_names_file_and_line(project, tum):
    f = gt_fields(tum, 3)
    f[2] = "abc"
    set_line(tum / "groundtruth.txt", 3, " ".join(f))
    import_refused(project, tum, "groundtruth.txt:3", "'abc'")


def test_wrong_size_depth_gives_actual_and_expected_size(project, tum):
    """The message said 'is 160x120, the intrinsics say 160x120' (the rgb image's size)."""
    Image.fromarray(np.full((10, 20), 7500, np.uint16)).save(tum / "depth" / f"{TS[1]}.png")
    res = import_refused(project, tum, f"depth/{TS[1]}.png", "20x10", f"{W}x{H}")
    assert f"is {W}x{H}, the intrinsics say" not in res.err


def _gt(values):
    def mutate(tum):
        f = gt_fields(tum, 3)
        for i, v in values.items():
            f[i] = v
        set_line(tum / "groundtruth.txt", 3, " ".join(f))
    return mutate


def _corrupt(rel, data=b"not a png at all"):
    def mutate(tum):
        (tum / rel).write_bytes(data)
    return mutate


def _truncate(rel):
    def mutate(tum):
        b = (tum / rel).read_bytes()
        (tum / rel).write_bytes(b[:-30])  # header intact, pixel data cut
    return mutate


def _image(rel, arr, mode=None):
    def mutate(tum):
        Image.fromarray(arr, mode=mode).save(tum / rel)
    return mutate


def _write(rel, text):
    def mutate(tum):
        (tum / rel).write_text(text)
    return mutate


def _unlink(*rels):
    def mutate(tum):
        for r in rels:
            (tum / r).unlink()
    return mutate


@pytest.mark.parametrize("mutate, names", [
    pytest.param(_unlink(f"rgb/{TS[1]}.png"), ["rgb.txt:3", f"rgb/{TS[1]}.png", "no such file"], id="missing-listed-rgb"),
    pytest.param(_unlink(f"depth/{TS[2]}.png"), ["depth.txt:4", f"depth/{TS[2]}.png"], id="missing-listed-depth"),
    pytest.param(lambda t: set_line(t / "rgb.txt", 3, TS[1]), ["rgb.txt:3", "expected 2 fields"], id="rgb-field-count"),
    pytest.param(lambda t: set_line(t / "depth.txt", 2, f"{TS[0]} depth/a.png extra"), ["depth.txt:2", "expected 2 fields"], id="depth-field-count"),
    pytest.param(lambda t: set_line(t / "groundtruth.txt", 3, " ".join(gt_fields(t, 3)[:-1])), ["groundtruth.txt:3", "expected 8 fields"], id="gt-field-count"),
    pytest.param(_gt({1: "nan"}), ["groundtruth.txt:3", "NaN or infinite"], id="gt-nan"),
    pytest.param(_gt({3: "inf"}), ["groundtruth.txt:3", "NaN or infinite"], id="gt-inf"),
    pytest.param(_gt({4: "0", 5: "0", 6: "0", 7: "0"}), ["groundtruth.txt:3", "quaternion", "norm 0"], id="zero-quaternion"),
    pytest.param(_gt({4: "1", 5: "1", 6: "1", 7: "1"}), ["groundtruth.txt:3", "quaternion", "norm 2"], id="non-unit-quaternion"),
    pytest.param(lambda t: set_line(t / "depth.txt", 3, f"nan depth/{TS[1]}.png"), ["depth.txt:3", "timestamp"], id="nan-timestamp"),
    pytest.param(lambda t: set_line(t / "rgb.txt", 2, f"t0 rgb/{TS[0]}.png"), ["rgb.txt:2", "'t0'"], id="bad-timestamp"),
    pytest.param(_corrupt(f"rgb/{TS[1]}.png"), [f"rgb/{TS[1]}.png", "not a readable image"], id="corrupt-rgb-png"),
    pytest.param(_truncate(f"depth/{TS[0]}.png"), [f"depth/{TS[0]}.png", "corrupt or truncated"], id="truncated-depth-png"),
    pytest.param(_image(f"rgb/{TS[1]}.png", np.zeros((10, 20, 3), np.uint8)), [f"rgb/{TS[1]}.png", "20x10", f"{W}x{H}"], id="rgb-size-differs"),
    pytest.param(_image(f"depth/{TS[0]}.png", np.zeros((H, W, 3), np.uint8)), [f"depth/{TS[0]}.png", "mode RGB", "16-bit"], id="rgb-depth-image"),
    pytest.param(_image(f"rgb/{TS[0]}.png", np.zeros((H, W), np.uint16)), [f"rgb/{TS[0]}.png", "mode I;16", "8-bit"], id="16-bit-rgb"),
    pytest.param(_write("rgb.txt", "# nothing\n"), ["rgb.txt", "empty sequence"], id="empty-sequence"),
    pytest.param(_unlink("rgb.txt", "depth.txt", "groundtruth.txt"), ["missing rgb.txt"], id="no-tum-lists"),
    pytest.param(_write("intrinsics.json", '{"width": 16, "height": 12, "fx": -7.5, "fy": 7.5, "cx": 8, "cy": 6}'), ["intrinsics.json", "fx"], id="json-negative-fx"),
    pytest.param(_write("intrinsics.json", '{"width": 16, "height": 12, "fx": 7.5, "fy": 7.5, "cx": 80, "cy": 6}'), ["intrinsics.json", "cx"], id="json-cx-outside"),
    pytest.param(_write("intrinsics.json", '{"width": 16.5, "height": 12, "fx": 7.5, "fy": 7.5, "cx": 8, "cy": 6}'), ["intrinsics.json", "width"], id="json-fractional-width"),
    pytest.param(_write("intrinsics.json", '[1, 2]'), ["intrinsics.json", "JSON object"], id="json-not-object"),
    pytest.param(_write("intrinsics.json", '{"width": 16, "height": 12, "fx": 7.5, "fy": 7.5, "cx": 8, "cy": 6, "depth_scale": "x"}'), ["intrinsics.json", "depth_scale"], id="json-depth-scale"),
    pytest.param(_write("intrinsics.json", '{"width": 16, "height": 12, "fx": 7.5, "fy": 7.5, "cx": 8, "cy": 6, "camera_height": -1}'), ["intrinsics.json", "camera_height"], id="json-camera-height"),
    pytest.param(_write("intrinsics.json", '{"width": 16, "height": 12, "fx": 7.5, "fy": 7.5, "cx": 8, "cy": 6, "box": [[0, 0], [1, 1]]}'), ["intrinsics.json", "box"], id="json-box"),
])
def test_malformed_tum_directory_is_one_line(project, tum, mutate, names):
    mutate(tum)
    import_refused(project, tum, *names)


# --- failure 2: sizes checked against memory before allocating -------------------------------

@pytest.fixture
def no_sampling(monkeypatch):
    """Pose sampling is the first thing a collection allocates: a regression fails here fast
    instead of growing until the kernel kills the test run."""
    import navbench.worldmodel.views as views_mod

    def refuse(*a, **k):
        raise AssertionError("collect_views sampled poses: the memory check did not refuse")

    monkeypatch.setattr(views_mod, "sample_free_poses", refuse)


def test_collect_views_huge_count_is_refused_before_allocating(project, no_sampling):
    """``collect-views --count 100000000`` grew to 23.5 GB and was killed by the kernel."""
    before = tree_snapshot(project)
    res = nb("collect-views", "tiny", "--count", "100000000", "--profile", "tiny.toml")
    assert_clean_error(res, "--count", "100000000 views of 160x120", "of memory", "available")
    assert tree_snapshot(project) == before


def test_collect_views_memory_check_with_little_memory(project, no_sampling, monkeypatch):
    """The same check with a modest count, the available memory made small."""
    import navbench.worldmodel.memory as mem

    monkeypatch.setattr(mem, "available_memory", lambda: 1 << 20)
    before = tree_snapshot(project)
    res = nb("collect-views", "tiny", "--count", "12", "--profile", "tiny.toml")
    assert_clean_error(res, "--count", "12 views", "1.0 MiB is available")
    res = nb("collect-views", "tiny", "--profile", "tiny.toml")  # the profile's count
    assert_clean_error(res, "[views] count", "12 views")
    assert tree_snapshot(project) == before


def test_import_views_memory_check(project, tum, monkeypatch):
    import navbench.worldmodel.memory as mem

    monkeypatch.setattr(mem, "available_memory", lambda: 1 << 20)
    import_refused(project, tum, "import-views", "3 views of 16x12", "available")


BIG_GRID = """
name = "biggrid"
levels = ["tiny"]
[views]
camera = "half"
count = 2
seed = 0
eval_count = 1
eval_seed = 1
[fit]
steps = 1
grid_shape = GRID
n_samples = 10
"""


def test_fit_grid_shape_too_big_is_refused(project):
    """``grid_shape = [5000, 5000, 5000]`` in a profile's [fit] table was a MemoryError traceback.
    The profile's bound on the grid's cell count refuses it when the profile loads (the fit's
    own memory check, for library callers, is unit-tested in tests/worldmodel)."""
    (project / "big.toml").write_text(BIG_GRID.replace("GRID", "[5000, 5000, 5000]"))
    res = nb("fit-map", "tiny", "--profile", "big.toml", "--device", "cpu")
    assert_clean_error(res, "big.toml", "grid_shape", "125000000000 cells", "at most")
    assert not list(project.rglob("map.npz"))


@pytest.mark.parametrize("grid", ["[5000, 5000]", "[16, 12, 1]", '["a", 12, 8]', "[16.5, 12, 8]"])
def test_fit_grid_shape_malformed_is_refused_before_views(project, grid):
    (project / "big.toml").write_text(BIG_GRID.replace("GRID", grid))
    res = nb("fit-map", "tiny", "--profile", "big.toml", "--device", "cpu")
    assert_clean_error(res, "grid_shape")
    assert not list(project.rglob("views.json")), "views were collected before the fit config was checked"


# --- failure 3: other bad arguments ----------------------------------------------------------

@pytest.fixture
def views_artifact(project):
    from navbench.geometry import Intrinsics
    from navbench.worldmodel.views import Views, save_views

    rng = np.random.default_rng(1)
    n = 2
    v = Views(np.array([[1.0, 1.0, 0.0], [1.5, 1.2, 1.0]]), Intrinsics(W, H, 7.5, 7.5, 8.0, 6.0), 0.5,
              rng.integers(0, 256, (n, H, W, 3), dtype=np.uint8), np.full((n, H, W), 1.5, np.float32),
              np.ones((n, H, W), bool), "tiny", 0, ((0, 0, 0), (4, 3, 1.2)))
    return save_views(v, project.parent / "views")


def test_export_views_unknown_artifact(project):
    before = tree_snapshot(project)
    res = nb("export-views", "0123456789ab", "tum-out")
    assert_clean_error(res, "0123456789ab")
    assert tree_snapshot(project) == before and not (project / "tum-out").exists()


def test_export_views_to_a_file(project, views_artifact):
    target = project / "levels" / "tiny.json"
    content = target.read_bytes()
    before = tree_snapshot(project)
    res = nb("export-views", views_artifact, target)
    assert_clean_error(res, "levels/tiny.json", "is a file, not a folder")
    assert target.read_bytes() == content and tree_snapshot(project) == before


def test_export_views_into_a_non_empty_directory(project, views_artifact):
    """An export overwrote another sequence's rgb.txt and images (data lost)."""
    before = tree_snapshot(project)
    res = nb("export-views", views_artifact, project / "levels")
    assert_clean_error(res, "levels", "not empty")
    assert tree_snapshot(project) == before


def test_import_views_out_exists(project, tum):
    (project / "prev.npz").write_bytes(b"an earlier import")
    res = nb("import-views", tum, "--out", "prev.npz")
    assert_clean_error(res, "--out", "prev.npz", "already exists")
    assert (project / "prev.npz").read_bytes() == b"an earlier import"


def test_import_views_out_below_a_file(project, tum):
    before = tree_snapshot(project)
    res = nb("import-views", tum, "--out", "levels/tiny.json/views")
    assert_clean_error(res, "levels/tiny.json/views", "levels/tiny.json is a file, not a folder")
    assert tree_snapshot(project) == before


@pytest.mark.parametrize("where", ["file", "missing", "no-lists"])
def test_import_views_bad_directory(project, where):
    d = project.parent / "notum"
    if where == "file":
        d.write_text("x")
    elif where == "no-lists":
        d.mkdir()
        (d / "intrinsics.json").write_text('{"width": 16, "height": 12, "fx": 7.5, "fy": 7.5, "cx": 8, "cy": 6}')
    before = tree_snapshot(project)
    for extra in ([], ["--fx", "7.5"]):
        res = nb("import-views", d, "--out", "x.npz", *extra)
        assert_clean_error(res, "notum")
    assert tree_snapshot(project) == before
