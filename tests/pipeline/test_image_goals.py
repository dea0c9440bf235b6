"""Issue 15 through the pipeline: image-goal episodes on the tiny level end to end, preset
scoring of stored rows, and the keys of point goals and of today's task sets unchanged."""

from __future__ import annotations

import json
import re
import sqlite3

import numpy as np
import pandas as pd
import pytest

from navbench.levelio import save_level
from tests.pipeline.test_db import episode
from tests.pipeline.test_stages import tiny_level

PROFILE = """
name = "img"
levels = ["tiny"]
[views]
camera = "half"
count = 12
seed = 0
eval_count = 4
eval_seed = 1
[tasks]
count = 3
difficulty = ["easy"]
[navigation]
estimators = ["gt", "dynamics"]
noise = ["mid"]
workers = 1
map = "true"
goal = "image"
[scoring]
preset = "nrns"
"""


@pytest.fixture
def image_run(tmp_path, monkeypatch):
    from navbench.pipeline.run import run_profile

    (tmp_path / "levels").mkdir()
    save_level(tiny_level(), tmp_path / "levels" / "tiny.json")
    (tmp_path / "img.toml").write_text(PROFILE)
    monkeypatch.chdir(tmp_path)
    result = run_profile("img.toml", db=f"sqlite:///{tmp_path / 'img.db'}", until="report", workers=1)
    return tmp_path, result


def test_image_goal_episodes_end_to_end(image_run):
    from navbench.nav.imagegoal import goal_heading
    from navbench.plan.tasks import load_tasks

    root, result = image_run
    tasks = load_tasks(result.inputs[0].tasks.path)
    assert [t.id for t in tasks] == [0, 1, 2] and all(1.5 <= t.optimal_length < 3.0 for t in tasks)
    goals = {int(k): v for k, v in json.loads(result.inputs[0].goals.path.read_text()).items()}
    for t in tasks:
        g = goals[t.id]
        assert g["heading"] == goal_heading(0, t.id) and g["status"] in ("ok", "ambiguous", "failed")
        assert np.hypot(g["pose"][0] - t.target[0], g["pose"][1] - t.target[1]) == pytest.approx(g["error_m"])
        assert g["error_m"] < 0.05  # the true map: the goal is found where it is
    con = sqlite3.connect(root / "img.db")
    rows = pd.read_sql("SELECT * FROM episodes ORDER BY task_id, estimator", con)
    con.close()
    assert len(rows) == 6 and set(rows["goal"]) == {"image"}
    for r in rows.itertuples():
        assert r.goal_status == goals[r.task_id]["status"] and r.goal_err_m == goals[r.task_id]["error_m"]
        assert r.goal_heading == goals[r.task_id]["heading"]
        assert r.final_dist_m is not None and r.final_geo_m >= r.final_dist_m - 1e-9  # geodesic >= straight
    # scored against the TRUE target, as a point-goal episode: the stored success is the paper's rule
    assert all(bool(s) == (d < 0.4) for s, d in zip(rows["success"], rows["final_dist_m"]))
    score = result.scores
    assert set(score["preset"]) == {"nrns"} and set(score["goal"]) == {"image"}
    assert {"soft_spl", "final_dist_m"} <= set(score.columns)
    by_diff = pd.read_csv(result.score.path.parent / "by_difficulty.csv")
    assert set(by_diff["difficulty"]) == {"easy", "all"} and set(by_diff["preset"]) == {"nrns"}
    html = result.report_path.read_text()
    assert "Scoring preset &#x27;nrns&#x27;" in html or "Scoring preset 'nrns'" in html
    assert "goal_localization.csv" in html and "tiny: goal images" in html and "unavailable" not in html
    # one set of conditions: named in the caption, and the CSV keeps the column
    goals_html = html.split('id="goals"')[1].split("<h2")[0]
    # (the default version, navbench-5, runs its episodes' camera on texel tables: named)
    assert "one level; every row under texture=table" in goals_html and "<th>conditions</th>" not in goals_html
    assert "conditions" in by_diff.columns
    # one cell per difficulty, "SR [95 %] / SPL"; image goals only: no point-goal Fig. 5a beside them
    sr, spl = score[score["level"] == "tiny"].iloc[0][["success_rate", "spl"]]
    assert re.search(rf"<td>{sr:.2f} \[\d\.\d\d, \d\.\d\d\] / {spl:.2f}</td>", goals_html)
    assert "spl_paper.csv" not in html and "No point-goal episodes" in html


