"""Values into rows: cleaning Python values for storage, the facts a run records about its
machine, an episode's row from its score, and the column filters of the ``*_frame`` queries."""

from __future__ import annotations

import math
import os
import platform
import subprocess
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from navbench.nav.timing import TIMING_COLUMNS, TIMING_KEYS


def _utcnow() -> datetime:
    return datetime.now(timezone.utc)


def _clean(value: Any) -> Any:
    """numpy scalars -> Python; NaN/inf floats -> None (stored as NULL everywhere)."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _clean_json(obj: Any) -> Any:
    from navbench.config import to_jsonable

    return to_jsonable(obj if obj is not None else {})


def _one_line(exc: BaseException) -> str:
    """The first line of an error's message: of the driver's own error when SQLAlchemy wraps
    one (``DBAPIError.orig``)."""
    # getattr: ``exc`` may be any exception (ArgumentError, ValueError, ImportError...); only
    # SQLAlchemy's DBAPIError has ``orig``, and even there it may be None.
    orig = getattr(exc, "orig", None) or exc
    text = str(orig).strip().splitlines()
    return text[0] if text else type(orig).__name__


def git_commit(cwd: str | Path | None = None) -> str | None:
    """HEAD commit of the git checkout holding ``cwd`` (default: the current directory), else None."""
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=cwd, capture_output=True, text=True, timeout=5,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    sha = out.stdout.strip()
    return sha if out.returncode == 0 and len(sha) == 40 else None


def cpu_description() -> str:
    """CPU model name (from /proc/cpuinfo on Linux) and logical core count."""
    name = ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    name = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    name = name or platform.processor() or platform.machine() or "unknown"
    return f"{name} ({os.cpu_count() or '?'} threads)"


def _median(values: Any) -> float | None:
    arr = np.asarray(values, dtype=float).ravel()
    arr = arr[np.isfinite(arr)]
    return float(np.median(arr)) if arr.size else None


def episode_row_from_score(cell_key: str, meta: dict, score: Any, traj_key: str | None) -> dict:
    """One ``episodes`` row (for :meth:`ResultsDB.add_episodes`) from an episode's score.

    ``meta``: ``level, map_key, task_set_key, estimator, estimator_options (dict), noise, seed,
    task_id, timings_ms`` (component name of :data:`~navbench.nav.timing.TIMING_KEYS` -> (T,)
    per-step milliseconds), optionally ``condition_key`` (the cell's key without task set and
    estimator, :func:`navbench.pipeline.stages.grid.make_cells`). ``score`` is a :class:`navbench.nav.metrics.EpisodeScore` (success,
    path_length, optimal_length, spl_term, loc_rmse_m, rot_rmse_deg, steps, end_reason,
    collided). Timings are stored as per-component medians; ``step_ms`` is the median over steps
    of the per-step sum of all components (or the sum of the medians when their lengths differ).
    """
    timings = meta.get("timings_ms") or {}
    row: dict[str, Any] = {
        "cell_key": cell_key,
        "level": meta["level"],
        "map_key": meta.get("map_key"),
        "task_set_key": meta.get("task_set_key"),
        "task_id": int(meta["task_id"]),
        "estimator": meta["estimator"],
        "estimator_options": dict(meta.get("estimator_options") or {}),
        "noise": meta["noise"],
        "seed": int(meta["seed"]),
        "success": bool(score.success),
        "spl_term": float(score.spl_term),
        "path_length": float(score.path_length),
        "optimal_length": float(score.optimal_length),
        "steps": int(score.steps),
        "end_reason": score.end_reason,
        "collided": bool(score.collided),
        "loc_rmse_m": score.loc_rmse_m,
        "rot_rmse_deg": score.rot_rmse_deg,
        "traj_key": traj_key,
    }
    if meta.get("condition_key") is not None:
        row["condition_key"] = str(meta["condition_key"])
    for name in ("final_dist_m", "final_geo_m"):  # issue 15 (EpisodeScore fields, NaN -> NULL)
        row[name] = _clean(float(getattr(score, name, float("nan"))))
    for name in ("goal", "goal_status", "goal_err_m", "goal_confidence", "goal_heading"):  # image goals
        if meta.get(name) is not None:
            row[name] = _clean(meta[name])
    for name, column in zip(TIMING_KEYS, TIMING_COLUMNS):
        row[column] = _median(timings[name]) if name in timings else None
    arrays = [np.asarray(v, dtype=float).ravel() for v in timings.values()]
    if arrays and all(a.size == arrays[0].size for a in arrays) and arrays[0].size:
        row["step_ms"] = _median(np.sum(arrays, axis=0))
    elif arrays:
        meds = [_median(a) for a in arrays]
        row["step_ms"] = float(sum(m for m in meds if m is not None))
    else:
        row["step_ms"] = None
    return row


def _task_fields(task: Any) -> tuple[int, tuple, tuple, float]:
    if isinstance(task, dict):
        return int(task["id"]), tuple(task["start"]), tuple(task["target"]), float(task["optimal_length"])
    return int(task.id), tuple(task.start), tuple(task.target), float(task.optimal_length)


def _apply_filters(stmt, model, filters: dict):
    table = model.__table__
    for name, value in filters.items():
        if value is None:
            continue
        if name not in table.c:
            raise ValueError(f"unknown {table.name} column {name!r}")
        col = table.c[name]
        if isinstance(value, (list, tuple, set, frozenset)):
            stmt = stmt.where(col.in_(list(value)))
        else:
            stmt = stmt.where(col == value)
    return stmt
