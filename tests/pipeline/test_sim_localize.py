"""The localisation study, image goals and the health calibration on the chosen simulator
(issue 37 §3): ``localize-eval --sim vizdoom``, ``goal = "image"`` with ``sim = "vizdoom"``, the
calibration views of ``health_min_inliers = "auto"``.

The engine's frames must reach what consumes them (the localiser, the goal search, the
calibration), each labelled with the pose the engine shows; ``sim`` is in their keys only when
it is not pymunk (the pymunk keys below were computed before the choice existed, at ba9b0c8).
Tests that start the engine skip with a reason only where ``import vizdoom`` fails.
"""

from __future__ import annotations

import json
import sqlite3
import sys

import numpy as np
import pytest

from navbench.config import config_hash
from navbench.errors import ConfigError
from navbench.geometry import CAMERA_HEIGHT, HALF_CAMERA
from navbench.pipeline.artifacts import FORMAT
from navbench.pipeline.cache import stage_key
from navbench.pipeline.stages.context import Ref, StageContext

from .test_sim_choice import _cli, project  # noqa: F401  (the scratch project with the tiny level)
from .test_stages import tiny_level

#: Keys computed by the code before the simulator could be chosen for these stages (ba9b0c8):
#: the default localisation study and an OC2 one on trajectory queries (level "1"*64, map
#: "2"*64, bank "3"*64), the default image goals (level, map, tasks "4"*64) and the health
#: calibration's own views of level "1"*64.
KEYS_BEFORE = {
    "localize-eval": "37202e71d16654c69e64fb596955c796b289948b5afbc368e06601396f237a67",
    "localize-eval OC2": "f477fd13c149a8085867b6eabfe17968b5a9bc74a18a7ef41534eeff23fa8849",
    "image-goals": "792ba4fefe28840b7f4136829314d9703b542bd27558d9a66f6ed0073f7d9ccc",
    "calibration views": "22e1a673bbc9c84dbb837b48b4511e9f1ff086a65e849c1b9367e7d16a88733e",
}


def _require_vizdoom():
    try:
        import vizdoom  # noqa: F401
    except ImportError as e:
        pytest.skip(f"vizdoom cannot be imported here ({e}); pip install 'navbench[vizdoom]'")


class _KeyContext(StageContext):
    """A context whose ``run`` only computes the key of each stage it is asked for (``used``)."""

    def run(self, stage, config, inputs, compute, validate=None):
        key = stage_key(stage, config, inputs, FORMAT[stage])
        self.used.append((stage, key))
        return self.store / stage / key, key, True


def _keys(tmp_path, sim: str) -> dict[str, str]:
    from navbench.pipeline.stages.goals import ImageGoalConfig, image_goals_key_config
    from navbench.pipeline.stages.health import calibration_views
    from navbench.pipeline.stages.localize import LocalizeEvalConfig, localize_key_config

    ins = {"map": "2" * 64, "level": "1" * 64, "bank": "3" * 64}
    out = {"localize-eval": stage_key("localize-eval", localize_key_config(LocalizeEvalConfig(sim=sim).resolved()),
                                      ins, FORMAT["localize-eval"]),
           "localize-eval OC2": stage_key("localize-eval", localize_key_config(LocalizeEvalConfig(
               queries=50, changes="OC2", sampling="trajectory", sim=sim).resolved()), ins, FORMAT["localize-eval"])}
    g = ImageGoalConfig()
    out["image-goals"] = stage_key("image-goals", image_goals_key_config(g, sim),
                                   {"level": "1" * 64, "map": "2" * 64, "tasks": "4" * 64,
                                    "localizer": config_hash(g.localizer_settings())}, FORMAT["image-goals"])
    ctx = _KeyContext(store=tmp_path)
    calibration_views(ctx, "true", "true", Ref("make-level", "1" * 64, None, True, "tiny"), "half", 200, sim=sim)
    assert [s for s, _ in ctx.used] == ["collect-views"]
    out["calibration views"] = ctx.used[0][1]
    return out


def test_pymunk_keys_are_those_from_before_the_choice(tmp_path):
    assert _keys(tmp_path, "pymunk") == KEYS_BEFORE


def test_vizdoom_changes_each_of_these_keys(tmp_path):
    doom = _keys(tmp_path, "vizdoom")
    assert all(doom[k] != KEYS_BEFORE[k] for k in KEYS_BEFORE)
    assert len(set(doom.values())) == len(doom)


