"""The example plugin package (examples/navbench-example-plugin) installed for real, and the
real CLI run with it (issue 12): ``run-navigation --estimators ours-every-k`` on three tasks
with two workers, so that the estimator is found through its entry point in the parent (which
checks the name) and built in the pool's worker processes (which run every episode)."""

from __future__ import annotations

import importlib.util
import shutil
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from scripts._env import pythonpath_first
from tests.bad_input.conftest import assert_clean_error, nb_subprocess

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "navbench-example-plugin"


@pytest.fixture(scope="module")
def plugin_site(tmp_path_factory) -> Path:
    """The example installed with pip into a scratch directory (built from a copy, so the
    build leaves nothing in the repository)."""
    assert importlib.util.find_spec("setuptools") is not None, \
        "the example's build backend (setuptools) must be installed in the test environment"
    tmp = tmp_path_factory.mktemp("plugin")
    src = tmp / "src"
    shutil.copytree(EXAMPLE, src, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    site = tmp / "site"
    p = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation",
                        "--no-index", "--quiet", "--target", str(site), str(src)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr
    assert (site / "navbench_example" / "__init__.py").is_file()
    return site


def with_plugin(site: Path) -> dict:
    return {"PYTHONPATH": pythonpath_first(site, ROOT)}


def test_run_navigation_with_the_example_plugin(project, plugin_site):
    res = nb_subprocess("run-navigation", "--profile", "tiny.toml", "--estimators", "ours-every-k",
                        "--tasks", "3", "--workers", "2", "--map", "true",
                        cwd=project, env=with_plugin(plugin_site), timeout=180)
    assert res.code == 0, res.output
    assert "Traceback" not in res.output
    with sqlite3.connect(project / "results" / "navbench.db") as db:
        rows = db.execute("SELECT estimator, task_id, steps FROM episodes").fetchall()
    assert sorted((est, tid) for est, tid, _ in rows) == [("ours-every-k", t) for t in range(3)]
    assert sum(steps for *_, steps in rows) > 0  # the plugin's update() ran in the workers


def test_unknown_names_list_the_plugin(project, plugin_site):
    t0 = time.monotonic()
    res = nb_subprocess("run-navigation", "--profile", "tiny.toml", "--estimators", "nope",
                        cwd=project, env=with_plugin(plugin_site), timeout=60)
    elapsed = time.monotonic() - t0
    assert_clean_error(res, "--estimators", "unknown estimator 'nope'",
                       "(known: dynamics, emission, gt, no-map, ours, ours-every-k)")
    assert elapsed < 15, f"the name check took {elapsed:.1f} s"
    assert not (project / "results").exists()  # nothing ran


def test_the_plugins_options_are_checked_at_profile_load(project, plugin_site):
    (project / "k0.toml").write_text((project / "tiny.toml").read_text()
                                     + '\n[navigation.options.ours-every-k]\nk = 0\n')
    res = nb_subprocess("run-navigation", "--profile", "k0.toml", "--estimators", "ours-every-k",
                        cwd=project, env=with_plugin(plugin_site), timeout=60)
    assert_clean_error(res, "k0.toml", "[navigation.options.ours-every-k]", "k must be an integer >= 1")
    assert not (project / "results").exists()
