"""Speed benchmark of every per-step component (issue #7), the library behind ``navbench bench``.

The benchmark is a table of measurements driven by a short loop:

* :mod:`navbench.bench.core` -- the paper's figures, :class:`Stats`, :class:`Target`,
  :class:`BenchConfig`, :class:`Metric` and :func:`timed_loop`;
* :mod:`navbench.bench.timers` -- the ``time_*`` functions, each measuring one thing;
* :mod:`navbench.bench.table` -- :data:`TABLE`, one :class:`Measurement` row per result key
  (unit, repeats, conditions and why-n/a notes, device, paper figure), and :data:`TARGETS`;
* :mod:`navbench.bench.run` -- :func:`run_bench` (the loop), :func:`assemble_result`,
  :func:`bench_rows` and :func:`host_info`.

Each ``time_*`` function returns a list of wall-clock **milliseconds**, one per timed repeat:
``warmup`` untimed calls first (numba compilation, torch start-up, caches), then ``repeats``
timed calls with :func:`time.perf_counter`, stopping early once ``budget_s`` seconds are spent
and at least ``min(3, repeats)`` repeats are in. Inputs (poses, pixels, trajectories, tasks) are
drawn from explicit seeds, so two runs time the same work.

:func:`run_bench` runs all of them on one level (house-1) and one map -- the newest fitted map
of that level in the stage cache (``results/cache/fit-map``) if there is one, else the level's
true geometry voxelized on the paper's 200 x 200 x 20 grid -- and returns one JSON-ready dict:
medians under flat keys (``render_ms_paper`` ...), the full statistics per metric, the paper's
figures, the issue's targets with pass/fail, the host and the library versions. A key whose
measurement is impossible here (no CUDA device, an estimator that does not exist yet) holds
``None`` and ``notes[key]`` says why.

The paper's figures (section 5, fig. 4c) were taken on an NVIDIA Quadro RTX 8000 GPU with 8
Intel Xeon Gold 6252 cores; everything here runs on the CPU unless stated, so compare with care.
"""

from navbench.bench.core import (
    EMISSION_STEPS,
    FIT_BATCH,
    FIT_STEPS,
    PAPER_FIGURES,
    PAPER_HARDWARE,
    QUICK_EMISSION_STEPS,
    RAY_SAMPLES,
    RAY_STEP,
    TRACK_PIXELS,
    BenchConfig,
    Metric,
    Stats,
    Target,
    stats,
    timed_loop,
)
from navbench.bench.run import assemble_result, bench_rows, host_info, measure, run_bench
from navbench.bench.table import (
    CAMERA_NAMES,
    SHARED,
    TABLE,
    TARGETS,
    TRACKERS,
    BenchContext,
    Measurement,
    NotMeasured,
    Reading,
    metric_keys,
)
from navbench.bench.timers import (
    Throughput,
    Walk,
    bench_map,
    bench_tasks,
    far_pair,
    record_walk,
    time_control_step,
    time_diff_render,
    time_fit_step,
    time_map_render,
    time_navigation,
    time_plan,
    time_sim_frame,
    time_sim_step,
    time_tracking,
)

__all__ = [
    "CAMERA_NAMES", "EMISSION_STEPS", "FIT_BATCH", "FIT_STEPS", "PAPER_FIGURES", "PAPER_HARDWARE",
    "QUICK_EMISSION_STEPS", "RAY_SAMPLES", "RAY_STEP", "SHARED", "TABLE", "TARGETS", "TRACKERS",
    "TRACK_PIXELS", "BenchConfig", "BenchContext", "Measurement", "Metric", "NotMeasured",
    "Reading", "Stats", "Target", "Throughput", "Walk", "assemble_result", "bench_map",
    "bench_rows", "bench_tasks", "far_pair", "host_info", "measure", "metric_keys", "record_walk",
    "run_bench", "stats", "time_control_step", "time_diff_render", "time_fit_step",
    "time_map_render", "time_navigation", "time_plan", "time_sim_frame", "time_sim_step",
    "time_tracking", "timed_loop",
]
