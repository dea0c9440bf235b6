"""navbench bench: statistics, result layout, storage and the CLI (no timing assertions)."""

from __future__ import annotations

import json
import math

import pytest
from typer.testing import CliRunner

from navbench.bench import (
    TARGETS,
    Metric,
    Stats,
    Target,
    assemble_result,
    bench_rows,
    metric_keys,
    stats,
    timed_loop,
)
from navbench.cli.main import app
from navbench.results.db import ResultsDB


# ------------------------------------------------------------------------------ statistics

def test_stats_of_given_lists_are_exact():
    s = stats([4.0, 1.0, 3.0, 2.0])
    assert s == Stats(n=4, median=2.5, q1=1.75, q3=3.25, min=1.0, max=4.0)
    assert s.iqr == 1.5
    assert stats([7.0]) == Stats(1, 7.0, 7.0, 7.0, 7.0, 7.0)
    assert stats([5, 1, 3]) == Stats(3, 3.0, 2.0, 4.0, 1.0, 5.0)
    empty = stats([])
    assert empty.n == 0 and all(math.isnan(v) for v in empty[1:])


def test_timed_loop_drops_warmup_and_stops_on_budget():
    calls = []

    def call(k):
        calls.append(k)
        return float(k)

    assert timed_loop(call, repeats=4, warmup=2) == [2.0, 3.0, 4.0, 5.0]
    assert calls == [0, 1, 2, 3, 4, 5]
    # a spent budget stops after min(3, repeats) timed repeats
    assert timed_loop(call, repeats=10, warmup=1, budget_s=0.0) == [1.0, 2.0, 3.0]
    assert timed_loop(call, repeats=2, warmup=0, budget_s=0.0) == [0.0, 1.0]


def test_targets():
    t = Target("x", "<=", 10.0, "x <= 10")
    assert t.check(10.0) is True and t.check(10.5) is False and t.check(None) is None
    assert Target("y", ">=", 4.0, "").check(4.0) is True
    assert {t.key for t in TARGETS} <= set(metric_keys())


# ------------------------------------------------------------------------------ result and DB

def fake_result(na: frozenset = frozenset({"fit_step_ms_cuda", "diffrender_ms_5000_cuda",
                                          "fit_10k_steps_s_cuda"})) -> dict:
    """A complete result with made-up values (layout only; no measurement behind it)."""
    from navbench.bench import host_info

    metrics = {}
    for i, key in enumerate(metric_keys()):
        unit = "Hz" if "_hz_" in key else "s" if key.endswith("_s") and "steps_per" not in key else "ms"
        device = "cuda:0" if key.endswith("_cuda") else "cpu"
        if key in na:
            metrics[key] = Metric(key, "g", key, unit, None, None, device, note="no CUDA device")
        else:
            s = stats([1.0 + i, 2.0 + i, 3.0 + i])
            metrics[key] = Metric(key, "g", key, unit, s.median, s, device, paper=50.0)
    context = {**host_info(), "map": "test map", "level": "house-1", "quick": True, "repeats": 3,
               "config": {"budget_s": 1.0}, "load_avg_1m_end": 0.0, "wall_s": 1.0}
    return assemble_result(metrics, context)


def test_bench_rows_round_trip_through_the_db(tmp_path):
    result = fake_result()
    rows = bench_rows(result)
    assert {r["metric"] for r in rows} == {k for k in metric_keys() if result[k] is not None}
    with ResultsDB(f"sqlite:///{tmp_path / 'b.db'}") as db:
        run_id = db.start_run(profile="bench", command="bench", config={"quick": True}, config_hash="h")
        assert db.add_bench_rows(run_id, rows) == len(rows)
        assert db.add_bench_rows(run_id, rows) == 0  # duplicates ignored
        db.finish_run(run_id)
        frame = db.bench_frame()
    assert len(frame) == len(rows)
    got = {r.metric: (r.value, r.unit, r.device, r.run_id) for r in frame.itertuples()}
    for r in rows:
        assert got[r["metric"]] == (r["value"], r["unit"], r["device"], run_id)
    assert set(frame["navbench_version"]) == {result["navbench_version"]}
    assert set(frame["cpu"]) == {result["cpu"]}


