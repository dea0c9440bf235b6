"""health-calibration: the map's own alarm threshold for ``ours``'s health test
(``health_min_inliers = "auto"``, issue 14 section 3; the math: :mod:`navbench.track.health`).

The threshold is calibrated on pose-labelled views of the map, never on an evaluation
trajectory. :func:`calibration_views` picks them:

1. the map's **held-out views** when the map is a fit-map artifact that has them (``eval_views``
   of a level's fit, ``heldout`` of an imported fit): views the fit never saw, as the tracker's
   frames are;
2. else its **training views** (an imported fit that split its own views: the views input; the
   held-out ones are a subset the calibration cannot tell apart, so it uses them all);
3. else (``--map true``, or a map file that is no artifact) ``HealthCalibration.views`` views of
   the study's level rendered at seeded free poses (collect-views, seed
   :data:`CALIBRATION_VIEWS_SEED`, never the trajectories' stream) by the study's simulator
   (issue 37: on ``vizdoom`` the engine's frames, labelled with the pose it shows; the views'
   key carries the simulator unless it is pymunk).

Views of the map's own (1, 2) are those its fit saw or held out, of whichever simulator took
them: a map fitted with ``--sim vizdoom`` has the engine's.

A map file that lies in an artifact directory (``.../fit-map/<key>/map.npz``, e.g. another
checkout's cache) is found through that directory's manifest, its views in the same store.

The artifact (``calibration.json``) holds the threshold, the fractions' quantiles and the
views used; it is keyed by the calibration config (:class:`~navbench.track.health.HealthCalibration`,
resolved) plus the estimator's options that change it (:func:`tracker_options`) and the keys of
the map and the views. Cheap (a render and an alignment per view: 10-20 s for 200 half-camera
views on a loaded 2-core machine), cached all the same.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

from navbench.errors import ArtifactError, ConfigError
from navbench.pipeline.stages.context import Ref, StageContext

#: The file of a health-calibration artifact.
CALIBRATION_FILE = "calibration.json"
#: Pose-sampling seed of the level views rendered for a map that has none of its own.
CALIBRATION_VIEWS_SEED = 0xCA1
#: Stages whose artifacts hold views (a views directory).
VIEW_STAGES = ("collect-views", "import-views")


@dataclass(frozen=True)
class HealthCalibrationConfig:
    """health-calibration: ``calibration`` (the fields of
    :class:`~navbench.track.health.HealthCalibration`, defaults when empty) and the options
    ``tracker`` of the estimator being calibrated (its alignment and health-test tolerances,
    :func:`tracker_options`)."""

    calibration: dict = field(default_factory=dict)
    tracker: dict = field(default_factory=dict)

    def resolved(self):
        """The :class:`~navbench.track.health.HealthCalibration` (bad fields: ConfigError)."""
        from navbench.errors import TrackingError
        from navbench.track.health import HealthCalibration

        try:
            return HealthCalibration(**{k: (tuple(v) if isinstance(v, list) else v)
                                        for k, v in self.calibration.items()})
        except (TypeError, TrackingError) as e:
            raise ConfigError(f"health calibration: {e}") from None


#: Tracker options that do not change the calibration (left out of its key).
_NOT_CALIBRATION = ("health", "health_min_inliers", "recover", "relocalizer_name", "relocalize_top",
                    "relocalize_keep")


def tracker_options(options: dict) -> dict:
    """An estimator's options as the calibration reads them: all but :data:`_NOT_CALIBRATION`."""
    return {k: v for k, v in sorted(dict(options).items()) if k not in _NOT_CALIBRATION}


def calibration_views(ctx: StageContext, map_spec: str, map_key: str, level: Ref | None,
                      camera: str = "half", count: int = 200, sim: str = "pymunk") -> Ref:
    """The views the map's threshold is calibrated on (see the module doc), as a views Ref;
    ``sim``: the simulator that renders them when the map has none of its own."""
    man, store = _map_manifest(ctx, map_spec, map_key)
    if man is not None:
        inputs = man.get("inputs", {})
        for name in ("eval_views", "heldout", "views"):
            key = inputs.get(name)
            if not key:
                continue
            for stage in VIEW_STAGES:
                if store.path(stage, key).exists():
                    from navbench.pipeline.artifacts import VIEWS_FILE

                    p = store.load(stage, key)
                    ctx.used.append((stage, key))
                    return Ref(stage, key, p / VIEWS_FILE, True, level.name if level else "")
        raise ArtifactError(f"health calibration: the views of map {map_key[:12]} "
                            f"({', '.join(sorted(inputs))}) are not in {store.root}")
    if level is None:
        raise ConfigError(f"health_min_inliers=auto: map {map_spec} has no views of its own "
                          f"(not a fit-map artifact) and there is no level to render some")
    from navbench.pipeline.stages.views import ViewsConfig, collect_views_stage

    return collect_views_stage(ctx, level, ViewsConfig(int(count), camera, CALIBRATION_VIEWS_SEED, sim=sim))


