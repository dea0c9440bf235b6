"""Running the benchmark: :func:`run_bench` builds the shared :class:`BenchContext` once and
runs every row of :data:`~navbench.bench.table.TABLE` through :func:`measure`;
:func:`assemble_result` lays the rows out as the JSON-ready result and :func:`bench_rows` as
rows of the results database."""

from __future__ import annotations

import dataclasses
import math
import os
import platform
import socket
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from navbench.bench.core import PAPER_FIGURES, PAPER_HARDWARE, BenchConfig, Metric, stats
from navbench.bench.table import TARGETS, BenchContext, Measurement, NotMeasured, Reading, TABLE, metric_keys
from navbench.bench.timers import bench_map


def host_info() -> dict[str, Any]:
    """Host name, CPU model and cores, load average, library versions and thread counts."""
    import numba
    import torch

    from navbench import __version__
    from navbench.results.db import cpu_description

    cuda = torch.cuda.is_available()
    load = os.getloadavg() if hasattr(os, "getloadavg") else (math.nan,) * 3
    return {
        "host": socket.gethostname(),
        "cpu": cpu_description(),
        "cpu_count": os.cpu_count(),
        "platform": platform.platform(),
        "python_version": platform.python_version(),
        "navbench_version": __version__,
        "torch_version": torch.__version__,
        "numba_version": numba.__version__,
        "numpy_version": np.__version__,
        "torch_threads": torch.get_num_threads(),
        "numba_threads": numba.get_num_threads(),
        "cuda_device": torch.cuda.get_device_name(0) if cuda else None,
        "device": "cpu + cuda:0" if cuda else "cpu",
        "load_avg_1m_start": float(load[0]),
    }


def measure(row: Measurement, ctx: BenchContext) -> Metric:
    """Run one row of the table: n/a with the reason when ``row.needs`` gives one (or the run
    raises :class:`~navbench.bench.table.NotMeasured`), else build its shared inputs, announce
    it, run it and turn what it returns into a :class:`Metric` (timed repeats: their
    :class:`Stats` and median; a number: a derived value)."""
    label = row.label(ctx) if callable(row.label) else row.label

    def na(why: str) -> Metric:
        return Metric(row.key, row.group, label, row.unit, None, None, row.device, row.paper, why)

    why = row.needs(ctx)
    if why is not None:
        return na(why)
    for name in row.uses:
        ctx.use(name)
    if row.progress is not None:
        ctx.say(row.progress)
    try:
        got = row.run(ctx, row.repeats(ctx.n, ctx.quick))
    except NotMeasured as e:
        return na(str(e))
    r = got if isinstance(got, Reading) else Reading(times=got) if isinstance(got, list) else Reading(value=got)
    note = r.note if r.note is not None else row.note(ctx) if callable(row.note) else row.note
    label = r.label or label
    if r.times is None:
        return Metric(row.key, row.group, label, row.unit, r.value, r.stats, row.device, row.paper, note)
    s = stats(r.times)
    if not s.n:
        note = "nothing was timed (no repeat completed)" + (f"; {note}" if note else "")
    return Metric(row.key, row.group, label, row.unit, s.median if s.n else None, s, row.device, row.paper, note)


