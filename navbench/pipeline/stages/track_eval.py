"""track-eval: the tracking study (paper appendix E) as a cached stage.

Trajectories are recorded once with the study's noise and every estimator is replayed on them
(:func:`navbench.track.study.run_tracking_study`); the artifact is the study's results
(``study.npz``, :func:`navbench.pipeline.artifacts.save_study`), keyed by the study config, the
level's content key and the map's key. The map is one of

* ``fit``: the profile's fitted world model (collect-views -> fit-map, built if missing), the
  map the paper's tracking study runs on;
* ``true``: the level's true geometry voxelized on the default grid (an upper bound);
* ``online``: no prior map; the map-based estimators track and map together, each fusing its
  frames at its own estimates into an empty map on the level's default grid (the level's box,
  nothing of its content; :mod:`navbench.track.slam`), keyed by the grid and fusion settings;
* a path to a map file (the ``map.npz`` format, or a world-model plugin's), keyed by its
  content hash.

A study whose estimators read no map (``dynamics``, ``gt``) uses none (map key ``none``).
Step times are measured when the study runs and cached with it: a cached rerun prints the
numbers of the run that computed them.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from navbench.errors import ConfigError
from navbench.pipeline.artifacts import STUDY_FILE, load_study, save_study
from navbench.pipeline.stages.context import Ref, StageContext
from navbench.pipeline.stages.inputs import fit_map_for_profile
from navbench.pipeline.stages.level import LevelConfig, load_level_ref, make_level_stage

#: The ``--map`` choices besides a file path.
MAP_CHOICES = ("fit", "true", "online")


@dataclass(frozen=True)
class StudyMap:
    """The map a study replays its estimators on: ``spec`` as given (fit, true, a path or none),
    its content ``key`` and a loader (``None`` when no estimator reads a map)."""

    spec: str
    key: str
    load: Callable[[], Any] | None = None


def study_level(ctx: StageContext, level: str, profile: Any = None) -> Ref:
    """The make-level reference of ``level``: a level name (``levels/NAME.json``, a benchmark
    level generated and cached, or one of ``profile``'s levels generated from its seed,
    :meth:`LevelConfig.for_profile`) or a path to a level file named after its level. Any
    other name is an error, never a silently generated level."""
    from navbench.safeio import names_a_file

    p = Path(level)
    if names_a_file(level):
        from navbench.errors import LevelError
        from navbench.safeio import check_regular_file

        check_regular_file(p, LevelError, "level file")  # missing, a directory, a FIFO: one line
        ctx = dataclasses.replace(ctx, levels_dir=p.parent)  # same store, db and used list
        return make_level_stage(ctx, LevelConfig(p.stem))
    return make_level_stage(ctx, LevelConfig.for_profile(level, profile) if profile is not None
                            else LevelConfig(level))


def check_map_spec(spec: str, choices: tuple[str, ...] = MAP_CHOICES) -> None:
    """Refuse a ``--map`` that is neither one of ``choices`` nor a readable map file (its
    header: a navbench ``.npz``), in one line and before anything is built or recorded: a
    command checks it before it opens the results database (issue 34)."""
    if spec in choices:
        return
    from navbench.safeio import check_regular_file
    from navbench.worldmodel.base import read_kind

    if not (Path(spec).exists() or Path(spec).is_symlink()):
        raise ConfigError(f"--map: no such map file {spec!r} (or use {' or '.join(choices)})")
    check_regular_file(spec, ConfigError, "map file")
    read_kind(spec)


def study_map(ctx: StageContext, spec: str, level: Ref, profile: Any = None,
              needed: bool = True) -> StudyMap:
    """Resolve ``--map`` (:data:`MAP_CHOICES` or a map file path) for ``level``. ``fit`` builds
    (or fetches) ``profile``'s fitted map; nothing is built when ``needed`` is false."""
    if not needed:
        check_map_spec(spec)  # a map file nobody uses is still checked: never ignored
        return StudyMap(spec, "none")
    if spec == "true":
        def load_true():
            from navbench.worldmodel.grid import voxelize_level

            return voxelize_level(load_level_ref(level))

        return StudyMap(spec, "true", load_true)
    if spec == "online":
        return online_study_map(level)
    if spec == "fit":
        if profile is None:
            raise ConfigError("--map fit: needs a profile (its fit settings)")
        ref = fit_map_for_profile(ctx, profile, level)
        return StudyMap(spec, ref.key, lambda: _load_map_file(ref.path))
    path = Path(spec)
    if path.exists() or path.is_symlink():
        from navbench.safeio import check_regular_file

        check_regular_file(path, ConfigError, "map file")  # a directory, FIFO or device: one line
    else:
        raise ConfigError(f"--map: no such map file {spec!r} (or use {' or '.join(MAP_CHOICES)})")
    model = _load_map_file(path)  # a bad file fails here, before any trajectory is recorded
    return StudyMap(spec, model.content_hash(), lambda: model)


