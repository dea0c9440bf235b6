"""``run-navigation --goal image --map online`` (issue 15 §5): the unknown-house loop through the
pipeline on the tiny level: one stored row per episode, resumable, keyed apart from every other
map mode, labelled with its sensing model and rescored by the presets from the stored columns."""

from __future__ import annotations

import math
import sqlite3

import numpy as np
import pandas as pd
import pytest

from navbench.levelio import save_level
from tests.pipeline.test_stages import tiny_level

PROFILE = """
name = "onl"
levels = ["tiny"]
[tasks]
count = 2
difficulty = ["easy"]
[navigation]
estimators = ["gt"]
noise = ["mid"]
workers = 1
map = "online"
goal = "image"
"""


def _rows(db_path) -> pd.DataFrame:
    con = sqlite3.connect(db_path)
    try:
        return pd.read_sql("SELECT * FROM episodes ORDER BY task_id", con)
    finally:
        con.close()


@pytest.fixture(scope="module")
def online_run(tmp_path_factory):
    import os

    from navbench.pipeline.run import run_profile

    root = tmp_path_factory.mktemp("online")
    (root / "levels").mkdir()
    save_level(tiny_level(), root / "levels" / "tiny.json")
    (root / "onl.toml").write_text(PROFILE)
    cwd = os.getcwd()
    os.chdir(root)
    try:
        result = run_profile("onl.toml", db=f"sqlite:///{root / 'onl.db'}", until="score", workers=1)
    finally:
        os.chdir(cwd)
    return root, result


def test_rows_of_the_unknown_house_loop(online_run, monkeypatch):
    from navbench.nav.imagegoal import goal_heading
    from navbench.nav.imagenav import OnlineEpisodeRecord
    from navbench.pipeline.artifacts import TRAJ_FILE, load_record
    from navbench.pipeline.cache import ArtifactStore
    from navbench.plan.tasks import load_tasks

    root, result = online_run
    monkeypatch.chdir(root)
    assert result.inputs[0].goals is None  # nothing is localised beforehand: there is no map
    assert result.inputs[0].map.stage == "true-map"  # what the perfect sensor reads
    assert result.profile.scoring_preset == "nrns"  # the default 'paper' became this mode's
    tasks = {t.id: t for t in load_tasks(result.inputs[0].tasks.path)}
    rows = _rows(root / "onl.db")
    assert rows["task_id"].tolist() == [0, 1] and set(rows["estimator"]) == {"gt"}
    store = ArtifactStore(root / "results" / "cache")
    from navbench.worldmodel.base import load_world_model

    shape = load_world_model(result.inputs[0].map.path).occupancy_slice()[0].shape
    for r in rows.itertuples():
        t = tasks[r.task_id]
        assert r.goal == "image" and r.goal_status.startswith("online-")
        assert r.goal_heading == goal_heading(0, r.task_id)
        assert r.end_reason in ("reached", "step-limit", "stuck", "explored") and 0 < r.steps <= 500
        rec = load_record(store.lookup("episode", r.traj_key) / TRAJ_FILE, OnlineEpisodeRecord)
        assert rec.steps == r.steps and len(rec.true_poses) == r.steps + 1
        np.testing.assert_allclose(rec.true_poses[0], np.asarray(t.start), rtol=0, atol=1e-12)
        np.testing.assert_array_equal(rec.est_poses, rec.true_poses)  # pose = true
        assert r.final_dist_m == pytest.approx(math.dist(rec.true_poses[-1, :2], t.target[:2]), abs=1e-12)
        assert r.path_length == pytest.approx(np.hypot(*np.diff(rec.true_poses[:, :2], axis=0).T).sum(), abs=1e-9)
        assert rec.goal_status == r.goal_status.removeprefix("online-")
        assert rec.known.shape == shape and rec.known.any() and 0 < rec.seen_share <= 1
        assert bool(r.success) == (r.final_dist_m < 0.4)  # stored: the paper rule, as every row
        if r.goal_err_m is not None and not pd.isna(r.goal_err_m):
            assert r.goal_confidence > 0


