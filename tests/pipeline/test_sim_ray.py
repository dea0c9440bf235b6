"""Episodes on the engine under Ray (issue 37 §3: "Ray too: the engine is a process per worker"):
a Ray worker starts its own ViZDoom process per episode, and its rows are the local pool's to the
last digit."""

from __future__ import annotations

import sqlite3

import pytest
from typer.testing import CliRunner

from .test_run_navigation import workdir

COLUMNS = "task_id, seed, estimator, success, spl_term, path_length, steps, loc_rmse_m, benchmark_version"
# no-map reads every frame, so the engine renders each step; --map true needs no views or fit
ARGS = ["run-navigation", "tiny", "--estimators", "no-map", "--noise", "low", "--tasks", "2", "--seeds", "1",
        "--map", "true", "--sim", "vizdoom", "--workers", "1"]


def _rows(db) -> list[tuple]:
    with sqlite3.connect(db) as con:
        return sorted(con.execute(f"SELECT {COLUMNS} FROM episodes").fetchall())


@pytest.mark.slow
def test_engine_episodes_under_ray_match_the_local_pool(tmp_path, monkeypatch):
    pytest.importorskip("vizdoom", reason="vizdoom is not installed (optional extra navbench[vizdoom])")
    pytest.importorskip("ray", reason="ray is not installed (optional extra navbench[ray])")
    from navbench.cli.main import app

    root = workdir(tmp_path)
    monkeypatch.chdir(root)
    monkeypatch.setenv("RAY_ENABLE_UV_RUN_RUNTIME_ENV", "0")
    rows = {}
    for executor in ("local", "ray"):
        monkeypatch.setenv("NAVBENCH_CACHE", str(root / f"cache-{executor}"))  # nothing shared
        db = root / f"{executor}.db"
        res = CliRunner().invoke(app, [*ARGS, "--executor", executor, "--db", f"sqlite:///{db}"])
        assert res.exit_code == 0, res.output
        assert "0 from stored trajectories, 2 run now" in res.output
        rows[executor] = _rows(db)
    assert len(rows["local"]) == 2
    assert {r[-1] for r in rows["local"]} == {"navbench-5+vizdoom"}
    assert rows["ray"] == rows["local"]
