"""Your own views through the CLI (issue 13): fit-map --views with a path, a TUM directory and a
cache key (no level needed), import-views --store, export-views KEY, the level-name error, and
the malformed TUM directories the issue lists that tests/bad_input/test_views.py did not cover
(each one line naming the file and line)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.bad_input.conftest import assert_clean_error, nb, tree_snapshot
from tests.bad_input.test_views import TS, import_refused, make_tum, set_line


@pytest.fixture
def seq(project):
    """12 views of the tiny level rendered at 16x12 and exported as TUM RGB-D outside the project."""
    from navbench.geometry import Intrinsics
    from navbench.levelio import load_level
    from navbench.worldmodel.tum import export_views
    from navbench.worldmodel.views import collect_views

    v = collect_views(load_level(project / "levels" / "tiny.json"), 12,
                      Intrinsics(16, 12, 7.5, 7.5, 8.0, 6.0), seed=0)
    return export_views(v, project.parent / "seq")


def fit(*args):
    res = nb("fit-map", *args, "--profile", "tiny.toml", "--device", "cpu", "--json")
    assert res.code == 0, res.output
    return json.loads(res.out[res.out.index("{"):])


def test_fit_map_views_path_tum_dir_and_key_give_one_map(project, seq):
    """The same content by path, TUM directory or cache key: one fit, one key (the views'
    content hash), no level; quality on every 4th view; no slice scores."""
    res = nb("import-views", seq, "--out", "seq.npz", "--store", "--json")
    assert res.code == 0, res.output
    imp = json.loads(res.out)
    assert imp["count"] == 12 and (project / "seq.npz").is_file()
    a = fit("--views", "seq.npz", "--heldout-every", "4")
    assert a["cached"] is False and a["level"] is None
    assert a["slice_precision"] is None and a["slice_recall"] is None
    assert a["train_views"] == 9 and a["heldout_views"] == 3 and a["split"] == "every 4"
    assert a["views_key"] == imp["content_key"] and np.isfinite(a["depth_mae_m"])
    b = fit("--views", seq, "--heldout-every", "4")
    c = fit("--views", imp["key"][:10], "--heldout-every", "4")
    assert b["map_key"] == c["map_key"] == a["map_key"] and b["cached"] and c["cached"]
    for k in ("depth_mae_m", "rgb_l1", "coverage"):
        assert a[k] == b[k] == c[k]
    # another split is another map; a level adds the slice scores
    d = fit("--views", "seq.npz", "--heldout-every", "3")
    assert d["map_key"] != a["map_key"] and d["heldout_views"] == 4
    e = fit("tiny", "--views", "seq.npz", "--heldout-every", "4")
    assert e["map_key"] != a["map_key"] and 0 <= e["slice_precision"] <= 1 and e["level"] == "tiny"
    assert e["depth_mae_m"] == a["depth_mae_m"]  # the same fit and held-out views


def test_fit_map_heldout_given(project, seq):
    from navbench.worldmodel.views import load_views, save_views

    assert nb("import-views", seq, "--out", "all.npz").code == 0
    v = load_views(project / "all.npz")
    save_views(v.subset(np.arange(8)), project / "train.npz")
    save_views(v.subset(np.arange(8, 12)), project / "held")
    r = fit("--views", "train.npz", "--heldout", "held")
    assert r["split"] == "given" and r["train_views"] == 8 and r["heldout_views"] == 4


def test_export_views_takes_a_cache_key(project, seq):
    res = nb("import-views", seq, "--store", "--json")
    key = json.loads(res.out)["key"]
    res = nb("export-views", key[:8], project.parent / "again")
    assert res.code == 0, res.output
    a = (seq / "groundtruth.txt").read_text().splitlines()
    b = (project.parent / "again" / "groundtruth.txt").read_text().splitlines()
    assert len(a) == len(b) == 14 and a[2:] == b[2:]  # pose text survives import -> export


@pytest.mark.parametrize("args, names", [
    (["--profile", "tiny.toml"], ["LEVEL", "--views"]),
    (["--views", "no-such-views", "--profile", "tiny.toml"], ["--views", "no-such-views", "no such file"]),
    (["--views", "abcdef123456", "--profile", "tiny.toml"], ["--views", "abcdef123456", "no import-views or collect-views"]),
    (["--views", "SEQ", "--heldout-every", "13", "--profile", "tiny.toml"], ["every 13", "--heldout-every"]),
    (["--views", "SEQ", "--camera", "paper", "--profile", "tiny.toml"], ["--camera"]),
    (["--views", "SEQ", "--heldout", "nope", "--profile", "tiny.toml"], ["--heldout", "nope"]),
    (["tiny", "--heldout", "SEQ", "--profile", "tiny.toml"], ["--heldout", "--views"]),
    (["--views", "SEQ", "--max-tilt", "-1", "--profile", "tiny.toml"], ["--max-tilt"]),
])
def test_fit_map_views_bad_arguments(project, seq, args, names):
    before = tree_snapshot(project)
    res = nb("fit-map", *[str(seq) if a == "SEQ" else a for a in args])
    assert_clean_error(res, *names)
    assert not list(project.rglob("map.npz"))
    assert not [p for p in tree_snapshot(project) if p not in before and not p.startswith("results/")]


@pytest.mark.parametrize("cmd", [["fit-map", "tyop"], ["collect-views", "tyop"],
                                 ["fit-map", "tyop", "--views", "SEQ"]])
def test_unknown_level_name_is_an_error_not_a_generated_level(project, seq, cmd):
    """A typo'd level name was silently generated; now it names the name and make-level."""
    res = nb(*[str(seq) if a == "SEQ" else a for a in cmd], "--profile", "tiny.toml")
    assert_clean_error(res, "'tyop'", "levels/tyop.json", "navbench make-level tyop --seed S")
    assert not list(project.rglob("level.json")) and not list(project.rglob("map.npz"))