@pytest.mark.parametrize("sim,missing,says", [
    ("vizdoom", True, "pip install 'navbench[vizdoom]'"),
    ("doom", False, "known: pymunk, vizdoom"),
])
def test_localize_eval_refuses_in_one_line_before_anything_begins(project, monkeypatch, capsys, sim, missing, says):
    assert _cli(["localize-eval", "tiny", "--map", "true", "--queries", "2", "--sim", sim], monkeypatch,
                missing_vizdoom=missing) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err and says in err
    assert not (project / "nb.db").exists() and not (project / "cache").exists()


def _spy_localizer(monkeypatch) -> list:
    """Every ``(frame, intrinsics)`` the localiser is handed from now on, in order."""
    from navbench.localize import Localizer

    seen = []
    original = Localizer.localize

    def spy(self, frame, *a, **kw):
        seen.append((frame, self.intrinsics))
        return original(self, frame, *a, **kw)

    monkeypatch.setattr(Localizer, "localize", spy)
    return seen


def test_localize_eval_on_the_engines_frames(project, monkeypatch):
    """The localiser is handed the engine's frames, with the engine's projection, and the study
    stores the pose the engine showed as each query's truth; the run is navbench-5+vizdoom (the
    default version on the engine)."""
    _require_vizdoom()
    from typer.testing import CliRunner

    from navbench.cli.main import app
    from navbench.pipeline.stages.localize import load_localize_results
    from navbench.sim.backends import PoseRenderer

    seen = _spy_localizer(monkeypatch)
    args = ["localize-eval", "tiny", "--map", "true", "--queries", "3", "--json", "-o", "lattice_step=0.5"]
    res = CliRunner().invoke(app, [*args, "--sim", "vizdoom"])
    assert res.exit_code == 0, res.output + repr(res.exception)
    doom = json.loads(res.stdout)
    assert doom["meta"]["sim"] == "vizdoom" and doom["queries"] == 3
    study = next((project / "cache" / "localize-eval").glob(f"{doom['meta']['study_key']}/*.npz"))
    true = load_localize_results(study)["true"]
    # the truth is the engine's pose: whole centimetres
    assert np.abs(true[:, :2] * 100 - np.rint(true[:, :2] * 100)).max() < 1e-6
    assert len(seen) == 3 and all((i.fx, i.fy) == (80.0, 94.0) for _, i in seen)
    with PoseRenderer("vizdoom", tiny_level(), HALF_CAMERA, CAMERA_HEIGHT) as cam:
        for (frame, _), pose in zip(seen, true):
            engine = cam.render(pose)
            np.testing.assert_array_equal(frame.rgb, engine.rgb)
            np.testing.assert_array_equal(frame.valid, engine.valid)
    con = sqlite3.connect(project / "nb.db")
    (version, config), = con.execute("select benchmark_version, config from runs").fetchall()
    assert version == "navbench-5+vizdoom" and json.loads(config)["localize"]["sim"] == "vizdoom"
    # pymunk, same queries: its own study key and version, its poses within half a centimetre
    seen.clear()
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output + repr(res.exception)
    ray = json.loads(res.stdout)
    assert ray["meta"]["study_key"] != doom["meta"]["study_key"] and ray["meta"]["sim"] == "pymunk"
    true_ray = load_localize_results(next((project / "cache" / "localize-eval").glob(
        f"{ray['meta']['study_key']}/*.npz")))["true"]
    assert np.abs(true_ray[:, :2] - true[:, :2]).max() <= 0.005 + 1e-9
    assert all((i.fx, i.fy) == (HALF_CAMERA.fx, HALF_CAMERA.fy) for _, i in seen)
    versions = [v for v, in con.execute("select benchmark_version from runs order by id")]
    assert versions == ["navbench-5+vizdoom", "navbench-5"]
    assert con.execute("select count(*) from localize").fetchone() == (6,)


IMAGE_GOALS = """
name = "imgdoom"
levels = ["tiny"]
sim = "vizdoom"
[views]
camera = "half"
count = 12
seed = 0
eval_count = 4
eval_seed = 1
[tasks]
count = 2
difficulty = ["easy"]
[navigation]
estimators = ["gt"]
noise = ["low"]
workers = 1
map = "true"
goal = "image"
[navigation.goal_localizer]
lattice_step = 0.5
"""


