"""Where a run's time went: a per-stage and per-component breakdown of ``navbench all``.

Stages (kind ``stage``): the wall-clock seconds of every cached stage the run went through
(:meth:`StageContext.run <navbench.pipeline.stages.StageContext.run>` records each call: the
compute when it ran, the cache lookup when it did not), summed by stage name, with the number of
calls and how many were cache hits; plus ``run-navigation``, the episodes' stage as a whole.

With overlap (:mod:`navbench.pipeline.overlap`), the stages of the levels after the first run in
a background process beside the episodes: their compute seconds are rows of their own,
``<stage> (overlapped)``, and stage seconds then add up to more than the run took. The row of
kind ``wall`` (name ``run``) is the run's wall-clock seconds, printed under the stages' sum.

Components (kind ``component``): the per-step timing components of every episode simulated by
the run (:data:`navbench.nav.timing.TIMING_KEYS`: ``sim``, ``render``, ``estimate``, ``plan``,
``control``), summed over steps and episodes in seconds of worker time, with the number of steps;
``store``, the parent's writing of trajectories and rows; and ``other``, the workers' time
outside the components (``wall x workers - components``: simulator and estimator set-up,
transfers, idle workers at the end of the run).

Estimators (kind ``estimator``): the same component seconds split by the estimator whose
episodes they were (``count``: its steps), so the cost of ``ours`` and ``no-map`` steps shows
beside the frame-less ``dynamics``.

:func:`breakdown_rows` builds the rows (plain dicts: ``kind, name, seconds, count, cached``), the
results database stores them with the run (:meth:`ResultsDB.add_run_timings
<navbench.results.db.ResultsDB.add_run_timings>`, table ``run_timings``), :func:`format_breakdown`
lays them out as text (the CLI prints it at the end of ``navbench all``).
"""

from __future__ import annotations

from typing import Any, Iterable

from navbench.nav.timing import TIMING_KEYS

KINDS = ("stage", "component", "estimator", "wall")
#: The name suffix of the stage rows computed in the background beside the episodes.
OVERLAPPED = " (overlapped)"


def stage_rows(timings: Iterable[tuple]) -> list[dict]:
    """``(stage, seconds, cached)`` calls summed by stage, in first-seen order; a call
    ``(stage, seconds, cached, True)`` ran in the background: row ``<stage> (overlapped)``."""
    out: dict[str, dict] = {}
    for stage, seconds, cached, *background in timings:
        name = stage + OVERLAPPED if background and background[0] else stage
        row = out.setdefault(name, {"kind": "stage", "name": name, "seconds": 0.0, "count": 0, "cached": 0})
        row["seconds"] += float(seconds)
        row["count"] += 1
        row["cached"] += int(bool(cached))
    return list(out.values())


def breakdown_rows(stage_timings: Iterable[tuple], navigation: Any = None,
                   navigation_s: float | None = None, workers: int = 1,
                   wall_s: float | None = None) -> list[dict]:
    """The breakdown of a run: its stages, then (with ``navigation``, a
    :class:`~navbench.pipeline.stages.NavigationSummary`) the episodes' components.

    ``navigation_s``: the navigation stage's wall-clock seconds; ``workers``: the executor's
    worker count (for ``other``); ``wall_s``: the run's wall-clock seconds (a ``wall`` row).
    """
    rows = stage_rows(stage_timings)
    if wall_s is not None:
        rows.append({"kind": "wall", "name": "run", "seconds": float(wall_s), "count": 1, "cached": 0})
    if navigation is None:
        return rows
    if navigation_s is not None:
        rows.append({"kind": "stage", "name": "run-navigation", "seconds": float(navigation_s),
                     "count": int(navigation.ran), "cached": int(navigation.already_done + navigation.from_cache)})
    comp = dict(getattr(navigation, "component_s", {}) or {})
    steps = int(getattr(navigation, "steps", 0) or 0)
    for key in TIMING_KEYS:
        rows.append({"kind": "component", "name": key, "seconds": float(comp.get(key, 0.0)),
                     "count": steps, "cached": 0})
    rows.append({"kind": "component", "name": "store", "seconds": float(getattr(navigation, "store_s", 0.0)),
                 "count": int(navigation.ran), "cached": 0})
    for name, (seconds, n) in (getattr(navigation, "estimator_s", {}) or {}).items():
        rows.append({"kind": "estimator", "name": str(name), "seconds": float(seconds), "count": int(n),
                     "cached": 0})
    if navigation_s is not None and navigation.ran:
        busy = sum(float(comp.get(k, 0.0)) for k in TIMING_KEYS)
        rows.append({"kind": "component", "name": "other",
                     "seconds": max(0.0, float(navigation_s) * max(1, int(workers)) - busy),
                     "count": int(navigation.ran), "cached": 0})
    return rows


def format_breakdown(rows: list[dict]) -> str:
    """The breakdown as a plain-text table: stages with their share of the stages' total, then
    components with their share of the components' total and milliseconds per step."""
    lines = []
    wall = [r for r in rows if r["kind"] == "wall"]
    overlapped = any(r["kind"] == "stage" and r["name"].endswith(OVERLAPPED) for r in rows)
    w = max([20, *(len(r["name"]) + 1 for r in rows)])  # "fit-map (overlapped)" and the like
    for kind, title in (("stage", "stage"), ("component", "episode component"), ("estimator", "estimator")):
        part = [r for r in rows if r["kind"] == kind]
        if not part:
            continue
        total = sum(r["seconds"] for r in part)
        if kind != "stage" and total == 0 and not any(r["count"] for r in part):
            lines.append(f"{title}s: none (no episode ran in this run)")
            continue
        lines.append(f"{title:<{w}} {'seconds':>10} {'share':>7} {'count':>8}  notes")
        for r in part:
            share = 100.0 * r["seconds"] / total if total > 0 else 0.0
            if kind == "stage":
                note = f"{r['cached']} cached" if r["cached"] else ""
            else:
                steps = r["count"] if kind == "estimator" or r["name"] in TIMING_KEYS else 0
                note = f"{1e3 * r['seconds'] / steps:.2f} ms/step" if steps else \
                    ("per episode" if r["count"] else "")
            lines.append(f"{r['name']:<{w}} {r['seconds']:>10.2f} {share:>6.1f}% {r['count']:>8}  {note}".rstrip())
        label = "total (summed)" if kind == "stage" and overlapped else "total"
        lines.append(f"{label:<{w}} {total:>10.2f}")
        if kind == "stage" and wall:
            note = ("  the overlapped stages ran beside the episodes: the sum exceeds the wall time"
                    if overlapped else "")
            lines.append(f"{'wall':<{w}} {wall[0]['seconds']:>10.2f}{note}")
    return "\n".join(lines)
