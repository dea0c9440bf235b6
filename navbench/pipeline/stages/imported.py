"""Views from outside the pipeline: a views file, a TUM RGB-D directory or a cached views key
(:func:`resolve_views`), stored into the cache by their content (import-views,
:func:`store_views_stage`), and a map fitted to them without a level (:func:`fit_views_stage`).

Views are keyed by :func:`navbench.worldmodel.views.views_content_hash` (the arrays, the
intrinsics, the camera height and the box; never a path), so the same images and poses reach
the same fit-map key whichever way they are given.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path

from navbench.config import to_jsonable
from navbench.errors import ArtifactError, ConfigError
from navbench.pipeline.artifacts import METRICS_FILE, MAP_FILE, VIEWS_FILE
from navbench.pipeline.stages.context import Ref, StageContext
from navbench.pipeline.stages.level import load_level_ref
from navbench.pipeline.stages.maps import FitMapConfig, fit_key_settings, resolve_fit_device
from navbench.worldmodel.tum import MAX_HEIGHT_DEV, MAX_TILT_DEG

#: Cache stages whose artifacts hold a views directory (``VIEWS_FILE``).
VIEWS_STAGES = ("import-views", "collect-views")
_HEX = re.compile(r"[0-9a-f]{6,64}")


@dataclass(frozen=True)
class ImportOptions:
    """How a TUM RGB-D directory is read (:func:`navbench.worldmodel.tum.import_views`).

    ``fx`` (px) given: the intrinsics are ``fx``, ``fy`` (default ``fx``), ``cx``, ``cy``
    (default the image centre) with the first rgb image's size; else ``intrinsics.json``.
    ``camera_height`` (m) and ``depth_scale`` (PNG units per metre): ``None`` reads
    ``intrinsics.json`` (else the median camera z, and 5000). ``max_dt`` (s): the timestamp
    association tolerance. ``max_tilt_deg`` (deg) / ``max_height_dev`` (m): how far a pose may
    be from planar at the camera height before the import refuses it.
    """

    fx: float | None = None
    fy: float | None = None
    cx: float | None = None
    cy: float | None = None
    camera_height: float | None = None
    depth_scale: float | None = None
    max_dt: float = 0.02
    max_tilt_deg: float = MAX_TILT_DEG
    max_height_dev: float = MAX_HEIGHT_DEV

    def read(self, directory):
        """The :class:`~navbench.worldmodel.views.Views` of the TUM directory."""
        from navbench.geometry import Intrinsics
        from navbench.worldmodel.tum import first_rgb_size, import_views
        from navbench.worldmodel.views import check_intrinsics

        intr, source = None, "given"
        if self.fx is not None:
            W, H = first_rgb_size(directory)
            source = "--fx/--fy/--cx/--cy and the first rgb image's size"
            intr = Intrinsics(W, H, self.fx, self.fy if self.fy is not None else self.fx,
                              self.cx if self.cx is not None else W / 2,
                              self.cy if self.cy is not None else H / 2)
            for name, v, size in (("--cx", intr.cx, W), ("--cy", intr.cy, H)):
                if not 0 <= v <= size:
                    raise ConfigError(f"{name} {v:g} is outside the {W}x{H} image (0 .. {size})")
            check_intrinsics(intr, source)
        return import_views(directory, intr, self.camera_height, self.depth_scale, self.max_dt,
                            intrinsics_source=source, max_tilt_deg=self.max_tilt_deg,
                            max_height_dev=self.max_height_dev)


def is_tum_dir(path: Path) -> bool:
    """A directory that is not a views artifact (no ``views.json``): read as TUM RGB-D."""
    return path.is_dir() and not (path / "views.json").is_file()


def check_views_spec(spec: str, what: str = "--views") -> None:
    """Refuse at once (before the results database is opened) a views ``spec`` that can be
    neither a views file or directory nor a cache key: a FIFO, a device, a missing path that
    is no hex key (issue 34)."""
    from navbench.safeio import check_regular_file

    p = Path(spec)
    if p.exists() or p.is_symlink():
        if not p.is_dir():
            check_regular_file(p, ConfigError, "views file")
        return
    if spec != "auto" and not _HEX.fullmatch(spec):
        raise ConfigError(f"{what} {spec}: no such file or directory, and not a views key (>= 6 "
                          f"hex digits of an import-views or collect-views artifact, see "
                          f"`navbench cache ls`)")


def resolve_views(spec: str, ctx: StageContext | None = None, options: ImportOptions = ImportOptions(),
                  what: str = "--views"):
    """The views ``spec`` names and their content key: ``(Views, key)``.

    ``spec`` is, in this order: a views artifact (``.npz`` file or directory with
    ``views.json``, what ``import-views --out`` and ``save_views`` write); a TUM RGB-D directory
    (read with ``options``; :class:`ImportOptions`); or the key (>= 6 hex digits) of a cached
    import-views or collect-views artifact in ``ctx``'s store (default: ``results/cache``).
    The key is :func:`~navbench.worldmodel.views.views_content_hash`. Every failure is one
    :class:`~navbench.errors.NavbenchError` line naming ``what`` or the file.
    """
    from navbench.worldmodel.views import load_views, views_content_hash

    p = Path(spec)
    if p.exists():
        views = options.read(p) if is_tum_dir(p) else load_views(p)
        return views, views_content_hash(views)
    if not _HEX.fullmatch(spec):
        raise ConfigError(f"{what} {spec}: no such file or directory, and not a views key (>= 6 "
                          f"hex digits of an import-views or collect-views artifact, see "
                          f"`navbench cache ls`)")
    if ctx is None:
        from navbench.pipeline.cache import ArtifactStore

        ctx = StageContext(ArtifactStore())
    stage, key = _find_views_key(ctx, spec, what)
    d = ctx.store.load(stage, key)
    views = load_views(d / VIEWS_FILE)
    man = json.loads((d / "manifest.json").read_text())
    content = man.get("config", {}).get("content") if stage == "import-views" else None
    ctx.used.append((stage, key))
    return views, content or views_content_hash(views)


def _find_views_key(ctx: StageContext, spec: str, what: str) -> tuple[str, str]:
    try:
        return ctx.store.find(spec, VIEWS_STAGES)
    except ArtifactError as e:
        raise ArtifactError(f"{what} {spec}: no such file or directory, and {e}") from None


def store_views_stage(ctx: StageContext, views, content_key: str | None = None) -> Ref:
    """import-views: store ``views`` in the cache (a views directory), keyed by their content
    (:func:`~navbench.worldmodel.views.views_content_hash`; the manifest's config holds it).
    ``ref.meta['content']`` is the content key."""
    from navbench.worldmodel.views import save_views, views_content_hash

    content = content_key or views_content_hash(views)
    path, key, cached = ctx.run("import-views", {"content": content}, {},
                                lambda d: save_views(views, d / VIEWS_FILE))
    return Ref("import-views", key, path / VIEWS_FILE, cached, views.level, {"content": content})


@dataclass(frozen=True)
class FitViewsConfig:
    """fit-map of given views: ``steps`` Adam steps from batch seed ``seed``, ``fit`` any other
    :class:`~navbench.worldmodel.fit.FitConfig` field; without held-out views, every
    ``heldout_every``-th view is held out (:func:`navbench.worldmodel.views.heldout_split`)."""

    steps: int = 200
    seed: int = 0
    fit: dict = field(default_factory=dict)
    heldout_every: int = 10

    def fit_config(self):
        """The resolved :class:`~navbench.worldmodel.fit.FitConfig` (unknown fields refused)."""
        return FitMapConfig(self.steps, self.seed, dict(self.fit)).fit_config()


def fit_views_stage(ctx: StageContext, views, views_key: str, cfg: FitViewsConfig,
                    heldout=None, heldout_key: str | None = None, level: Ref | None = None) -> Ref:
    """Fit a map to ``views`` (content key ``views_key``) and evaluate it on ``heldout`` (key
    ``heldout_key``) or the split (:func:`navbench.worldmodel.fitviews.fit_views`); slice scores
    only with ``level``. The artifact is a fit-map one (``map.npz``, ``metrics.json``), keyed by
    the resolved fit config, the split and the content keys; ``ref.meta`` is the metrics."""
    from navbench.worldmodel.fitconfig import require_depth_within
    from navbench.worldmodel.views import heldout_split

    fit_cfg = resolve_fit_device(ctx, cfg.fit_config())
    if heldout is None:
        train_idx, held_idx = heldout_split(len(views), cfg.heldout_every)  # nothing held out fails now
        require_depth_within(views, fit_cfg.max_range, "--views (the fitted part of the split)", train_idx)
        require_depth_within(views, fit_cfg.max_range,
                             f"--views (the held-out part: every {cfg.heldout_every}th view)", held_idx)
    else:
        require_depth_within(views, fit_cfg.max_range, "--views")
        require_depth_within(heldout, fit_cfg.max_range, "--heldout")
        _require_disjoint(views, views_key, heldout, heldout_key)
    resolved = {**fit_key_settings(fit_cfg),
                "heldout": "given" if heldout is not None else f"every {cfg.heldout_every}"}
    inputs = {"views": views_key}
    if heldout is not None:
        inputs["heldout"] = heldout_key
    if level is not None:
        inputs["level"] = level.key
    name = level.name if level is not None else views.level

    def compute(d: Path) -> None:
        from navbench.worldmodel.fitviews import fit_views

        from navbench.interrupts import checked, deferred

        update = ctx.progress(f"fit {name}", fit_cfg.steps)
        with deferred():  # Ctrl-C at the next progress call, never inside torch (an abort)
            vmap, metrics = fit_views(views, fit_cfg, heldout, cfg.heldout_every,
                                      load_level_ref(level) if level is not None else None,
                                      checked(update))
        metrics.setdefault("fit_seconds", metrics.get("fit_time_s"))
        metrics.update(views_key=views_key, heldout_key=heldout_key)
        vmap.save(d / MAP_FILE)
        (d / METRICS_FILE).write_text(json.dumps(to_jsonable(metrics), indent=1, sort_keys=True))

    path, key, cached = ctx.run("fit-map", resolved, inputs, compute)
    metrics = json.loads((path / METRICS_FILE).read_text())
    if ctx.db is not None:
        ctx.db.record_map(name, key, metrics)
    return Ref("fit-map", key, path / MAP_FILE, cached, name, metrics)


def _require_disjoint(views, views_key: str, heldout, heldout_key: str | None) -> None:
    """One :class:`ConfigError` when the held-out views are the training views (the same
    content), or share a view with them (identical pose and colour image): held-out quality
    is measured on views the map was not fitted to (the profiles' [views] eval_seed rule)."""
    import hashlib

    import numpy as np

    if heldout_key is not None and heldout_key == views_key:
        raise ConfigError(f"--heldout: the same views as --views (content key {views_key[:12]}); "
                          f"held-out quality must come from views the map is not fitted to (leave "
                          f"--heldout out to hold out every Nth view of --views)")

    def frame_ids(v) -> set[str]:
        out = set()
        for k in range(len(v)):
            h = hashlib.sha1(np.asarray(v.poses[k], np.float64).tobytes())
            h.update(np.ascontiguousarray(v.rgb[k]).tobytes())
            out.add(h.hexdigest())
        return out

    shared = frame_ids(heldout) & frame_ids(views)
    if shared:
        raise ConfigError(f"--heldout: {len(shared)} of its {len(heldout)} views are also in --views "
                          f"(identical pose and colour image); held-out quality must come from views "
                          f"the map is not fitted to")
