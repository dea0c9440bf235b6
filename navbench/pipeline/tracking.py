"""Python front doors of issue 13's tracking commands: ``track-sequence`` (:func:`track_sequence`)
and ``export-trajectories`` (:func:`export_trajectories`). The CLI commands adapt these; both
write TUM pose files through :mod:`navbench.worldmodel.tumtraj`."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from navbench.errors import ArtifactError
from navbench.pipeline.run import recorded_run
from navbench.pipeline.stages.sequence import (
    SequenceResult,
    TrackSequenceConfig,
    default_output,
    parse_odometry,
    run_tracking,
)
from navbench.pipeline.stages.context import StageContext
from navbench.pipeline.stages.maps import resolve_map


def track_sequence(directory, map: Any = None, config: TrackSequenceConfig | None = None, *,
                   out: str | Path | None = None, db: Any = None, store: Any = None,
                   command: str = "track_sequence()", reading: Any = None,
                   **overrides) -> SequenceResult:
    """Track the TUM sequence in ``directory`` (the Python front door of ``track-sequence``).

    ``map``: a world model, a map file, a map artifact directory or a cache key (``None`` for
    ``no-map`` / ``dynamics``); ``config`` or keyword ``overrides`` of
    :class:`TrackSequenceConfig` (``estimator="ours", odometry="gt+mid", seed=0, options=...``).
    Writes the estimate as a strict TUM file to ``out`` (``None``: no file; ``"default"``:
    :func:`default_output`); with ``db`` (a :class:`~navbench.results.db.ResultsDB`) records a
    run and stores one ``sequence_tracking`` row. ``store``: the artifact store cache keys are
    looked up in (default ``results/cache``). ``reading``: an
    :class:`~navbench.pipeline.stages.imported.ImportOptions` when the directory's intrinsics,
    camera height or depth scale are given rather than read from its ``intrinsics.json``.
    """
    import dataclasses

    from navbench.track.registry import check_estimator_names, uses_map
    from navbench.worldmodel.tumtraj import read_sequence, write_trajectory

    cfg = dataclasses.replace(config or TrackSequenceConfig(), **overrides)
    check_estimator_names((cfg.estimator,), "--estimator")
    if cfg.estimator == "gt":
        from navbench.errors import ConfigError

        raise ConfigError("--estimator gt: reads the true pose while tracking; choose one of "
                          "ours, no-map, dynamics, emission")
    parse_odometry(cfg.odometry)
    model, map_key = None, None
    if map is not None and uses_map(cfg.estimator):
        if isinstance(map, (str, Path)):  # resolve_map's own default store: results/cache
            model, map_key = resolve_map(str(map), StageContext(store) if store is not None else None)
        else:
            model, map_key = map, map.content_hash()
    seq = read_sequence(directory, cfg.max_tilt_deg, cfg.max_dt,
                        read_views=reading.read if reading is not None else None)

    threshold = None
    if model is not None and dict(cfg.options).get("health_min_inliers") == "auto":
        from navbench.pipeline.stages.health import sequence_health_threshold

        threshold = sequence_health_threshold(StageContext(store) if store is not None else None,
                                              map, map_key, model, cfg.options)

    def work() -> SequenceResult:
        res = run_tracking(seq, model, map_key, cfg, str(directory), threshold)
        if out is not None:
            path = default_output(seq, cfg) if str(out) == "default" else Path(out)
            res.out = write_trajectory(path, seq.timestamps, res.est_poses, seq.views.camera_height)
        return res

    if db is None:
        return work()
    conf = {"sequence": str(directory), "map": map_key, "track": cfg}
    with recorded_run(db, "track-sequence", command, conf) as run_id:  # done, failed or interrupted
        res = work()
        res.stored = db.add_sequence_rows(run_id, [res.row])
    return res


# ------------------------------------------------------------------------------ export-trajectories

#: The time step (s) of exported trajectories: pose ``t`` (after ``t`` controls) gets timestamp
#: ``t * CONTROL_PERIOD_S``. navbench's steps have no wall-clock period; this nominal 10 Hz gives
#: the true and estimated files identical, increasing timestamps (all evo associates on).
CONTROL_PERIOD_S = 0.1

#: What ``export_trajectories`` can read: navigation episodes, track-eval studies, or both.
EXPORT_SOURCES = ("all", "episodes", "track-eval")


@dataclass
class ExportedPair:
    """One exported trajectory pair: ``gt`` and ``est`` TUM files with identical timestamps."""

    source: str  # "episode" or "track-eval"
    level: str
    estimator: str
    noise: str | None
    task: int  # the task id (episodes) or the trajectory index (track-eval)
    seed: int
    key: str  # the episode's trajectory key or the study's key
    gt: Path
    est: Path
    poses: int
    loc_rmse_m: float


def _slug(text: Any) -> str:
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", str(text))


def _as_list(v) -> list | None:
    if v is None:
        return None
    return [v] if isinstance(v, (str, int)) else list(v)


def export_trajectories(out_dir, db, store=None, *, run: int | None = None, level=None,
                        estimator=None, noise=None, task=None, source: str = "all",
                        dt: float = CONTROL_PERIOD_S) -> list[ExportedPair]:
    """Write the true and estimated trajectories of the selected stored episodes and track-eval
    trajectories as TUM pose files under ``out_dir`` (new or empty), one pair per trajectory:

    * episodes: ``episodes/<level>/<estimator>_<noise>_task<id>_seed<s>_<traj key[:8]>.{gt,est}.txt``;
    * studies: ``track-eval/<level>/<estimator>_<noise>_traj<i>_seed<s>_<study key[:8]>.{gt,est}.txt``;

    plus ``index.csv`` (one line per pair). Poses are the camera poses of the planar poses at the
    camera height (the convention of ``groundtruth.txt``); pose ``t`` has timestamp ``t * dt``.
    Selection (each ``None`` = all; a value or a list): ``run`` id(s), ``level``, ``estimator``,
    ``noise``, ``task`` (task id, or trajectory index of a study). A selection that matches
    nothing, or whose trajectories are no longer in the cache, is one :class:`ConfigError`.
    """
    import math

    import numpy as np

    from navbench.errors import ConfigError

    if source not in EXPORT_SOURCES:
        raise ConfigError(f"--source: expected one of {', '.join(EXPORT_SOURCES)}, got {source!r}")
    if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
        raise ConfigError(f"--dt: must be a positive number of seconds, got {dt!r}")
    out = Path(out_dir)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ConfigError(f"{out}: exists and is not an empty directory; export into a new one")
    if store is None:
        from navbench.pipeline.cache import ArtifactStore

        store = ArtifactStore()
    runs = None if run is None else ([int(run)] if isinstance(run, (int, str)) else [int(r) for r in run])
    sel = {"level": _as_list(level), "estimator": _as_list(estimator), "noise": _as_list(noise)}
    tasks = None if task is None else [int(t) for t in _as_list(task)]
    pairs: list[tuple] = []  # (meta, true (T+1, 3), est (T+1, 3), camera height)
    missing = 0
    if source in ("all", "episodes"):
        from navbench.geometry import CAMERA_HEIGHT
        from navbench.pipeline.artifacts import TRAJ_FILE, load_record

        eps = db.episodes_frame(runs, task_id=tasks, **sel)
        for r in eps.itertuples(index=False):
            if not isinstance(r.traj_key, str):
                missing += 1
                continue
            try:
                rec = load_record(store.load("episode", r.traj_key) / TRAJ_FILE)
            except Exception:  # noqa: BLE001 - gc'd or damaged: counted and reported
                missing += 1
                continue
            meta = ("episode", r.level, r.estimator, r.noise, int(r.task_id), int(r.seed), r.traj_key)
            pairs.append((meta, rec.true_poses, rec.est_poses, CAMERA_HEIGHT))
    if source in ("all", "track-eval"):
        from navbench.pipeline.artifacts import STUDY_FILE, load_study

        rows = db.tracking_frame(runs, trajectory_id=tasks, **sel)
        for key, group in rows.groupby("study_key", sort=False):
            try:
                study = load_study(store.load("track-eval", key) / STUDY_FILE)
            except Exception:  # noqa: BLE001
                missing += len(group)
                continue
            cam_h = float(study.get("config", {}).get("camera_height", 0.5))
            truth = study["trajectories"]["true_poses"]
            for r in group.itertuples(index=False):
                e = study["estimators"].get(r.estimator)
                hit = [] if e is None else np.flatnonzero((e["trajectory"] == r.trajectory_id)
                                                          & (e["seed"] == r.seed))
                if not len(hit):
                    missing += 1
                    continue
                meta = ("track-eval", r.level, r.estimator, r.noise, int(r.trajectory_id), int(r.seed), key)
                pairs.append((meta, truth[r.trajectory_id], e["est_poses"][hit[0]], cam_h))
    what = ", ".join(f"{k} {v if len(v) > 1 else v[0]}" for k, v in
                     (("run", runs), *sel.items(), ("task", tasks)) if v)
    if not pairs:
        counts = db.table_counts()
        why = (f"; {missing} matching trajectories are not in the cache {store.root}"
               f"{_cache_hint(db, store)}" if missing else f"; the database holds {counts.get('episodes', 0)} "
               f"episodes and {counts.get('tracking', 0)} track-eval rows")
        raise ConfigError(f"export-trajectories: no stored trajectory matches "
                          f"{what or 'anything'} (source {source}){why}")
    created = not out.exists()
    try:
        return _write_pairs(out, pairs, dt)
    except (OSError, ArtifactError) as e:
        if created:  # no half-written export: the folder this call made goes
            import shutil

            shutil.rmtree(out, ignore_errors=True)
        if isinstance(e, ArtifactError):
            raise
        raise ArtifactError(f"{out}: cannot write the export ({e.strerror or e})") from None


def _write_pairs(out: Path, pairs: list[tuple], dt: float) -> list[ExportedPair]:
    """Write the TUM pairs and ``index.csv`` of :func:`export_trajectories` under ``out``."""
    import numpy as np

    from navbench.nav.metrics import location_rmse
    from navbench.worldmodel.tumtraj import write_trajectory

    exported = []
    lines = ["source,level,estimator,noise,task,seed,key,poses,loc_rmse_m,gt,est"]
    for (src, lvl, est_name, nz, tid, seed, key), truth, est, cam_h in pairs:
        truth, est = np.asarray(truth, float), np.asarray(est, float)
        n = min(len(truth), len(est))
        keep = np.all(np.isfinite(est[:n]), axis=1)  # a replay cut short leaves NaN rows
        truth, est = truth[:n][keep], est[:n][keep]
        stamps = [t * dt for t in np.flatnonzero(keep)]
        folder = "episodes" if src == "episode" else "track-eval"
        tag = f"task{tid}" if src == "episode" else f"traj{tid}"
        stem = out / folder / _slug(lvl) / _slug(f"{est_name}_{nz}_{tag}_seed{seed}_{key[:8]}")
        gt_p = write_trajectory(stem.with_name(stem.name + ".gt.txt"), stamps, truth, cam_h)
        est_p = write_trajectory(stem.with_name(stem.name + ".est.txt"), stamps, est, cam_h)
        pair = ExportedPair(src, lvl, est_name, nz, tid, seed, key, gt_p, est_p, len(truth),
                            location_rmse(truth, est))
        exported.append(pair)
        lines.append(",".join(str(v) for v in (src, lvl, est_name, nz, tid, seed, key, pair.poses,
                                                f"{pair.loc_rmse_m:.9g}", gt_p.relative_to(out),
                                                est_p.relative_to(out))))
    (out / "index.csv").write_text("\n".join(lines) + "\n")
    return exported


def _cache_hint(db, store) -> str:
    """Why trajectories may be missing from ``store``: a SQLite database in another project
    folder than the cache's (its own cache is beside it: give ``--cache``), else a cache gc."""
    url = str(getattr(db, "url", ""))
    if url.startswith("sqlite:///"):
        db_file = Path(url[len("sqlite:///"):].split("?", 1)[0]).expanduser().resolve()
        beside = db_file.parent / "cache"
        if beside.resolve() != store.root.resolve():
            return (f" (the database {db_file} is another project's: its cache is likely {beside}; "
                    f"give --cache DIR or set $NAVBENCH_CACHE)")
    return " (removed by cache gc?)"