def run_bench(quick: bool = False, repeats: int | None = None, config: BenchConfig | None = None,
              progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run every measurement of the table (see :mod:`navbench.bench`) and return the JSON-ready
    result.

    ``quick``/``repeats`` fill a default :class:`BenchConfig` when ``config`` is None.
    ``progress(label)`` is called before each measurement. Result keys: every
    :func:`metric_keys` entry (a positive float, or None with ``notes[key]``), ``stats``
    (per key: n, median, q1, q3, min, max), ``units``, ``devices``, ``paper`` (the paper's
    figures), ``paper_hardware``, ``targets``, ``map``, ``config``, ``wall_s``, ``notes`` and
    :func:`host_info`.
    """
    import torch

    from navbench.levelio import level_path, resolve_level
    from navbench.track.registry import known_estimators
    from navbench.worldmodel.fastrender import map_step

    cfg = config if config is not None else BenchConfig(quick=quick, repeats=repeats)
    sections: dict[str, float] = {}
    last: list[Any] = [None, time.perf_counter()]

    def say(label: str) -> None:
        """Announce a section; the time since the previous one is that one's ``section_s``."""
        now = time.perf_counter()
        if last[0] is not None:
            sections[last[0]] = round(now - last[1], 3)
        last[0], last[1] = label, now
        if progress is not None:
            progress(label)

    t_start = time.perf_counter()
    info = host_info()
    level = resolve_level(cfg.level, cfg.root)
    level_file = Path(cfg.level) if Path(cfg.level).suffix == ".json" else level_path(cfg.level, cfg.root)
    level_file = level_file if level_file.is_file() else None
    say("map")
    vmap, map_desc = bench_map(level, level_file, cfg.cache_root, cfg.map_path)
    use_cuda = torch.cuda.is_available() if cfg.cuda is None else (cfg.cuda and torch.cuda.is_available())
    ctx = BenchContext(cfg, level, level_file, vmap, map_desc, map_step(vmap, None),
                       frozenset(known_estimators()), use_cuda, say)
    for row in TABLE:
        ctx.metrics[row.key] = measure(row, ctx)
    say("done")

    load = os.getloadavg() if hasattr(os, "getloadavg") else (math.nan,)
    context = {**info, "map": map_desc, "render_step_m": ctx.step, "level": cfg.level, "quick": cfg.quick,
               "repeats": cfg.n, "config": {**dataclasses.asdict(cfg), "repeats": cfg.n, "budget_s": cfg.budget},
               "load_avg_1m_end": float(load[0]), "wall_s": time.perf_counter() - t_start,
               "section_s": sections}
    return assemble_result(ctx.metrics, context)


def assemble_result(metrics: dict[str, Metric], context: dict[str, Any]) -> dict[str, Any]:
    """The JSON-ready result of :func:`run_bench` from its :class:`Metric` rows (one per
    :func:`metric_keys` entry) and ``context`` (host information, map, config, ...)."""
    missing = [k for k in metric_keys() if k not in metrics]
    if missing:
        raise ValueError(f"bench result lacks {missing}")  # a bug in the caller, not a user error
    out: dict[str, Any] = {k: metrics[k].value for k in metric_keys()}
    out.update(context)
    out["stats"] = {k: m.stats._asdict() | {"iqr": m.stats.iqr} for k, m in metrics.items()
                    if m.stats is not None and m.stats.n}
    out["units"] = {k: m.unit for k, m in metrics.items()}
    out["labels"] = {k: m.label for k, m in metrics.items()}
    out["groups"] = {k: m.group for k, m in metrics.items()}
    out["devices"] = {k: m.device for k, m in metrics.items()}
    out["paper_vs"] = {k: m.paper for k, m in metrics.items() if m.paper is not None}
    out["notes"] = {k: m.note for k, m in metrics.items() if m.note}
    out["paper"] = dict(PAPER_FIGURES)
    out["paper_hardware"] = PAPER_HARDWARE
    out["targets"] = [{"key": t.key, "label": t.label, "op": t.op, "threshold": t.threshold,
                       "value": out[t.key], "passed": t.check(out[t.key])} for t in TARGETS]
    return out


def bench_rows(result: dict[str, Any]) -> list[dict]:
    """Rows for :meth:`navbench.results.db.ResultsDB.add_bench_rows`: one per measured key
    (the median, or the derived value), with its unit and device; n/a keys are left out."""
    rows = []
    for key in metric_keys():
        value = result.get(key)
        if value is None:
            continue
        rows.append({"metric": key.removesuffix("_cuda"), "value": float(value),
                     "unit": result["units"][key], "device": result["devices"][key],
                     "host": result.get("host"), "cpu": result.get("cpu"),
                     "navbench_version": result.get("navbench_version")})
    return rows