def test_presets_rescore_the_stored_rows(online_run, monkeypatch):
    from navbench.results.db import ResultsDB
    from navbench.results.score import select_episodes
    from navbench.results.presets import apply_preset

    root, result = online_run
    monkeypatch.chdir(root)
    db = ResultsDB(f"sqlite:///{root / 'onl.db'}")
    try:
        raw = select_episodes(db)
    finally:
        db.close()
    nrns = apply_preset(raw, "nrns")
    want = (raw["end_reason"] == "reached") & (raw["final_dist_m"] <= 1.0)
    assert nrns["success"].tolist() == want.tolist()
    spl = np.where(want, raw["optimal_length"] / np.maximum(raw["path_length"], raw["optimal_length"]), 0.0)
    np.testing.assert_allclose(nrns["spl_term"], spl, rtol=0, atol=1e-15)
    habitat = apply_preset(raw, "habitat")
    assert habitat["success"].tolist() == ((raw["end_reason"] == "reached") & (raw["final_geo_m"] < 0.2)).tolist()
    # the score table: its own conditions label (never pooled with tracked or fused rows) and preset
    label = set(result.scores["conditions"])
    assert label == {"pose_quantisation=off, direction_limit=believed, collision_check=swept, "
                     "texture=table, map=online, mapping=perfect, pose=true"}
    assert set(result.scores["preset"]) == {"nrns"} and set(result.scores["goal"]) == {"image"}
    assert result.scores.iloc[0]["success_rate"] == pytest.approx(nrns["success"].mean())


def test_rerun_adds_nothing_and_stored_trajectories_restore_the_rows(online_run, monkeypatch):
    from navbench.pipeline.run import run_profile

    root, result = online_run
    monkeypatch.chdir(root)
    db = f"sqlite:///{root / 'onl.db'}"
    again = run_profile("onl.toml", db=db, until="navigation", workers=1)
    assert again.navigation.stored == 0 and again.navigation.ran == 0 and again.navigation.already_done == 2
    before = _rows(root / "onl.db")
    con = sqlite3.connect(root / "onl.db")
    con.execute("DELETE FROM episodes")  # a run killed after writing its trajectories
    con.commit()
    con.close()
    resumed = run_profile("onl.toml", db=db, until="navigation", workers=1)
    assert resumed.navigation.from_cache == 2 and resumed.navigation.ran == 0
    after = _rows(root / "onl.db")
    cols = ["cell_key", "task_id", "success", "spl_term", "steps", "end_reason", "final_dist_m", "final_geo_m",
            "goal", "goal_status", "goal_err_m", "goal_confidence", "goal_heading", "condition_key"]
    pd.testing.assert_frame_equal(before[cols], after[cols])


def test_online_cells_are_keyed_apart_and_other_keys_unchanged():
    from navbench.pipeline.stages.context import Ref
    from navbench.pipeline.stages.goals import ImageGoalConfig
    from navbench.pipeline.stages.grid import NavigationConfig, make_cells
    from navbench.pipeline.stages.inputs import LevelInputs
    from navbench.pipeline.stages.online import OnlineConfig, online_key_part

    li = LevelInputs(Ref("make-level", "a" * 64, "l"), Ref("true-map", "b" * 64, "m"), Ref("sample-tasks", "c" * 64, "t"))
    known = NavigationConfig(estimators=("gt",), goal="image", image_goal=ImageGoalConfig())
    online = NavigationConfig(estimators=("gt",), goal="image", image_goal=ImageGoalConfig(), online=OnlineConfig())
    assert online_key_part(known) == {}
    k, o = make_cells([li], known)[0], make_cells([li], online)[0]
    assert k.key != o.key and k.condition_key != o.condition_key
    # the loop's settings are in the key: another step limit is another cell
    longer = NavigationConfig(estimators=("gt",), goal="image", image_goal=ImageGoalConfig(), online=OnlineConfig(),
                              episode={"max_steps": 400})
    assert online_key_part(longer)["online"]["loop"]["max_steps"] == 400
    assert make_cells([li], longer)[0].key != o.key
    fused = NavigationConfig(estimators=("gt",), goal="image", image_goal=ImageGoalConfig(),
                             online=OnlineConfig(mapping="fused"))
    f = make_cells([li], fused)[0]
    assert f.key != o.key and f.condition_key != o.condition_key
    # every field of the localiser the loop matches the goal with (its defaults change with it)
    from dataclasses import asdict

    from navbench.localize import LocalizerConfig
    from navbench.nav.imagenav import ImageNavConfig

    from navbench.localize.localizer import keyed_settings

    part = online_key_part(online)["online"]["localizer"]
    assert part == keyed_settings(LocalizerConfig(lattice_step=ImageNavConfig().lattice_step, close_margin=0.0))
    # the loop matches without the near-tie search (2026-11-26), and its keys are those stored
    # before that option existed: every field but the two it added
    assert set(part) == {f for f in asdict(LocalizerConfig())} - {"close_margin", "close_max"}
    assert LocalizerConfig().close_margin > 0  # ... while the localiser's default has it
    assert "localizer_resolved" not in make_cells.__globals__["goal_key_part"](online)["goal"]


