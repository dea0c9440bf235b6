"""Relocalisers for the tracker's recovery from a lost track (issue 14, "kidnapped robot").

A relocaliser answers "where in the map is this view?" with no initial pose: an object with
``localize(frame, k=None) -> list[Hypothesis]``, best first, each hypothesis a planar ``pose``
``(x, y, theta)``, a ``score`` (higher is better) and a ``confidence`` in ``[0, 1]``. That is
the interface of ``navbench.localize.Localizer`` (issue 14, section 1); ``ours`` uses any
object with it (constructor argument ``relocalizer=``), or builds one lazily by name from
:data:`RELOCALIZERS` (option ``relocalizer_name``) the first time its health test fires:

``localize``
    ``navbench.localize.Localizer.build(world_model, intrinsics, camera_height)``, the
    signature-bank localiser (a one-line error where this build of navbench lacks it).
``grid``
    :class:`GridRelocalizer`: brute force over a pose lattice of the map's free space, rendered
    from the map at low resolution, the best candidates refined by the tracker's own alignment
    (eq. 7, Gauss-Newton, loose prior) and ranked by the health test's inlier fraction. Slow to
    build on a large level but simple and exact on a small one: the reference the faster
    localiser can be checked against, and the relocaliser of the tests.

Math layer: arrays in, arrays out; no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from navbench.errors import TrackingError
from navbench.geometry import AGENT_LENGTH, CAMERA_HEIGHT, Frame, Intrinsics, camera_pose


@dataclass(frozen=True)
class Hypothesis:
    """One answer of a relocaliser: planar ``pose (3,)``, ``score`` (higher is better) and
    ``confidence`` in ``[0, 1]`` (for :class:`GridRelocalizer`: the health inlier fraction)."""

    pose: np.ndarray
    score: float
    confidence: float


class GridRelocalizer:
    """Brute-force relocalisation over a lattice of poses (see the module doc).

    ``render(pose, small: bool) -> Frame`` renders the map at full (``intrinsics``) or low
    (``small_intrinsics``) resolution; ``positions (P, 2)`` and ``headings (A,)`` (rad) span the
    lattice. Building renders ``P x A`` low-resolution views (the bank); a query compares the
    frame, sampled at the low-resolution pixel centres, with every bank view (mean clipped
    log-depth difference, colour L1 and validity mismatch), refines the ``top`` best by
    ``rounds`` rounds of the tracker's alignment ``align(ref, frame, pose, cfg, seed,
    camera_height) -> pose`` (:func:`navbench.track.ours.align`, injected) against the map's
    full rendering, and ranks them by the health inlier fraction at the refined pose.
    """

    def __init__(self, render: Callable[[np.ndarray, bool], Frame], intrinsics: Intrinsics,
                 small_intrinsics: Intrinsics, positions: np.ndarray, headings: np.ndarray,
                 align: Callable, camera_height: float = CAMERA_HEIGHT, top: int = 5,
                 rounds: int = 3):
        from navbench.track.eq7 import TrackerConfig

        positions = np.asarray(positions, dtype=np.float64).reshape(-1, 2)
        if len(positions) == 0:
            raise TrackingError("grid relocaliser: the map has no free lattice position")
        self.render = render
        self.align = align
        rng = np.random.default_rng([0x6E1C, *intrinsics.shape])
        self._health_idx = np.sort(rng.choice(intrinsics.width * intrinsics.height,
                                              min(1000, intrinsics.width * intrinsics.height),
                                              replace=False))
        self.intrinsics = intrinsics
        self.small = small_intrinsics
        self.camera_height = float(camera_height)
        self.top = int(top)
        self.rounds = int(rounds)
        self.poses = np.array([(x, y, float(a)) for x, y in positions for a in headings])
        # the tracker's Gauss-Newton with a prior loose enough to cross half a lattice cell
        self.refine_cfg = TrackerConfig(prior_sigma=(0.3, 0.3))
        h, w = small_intrinsics.shape
        f = small_intrinsics.fx / intrinsics.fx
        H, W = intrinsics.shape
        us = np.clip(np.round(np.arange(w) / f), 0, W - 1).astype(np.int64)
        vs = np.clip(np.round(np.arange(h) / f), 0, H - 1).astype(np.int64)
        self._sample = (vs[:, None] * W + us[None, :]).reshape(-1)
        bank = [self._signature(render(p, True), small=True) for p in self.poses]
        self.depth = np.stack([b[0] for b in bank])
        self.rgb = np.stack([b[1] for b in bank])

    @classmethod
    def from_world_model(cls, vmap, intrinsics: Intrinsics, align: Callable,
                         camera_height: float = CAMERA_HEIGHT, step: float = 0.25, heading_step_deg: float = 10.0, scale: float = 0.125,
                         clearance: float = AGENT_LENGTH / 2, **kw) -> "GridRelocalizer":
        """The lattice every ``step`` metres over the map's free band slice at ``clearance`` from
        occupied cells (inside the occupied cells' bounding box), headings every
        ``heading_step_deg``, the bank at ``scale`` times the camera's resolution."""
        from scipy.ndimage import distance_transform_edt

        occ, xs, ys = vmap.occupancy_slice("band")
        if not occ.any():
            raise TrackingError("grid relocaliser: the map has no occupied cell")
        cell = float(abs(xs[1] - xs[0])) if len(xs) > 1 else step
        dist = distance_transform_edt(~occ) * cell
        ix, iy = np.nonzero(occ)
        lo, hi = np.array([xs[ix.min()], ys[iy.min()]]), np.array([xs[ix.max()], ys[iy.max()]])
        gx = np.arange(lo[0] + step / 2, hi[0], step)
        gy = np.arange(lo[1] + step / 2, hi[1], step)
        P = np.stack(np.meshgrid(gx, gy, indexing="ij"), -1).reshape(-1, 2)
        i = np.clip(np.searchsorted(xs, P[:, 0]), 0, len(xs) - 1)
        j = np.clip(np.searchsorted(ys, P[:, 1]), 0, len(ys) - 1)
        P = P[dist[i, j] >= clearance]
        small = intrinsics.scaled(scale)
        full_r = vmap.renderer(intrinsics, camera_height)
        small_r = vmap.renderer(small, camera_height)
        headings = np.radians(np.arange(-180.0, 180.0, heading_step_deg))

        def render(pose, is_small):
            return (small_r if is_small else full_r).render(pose)

        return cls(render, intrinsics, small, P, headings, align, camera_height, **kw)

    def _signature(self, frame: Frame, small: bool) -> tuple[np.ndarray, np.ndarray]:
        """(log z-depth, 0 where invalid; rgb) at the low-resolution pixels, flattened."""
        if small:
            d = np.asarray(frame.depth, np.float64).reshape(-1)
            ok = np.asarray(frame.valid).reshape(-1)
            rgb = np.asarray(frame.rgb, np.float64).reshape(-1, 3)
        else:
            d = np.asarray(frame.depth, np.float64).reshape(-1)[self._sample]
            ok = np.asarray(frame.valid).reshape(-1)[self._sample]
            rgb = np.asarray(frame.rgb, np.float64).reshape(-1, 3)[self._sample]
        ok = ok & np.isfinite(d) & (d > 0)
        logd = np.where(ok, np.log(np.where(ok, d, 1.0)), np.nan)
        return logd.astype(np.float32), rgb.astype(np.float32)

    def candidates(self, frame: Frame) -> np.ndarray:
        """Lattice poses ``(M, 3)`` ordered by their low-resolution cost (best first)."""
        qd, qc = self._signature(frame, small=False)
        both = np.isfinite(self.depth) & np.isfinite(qd)[None]
        dd = np.where(both, np.minimum(np.abs(self.depth - qd[None]), 0.5), 0.0)
        mismatch = np.isfinite(self.depth) != np.isfinite(qd)[None]
        col = np.abs(self.rgb - qc[None]).sum(axis=2)
        cost = (dd.sum(axis=1) + 0.5 * mismatch.sum(axis=1) + 0.2 * col.sum(axis=1)) / len(qd)
        return self.poses[np.argsort(cost, kind="stable")]

    def localize(self, frame: Frame, k: int | None = None) -> list[Hypothesis]:
        """Hypotheses, best first (``k`` of them; default ``top``)."""
        from navbench.track.eq7 import prepare_reference
        from navbench.track.health import inlier_fraction

        idx = self._health_idx
        out = []
        for pose in self.candidates(frame)[: self.top]:
            for _ in range(self.rounds):
                ref = prepare_reference(self.render(pose, False), self.intrinsics,
                                        camera_pose(pose, self.camera_height))
                pose = self.align(ref, frame, pose, self.refine_cfg, 0, self.camera_height)
            ref = prepare_reference(self.render(pose, False), self.intrinsics,
                                    camera_pose(pose, self.camera_height))
            f = inlier_fraction(ref, frame, pose, idx, camera_height=self.camera_height)
            f = 0.0 if math.isnan(f) else f
            out.append(Hypothesis(pose, f, f))
        out.sort(key=lambda h: -h.score)
        return out[: (self.top if k is None else int(k))]


def _build_localizer(vmap, intrinsics: Intrinsics, camera_height: float, align: Callable):
    from navbench.localize import Localizer

    return Localizer.build(vmap, intrinsics, camera_height)


def _build_grid(vmap, intrinsics: Intrinsics, camera_height: float, align: Callable):
    return GridRelocalizer.from_world_model(vmap, intrinsics, align, camera_height)


#: Relocaliser factories by name: ``(world_model, intrinsics, camera_height, align) ->
#: relocaliser`` (``align``: the tracker's eq. 7 alignment, for those that refine with it).
#: Replace or add an entry to swap the relocaliser ``ours`` builds.
RELOCALIZERS: dict[str, Callable] = {"localize": _build_localizer, "grid": _build_grid}


def relocalizer_settings(options: dict) -> dict | None:
    """What a cache key must hold of the relocaliser an estimator with keyword ``options`` would
    build: ``None`` without ``recover``; else its name and, for ``localize``, every field of the
    :class:`~navbench.localize.LocalizerConfig` it builds with (its defaults change as the
    localiser improves, and a study that recovers through it changes with them)."""
    if options.get("recover") is not True:
        return None
    name = options.get("relocalizer_name", "localize")
    if name != "localize":
        return {"name": name}
    from navbench.localize import LocalizerConfig
    from navbench.localize.localizer import keyed_settings

    return {"name": name, "config": keyed_settings(LocalizerConfig())}


def check_relocalizer(name: str) -> None:
    """Raise :class:`TrackingError` now (before any tracking) when ``name`` is not a known
    relocaliser."""
    if name not in RELOCALIZERS:
        raise TrackingError(f"unknown relocalizer {name!r}; choose one of {sorted(RELOCALIZERS)}")


def build_relocalizer(name: str, vmap, intrinsics: Intrinsics, camera_height: float,
                      align: Callable):
    """The relocaliser ``name`` of :data:`RELOCALIZERS` for the world model ``vmap``."""
    check_relocalizer(name)
    if vmap is None:
        raise TrackingError(f"relocalizer {name!r} needs a map (vmap=...)")
    hash_of = getattr(vmap, "content_hash", None)
    key = (name, RELOCALIZERS[name], hash_of() if callable(hash_of) else id(vmap), intrinsics,
           float(camera_height))
    if key not in _BUILT:  # one per map and camera per process (navigation builds an estimator per episode)
        if len(_BUILT) >= 4:
            _BUILT.pop(next(iter(_BUILT)))
        _BUILT[key] = RELOCALIZERS[name](vmap, intrinsics, camera_height, align)
    return _BUILT[key]


#: Relocalisers built by :func:`build_relocalizer` in this process, oldest first (at most 4).
_BUILT: dict = {}

