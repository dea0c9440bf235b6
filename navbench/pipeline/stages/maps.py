"""fit-map (the voxel world model of eq. 1-3 fitted to views by differentiable rendering) and
true-map (the level's true geometry voxelized: the upper bound for planning)."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

from navbench.config import to_jsonable
from navbench.errors import ConfigError
from navbench.pipeline.artifacts import MAP_FILE, METRICS_FILE
from navbench.pipeline.stages.context import Ref, StageContext
from navbench.pipeline.stages.level import load_level_ref


@dataclass(frozen=True)
class FitMapConfig:
    """fit-map: ``steps`` Adam steps from batch seed ``seed``; ``fit`` holds any other
    :class:`navbench.worldmodel.fit.FitConfig` field. The map is evaluated on held-out views
    (a separate collect-views with ``eval_count`` views from ``eval_seed``)."""

    steps: int = 200
    seed: int = 0
    fit: dict = field(default_factory=dict)
    eval_count: int = 200
    eval_seed: int = 1

    def fit_config(self):
        """The resolved :class:`FitConfig` (imports the world-model fit module)."""
        from navbench.worldmodel.fit import FitConfig

        names = {f.name for f in dataclasses.fields(FitConfig)}
        unknown = set(self.fit) - names
        if unknown:
            raise ConfigError(f"unknown FitConfig field(s) {sorted(unknown)}; known: {sorted(names)}")
        kw = dict(self.fit)
        kw.update(steps=self.steps, seed=self.seed)
        return FitConfig(**kw)


#: The device path's generation in a fit key: 2 since its batches are drawn on the device
#: (navbench.worldmodel.fit_device); maps of the first device path (host-drawn batches) keep
#: their keys and are not served for the new one. CPU-path keys carry nothing.
DEVICE_PATH = 2


def fit_key_settings(fit_cfg) -> dict:
    """What a resolved :class:`~navbench.worldmodel.fit.FitConfig` puts into a fit key: its
    fields, and :data:`DEVICE_PATH` when the fit runs on a torch device (``cuda``,
    ``torch-cpu``), whose batches and arithmetic differ from the CPU path's."""
    out = {"fit": to_jsonable(fit_cfg)}
    if fit_cfg.device not in ("cpu", "auto"):
        out["device_path"] = DEVICE_PATH
    return out


def resolve_fit_device(ctx: StageContext, fit_cfg):
    """``fit_cfg`` with an ``"auto"`` device resolved for this machine
    (:func:`navbench.pipeline.devices.resolve_auto_fit_device`), said in the run's log when it
    leaves the CPU path."""
    if fit_cfg.device != "auto":
        return fit_cfg
    from navbench.pipeline.devices import resolve_auto_fit_device

    device, why = resolve_auto_fit_device(ctx.db)
    if device == "auto":
        return fit_cfg
    ctx.log(f"fit-map: {why}")
    return dataclasses.replace(fit_cfg, device=device)


#: Fields the fit-map command's ``--json`` always prints.
MAP_METRIC_KEYS = ("depth_mae_m", "rgb_l1", "slice_precision", "slice_recall", "fit_seconds", "steps")


def fit_map_stage(ctx: StageContext, level: Ref, views: Ref, eval_views: Ref, cfg: FitMapConfig) -> Ref:
    """Fit a voxel map to ``views``, evaluate it on ``eval_views`` and the level's true slice;
    the artifact holds ``map.npz`` and ``metrics.json``. ``ref.meta`` is the metrics dict."""
    fit_cfg = resolve_fit_device(ctx, cfg.fit_config())
    resolved = {**fit_key_settings(fit_cfg), "eval_count": cfg.eval_count}

    def compute(d: Path) -> None:
        from navbench.worldmodel.fit import evaluate_map, fit_map
        from navbench.interrupts import checked, deferred
        from navbench.worldmodel.fitconfig import require_depth_within
        from navbench.worldmodel.grid import check_fitted_finite
        from navbench.worldmodel.views import load_views

        # a score of nothing is never stored: both view sets must see something within max_range
        require_depth_within(load_views(eval_views.path), fit_cfg.max_range,
                             f"fit-map {level.name}: the held-out views ([views] eval_count)")
        train = load_views(views.path)
        require_depth_within(train, fit_cfg.max_range, f"fit-map {level.name}: the views")
        update = ctx.progress(f"fit {level.name}", fit_cfg.steps)
        with deferred():  # Ctrl-C at the next progress call, never inside torch (an abort)
            vmap, metrics = fit_map(train, fit_cfg, progress=checked(update))
        del train
        check_fitted_finite(vmap, metrics, fit_cfg)  # a diverged fit is never cached
        held = load_views(eval_views.path)
        quality = evaluate_map(vmap, load_level_ref(level), held)
        out = {**dict(metrics), **dict(quality)}
        out.setdefault("fit_seconds", out.get("fit_time_s"))
        out.setdefault("steps", fit_cfg.steps)
        out["eval_views"] = int(cfg.eval_count)
        vmap.save(d / MAP_FILE)
        (d / METRICS_FILE).write_text(json.dumps(to_jsonable(out), indent=1, sort_keys=True))

    path, key, cached = ctx.run("fit-map", resolved,
                                {"level": level.key, "views": views.key, "eval_views": eval_views.key},
                                compute)
    metrics = json.loads((path / METRICS_FILE).read_text())
    if ctx.db is not None:
        ctx.db.record_map(level.name, key, metrics)
    return Ref("fit-map", key, path / MAP_FILE, cached, level.name, metrics)


