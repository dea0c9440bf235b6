"""localize-bank and localize-eval: the localiser's signature bank as a cached artifact, and the
image-based localisation study (RNR-Map supplementary C.2-C.3) as a cached stage.

``localize-bank`` is keyed by the map's key, the camera height and the fields of
:class:`~navbench.localize.LocalizerConfig` the bank depends on (:func:`bank_config`); its
artifact is ``bank.npz`` (lattice points, panoramas, build seconds). A second build is a cache
hit; a tampered or truncated bank fails the store's checksum and is rebuilt
(:mod:`navbench.pipeline.cache`).

``localize-eval`` draws ``queries`` poses uniformly in the level's free space (``clearance`` m
from every solid, headings uniform; a seeded stream of its own, so never a training view),
renders each with the true camera, localises it in the map and stores, per query, the true and
the found pose, the confidence, the query time and, for changed rooms, the image difference.
With ``changes`` (``OC1`` .. ``OC4``) the queries are rendered in a changed level
(:func:`navbench.levelgen.changed.change_level` of the base with :data:`CHANGE_COUNT` edits) and
kept only when their image difference (:func:`image_difference`) lies in the band of
:data:`OC_BANDS`, as RNR-Map sorts its queries into difficulties by their image difference.

The study's ``sim`` (issue 37) picks the camera of the queries
(:class:`~navbench.sim.backends.PoseRenderer`): ``pymunk``'s exact ray caster, or the ViZDoom
engine, whose frame is taken from the pose it shows (whole centimetres, 1/65536 turn): that pose
is the query's true pose, and the localiser reads the frame with the engine's projection. A
changed level's queries and their image difference are the engine's too. ``sim`` is in the
study's key only when it is not pymunk (:func:`localize_key_config`): every study stored before
it keeps its key.
"""

from __future__ import annotations

import dataclasses
import json
import time
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from navbench.errors import ConfigError
from navbench.pipeline.stages.context import Ref, StageContext
from navbench.pipeline.stages.level import load_level_ref

BANK_FILE = "bank.npz"
LOCALIZE_FILE = "localize.npz"
#: RNR-Map's object-change difficulties as bands of the image difference (fraction of pixels
#: changed); their measured means sit near RNR-Map's 7, 14, 24, 34 %.
OC_BANDS = {"OC1": (0.03, 0.10), "OC2": (0.10, 0.18), "OC3": (0.18, 0.30), "OC4": (0.30, 0.40)}
#: Furniture edits of the changed level every OC draws its queries from (measured on house-1:
#: enough of the views fall in each band, see docs).
CHANGE_COUNT = 25
#: Draws per kept query before an OC study gives up.
MAX_DRAWS_PER_QUERY = 60
_BANK_FIELDS = ("lattice_step", "clearance", "bins", "rows", "row_top", "row_step", "depth_feature",
                "feature_range", "grey_weight")


def bank_config(cfg, camera_height: float) -> dict:
    """The part of a :class:`~navbench.localize.LocalizerConfig` the bank depends on (its key)."""
    return {**{f: getattr(cfg, f) for f in _BANK_FIELDS}, "camera_height": float(camera_height)}


def map_inputs(vmap, level: Ref | None) -> dict[str, str]:
    """The bank's input keys: the map's key, plus the level's for ``--map true`` (whose map key
    names no level)."""
    if vmap.key == "true":
        if level is None:
            raise ConfigError("the true map's bank needs its level")
        return {"map": vmap.key, "level": level.key}
    return {"map": vmap.key}


def localize_bank_stage(ctx: StageContext, vmap, camera_height: float, cfg, level: Ref | None = None) -> Ref:
    """Build (or fetch) the signature bank of ``vmap`` (a :class:`StudyMap` of ``level``);
    ``ref.meta`` holds ``build_s`` (seconds the build took when it ran) and ``bytes`` (the
    panoramas' size)."""

    def compute(d: Path) -> None:
        from navbench.localize.localizer import build_bank

        model = vmap.load()
        t0 = time.perf_counter()
        bank = build_bank(model, camera_height, cfg)
        build_s = time.perf_counter() - t0
        np.savez(d / BANK_FILE, points=bank.points, pano=bank.pano,
                 info=np.array(json.dumps({"build_s": build_s})))

    path, key, cached = ctx.run("localize-bank", bank_config(cfg, camera_height), map_inputs(vmap, level),
                                compute)
    with np.load(path / BANK_FILE) as z:
        info = json.loads(str(z["info"]))
        nbytes = int(z["pano"].nbytes + z["points"].nbytes)
    return Ref("localize-bank", key, path / BANK_FILE, cached, "", {**info, "bytes": nbytes})