def test_image_and_point_goal_cells_have_different_keys_and_point_keys_are_todays():
    from navbench.config import config_hash
    from navbench.pipeline.stages.context import Ref
    from navbench.pipeline.stages.grid import NavigationConfig, make_cells, resolved_episode_config
    from navbench.pipeline.stages.inputs import LevelInputs

    li = LevelInputs(Ref("make-level", "a" * 64, "l"), Ref("fit-map", "b" * 64, "m"), Ref("sample-tasks", "c" * 64, "t"))
    point = make_cells([li], NavigationConfig(estimators=("ours",)))[0]
    image = make_cells([li], NavigationConfig(estimators=("ours",), goal="image"))[0]
    today = config_hash({"level": "a" * 64, "map_key": "b" * 64, "task_set_key": "c" * 64, "estimator": "ours",
                         "estimator_options": {}, "noise": "mid",
                         "episode": resolved_episode_config(NavigationConfig())})
    assert point.key == today and image.key != point.key and image.condition_key != point.condition_key


def test_image_goal_keys_hold_every_field_of_the_goal_search_localiser(image_run, monkeypatch):
    """A goal is searched with the localiser's resolved config, so the cell key and the
    image-goals artifact key hold every one of its fields: a changed localiser default (the
    robust search, ``reverify``) gives new keys instead of serving goals found by the old one."""
    from dataclasses import asdict, replace

    from navbench.localize import LocalizerConfig
    from navbench.pipeline.stages.context import Ref
    from navbench.pipeline.stages.goals import ImageGoalConfig
    from navbench.pipeline.stages.grid import NavigationConfig, goal_key_part, make_cells
    from navbench.pipeline.stages.inputs import LevelInputs

    cfg = NavigationConfig(estimators=("ours",), goal="image", image_goal=ImageGoalConfig())
    assert goal_key_part(cfg)["goal"]["localizer_resolved"] == asdict(replace(LocalizerConfig(), k=2))
    li = LevelInputs(Ref("make-level", "a" * 64, "l"), Ref("fit-map", "b" * 64, "m"), Ref("sample-tasks", "c" * 64, "t"))
    before = make_cells([li], cfg)[0]
    from navbench.pipeline.run import stage_context
    from navbench.pipeline.stages.inputs import with_image_goals

    root, result = image_run
    stored = result.inputs[0]
    ctx = stage_context()
    same = with_image_goals(ctx, replace(stored, goals=None), ImageGoalConfig(camera="half"))
    assert same.goals.key == stored.goals.key and same.goals.cached
    # a localiser whose default changed: the same profile, other keys, goals searched anew
    changed = replace(LocalizerConfig(), reverify=0.0)
    monkeypatch.setattr(ImageGoalConfig, "localizer_config", lambda self: replace(changed, k=2, **self.localizer))
    after = make_cells([li], cfg)[0]
    assert after.key != before.key and after.condition_key != before.condition_key
    again = with_image_goals(ctx, replace(stored, goals=None), ImageGoalConfig(camera="half"))
    assert again.goals.key != stored.goals.key and not again.goals.cached


def test_task_config_key_without_difficulty_is_todays():
    from navbench.errors import ConfigError
    from navbench.pipeline.stages.tasks import TasksConfig

    # the JSON the sample-tasks key hashed before difficulties existed (the dataclass's two fields)
    assert TasksConfig(30, 0).key_config() == {"count": 30, "seed": 0}
    assert TasksConfig(10, 0, ("easy", "hard")).key_config()["difficulty"] == ["easy", "hard"]
    with pytest.raises(ConfigError, match="difficulty"):
        TasksConfig(10, 0, ("easy", "easy"))


