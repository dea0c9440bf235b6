"""The report's two loaders read from the stage cache (trajectories and maps).

:func:`navbench.report.build.build_report` is handed ``load_trajectory`` and ``load_map`` so the
report never depends on where artifacts are stored; this module builds them from an
:class:`~navbench.pipeline.cache.ArtifactStore`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from navbench.report.build import MapLoader, TrajectoryLoader


def store_loaders(cache_root: str | Path | None = None, option: str = "--cache") -> tuple[TrajectoryLoader, MapLoader]:
    """``(load_trajectory, load_map)`` reading verified artifacts of the stage cache: episode
    records (``episode`` stage) and fitted maps (``fit-map`` stage). A cache path that exists
    and is not a folder (a file, ``/dev/zero``, a dangling link) is one-line
    :class:`~navbench.errors.ConfigError` naming ``option``: read as "no cache", it gave a report
    without a word of why its figures were missing (issue 34)."""
    import os

    from navbench.errors import ConfigError
    from navbench.pipeline.cache import ArtifactStore

    store = ArtifactStore(cache_root)
    if os.path.lexists(store.root) and not store.root.is_dir():
        what = ("a file" if store.root.is_file() else "a dangling link" if not store.root.exists()
                else "a device, FIFO or socket")
        raise ConfigError(f"{option} {store.root}: is {what}, not a folder; the stage cache is a "
                          "folder (results/cache by default); move the file aside or give --cache DIR")

    def load_trajectory(key: str) -> dict:
        from navbench.pipeline.artifacts import TRAJ_FILE, load_record

        from navbench.report.topviews import online_extras

        path = store.load("episode", key) / TRAJ_FILE
        rec = load_record(path)
        return {"true_poses": np.asarray(rec.true_poses), "est_poses": np.asarray(rec.est_poses),
                "target": np.asarray(rec.target), "plan": np.asarray(rec.plan),
                "end_reason": rec.end_reason, **online_extras(path)}  # online: known, seen_share

    def load_map(key: str):
        from navbench.errors import ArtifactError
        from navbench.pipeline.artifacts import MAP_FILE
        from navbench.worldmodel.base import load_world_model

        for stage in ("fit-map", "true-map"):  # a fitted map, or the true geometry (--map true)
            try:
                return load_world_model(store.load(stage, key) / MAP_FILE)
            except ArtifactError:
                continue
        raise ArtifactError(f"no fit-map or true-map artifact with key {key[:12]} in {store.root} "
                            "(a map brought with --map FILE is not kept in the cache)")

    return load_trajectory, load_map