def load_localizer(ctx: StageContext, vmap, intrinsics, camera_height: float, cfg, model=None,
                   level: Ref | None = None):
    """``(Localizer, bank Ref)`` for ``vmap`` (of ``level``) through the cached bank (built if
    missing): what a stage that localises calls."""
    ref = localize_bank_stage(ctx, vmap, camera_height, cfg, level)
    return localizer_from_bank(ref.path, vmap.load() if model is None else model, intrinsics,
                               camera_height, cfg), ref


def localizer_from_bank(bank_path, model, intrinsics, camera_height: float, cfg):
    """The :class:`~navbench.localize.Localizer` of ``model`` with the cached bank at
    ``bank_path`` (a ``localize-bank`` artifact): what :func:`load_localizer` returns, for a
    process that has the artifact's path but no stage context (a pool worker)."""
    from navbench.localize import Bank, Localizer

    with np.load(bank_path) as z:
        bank = Bank(z["points"], z["pano"])
    return Localizer(model, intrinsics, camera_height, cfg, bank)


@dataclass(frozen=True)
class LocalizeEvalConfig:
    """One localisation study: ``queries`` views (seed ``seed``), camera preset ``camera``,
    ``changes`` None or an OC name, the localiser's settings."""

    queries: int = 1000
    seed: int = 0
    camera: str = "half"
    changes: str | None = None
    clearance: float = 0.1
    localizer: object = field(default=None)  # a LocalizerConfig (None: its defaults)
    sampling: str = "uniform"  # query poses: "uniform" (free space) or "trajectory" (RNR-Map C.2)
    # issue 37: the simulator whose frames are the queries (navbench.sim.backends); on "vizdoom"
    # the pose the engine shows is the query's true pose. Keyed only when not "pymunk".
    sim: str = "pymunk"

    def resolved(self) -> "LocalizeEvalConfig":
        from navbench.localize import LocalizerConfig
        from navbench.sim.backends import check_sim

        if self.changes is not None and self.changes not in OC_BANDS:
            raise ConfigError(f"--changes: expected one of {', '.join(OC_BANDS)}, got {self.changes!r}")
        if self.sampling not in SAMPLINGS:
            raise ConfigError(f"--sampling: expected one of {', '.join(SAMPLINGS)}, got {self.sampling!r}")
        check_sim(self.sim)
        return self if self.localizer is not None else dataclasses.replace(self, localizer=LocalizerConfig())


def localize_key_config(cfg: LocalizeEvalConfig) -> dict:
    """What the localize-eval key hashes: the resolved study config (``sim`` only when it is not
    the reference simulator, :func:`navbench.benchmark.sim_key_part`) and :data:`CHANGE_COUNT`."""
    from navbench.benchmark import sim_key_part
    from navbench.config import to_jsonable

    study = to_jsonable(cfg)
    del study["sim"]
    return {"study": {**study, **sim_key_part(cfg.sim)}, "change_count": CHANGE_COUNT}


def image_difference(a, b) -> float:
    """Fraction of pixels that changed between frames ``a`` and ``b`` of one pose: mean colour
    difference over 0.02 or depth difference over 2 cm (the normalised L1 of the change mask)."""
    col = np.abs(np.asarray(a.rgb, np.float64) - b.rgb).mean(axis=-1) > 0.02
    da = np.where(a.valid, a.depth, 0.0)
    db = np.where(b.valid, b.depth, 0.0)
    return float((col | (np.abs(da - db) > 0.02)).mean())


#: ``sampling="trajectory"``: views taken per recorded trajectory, and its length in controls
#: (RNR-Map C.2 samples 10 query images from each camera-tracking trajectory).
VIEWS_PER_TRAJECTORY = 10
TRAJECTORY_STEPS = 100
SAMPLINGS = ("uniform", "trajectory")