def test_paper_preset_keeps_stored_values_and_nrns_rescores(tmp_path):
    from navbench.results.db import ResultsDB
    from navbench.results.score import score_tables, select_episodes
    from navbench.results.presets import apply_preset

    db = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    run = db.start_run("p", "probe", {}, "k")
    db.add_episodes(run, [
        episode("c", 0, success=True, spl_term=0.9, final_dist_m=0.3, final_geo_m=0.3),
        episode("c", 1, success=True, spl_term=0.8, end_reason="stuck", final_dist_m=0.35, final_geo_m=0.4),
        episode("c", 2, success=False, spl_term=0.0, final_dist_m=0.9, final_geo_m=1.2),
        episode("c", 3, success=True, spl_term=0.7),  # stored before final distances
    ])
    db.finish_run(run)
    raw = select_episodes(db)
    paper = apply_preset(raw, "paper")
    assert paper["success"].tolist() == raw["success"].tolist()
    assert paper["spl_term"].tolist() == raw["spl_term"].tolist()
    nrns = apply_preset(raw, "nrns")  # path 5.0, optimal 4.5, 40 steps
    assert nrns["success"].tolist() == [True, False, True, False]
    assert nrns["spl_term"].tolist() == [4.5 / 5.0, 0.0, 4.5 / 5.0, 0.0]
    table, _ = score_tables(db, n_boot=20, preset="habitat")
    row = table[table["level"] == "l1"].iloc[0]
    assert row["preset"] == "habitat" and row["success_rate"] == 0.0
    want_soft = np.mean([(1 - g / 4.5) * 4.5 / 5.0 for g in (0.3, 0.4, 1.2)])
    assert row["soft_spl"] == pytest.approx(want_soft, abs=1e-12)
    assert row["final_dist_m"] == pytest.approx(np.mean([0.3, 0.4, 1.2]), abs=1e-12)
    with pytest.raises(ValueError, match="already scored"):
        apply_preset(nrns, "paper")
    db.close()


def test_cli_goal_image_then_score_names_goal_and_preset(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from navbench.cli.main import app

    (tmp_path / "levels").mkdir()
    save_level(tiny_level(), tmp_path / "levels" / "tiny.json")
    (tmp_path / "p.toml").write_text(PROFILE.replace('goal = "image"\n', "").replace('difficulty = ["easy"]\n', ""))
    monkeypatch.chdir(tmp_path)
    url = f"sqlite:///{tmp_path / 'c.db'}"
    runner = CliRunner()
    for goal in ("image", "point"):
        res = runner.invoke(app, ["run-navigation", "--profile", "p.toml", "--tasks", "1", "--goal", goal,
                                  "--estimators", "gt", "--noise", "none", "--db", url])
        assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["score", "--db", url, "--boot", "20", "--by-difficulty", "--preset", "habitat",
                              "--format", "json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert {r["goal"] for r in doc["scores"]} == {"image", "point"}
    assert {r["preset"] for r in doc["scores"] + doc["by_difficulty"]} == {"habitat"}


def test_goals_localised_in_a_pool_are_the_serial_ones(image_run):
    """``ctx.workers > 1`` splits the goal localisations over a process pool: the same artifact
    key and the same goals (pose, status, confidence, error) as the serial loop; only the
    per-goal timing ``ms`` may differ."""
    from dataclasses import replace

    from navbench.pipeline.run import stage_context
    from navbench.pipeline.stages.goals import ImageGoalConfig, load_goals
    from navbench.pipeline.stages.inputs import with_image_goals

    _, result = image_run
    stored = result.inputs[0]
    serial = load_goals(stored.goals.path)
    ctx = stage_context(force={"image-goals"})
    ctx.workers = 2
    pooled = with_image_goals(ctx, replace(stored, goals=None), ImageGoalConfig(camera="half"))
    assert pooled.goals.key == stored.goals.key and not pooled.goals.cached
    parallel = load_goals(pooled.goals.path)

    def strip(goals):
        return {k: {f: v for f, v in g.items() if f != "ms"} for k, g in goals.items()}

    assert sorted(parallel) == sorted(serial) == [0, 1, 2]
    assert strip(parallel) == strip(serial)
    assert all(g["ms"] > 0 for g in parallel.values())