def test_profile_levels_with_a_level_seed_are_still_generated(project):
    """The bundled profiles name their levels with a level_seed: those keep being generated."""
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.profiles import load_profile
    from navbench.pipeline.stages import LevelConfig, StageContext, make_level_stage

    (project / "gen.toml").write_text((project / "tiny.toml").read_text()
                                      .replace('levels = ["tiny"]', 'levels = ["made-up"]\nlevel_seed = 5'))
    prof = load_profile(str(project / "gen.toml"))
    ctx = StageContext(ArtifactStore(project / "results" / "cache"))
    ref = make_level_stage(ctx, LevelConfig.for_profile("made-up", prof))
    assert ref.meta["source"] == "generated"
    with pytest.raises(Exception, match="make-level other --seed S"):
        make_level_stage(ctx, LevelConfig.for_profile("other", prof))
    # a benchmark level needs no seed: its table has one (and its cache key is seed 1's)
    a = make_level_stage(ctx, LevelConfig("maze"))
    assert a.key == make_level_stage(ctx, LevelConfig("maze", 1)).key


# --- malformed TUM directories not covered in test_views.py ------------------------------------

@pytest.mark.parametrize("missing", ["depth.txt", "groundtruth.txt"])
def test_one_missing_list_is_named(project, tum, missing):
    (tum / missing).unlink()
    import_refused(project, tum, f"missing {missing}")


def test_no_association_within_max_dt_names_file_and_line(project, tum):
    """Poses 0.5 s after every image: none within --max-dt 0.02."""
    lines = (tum / "groundtruth.txt").read_text().splitlines()
    for k in range(1, len(lines)):
        f = lines[k].split()
        f[0] = f"{float(f[0]) + 0.5:.6f}"
        lines[k] = " ".join(f)
    (tum / "groundtruth.txt").write_text("\n".join(lines) + "\n")
    import_refused(project, tum, "rgb.txt:2", "--max-dt 0.02", "groundtruth.txt", "nearest 0.500000")
    res = nb("import-views", tum, "--out", "ok.npz", "--max-dt", "0.6")
    assert res.code == 0, res.output


def test_tilted_pose_through_the_cli_names_line_and_tolerance(project, tum):
    from navbench.geometry import camera_pose
    from navbench.worldmodel.tum import _rot_to_quat

    T = camera_pose((1.4, 1.0, 0.6), 0.5)
    a = np.radians(10.0)
    T[:3, :3] = T[:3, :3] @ np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    set_line(tum / "groundtruth.txt", 3, f"{TS[1]} " + " ".join(
        f"{x:.9f}" for x in (*T[:3, 3], *_rot_to_quat(T[:3, :3]))))
    import_refused(project, tum, "groundtruth.txt:3", "tilted 10 deg", "tolerance 0.5 deg", "--max-tilt")
    before = tree_snapshot(project)
    res = nb("fit-map", "--views", tum, "--profile", "tiny.toml")
    assert_clean_error(res, "groundtruth.txt:3", "tilted")
    assert not list(project.rglob("map.npz")) and "imported.npz" not in tree_snapshot(project)
    assert set(tree_snapshot(project)) - set(before) <= {p for p in tree_snapshot(project) if p.startswith("results/")}


@pytest.fixture
def tum(project):
    return make_tum(project.parent / "tum")


def test_fit_map_views_collect_views_key_without_level(project):
    """A collect-views key without LEVEL: the level-free fit of those views (the level's box,
    which the views carry); with LEVEL the profile's route (its held-out collection) as before."""
    res = nb("collect-views", "tiny", "--count", "10", "--profile", "tiny.toml")
    assert res.code == 0, res.output
    key = res.out.split("key ")[1].split()[0]
    a = fit("--views", key, "--heldout-every", "5")
    assert a["train_views"] == 8 and a["heldout_views"] == 2 and a["slice_precision"] is None
    b = fit("tiny", "--views", key)
    assert "train_views" not in b and b["heldout_views"] == 4 and b["slice_precision"] is not None
