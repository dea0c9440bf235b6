"""`navbench all`, collect-views and fit-map end to end on a tiny level and a tiny fit."""

from __future__ import annotations

import json
import sqlite3

import pytest
from typer.testing import CliRunner

from navbench.levelio import save_level

from .test_stages import tiny_level

PROFILE = """
name = "tinytest"
levels = ["tiny"]
[views]
camera = "half"
count = 12
seed = 0
eval_count = 4
eval_seed = 1
[fit]
steps = 3
grid_shape = [16, 12, 8]
n_samples = 40
images_per_batch = 4
pixels_per_image = 50
threads = 1
[tasks]
count = 3
[navigation]
estimators = ["gt", "dynamics"]
noise = ["low"]
workers = 1
"""


@pytest.fixture
def project(tmp_path, monkeypatch):
    (tmp_path / "levels").mkdir()
    save_level(tiny_level(), tmp_path / "levels" / "tiny.json")
    (tmp_path / "tiny.toml").write_text(PROFILE)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("NAVBENCH_DB", f"sqlite:///{tmp_path / 'nb.db'}")
    return tmp_path


def invoke(*args):
    from navbench.cli.main import app

    res = CliRunner().invoke(app, list(args))
    assert res.exit_code == 0, res.output + repr(res.exception)
    return res.output


def forbid(monkeypatch, *targets):
    """Make heavy stage functions fail if anything calls them (a cache hit must not)."""
    import importlib

    for dotted in targets:
        mod, name = dotted.rsplit(".", 1)

        def boom(*a, _n=dotted, **k):
            raise AssertionError(f"{_n} was called on a cached run")

        monkeypatch.setattr(importlib.import_module(mod), name, boom)


HEAVY = ("navbench.worldmodel.views.collect_views", "navbench.worldmodel.fit.fit_map",
         "navbench.plan.tasks.sample_tasks", "navbench.pipeline.stages.navigation.run_episode_chunk",
         "navbench.report.build.build_report", "navbench.results.score.summarise")


@pytest.mark.slow
def test_all_then_cached_rerun_then_tampered_map(project, monkeypatch):
    out = invoke("all", "--profile", "tiny.toml")
    assert "profile tinytest: 6 new episodes, 6/6 stored" in out
    index = project / "results" / "report" / "index.html"
    assert index.is_file() and "<html" in index.read_text()
    with sqlite3.connect(project / "nb.db") as con:
        assert con.execute("SELECT count(*) FROM episodes").fetchone() == (6,)
        (metrics,) = con.execute("SELECT metrics FROM maps").fetchone()
    assert {"depth_mae_m", "rgb_l1", "slice_precision", "slice_recall"} <= set(json.loads(metrics))

    # nothing changed: every stage is a cache hit and nothing heavy runs
    with monkeypatch.context() as m:
        forbid(m, *HEAVY)
        out = invoke("all", "--profile", "tiny.toml")
    assert "0 new episodes, 6/6 stored" in out
    for stage in ("collect-views", "fit-map", "sample-tasks", "score", "report"):
        assert f"{stage}: cached" in out, stage
    assert "computing" not in out

    # a damaged map is detected, refitted with a warning; its key is unchanged, so no episode reruns
    from navbench.pipeline.cache import ArtifactStore

    (fit,) = ArtifactStore("results/cache").ls("fit-map")
    (fit.path / "map.npz").write_bytes(b"garbage")
    with monkeypatch.context() as m:
        forbid(m, "navbench.worldmodel.views.collect_views", "navbench.pipeline.stages.navigation.run_episode_chunk")
        out = invoke("all", "--profile", "tiny.toml")
    assert "warning" in out and "fit-map: computing" in out and "0 new episodes" in out

    out = invoke("cache", "ls")
    for stage in ("collect-views", "fit-map", "sample-tasks", "score", "report", "episode"):
        assert stage in out

    # gc keeps everything the profile's latest run used, episodes included; a stray collection goes
    assert "would remove 0 entries" in invoke("cache", "gc", "--keep-newest", "0", "--dry-run")
    stray = invoke("collect-views", "tiny", "--count", "3", "--seed", "7", "--profile", "tiny.toml")
    stray_key = stray.split("key ")[1].split()[0]
    out = invoke("cache", "gc", "--keep-newest", "0")
    assert "removed 1 entries" in out and stray_key in out
    assert "0 new episodes, 6/6 stored" in invoke("all", "--profile", "tiny.toml")


def test_collect_views_and_fit_map_commands(project, monkeypatch):
    out = invoke("collect-views", "tiny", "--count", "6", "--seed", "3", "--profile", "tiny.toml")
    assert "6 half views (seed 3) collected" in out
    key = out.split("key ")[1].split()[0]
    out = invoke("collect-views", "tiny", "--count", "6", "--seed", "3", "--profile", "tiny.toml")
    assert "cached" in out and key in out

    res = CliRunner().invoke(__import__("navbench.cli.main", fromlist=["app"]).app,
                             ["fit-map", "tiny", "--views", key, "--steps", "2", "--json",
                              "--profile", "tiny.toml"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout[res.stdout.index("{"):])
    for k in ("depth_mae_m", "rgb_l1", "slice_precision", "slice_recall", "fit_seconds", "steps"):
        assert k in doc, k
    assert doc["steps"] == 2 and doc["cached"] is False
    # auto: the GPU where torch sees one, else the CPU path
    assert doc["device"].startswith("cuda:" if __import__("torch").cuda.is_available() else "cpu")

    # --device picks the path and is part of the map's key: the GPU path's code on the CPU
    res = CliRunner().invoke(__import__("navbench.cli.main", fromlist=["app"]).app,
                             ["fit-map", "tiny", "--views", key, "--steps", "2", "--json",
                              "--profile", "tiny.toml", "--device", "torch-cpu"])
    assert res.exit_code == 0, res.output
    dev_doc = json.loads(res.stdout[res.stdout.index("{"):])
    assert dev_doc["device"] == "torch-cpu" and dev_doc["cached"] is False
    assert dev_doc["map_key"] != doc["map_key"]
    res = CliRunner().invoke(__import__("navbench.cli.main", fromlist=["app"]).app,
                             ["fit-map", "tiny", "--views", key, "--device", "tpu", "--profile", "tiny.toml"])
    assert res.exit_code != 0 and "unknown device" in str(res.exception)
    if not __import__("torch").cuda.is_available():  # a GPU asked for where there is none:
        with monkeypatch.context() as m:  # refused before any views are collected
            forbid(m, "navbench.worldmodel.views.collect_views")
            res = CliRunner().invoke(__import__("navbench.cli.main", fromlist=["app"]).app,
                                     ["fit-map", "tiny", "--device", "cuda", "--profile", "tiny.toml"])
        assert res.exit_code != 0 and "no CUDA device" in str(res.exception)

    with monkeypatch.context() as m:
        forbid(m, "navbench.worldmodel.fit.fit_map")
        out = invoke("fit-map", "tiny", "--views", key, "--steps", "2", "--profile", "tiny.toml")
    assert "cached" in out and "depth_mae_m" in out

    from navbench.cli.main import app

    res = CliRunner().invoke(app, ["fit-map", "tiny", "--views", "0000000000", "--profile", "tiny.toml"])
    assert res.exit_code != 0 and "collect-views artifact with that key" in str(res.exception)