def online_study_map(level: Ref) -> StudyMap:
    """``--map online``: an empty fused map on the level's default grid; its key hashes the
    grid spec and the fusion settings (so a change of either is another study)."""
    from navbench.config import config_hash
    from navbench.worldmodel.fusion import FUSION_VERSION, FusedMap, FusionConfig
    from navbench.worldmodel.grid import grid_for_level

    lvl = load_level_ref(level)
    spec, fcfg = grid_for_level(lvl), FusionConfig()
    key = "online-" + config_hash({"spec": spec.to_dict(), "fusion": fcfg,
                                   "version": FUSION_VERSION})[:16]
    return StudyMap("online", key, lambda: FusedMap.empty(spec, fcfg))


def _load_map_file(path: Path):
    from navbench.worldmodel.base import load_world_model

    return load_world_model(path)


#: Study-config fields added after studies were stored, with the defaults that leave them out of
#: the cache key (so every study stored before them keeps its key).
_KEY_DEFAULTS = {"kidnap_every": 0, "odometry": "world", "collisions": "freeze", "sim": "pymunk",
                 "texture": "procedural"}


def study_key_config(cfg) -> dict:
    """The study config as hashed into the track-eval key: every field, except those of
    :data:`_KEY_DEFAULTS` while at their default; estimator options as
    :func:`~navbench.track.trackconfig.keyed_options` keys them; with recovery on, the
    relocalisers' settings (:func:`~navbench.track.relocalize.relocalizer_settings`); the
    benchmark version as :func:`navbench.benchmark.key_part` keys it (nothing for
    ``navbench-1``, ``{"benchmark": NAME}`` for any later one, as every navigation cell: a study
    is a result of its version whatever its estimators read)."""
    from navbench.config import to_jsonable
    from navbench.track.relocalize import relocalizer_settings
    from navbench.track.trackconfig import keyed_options

    d = to_jsonable(cfg)
    reloc = {name: relocalizer_settings(o) for name, o in d["estimator_options"].items()}
    d["estimator_options"] = {name: keyed_options(o) for name, o in d["estimator_options"].items()}
    if any(reloc.values()):  # recovery: the relocaliser's settings (since 2026-11-26)
        d["relocalizers"] = {k: v for k, v in reloc.items() if v}
    for k, default in _KEY_DEFAULTS.items():
        if d.get(k) == default:
            d.pop(k, None)
    from navbench.benchmark import LEGACY_VERSION, key_part

    version = d.pop("benchmark_version", LEGACY_VERSION)
    return {**d, **key_part(version)}


def track_eval_stage(ctx: StageContext, level: Ref, vmap: StudyMap, cfg) -> Ref:
    """Run (or fetch) the tracking study ``cfg`` (a :class:`~navbench.track.study.TrackingStudyConfig`)
    on ``level`` with map ``vmap``; ``ref.meta`` holds the map key and the calibrated health
    thresholds of the estimators with ``health_min_inliers="auto"`` (their calibration keys
    join the study's inputs; :mod:`navbench.pipeline.stages.health`)."""
    from navbench.pipeline.stages.health import study_health_thresholds

    thresholds, calibration_keys = study_health_thresholds(ctx, cfg, level, vmap)

    def compute(d: Path) -> None:
        from navbench.track.study import run_tracking_study

        model = vmap.load() if vmap.load is not None else None
        update = ctx.progress(f"tracking {level.name}", cfg.trajectories)
        results = run_tracking_study(load_level_ref(level), model, cfg,
                                     progress=lambda done, total: update(done),
                                     health_thresholds=thresholds)
        save_study(results, d / STUDY_FILE)

    path, key, cached = ctx.run("track-eval", study_key_config(cfg),
                                {"level": level.key, "map": vmap.key, **calibration_keys}, compute,
                                validate=lambda d: load_study(d / STUDY_FILE))  # never cache what fails to load
    meta = {"map_key": vmap.key}
    if thresholds:
        meta["health_thresholds"] = thresholds
    return Ref("track-eval", key, path / STUDY_FILE, cached, level.name, meta)