def test_cli_stores_a_run_and_prints_the_table(tmp_path, monkeypatch):
    import navbench.bench

    canned = fake_result()
    monkeypatch.setattr(navbench.bench, "run_bench", lambda **kw: dict(canned))
    url = f"sqlite:///{tmp_path / 'b.db'}"
    r = CliRunner().invoke(app, ["bench", "--quick", "--json", "--db", url])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    with ResultsDB(url) as db:
        runs = db.runs_frame()
        frame = db.bench_frame()
    assert list(runs["profile"]) == ["bench"] and list(runs["status"]) == ["done"]
    assert out["run_id"] == int(runs["id"].iloc[0])
    assert len(frame) == len(bench_rows(canned))
    r = CliRunner().invoke(app, ["bench", "--no-store"])
    assert r.exit_code == 0, r.output
    assert "paper (GPU)" in r.stdout and "target" in r.stdout


# ------------------------------------------------------------------------------ the real thing

@pytest.mark.slow
def test_quick_bench_json_has_every_key(tmp_path):
    """A real run with 2 repeats: every key is a positive float or None with a note."""
    r = CliRunner().invoke(app, ["bench", "--quick", "--json", "--repeats", "2", "--no-store",
                                 "--e2e-tasks", "1", "--cache", str(tmp_path / "no-cache")])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    for key in ("sim_frame_ms_half", "sim_frame_ms_paper", "render_ms_half", "render_ms_paper",
                "fit_step_ms", "plan_ms", "track_ms_ours_half", "track_ms_ours_paper",
                "track_ms_emission_half", "control_step_hz_half", "control_step_hz_paper"):
        assert key in out
    for key in metric_keys():
        v = out[key]
        assert v is None or (isinstance(v, float) and v > 0 and math.isfinite(v)), (key, v)
        if v is None:
            assert out["notes"][key], key
    for key in ("paper", "host", "cpu", "navbench_version", "torch_version", "device", "map"):
        assert out[key], key
    assert out["paper"]["control_step_hz"] == 16.1
    assert "voxelized" in out["map"]


def test_device_rows_run_their_code_on_the_cpu():
    """The CUDA rows time the fit's device path (render_rays_torch, fit_map(device=...)); run
    that very code on the CPU (``torch-cpu``) so it is exercised on machines without a GPU."""
    from navbench.bench import time_diff_render, time_fit_step
    from navbench.levelio import resolve_level
    from navbench.worldmodel.grid import grid_for_level, voxelize_level

    level = resolve_level("house-1")
    vmap = voxelize_level(level, grid_for_level(level, shape=(60, 60, 12)))
    import torch

    gpu = ["cuda"] if torch.cuda.is_available() else []  # on a GPU machine: the GPU rows' own code
    for device in ["cpu", "torch-cpu", *gpu]:
        times = time_diff_render(level, vmap, 400, repeats=2, warmup=1, device=device)
        assert len(times) == 2 and all(t > 0 for t in times)
    for device in ["torch-cpu", *gpu]:
        times = time_fit_step(level, repeats=2, warmup=1, views_count=4, device=device)  # 3 x 10 steps
        assert len(times) == 2 and all(t > 0 for t in times)


def test_unknown_level_is_a_user_error(tmp_path):
    from navbench.errors import LevelError

    r = CliRunner().invoke(app, ["bench", "--level", "no-such-level", "--db", f"sqlite:///{tmp_path / 'b.db'}"])
    assert isinstance(r.exception, LevelError)
    assert not (tmp_path / "b.db").exists()  # failed before a run was recorded


def test_bench_map_prefers_a_cached_fitted_map_of_the_level(tmp_path):
    import hashlib
    from pathlib import Path

    from navbench.bench import bench_map
    from navbench.levelio import level_path, resolve_level
    from navbench.pipeline.cache import ArtifactStore
    from navbench.worldmodel.grid import GridSpec, save_map, voxelize_level

    level = resolve_level("house-1")
    level_file = level_path("house-1")
    key = hashlib.sha256(Path(level_file).read_bytes()).hexdigest()
    small = voxelize_level(level, GridSpec((0, 0, -0.15), (11.4, 11.4, 1.35), (8, 8, 4)))
    store = ArtifactStore(tmp_path / "cache")
    store.write("fit-map", "a" * 64, lambda d: save_map(small, d / "map.npz"), config={},
                inputs={"level": "0" * 64}, version=1)  # another level: ignored
    store.write("fit-map", "b" * 64, lambda d: save_map(small, d / "map.npz"), config={},
                inputs={"level": key}, version=1)
    vmap, desc = bench_map(level, level_file, tmp_path / "cache")
    assert vmap.spec.shape == (8, 8, 4)
    assert desc.startswith("fitted map fit-map/bbbbbbbbbbbb")