def test_online_profile_rules():
    from navbench.errors import ConfigError
    from navbench.pipeline.profiles import Profile
    from navbench.pipeline.stages.online import online_label, online_profile

    p = Profile(name="x", levels=("house-1",), estimators=("gt",), map_source="online", goal="image")
    logs = []
    assert online_profile(p, logs.append).scoring_preset == "nrns" and len(logs) == 1
    import dataclasses

    assert online_profile(dataclasses.replace(p, scoring_preset="habitat")).scoring_preset == "habitat"
    fit = dataclasses.replace(p, map_source="fit", estimators=("ours",), goal="point")
    assert online_profile(fit) is fit  # any other map: untouched
    with pytest.raises(ConfigError, match="--goal image"):
        online_profile(dataclasses.replace(p, goal="point"))
    with pytest.raises(ConfigError, match="--estimators gt"):
        online_profile(dataclasses.replace(p, estimators=("gt", "ours")))
    assert online_label({"map_source": "online"}) == ", map=online, mapping=perfect, pose=true"
    assert online_label({"map_source": "online-fused"}) == ", map=online-fused, mapping=fused, pose=true"
    assert online_label({"map_source": "fit"}) == online_label(None) == ""
    with pytest.raises(ConfigError, match="mapping"):
        from navbench.pipeline.stages.online import OnlineConfig

        OnlineConfig(mapping="noisy")


def _known_and_online_db(path):
    """A results database (open) with two runs of the same level, estimator (gt), noise, goal
    (image) and 3 tasks: run 1 on a known map (stopped at the goal), run 2 online (3 m away)."""
    from navbench.results.db import ResultsDB
    from tests.pipeline.test_db import episode

    db = ResultsDB(f"sqlite:///{path}")
    for cell, source, ok in (("known", "true", True), ("online", "online", False)):
        run = db.start_run("p", "probe", {"episode": {}, "map_source": source}, cell)
        db.add_episodes(run, [episode(cell, t, estimator="gt", success=ok, goal="image",
                                      final_dist_m=0.1 if ok else 3.0, final_geo_m=0.1 if ok else 3.0,
                                      condition_key=cell) for t in range(3)])
        db.finish_run(run)
    return db


def test_online_rows_never_pool_with_known_map_rows(tmp_path):
    """Same level, estimator, noise, goal and tasks, one run on a known map and one online: the
    score table and the difficulty table keep them apart by their conditions label."""
    from navbench.results.score import difficulty_table, select_episodes, summarise
    from navbench.results.presets import apply_preset

    db = _known_and_online_db(tmp_path / "r.db")
    try:
        frame = apply_preset(select_episodes(db), "nrns")
    finally:
        db.close()
    table = summarise(frame, n_boot=20)
    mine = table[table["level"] == "l1"]
    assert len(mine) == 2 and sorted(mine["success_rate"]) == [0.0, 1.0]
    online = mine[mine["conditions"].str.endswith("map=online, mapping=perfect, pose=true")]
    assert online["success_rate"].tolist() == [0.0] and online["episodes"].tolist() == [3]
    by = difficulty_table(frame)
    cells = by[(by["level"] == "l1") & (by["difficulty"] == "all")]
    assert len(cells) == 2 and sorted(cells["success_rate"]) == [0.0, 1.0]