def _map_manifest(ctx: StageContext, map_spec: str, map_key: str):
    """(manifest, store) of the fit-map artifact behind the map, or (None, None): the
    artifact directory of a map file or directory (a manifest beside it), else the artifact
    ``map_key`` or the key (prefix) ``map_spec`` in ``ctx``'s store."""
    import re

    from navbench.pipeline.cache import ArtifactStore

    p = Path(map_spec)
    if p.exists():  # a map file or an artifact directory: an artifact's if it has a fit-map manifest
        d = p if p.is_dir() else p.parent
        try:
            man = json.loads((d / "manifest.json").read_text())
        except (OSError, ValueError):
            return None, None
        if not isinstance(man, dict) or man.get("stage") != "fit-map":
            return None, None
        return man, ArtifactStore(d.parent.parent)
    for key in (map_key, map_spec):
        if key and re.fullmatch(r"[0-9a-f]{6,64}", key):
            try:
                stage, full = ctx.store.find(key, "fit-map")
            except ArtifactError:
                continue
            return json.loads((ctx.store.load(stage, full) / "manifest.json").read_text()), ctx.store
    return None, None


def health_calibration_stage(ctx: StageContext, views: Ref, map_key: str, load_map,
                             cfg: HealthCalibrationConfig = HealthCalibrationConfig()) -> Ref:
    """Calibrate (or fetch) the threshold of the map ``map_key`` (``load_map() -> world
    model``) on ``views``; ``ref.meta`` is the calibration dict (``threshold`` first)."""
    from navbench.track.trackconfig import keyed_options

    cal = cfg.resolved()

    def compute(d: Path) -> None:
        import numpy as np

        from navbench.track.eq7 import make_config
        from navbench.track.health import calibrated_threshold, view_inlier_fractions
        from navbench.track.ours import align, gn_pixels
        from navbench.track.sequence import frame_at
        from navbench.worldmodel.views import load_views

        v = load_views(views.path)
        n = min(int(cal.views), len(v))
        sel = np.sort(np.random.default_rng([int(cal.seed), 0x5E1]).choice(len(v), n, replace=False))
        intr = v.intrinsics
        tc = make_config(cfg.tracker)
        idx = gn_pixels(intr.height, intr.width, tc.health_pixels, 1)  # as an estimator of seed 0
        render = load_map().renderer(intr, v.camera_height).render
        f = view_inlier_fractions(render, [frame_at(v, int(i)) for i in sel], v.poses[sel], intr,
                                  idx, cal, v.camera_height, align, tc, tol=tc.health_tol,
                                  band=tc.health_band, photo_tol=tc.health_photo_tol,
                                  tol_abs=tc.health_tol_abs)
        finite = f[np.isfinite(f)]
        q = {f"q{p:g}": float(np.quantile(finite, p / 100)) for p in (0, 1, 5, 10, 50)} \
            if finite.size else {}
        out = {"threshold": calibrated_threshold(f, cal), "views": int(n),
               "views_without_evidence": int(n - finite.size), "views_stage": views.stage,
               "views_key": views.key, "quantiles": q, "calibration": asdict(cal)}
        (d / CALIBRATION_FILE).write_text(json.dumps(out, indent=1, sort_keys=True))

    # keyed by the resolved calibration: a change of HealthCalibration's defaults recalibrates
    path, key, cached = ctx.run("health-calibration",
                                {"calibration": asdict(cal),
                                 "tracker": tracker_options(keyed_options(cfg.tracker))},
                                {"map": map_key, "views": views.key}, compute)
    meta = json.loads((path / CALIBRATION_FILE).read_text())
    return Ref("health-calibration", key, path / CALIBRATION_FILE, cached, views.name, meta)


def auto_health_estimators(cfg) -> dict[str, dict]:
    """``{name: options}`` of the study config's estimators whose option ``health_min_inliers``
    is ``"auto"`` (the others need no calibration)."""
    out = {}
    for name in cfg.estimators:
        opts = dict((cfg.estimator_options or {}).get(name, {}))
        if opts.get("health_min_inliers") == "auto":
            out[name] = opts
    return out


def study_health_thresholds(ctx: StageContext, cfg, level: Ref,
                            vmap) -> tuple[dict[str, float], dict[str, str]]:
    """For a tracking study ``cfg`` on ``level`` with map ``vmap`` (a
    :class:`~navbench.pipeline.stages.track_eval.StudyMap`): ``({estimator: threshold},
    {"health_calibration.<estimator>": key})``, both empty when no estimator asks for
    ``"auto"``. The keys go into the study's inputs."""
    autos = auto_health_estimators(cfg)
    if not autos:
        return {}, {}
    if vmap.load is None:
        raise ConfigError("health_min_inliers=auto: the study has no map")
    from navbench.track.health import HealthCalibration

    views = calibration_views(ctx, vmap.spec, vmap.key, level, cfg.camera, HealthCalibration().views,
                              getattr(cfg, "sim", "pymunk"))
    thresholds, keys = {}, {}
    for name, opts in autos.items():
        ref = health_calibration_stage(ctx, views, vmap.key, vmap.load,
                                       HealthCalibrationConfig({}, tracker_options(opts)))
        thresholds[name] = float(ref.meta["threshold"])
        keys[f"health_calibration.{name}"] = ref.key
    return thresholds, keys


def sequence_health_threshold(ctx: StageContext | None, map_spec, map_key: str, model,
                              options: dict) -> float:
    """The calibrated threshold of ``model`` (given as ``map_spec``: a path, a key or the model
    itself) for an imported sequence's tracking with ``options``: from the views of the
    map's fit-map artifact (no level to render others: a map without one is an error)."""
    if ctx is None:
        from navbench.pipeline.cache import ArtifactStore

        ctx = StageContext(ArtifactStore())
    spec = str(map_spec) if isinstance(map_spec, (str, Path)) else map_key
    views = calibration_views(ctx, spec, map_key, None)
    ref = health_calibration_stage(ctx, views, map_key, lambda: model,
                                   HealthCalibrationConfig({}, tracker_options(options)))
    return float(ref.meta["threshold"])
