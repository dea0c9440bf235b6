"""navbench bench as a table of measurements: the keys are pinned, and the loop over the table
is run with fake timers (no timing), so the result's layout is checked in a second."""

from __future__ import annotations

import pytest

import navbench.bench.run as bench_run
from navbench.bench import (
    TABLE,
    TARGETS,
    BenchConfig,
    BenchContext,
    Measurement,
    NotMeasured,
    Reading,
    metric_keys,
    run_bench,
    timers,
)
from navbench.bench.run import measure

#: The metric keys of ``navbench bench`` before the table existed (a972844..439556e), in order.
PINNED_METRIC_KEYS = [
    "sim_frame_ms_half", "sim_frame_ms_paper", "sim_frame_ms_paper_ours", "sim_step_ms", "render_ms_half", "render_ms_paper",
    "diffrender_ms_5000", "diffrender_ms_1000", "fit_step_ms", "fit_10k_steps_s",
    "diffrender_ms_5000_cuda", "fit_step_ms_cuda", "fit_10k_steps_s_cuda", "plan_ms",
    "track_ms_ours_half", "track_ms_ours_adam_half", "track_ms_ours_gauss_newton_half",
    "track_ms_no_map_half", "track_ms_emission_half", "track_ms_ours_paper", "track_ms_ours_adam_paper",
    "track_ms_ours_gauss_newton_paper", "track_ms_no_map_paper", "track_ms_emission_paper",
    "emission_ours_ratio_half", "emission_ours_ratio_paper", "control_step_ms_half",
    "control_step_hz_half", "control_step_ms_paper", "control_step_hz_paper",
    "e2e_episodes_per_min", "e2e_steps_per_s",
    # issue 17: appended
    "agent_step_ms_half", "agent_step_ms_paper", "e2e_episodes_per_min_paper",
    # issue 15: appended
    "fusion_ms_half", "fusion_ms_paper",
    "agent_step_ms_paper_ref05", "control_step_ms_paper_ref05",  # issue 17, part 2
    "e2e_episodes_per_min_paper_ref05",  # the paper profile's ours
    "sim_frame_texture_ratio_half", "sim_frame_texture_ratio_paper",  # issue 36: texture modes
    # issue 36: the version under test (navbench-5; navbench-2's _v2 rows until it failed) beside
    # navbench-1 in the same run
    "agent_step_ms_paper_ref05_v5", "control_step_ms_paper_ref05_v5", "e2e_episodes_per_min_paper_ref05_v5",
    "e2e_v5_over_v1_paper_ref05",
]
#: The other top-level keys of the result (host, map, config, per-key tables ...).
PINNED_OTHER_KEYS = {
    "config", "cpu", "cpu_count", "cuda_device", "device", "devices", "groups", "host", "labels",
    "level", "load_avg_1m_end", "load_avg_1m_start", "map", "navbench_version", "notes",
    "numba_threads", "numba_version", "numpy_version", "paper", "paper_hardware", "paper_vs",
    "platform", "python_version", "quick", "render_step_m", "repeats", "section_s",
    "stats", "targets", "torch_threads", "torch_version", "units", "wall_s",
}
#: The progress labels of a quick run without CUDA, 2 workers (as before the table).
PINNED_PROGRESS = [
    "map", "simulator frame (half)", "simulator frame (paper)", "simulator frame (paper, ours' pixels)",
    "simulator step",
    "map render (half)", "map render (paper)", "differentiable render (5000 rays)",
    "differentiable render (1000 rays)", "fit-map step", "A* plan", "record a walk (half)",
    *(f"tracking {p} (half)" for p in ("ours", "ours_adam", "ours_gauss_newton", "no_map", "emission")),
    "record a walk (paper)",
    *(f"tracking {p} (paper)" for p in ("ours", "ours_adam", "ours_gauss_newton", "no_map", "emission")),
    "control step (half)", "control step (paper)", "end to end (2 tasks x 1 estimators, 2 workers)",
    "agent step (half)", "agent step (paper)", "end to end (2 tasks x 1 estimators, 2 workers), paper camera",
    "online fusion (half)", "online fusion (paper)",
    "agent step (paper, reference_scale 0.5)", "control step (paper, reference_scale 0.5)",
    "end to end (2 tasks x 1 estimators, 2 workers), paper camera, ours reference_scale 0.5",
    "simulator frame, texture modes (half)", "simulator frame, texture modes (paper)",
    "agent step (paper, reference_scale 0.5, navbench-5)", "control step (paper, reference_scale 0.5, navbench-5)",
    "end to end (2 tasks x 1 estimators, 2 workers), paper camera, ours reference_scale 0.5, navbench-5",
    "done",
]