@pytest.mark.slow
def test_image_goals_on_the_engine(project, monkeypatch):
    """goal = "image" with sim = "vizdoom" runs: each goal image is the engine's frame at the goal
    pose, localised with the engine's projection (the pool workers' path gives the same goals);
    the episodes are navbench-5+vizdoom, the goals' key is not pymunk's."""
    _require_vizdoom()
    from navbench.nav.imagegoal import goal_pose
    from navbench.pipeline.run import run_profile
    from navbench.pipeline.stages.goals import load_goals, localize_goals
    from navbench.plan.tasks import load_tasks
    from navbench.sim.backends import PoseRenderer

    seen = _spy_localizer(monkeypatch)
    (project / "img.toml").write_text(IMAGE_GOALS)
    result = run_profile("img.toml", db=f"sqlite:///{project / 'img.db'}", until="navigation", workers=1)
    li = result.inputs[0]
    tasks = load_tasks(li.tasks.path)
    goals = load_goals(li.goals.path)
    assert len(seen) == len(tasks) == 2 and all((i.fx, i.fy) == (80.0, 94.0) for _, i in seen)
    with PoseRenderer("vizdoom", tiny_level(), HALF_CAMERA, CAMERA_HEIGHT) as cam:
        for (frame, _), t in zip(seen, tasks):
            np.testing.assert_array_equal(frame.rgb, cam.render(goal_pose(t, 0)).rgb)
    con = sqlite3.connect(project / "img.db")
    assert {v for v, in con.execute("select benchmark_version from episodes")} == {"navbench-5+vizdoom"}
    assert {g for g, in con.execute("select goal from episodes")} == {"image"}
    # a pool worker's chunk: the same goal records (but the query time)
    bank = next((project / "cache" / "localize-bank").glob("*/bank.npz"))
    from navbench.pipeline.stages.goals import ImageGoalConfig

    cfg = ImageGoalConfig(camera="half", localizer={"lattice_step": 0.5})
    pooled = localize_goals((li.level.path, "tiny", li.map.path, bank, cfg, tasks, "vizdoom"))

    def strip(g):
        return json.loads(json.dumps({k: v for k, v in g.items() if k != "ms"}))  # tuples as stored

    assert {int(k): strip(v) for k, v in pooled.items()} == {k: strip(v) for k, v in goals.items()}
    # the same profile on pymunk: another goals artifact, from the ray-cast goal images
    seen.clear()
    ray = run_profile("img.toml", db=f"sqlite:///{project / 'img.db'}", until="navigation", workers=1,
                      sets=["sim=pymunk"]).inputs[0]
    assert ray.goals.key != li.goals.key and (ray.level.key, ray.map.key, ray.tasks.key) == \
        (li.level.key, li.map.key, li.tasks.key)
    assert len(seen) == 2 and all((i.fx, i.fy) == (HALF_CAMERA.fx, HALF_CAMERA.fy) for _, i in seen)


def test_health_calibration_views_from_the_engine(tmp_path):
    """health_min_inliers = "auto" on a map with no views of its own (--map true): the views it
    is calibrated on are rendered by the study's simulator, the engine's under vizdoom."""
    _require_vizdoom()
    from navbench.levelio import save_level
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.stages.health import study_health_thresholds
    from navbench.pipeline.stages.level import LevelConfig, make_level_stage
    from navbench.pipeline.stages.track_eval import study_map
    from navbench.track.study import TrackingStudyConfig
    from navbench.worldmodel.views import load_views

    (tmp_path / "levels").mkdir()
    save_level(tiny_level(), tmp_path / "levels" / "tiny.json")
    ctx = StageContext(ArtifactStore(tmp_path / "cache"), levels_dir=tmp_path / "levels")
    level = make_level_stage(ctx, LevelConfig("tiny"))
    vmap = study_map(ctx, "true", level)
    cfg = TrackingStudyConfig(estimators=("ours",), estimator_options={"ours": {"health_min_inliers": "auto"}},
                              sim="vizdoom")
    thresholds, keys = study_health_thresholds(ctx, cfg, level, vmap)
    assert 0.0 <= thresholds["ours"] <= 1.0 and list(keys) == ["health_calibration.ours"]
    (stage, key), = [u for u in ctx.used if u[0] == "collect-views"]
    manifest = json.loads((ctx.store.path(stage, key) / "manifest.json").read_text())
    assert manifest["config"]["sim"] == "vizdoom"
    views = load_views(ctx.store.path(stage, key) / "views")
    assert len(views.poses) == 200 and (views.intrinsics.fx, views.intrinsics.fy) == (80.0, 94.0)
    assert np.abs(views.poses[:, :2] * 100 - np.rint(views.poses[:, :2] * 100)).max() < 1e-6  # the engine's poses