def test_tracked_pose_inside_the_loop():
    """``online-fused`` with ``ours``: the agent tracks against the map it builds (no true pose
    after the start); the record keeps both trajectories. ``online`` (perfect) refuses it."""
    from navbench.errors import ConfigError
    from navbench.geometry import HALF_CAMERA
    from navbench.nav.imagenav import ImageNavConfig
    from navbench.pipeline.stages.online import OnlineConfig, online_label, run_online_episode
    from navbench.plan.tasks import sample_tasks
    from navbench.sim.world import Simulator
    from navbench.worldmodel.grid import voxelize_level

    level = tiny_level()
    full = voxelize_level(level)
    task = sample_tasks(level, 1, 0)[0]
    loop = ImageNavConfig(max_steps=40)
    rec = run_online_episode(level, full, task, Simulator(level, "mid", 5, HALF_CAMERA), HALF_CAMERA,
                             OnlineConfig("fused"), loop, 0, "mid", 0, "ours", 7)
    assert rec.estimator == "ours" and rec.true_poses.shape == rec.est_poses.shape
    np.testing.assert_array_equal(rec.est_poses[0], rec.true_poses[0])  # reset at the true start
    assert (rec.est_poses[1:] != rec.true_poses[1:]).any()  # then its own estimate
    gt = run_online_episode(level, full, task, Simulator(level, "mid", 5, HALF_CAMERA), HALF_CAMERA,
                            OnlineConfig("fused"), loop, 0, "mid", 0, "gt")
    np.testing.assert_array_equal(gt.est_poses, gt.true_poses)
    with pytest.raises(ConfigError, match="estimator 'ours'"):
        run_online_episode(level, full, task, Simulator(level, "mid", 5, HALF_CAMERA), HALF_CAMERA,
                           OnlineConfig("perfect"), loop, 0, "mid", 0, "ours")
    assert online_label({"map_source": "online-fused", "estimators": ["gt", "ours"]}).endswith("pose=estimator")
    assert online_label({"map_source": "online-fused", "estimators": ["gt"]}).endswith("pose=true")


def test_online_profile_estimators_by_mapping():
    import dataclasses

    from navbench.errors import ConfigError
    from navbench.pipeline.profiles import Profile
    from navbench.pipeline.stages.online import online_profile

    p = Profile(name="x", levels=("house-1",), estimators=("gt", "ours"), map_source="online-fused", goal="image")
    assert online_profile(p).estimators == ("gt", "ours")
    with pytest.raises(ConfigError, match="online-fused"):  # perfect mapping: gt only
        online_profile(dataclasses.replace(p, map_source="online"))
    with pytest.raises(ConfigError, match="no-map"):
        online_profile(dataclasses.replace(p, estimators=("no-map",)))


def test_score_defaults_to_nrns_for_unknown_house_rows_only(tmp_path):
    """``score`` without ``--preset``: ``nrns`` for a selection of unknown-house episodes (the
    agent's stop decision is what they measure), ``paper`` with a one-line warning naming them
    when they are mixed with known-map rows; ``--preset`` given is always obeyed."""
    import json

    from typer.testing import CliRunner

    from navbench.cli.main import app

    url = f"sqlite:///{tmp_path / 'r.db'}"
    _known_and_online_db(tmp_path / "r.db").close()
    runner = CliRunner()

    def presets(*extra):
        res = runner.invoke(app, ["score", "--db", url, "--boot", "20", "--format", "json", *extra])
        assert res.exit_code == 0, res.output
        return {d["preset"] for d in json.loads(res.stdout)["scores"]}, res.stderr

    got, err = presets("--run", "2")  # the online run alone
    assert got == {"nrns"} and "warning" not in err
    got, err = presets("--run", "1")  # the known-map run alone
    assert got == {"paper"} and "warning" not in err
    got, err = presets()  # both: paper, and a warning that names the online episodes
    assert got == {"paper"}
    assert "3 of the 6 episodes are unknown-house ones" in " ".join(err.split()) and "--preset nrns" in err
    got, err = presets("--preset", "habitat")
    assert got == {"habitat"} and "unknown-house" not in err