def test_metric_keys_are_the_table_and_pinned():
    assert metric_keys() == [row.key for row in TABLE] == PINNED_METRIC_KEYS
    assert [t.key for t in TARGETS] == ["render_ms_paper", "track_ms_ours_paper", "control_step_hz_paper",
                                        "control_step_hz_half", "emission_ours_ratio_half", "fit_10k_steps_s",
                                        "agent_step_ms_paper", "control_step_hz_paper",
                                        "agent_step_ms_paper_ref05_v5", "e2e_v5_over_v1_paper_ref05"]


@pytest.fixture
def fake_timers(monkeypatch):
    """Every timer returns [1, 2, 3] ms (the end-to-end run: 2 episodes, 90 steps in 1.5 s)."""
    from navbench.levelio import resolve_level
    from navbench.worldmodel.grid import grid_for_level, voxelize_level

    level = resolve_level("house-1")
    vmap = voxelize_level(level, grid_for_level(level, shape=(30, 30, 6)))
    calls = []

    def fake(name):
        def timer(*args, **kwargs):
            calls.append((name, args, kwargs))
            return [1.0, 2.0, 3.0]
        return timer

    for name in ("time_sim_frame", "time_sim_step", "time_map_render", "time_diff_render",
                 "time_fit_step", "time_plan", "time_tracking", "time_control_step", "time_fusion"):
        monkeypatch.setattr(timers, name, fake(name))
    monkeypatch.setattr(timers, "time_sim_frame_textures",
                        lambda *a, **k: {"procedural": [4.0, 6.0, 8.0], "table": [2.0, 2.0, 2.0],
                                         "polynomial": [3.0, 3.0, 3.0]})
    monkeypatch.setattr(timers, "record_walk", lambda *a, **k: "walk")
    monkeypatch.setattr(timers, "bench_tasks", lambda *a, **k: [])
    monkeypatch.setattr(timers, "time_navigation", lambda *a, **k: timers.Throughput(2, 90, 1.5, 2))
    monkeypatch.setattr(bench_run, "bench_map", lambda *a, **k: (vmap, "fake map"))
    return calls