def trajectory_poses(level, seed: int):
    """Endless poses of views along ``level``'s tracking trajectories (RNR-Map C.2's query
    protocol): :func:`navbench.track.study.record_trajectories` at seed ``seed`` (the
    trajectories ``track-eval --seed`` drives), :data:`VIEWS_PER_TRAJECTORY` distinct steps of
    each of its :data:`TRAJECTORY_STEPS` controls drawn uniformly (stream ``[seed, 0x10CA1, 1]``),
    trajectories driven in doubling batches."""
    from navbench.track.study import record_trajectories

    rng = np.random.default_rng([int(seed), 0x10CA1, 1])
    done, total = 0, 8
    while True:  # trajectory i does not depend on the count: redrive doubling batches (<= 2x work)
        for tr in record_trajectories(level, total, TRAJECTORY_STEPS, "tracking", seed)[done:]:
            for t in np.sort(rng.choice(np.arange(1, len(tr.true_poses)), VIEWS_PER_TRAJECTORY,
                                        replace=False)):
                yield np.asarray(tr.true_poses[t], np.float64)
        done, total = total, 2 * total


def draw_queries(level, count: int, seed: int, clearance: float, intrinsics, original=None,
                 band: tuple[float, float] | None = None, sampling: str = "uniform", sim: str = "pymunk"):
    """Yield ``count`` ``(pose, frame, image difference)``: poses uniform in ``level``'s free
    space (``sampling="uniform"``) or views along its trajectories (``"trajectory"``,
    :func:`trajectory_poses`), frames of the true camera of simulator ``sim`` (on ``vizdoom`` the
    engine's, and ``pose`` the pose it shows); with ``original`` and ``band``, only poses whose
    :func:`image_difference` to the original level's view lies in ``band`` (at most
    :data:`MAX_DRAWS_PER_QUERY` draws per query, then :class:`ConfigError`)."""
    from contextlib import ExitStack

    from navbench.geometry import CAMERA_HEIGHT
    from navbench.levelgen.validate import clearance_mask
    from navbench.sim.backends import PoseRenderer

    res = 0.05
    free, xs, ys = clearance_mask(level, res, clearance)
    cells = np.argwhere(free)
    if len(cells) == 0:
        raise ConfigError(f"level {level.name!r}: no free space at {clearance} m clearance")
    with ExitStack() as stack:  # the engines (vizdoom) stop when the generator ends or is closed
        cam = stack.enter_context(PoseRenderer(sim, level, intrinsics, CAMERA_HEIGHT))
        cam0 = stack.enter_context(PoseRenderer(sim, original, intrinsics, CAMERA_HEIGHT)) \
            if original is not None else None
        yield from _draw(level, count, seed, sampling, band, cells, xs, ys, res, cam, cam0)


def _draw(level, count, seed, sampling, band, cells, xs, ys, res, cam, cam0):
    """:func:`draw_queries`' loop with its renderers ``cam`` (and ``cam0`` of the original level)."""
    rng = np.random.default_rng([int(seed), 0x10CA1])
    kept = 0
    along = trajectory_poses(level, seed) if sampling == "trajectory" else None
    for _ in range(count * (MAX_DRAWS_PER_QUERY if band else 1)):
        if along is not None:
            pose = next(along)
        else:
            i, j = cells[rng.integers(len(cells))]
            pose = np.array([xs[i] + rng.uniform(-res / 2, res / 2), ys[j] + rng.uniform(-res / 2, res / 2),
                             rng.uniform(-np.pi, np.pi)])
        f = cam.render(pose)
        pose = cam.shown  # the asked pose (pymunk), or the one the engine shows (vizdoom)
        d = image_difference(f, cam0.render(pose)) if cam0 is not None else 0.0
        if band is not None and not band[0] <= d < band[1]:
            continue
        yield pose, f, d
        kept += 1
        if kept == count:
            return
    raise ConfigError(f"level {level.name!r}: only {kept} of {count} queries found in the "
                      f"image-difference band {band} after {count * MAX_DRAWS_PER_QUERY} draws")


def study_queries(base, cfg: "LocalizeEvalConfig", intrinsics):
    """The study's queries (:func:`draw_queries`): in ``base`` itself, or with ``cfg.changes``
    in its seeded changed copy, kept in that difficulty's image-difference band."""
    if cfg.changes is None:
        return draw_queries(base, cfg.queries, cfg.seed, cfg.clearance, intrinsics,
                            sampling=cfg.sampling, sim=cfg.sim)
    from navbench.levelgen.changed import change_level

    changed = change_level(base, f"{base.name}-changed", CHANGE_COUNT, cfg.seed)
    return draw_queries(changed, cfg.queries, cfg.seed, cfg.clearance, intrinsics, base,
                        OC_BANDS[cfg.changes], cfg.sampling, cfg.sim)


