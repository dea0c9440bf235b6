"""Python front doors of issue 13's tracking commands: ``track-sequence`` (:func:`track_sequence`)
and ``export-trajectories`` (:func:`export_trajectories`). The CLI commands adapt these."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from navbench.pipeline.run import recorded_run
from navbench.pipeline.stages.sequence import (
    SequenceResult,
    TrackSequenceConfig,
    default_output,
    parse_odometry,
    resolve_map,
    run_tracking,
)


def track_sequence(directory, map: Any = None, config: TrackSequenceConfig | None = None, *,
                   out: str | Path | None = None, db: Any = None, store: Any = None,
                   command: str = "track_sequence()", **overrides) -> SequenceResult:
    """Track the TUM sequence in ``directory`` (the Python front door of ``track-sequence``).

    ``map``: a world model, a map file, a map artifact directory or a cache key (``None`` for
    ``no-map`` / ``dynamics``); ``config`` or keyword ``overrides`` of
    :class:`TrackSequenceConfig` (``estimator="ours", odometry="gt+mid", seed=0, options=...``).
    Writes the estimate as a strict TUM file to ``out`` (``None``: no file; ``"default"``:
    :func:`default_output`); with ``db`` (a :class:`~navbench.pipeline.db.ResultsDB`) records a
    run and stores one ``sequence_tracking`` row. ``store``: the artifact store cache keys are
    looked up in (default ``results/cache``).
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
        if isinstance(map, (str, Path)):
            if store is None:
                from navbench.pipeline.cache import ArtifactStore

                store = ArtifactStore("results/cache")
            model, map_key = resolve_map(store, str(map))
        else:
            model, map_key = map, map.content_hash()
    seq = read_sequence(directory, cfg.max_tilt_deg, cfg.max_dt)
    res = run_tracking(seq, model, map_key, cfg, str(directory))
    if out is not None:
        path = default_output(seq, cfg) if str(out) == "default" else Path(out)
        res.out = write_trajectory(path, seq.timestamps, res.est_poses, seq.views.camera_height)
    if db is not None:
        conf = {"sequence": res.row["sequence_hash"], "map": map_key, "track": cfg}
        with recorded_run(db, "track-sequence", command, conf) as run_id:
            res.stored = db.add_sequence_rows(run_id, [res.row])
    return res