def test_the_loop_gives_the_pinned_layout(fake_timers):
    said = []
    result = run_bench(config=BenchConfig(quick=True, cuda=False, workers=2), progress=said.append)
    assert set(result) == set(PINNED_METRIC_KEYS) | PINNED_OTHER_KEYS
    assert said == PINNED_PROGRESS
    assert set(result["section_s"]) == set(PINNED_PROGRESS[:-1])
    for key in PINNED_METRIC_KEYS:
        assert set(result["units"]) == set(result["labels"]) == set(result["devices"]) == set(PINNED_METRIC_KEYS)
        assert result[key] is not None or result["notes"][key], key
    # timed rows: the median; derived rows: from the rows above them
    assert result["render_ms_paper"] == 2.0 and result["stats"]["render_ms_paper"]["n"] == 3
    assert result["fit_10k_steps_s"] == 20.0 and result["units"]["fit_10k_steps_s"] == "s"
    assert result["track_ms_emission_half"] == 20.0  # quick: 10 Adam steps scaled to 100
    assert result["notes"]["track_ms_emission_half"].startswith("quick: measured with 10 Adam steps")
    assert result["emission_ours_ratio_half"] == 10.0 and result["units"]["emission_ours_ratio_half"] == "x"
    # issue 36: the median of the interleaved per-repeat ratios, both medians in the note
    assert result["sim_frame_texture_ratio_paper"] == 3.0
    assert "procedural 6.00 ms, table 2.00 ms" in result["notes"]["sim_frame_texture_ratio_paper"]
    assert result["control_step_hz_half"] == 500.0 and result["stats"]["control_step_hz_half"]["q1"] == 1000 / 2.5
    assert result["e2e_episodes_per_min"] == 80.0 and result["e2e_steps_per_s"] == 60.0
    assert result["labels"]["e2e_steps_per_s"] == "episode steps per second (2 workers)"
    assert result["labels"]["track_ms_ours_half"].startswith("track ours, default = ")
    # CUDA off: n/a with the reason, on the cuda device; the extrapolation is n/a too
    for key in ("diffrender_ms_5000_cuda", "fit_step_ms_cuda", "fit_10k_steps_s_cuda"):
        assert result[key] is None and result["devices"][key] == "cuda:0"
    assert result["notes"]["fit_step_ms_cuda"] == "CUDA disabled"
    assert [t["key"] for t in result["targets"]] == [t.key for t in TARGETS]
    assert result["paper_vs"]["render_ms_paper"] == 50.0 and "render_ms_half" not in result["paper_vs"]
    # the declared repeats: 5 quick, 50 x 5 simulator steps, 3 fit blocks, >= 10 control steps
    n_of = {name: args[-1] if name != "time_tracking" else args[5] for name, args, _ in fake_timers
            if name in ("time_sim_step", "time_fit_step", "time_tracking", "time_control_step")}
    assert n_of == {"time_sim_step": 250, "time_fit_step": 3, "time_tracking": 5, "time_control_step": 10}
    # the agent step: the control step's timer without the simulator's component
    agent = [kw for name, _, kw in fake_timers if name == "time_control_step" and kw.get("exclude")]
    assert len(agent) == 4 and all(kw["exclude"] == ("sim",) for kw in agent)
    # issue 17, part 2: the _ref05 rows pass ours' option reference_scale = 0.5, the others none;
    # issue 36: the _v5 rows add navbench-5's settings (ours' options, the camera's texture mode)
    ref05 = [kw for name, _, kw in fake_timers if name == "time_control_step" and kw.get("options")]
    from navbench.benchmark import version_settings

    v2 = {k.rsplit(".", 1)[1]: v for k, v in version_settings("navbench-5").items()
          if k.startswith("navigation.options.ours.")}
    assert v2 and [kw["options"] for kw in ref05] == [{"reference_scale": 0.5}] * 2 + [{"reference_scale": 0.5, **v2}] * 2
    assert [kw.get("exclude", ()) for kw in ref05] == [("sim",), (), ("sim",), ()]
    assert [kw.get("texture", "procedural") for kw in ref05] == ["procedural"] * 2 + ["table"] * 2
    assert result["e2e_episodes_per_min_paper"] == 80.0


def test_e2e_and_estimator_conditions(fake_timers, monkeypatch):
    result = run_bench(config=BenchConfig(quick=True, cuda=False, e2e_tasks=0))
    assert result["e2e_steps_per_s"] is None and result["notes"]["e2e_steps_per_s"] == "disabled (0 tasks)"
    assert result["labels"]["e2e_steps_per_s"] == "episode steps per second"
    monkeypatch.setattr("navbench.track.registry.known_estimators", lambda: ["ours"])
    result = run_bench(config=BenchConfig(quick=True, cuda=False, e2e_tasks=0))
    assert result["track_ms_emission_paper"] is None
    assert result["notes"]["track_ms_emission_paper"] == "estimator 'emission' not available yet"
    assert result["emission_ours_ratio_paper"] is None
    assert result["notes"]["emission_ours_ratio_paper"] == "needs both the emission and the ours-Adam step"
    assert result["paper_vs"]["track_ms_emission_paper"] == 250.0
    assert result["control_step_hz_paper"] == 500.0


def test_measure_rows():
    ctx = BenchContext(BenchConfig(quick=True), None, None, None, "", 0.1, frozenset(), False)

    def failing(_ctx, _n):
        raise NotMeasured("CUDA run failed: out of memory")

    na = measure(Measurement("k", "g", "a label", failing, paper=3.0), ctx)
    assert (na.value, na.stats, na.note, na.paper) == (None, None, "CUDA run failed: out of memory", 3.0)
    empty = measure(Measurement("k", "g", "l", lambda _c, _n: [], note="why"), ctx)
    assert empty.value is None and empty.stats.n == 0
    assert empty.note == "nothing was timed (no repeat completed); why"
    got = measure(Measurement("k", "g", lambda c: f"{c.n} repeats", lambda _c, n: Reading(value=n, note="x"),
                              repeats=lambda n, quick: 2 * n if quick else n), ctx)
    assert (got.value, got.label, got.note) == (10, "5 repeats", "x")
    assert measure(Measurement("k", "g", "l", lambda _c, _n: None, needs=lambda c: "no"), ctx).note == "no"