def localize_eval_stage(ctx: StageContext, level: Ref, vmap, cfg: LocalizeEvalConfig,
                        progress=None) -> Ref:
    """Run (or fetch) the study ``cfg`` on ``level`` with map ``vmap``; ``ref.meta``: the bank's
    ``build_s`` and ``bytes``, its key and the map key."""
    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.sim.backends import sim_intrinsics

    cfg = cfg.resolved()
    intr = camera_by_name(cfg.camera)
    model = vmap.load()
    # the projection the queries are taken with: the engine's on vizdoom (its pixels are not square)
    loc, bank = load_localizer(ctx, vmap, sim_intrinsics(cfg.sim, intr), CAMERA_HEIGHT, cfg.localizer,
                               model, level)

    def compute(d: Path) -> None:
        q = study_queries(load_level_ref(level), cfg, intr)
        true, est = np.zeros((cfg.queries, 3)), np.zeros((cfg.queries, 3))
        conf, ms, diff = np.zeros(cfg.queries), np.zeros(cfg.queries), np.zeros(cfg.queries)
        cpu = np.zeros(cfg.queries)
        update = ctx.progress(f"localizing {level.name}", cfg.queries)
        with closing(q):  # an engine's process (vizdoom) stops here, also on an error
            for n, (pose, f, dif) in enumerate(q):
                h = loc.localize(f)[0]
                true[n], diff[n] = pose, dif
                est[n], conf[n], ms[n] = h.pose, h.confidence, loc.last_timing["total"]
                cpu[n] = loc.last_timing["cpu"]
                update(n + 1)
        np.savez(d / LOCALIZE_FILE, true=true, est=est, confidence=conf, query_ms=ms, query_cpu_ms=cpu,
                 diff=diff, info=np.array(json.dumps({"bank_build_s": bank.meta["build_s"],
                                                             "bank_bytes": bank.meta["bytes"]})))

    inputs = {**map_inputs(vmap, level), "level": level.key, "bank": bank.key}
    path, key, cached = ctx.run("localize-eval", localize_key_config(cfg), inputs, compute)
    return Ref("localize-eval", key, path / LOCALIZE_FILE, cached, level.name,
               {"map_key": vmap.key, "bank_key": bank.key, "bank_cached": bank.cached, **bank.meta})


def load_localize_results(path) -> dict:
    """The arrays of a localize-eval artifact plus its ``info`` dict."""
    with np.load(path) as z:
        out = {k: z[k] for k in z.files if k != "info"}
        out["info"] = json.loads(str(z["info"]))
    return out


def summarise_localization(res: dict) -> dict:
    """Recall within 25 / 50 / 100 cm, within 50 cm and 10 degrees, median errors, query times."""
    from navbench.geometry import wrap_angle

    err = np.hypot(*(res["est"][:, :2] - res["true"][:, :2]).T)
    herr = np.degrees(np.abs(wrap_angle(res["est"][:, 2] - res["true"][:, 2])))
    ms = res["query_ms"]
    return {
        "queries": int(len(err)),
        "recall_25cm": float(np.mean(err <= 0.25)), "recall_50cm": float(np.mean(err <= 0.5)),
        "recall_100cm": float(np.mean(err <= 1.0)),
        "recall_50cm_10deg": float(np.mean((err <= 0.5) & (herr <= 10))),
        "heading_10deg": float(np.mean(herr <= 10)),
        "median_loc_err_m": float(np.median(err)), "median_heading_err_deg": float(np.median(herr)),
        "query_ms_median": float(np.median(ms)), "query_ms_p90": float(np.percentile(ms, 90)),
        "query_cpu_ms_median": float(np.median(res["query_cpu_ms"])) if "query_cpu_ms" in res else None,
        "query_cpu_ms_p90": float(np.percentile(res["query_cpu_ms"], 90)) if "query_cpu_ms" in res else None,
        "image_diff_mean": float(np.mean(res["diff"])),
        "bank_build_s": float(res["info"]["bank_build_s"]), "bank_mb": res["info"]["bank_bytes"] / 1e6,
    }
