"""``run-navigation --map PATH``: a map the user brings, checked before any episode runs."""

from __future__ import annotations

import sqlite3

from tests.bad_input.conftest import assert_clean_error, nb, project  # noqa: F401  (fixture)

ARGS = ("run-navigation", "--profile", "tiny.toml", "--tasks", "2", "--estimators", "gt,dynamics")


def _episodes(db, map_key=None):
    with sqlite3.connect(db) as con:
        q = "SELECT estimator, task_id, success, spl_term, path_length, steps, map_key FROM episodes"
        rows = con.execute(q + " ORDER BY estimator, task_id").fetchall()
    return [r for r in rows if map_key is None or r[-1] == map_key]


def test_a_map_file_drives_the_same_episodes_as_the_map_it_holds(project):
    res = nb(*ARGS, "--map", "true")
    assert res.code == 0, res.output
    true_map = next((project / "results" / "cache" / "true-map").iterdir()) / "map.npz"
    mine = project / "maps" / "tiny.npz"
    mine.parent.mkdir()
    mine.write_bytes(true_map.read_bytes())
    res = nb(*ARGS, "--map", "maps/{level}.npz")
    assert res.code == 0, res.output
    from navbench.worldmodel.base import load_world_model

    key = load_world_model(mine).content_hash()
    db = project / "results" / "navbench.db"
    from_file = _episodes(db, key)
    assert len(from_file) == 4  # 2 tasks x 2 estimators, keyed by the map's content hash
    from_true = [r for r in _episodes(db) if r[-1] != key]
    assert [r[:-1] for r in from_file] == [r[:-1] for r in from_true]  # same map content, same episodes


def test_a_bad_map_file_fails_before_any_episode(project):
    assert_clean_error(nb(*ARGS, "--map", "nope.npz"), "--map", "nope.npz")
    (project / "junk.npz").write_bytes(b"not a zip")
    assert_clean_error(nb(*ARGS, "--map", "junk.npz"), "junk.npz")
    assert_clean_error(nb(*ARGS, "--map", "maps/x.png"), "map", "x.png", ".npz")
    # a valid map whose grid does not cover the level
    from navbench.levelio import load_level
    from navbench.worldmodel.grid import grid_for_box, save_map, voxelize_level

    lv = load_level(project / "levels" / "tiny.json")
    small = voxelize_level(lv, grid_for_box((0.0, 0.0, 0.0), (lv.width / 2, lv.depth, lv.height), (8, 8, 8)))
    save_map(small, project / "small.npz")
    assert_clean_error(nb(*ARGS, "--map", "small.npz"), "small.npz", "does not cover level tiny")
    db = project / "results" / "navbench.db"
    assert not db.exists() or not _episodes(db)


def test_one_map_file_for_several_levels_needs_the_placeholder(project):
    (project / "levels" / "tiny2.json").write_text(
        (project / "levels" / "tiny.json").read_text().replace('"name": "tiny"', '"name": "tiny2"'))
    (project / "m.npz").write_bytes(b"")
    res = nb("run-navigation", "tiny", "tiny2", "--profile", "tiny.toml", "--map", "m.npz")
    assert_clean_error(res, "--map m.npz", "2 levels", "{level}")