@dataclass(frozen=True)
class TrueMapConfig:
    """true-map: the level's TRUE geometry voxelized (:func:`navbench.worldmodel.grid.voxelize_level`)
    with square cells of ``cell`` metres in x, y (the paper's grid: 11.4 m / 200) and ``nz``
    cells in z. An upper bound for planning, and a map for tests that need no fit."""

    cell: float = 11.4 / 200
    nz: int = 20


def true_map_stage(ctx: StageContext, level: Ref, cfg: TrueMapConfig = TrueMapConfig()) -> Ref:
    """The voxelized true geometry as a map artifact (``map.npz``, ``metrics.json``)."""

    def compute(d: Path) -> None:
        import math

        from navbench.worldmodel.grid import grid_for_level, voxelize_level

        lv = load_level_ref(level)
        shape = (max(2, math.ceil(lv.width / cfg.cell - 1e-9)), max(2, math.ceil(lv.depth / cfg.cell - 1e-9)), cfg.nz)
        voxelize_level(lv, grid_for_level(lv, shape=shape)).save(d / MAP_FILE)
        (d / METRICS_FILE).write_text(json.dumps({"source": "true", "steps": 0}))

    path, key, cached = ctx.run("true-map", cfg, {"level": level.key}, compute)
    metrics = json.loads((path / METRICS_FILE).read_text())
    if ctx.db is not None:
        ctx.db.record_map(level.name, key, metrics)
    return Ref("true-map", key, path / MAP_FILE, cached, level.name, metrics)


#: Stands for the level's name in a map file path (one map file per level).
LEVEL_PLACEHOLDER = "{level}"


def map_file_stage(ctx: StageContext, level: Ref, spec: str, what: str = "--map") -> Ref:
    """A map the user brings: the file ``spec`` (``{level}`` replaced by the level's name), loaded
    now through :func:`navbench.worldmodel.base.load_world_model` (any registered world-model
    kind; its errors name the file) and checked to cover the level's floor plan, keyed by its
    :meth:`~navbench.worldmodel.base.WorldModel.content_hash` (the same map saved again keeps
    its key). Nothing is copied into the cache; the episodes' cell keys hold the map's key."""
    from navbench.worldmodel.base import load_world_model

    path = Path(spec.replace(LEVEL_PLACEHOLDER, level.name))
    if path.exists() or path.is_symlink():
        from navbench.safeio import check_regular_file

        check_regular_file(path, ConfigError, "map file")  # a directory, FIFO or device: one line
    else:
        raise ConfigError(f"{what}: no such map file {str(path)!r} (or use fit or true)")
    model = load_world_model(path)
    lv = load_level_ref(level)
    _, xs, ys = model.occupancy_slice("band")
    (x0, x1), (y0, y1) = _cell_extent(xs), _cell_extent(ys)
    tol = 1e-6
    if x0 > tol or y0 > tol or x1 < lv.width - tol or y1 < lv.depth - tol:
        raise ConfigError(f"{what}: {path}: the map's grid [{x0:g}, {x1:g}] x [{y0:g}, {y1:g}] m "
                          f"does not cover level {level.name} ([0, {lv.width:g}] x [0, {lv.depth:g}] m)")
    key = model.content_hash()
    ctx.log(f"map: {level.name} from {path} ({key[:12]})")
    meta = {"source": "file", "path": str(path), "kind": model.kind, "steps": 0}
    if ctx.db is not None:
        ctx.db.record_map(level.name, key, meta)
    return Ref("map-file", key, path.resolve(), True, level.name, meta)


def _cell_extent(centres) -> tuple[float, float]:
    """The span ``[lo, hi]`` covered by equally spaced cell ``centres``."""
    half = (float(centres[1]) - float(centres[0])) / 2 if len(centres) > 1 else 0.0
    return float(centres[0]) - half, float(centres[-1]) + half


#: Cache stages whose artifacts hold a map (``MAP_FILE``).
MAP_STAGES = ("fit-map", "true-map")


def resolve_map(spec: str, ctx: StageContext | None = None, what: str = "--map"):
    """The world model ``spec`` names and its key: ``(model, key)``.

    ``spec`` is a map file (any registered world-model kind,
    :func:`navbench.worldmodel.base.load_world_model`), a map artifact's directory, or the key (>= 6 hex digits) of a cached
    fit-map or true-map artifact in ``ctx``'s store (default ``results/cache``). The key is the
    model's :meth:`~navbench.worldmodel.base.WorldModel.content_hash` either way (as
    :func:`map_file_stage` keys a brought map). Failures are one line naming ``what``."""
    import re

    from navbench.errors import ArtifactError
    from navbench.worldmodel.base import load_world_model

    path = Path(spec)
    if not path.exists():
        if not re.fullmatch(r"[0-9a-f]{6,64}", spec):
            raise ConfigError(f"{what} {spec}: no such map file, and not a map key (>= 6 hex "
                              f"digits of a fit-map or true-map artifact, see `navbench cache ls`)")
        if ctx is None:
            from navbench.pipeline.cache import ArtifactStore

            ctx = StageContext(ArtifactStore())
        try:
            stage, key = ctx.store.find(spec, MAP_STAGES)
        except ArtifactError as e:
            raise ArtifactError(f"{what} {spec}: not a map file, nor a map key: {e}") from None
        path = ctx.store.load(stage, key) / MAP_FILE
        ctx.used.append((stage, key))
    elif path.is_dir():  # a map artifact's directory
        if not (path / MAP_FILE).is_file():
            raise ConfigError(f"{what} {spec}: a directory without a {MAP_FILE}; give a map file "
                              f"or a fit-map cache key")
        path = path / MAP_FILE
    model = load_world_model(path)
    return model, model.content_hash()