def test_report_defaults_to_nrns_for_unknown_house_rows_only(tmp_path):
    """``report`` without ``--preset`` follows ``score``'s default (nrns for unknown-house rows)."""
    from typer.testing import CliRunner

    from navbench.cli.main import app
    from navbench.results.db import ResultsDB
    from tests.pipeline.test_db import episode

    url = f"sqlite:///{tmp_path / 'r.db'}"
    db = ResultsDB(url)
    try:
        run = db.start_run("p", "probe", {"episode": {}, "map_source": "online"}, "online")
        db.add_episodes(run, [episode("online", t, estimator="gt", success=False, goal="image",
                                      final_dist_m=0.1, final_geo_m=0.1, condition_key="online")
                              for t in range(3)])
        db.finish_run(run)
    finally:
        db.close()
    res = CliRunner().invoke(app, ["report", "--db", url, "--out", str(tmp_path / "rep"), "--boot", "20",
                                   "--cache", str(tmp_path / "cache"), "--levels", str(tmp_path / "levels")])
    assert res.exit_code == 0, res.output
    scores = pd.read_csv(tmp_path / "rep" / "scores.csv")
    # stored success False (the paper rule), stopped within 1 m: a success under nrns
    assert set(scores["preset"]) == {"nrns"} and scores["success_rate"].eq(1.0).all()


def test_ablations_are_keyed_apart_and_the_full_model_keeps_its_keys():
    """``--online-ablation`` (RNR-Map's Table 4 rows): each ablation is its own cell; the full
    model's key part is the one runs stored before ablations existed (no ``ablation`` entry)."""
    from navbench.errors import ConfigError
    from navbench.pipeline.stages.context import Ref
    from navbench.pipeline.stages.goals import ImageGoalConfig
    from navbench.pipeline.stages.grid import NavigationConfig, make_cells
    from navbench.pipeline.stages.inputs import LevelInputs
    from navbench.pipeline.stages.online import ABLATIONS, OnlineConfig, loop_config, online_key_part

    li = LevelInputs(Ref("make-level", "a" * 64, "l"), Ref("true-map", "b" * 64, "m"), Ref("sample-tasks", "c" * 64, "t"))

    def cfg(ablation):
        return NavigationConfig(estimators=("gt",), goal="image", image_goal=ImageGoalConfig(),
                                online=OnlineConfig(ablation=ablation))

    full = online_key_part(cfg("full"))["online"]
    assert set(full) == {"mapping", "loop", "version", "localizer"} and full["mapping"] == "perfect"
    keys = {a: make_cells([li], cfg(a))[0].key for a in ABLATIONS}
    assert len(set(keys.values())) == len(ABLATIONS)
    assert online_key_part(cfg("no-goal"))["online"]["loop"]["goal_score"] is False
    assert online_key_part(cfg("no-explore"))["online"]["loop"]["exploration_score"] is False
    assert loop_config({}, "gt-stopper") == loop_config({})  # the same loop, stopped by the oracle
    # the Voronoi variant: the full loop with the explorer's other candidate kind only
    voronoi = online_key_part(cfg("voronoi"))["online"]["loop"]
    assert voronoi["explorer"]["candidates"] == "voronoi"
    assert {k: v for k, v in voronoi.items() if k != "explorer"} == \
        {k: v for k, v in full["loop"].items() if k != "explorer"}
    assert loop_config({}, "voronoi").explorer.candidates == "voronoi"
    assert loop_config({}).explorer.candidates == "frontier"
    with pytest.raises(ConfigError, match="--online-ablation: unknown 'half'"):
        OnlineConfig(ablation="half")


def test_gt_stopper_through_the_pipeline(online_run, monkeypatch):
    """The oracle stopper as a stored run: new cells beside the full model's, labelled with the
    ablation, every episode that came within 1 m stopped there; an ablation without an online
    map is refused by name."""
    from navbench.errors import ConfigError
    from navbench.pipeline.profiles import load_profile, override
    from navbench.pipeline.run import run_profile

    root, _ = online_run
    monkeypatch.chdir(root)
    db = f"sqlite:///{root / 'gt-stopper.db'}"
    prof = override(load_profile("onl.toml"), online_ablation="gt-stopper")
    res = run_profile(prof, db=db, until="score", workers=1)
    assert res.navigation.stored == 2
    assert set(res.scores["conditions"]) == {
        "pose_quantisation=off, direction_limit=believed, collision_check=swept, "
        "texture=table, map=online, mapping=perfect, pose=true, ablation=gt-stopper"}
    rows = _rows(root / "gt-stopper.db")
    for r in rows.itertuples():
        assert (r.end_reason == "reached") == (r.final_dist_m <= 1.0)
    with pytest.raises(ConfigError, match="--online-ablation gt-stopper: .* --map online"):
        run_profile(override(prof, map_source="true"), db=db, until="navigation", workers=1)