def test_the_report_keeps_engine_studies_apart(tmp_path, monkeypatch):
    """A pymunk and a vizdoom study of one level are two rows of the report's table, each
    naming its benchmark version, and two curves of its CDF (neither overwrites the other)."""
    from navbench.report.localize import localization_table, section_localization
    from navbench.results.db import ResultsDB

    db = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    for version, key, err in (("navbench-1", "a" * 64, 0.1), ("navbench-1+vizdoom", "b" * 64, 2.0)):
        run = db.start_run("localize-eval", "test", {}, key, benchmark_version=version)
        db.add_localize_rows(run, [{"study_key": key, "level": "tiny", "query_id": i, "true_x": 1.0,
                                    "true_y": 1.0, "true_theta": 0.0, "est_x": 1.0 + err, "est_y": 1.0,
                                    "est_theta": 0.0, "loc_err_m": err, "heading_err_deg": 1.0,
                                    "query_ms": 5.0, "query_cpu_ms": 5.0, "image_diff": 0.0} for i in range(3)])
    runs = db.runs_frame()
    table = localization_table(db.localize_frame(), dict(zip(runs["id"], runs["benchmark_version"])))
    assert list(table["benchmark"]) == ["navbench-1", "navbench-1+vizdoom"]
    assert list(table["recall_50cm"]) == [1.0, 0.0]

    class Page:
        def __init__(self):
            self.figures, self.tables = [], []

        def h2(self, *a):
            pass

        def note(self, *a):
            pass

        def table(self, t, *a):
            self.tables.append(t)

        def figure(self, draw, caption, size):
            self.figures.append((draw, caption))

    page = Page()
    captured = {}
    monkeypatch.setattr("navbench.report.plots.plot_cdf", lambda ax, groups, *a, **k: captured.update(groups))
    section_localization(page, db, tmp_path)
    page.figures[0][0](type("Fig", (), {"add_subplot": lambda self: None})())
    assert sorted(captured) == ["tiny", "tiny vizdoom"]
    db.close()


def test_the_reports_goal_strip_draws_the_engines_goal_image(tmp_path, monkeypatch):
    """An engine row's goal image in the report is the engine's frame (what the agent was given);
    a pymunk row's the ray-cast one; without the engine, the ray-cast one titled as such."""
    _require_vizdoom()
    import pandas as pd
    from matplotlib.figure import Figure

    from navbench.levelio import save_level
    from navbench.report.goals import _draw_goals
    from navbench.sim.backends import PoseRenderer
    from navbench.sim.camera import RaycastCamera

    path = save_level(tiny_level(), tmp_path / "tiny.json")
    tasks = pd.DataFrame({"task_set_key": ["t", "t"], "task_id": [0, 1], "target_x": [0.6, 2.4],
                          "target_y": [0.6, 1.8]})
    rows = pd.DataFrame({"task_set_key": ["t", "t"], "task_id": [0, 1], "goal_heading": [0.3, -2.0],
                         "goal_status": ["ok", "failed"], "goal_err_m": [0.01, 1.5],
                         "benchmark_version": ["navbench-1+vizdoom", None]})
    fig = Figure()
    _draw_goals(fig, rows, path, tasks)
    with PoseRenderer("vizdoom", tiny_level(), HALF_CAMERA, CAMERA_HEIGHT) as engine:
        np.testing.assert_array_equal(fig.axes[0].images[0].get_array(), engine.render(np.array([0.6, 0.6, 0.3])).rgb)
    ray = RaycastCamera(tiny_level(), HALF_CAMERA, CAMERA_HEIGHT).render(np.array([2.4, 1.8, -2.0])).rgb
    np.testing.assert_array_equal(fig.axes[1].images[0].get_array(), ray)
    monkeypatch.setitem(sys.modules, "vizdoom", None)
    fig = Figure()
    _draw_goals(fig, rows, path, tasks)
    assert fig.axes[0].get_title().endswith("(ray-cast: vizdoom not installed)")
    assert not fig.axes[1].get_title().endswith("installed)")
