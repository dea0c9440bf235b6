"""The localiser: panoramic signature bank, circular correlation, eq.-7 refinement.

Build (once per map and camera, :meth:`Localizer.build`)
    1. a lattice of planar positions every ``lattice_step`` metres in the map's free space (the
       world model's body-band occupancy slice, ``clearance`` metres from any occupied cell);
    2. at each lattice point a 360-degree *panorama signature*: ``bins`` uniform heading bins,
       and per bin the inverse horizontal range and the grey level at ``rows`` elevations
       (thin renders through the world model's renderer, four 90-degree quadrants resampled
       to the bins). Headings are not stored separately: a query's field of view is a window
       of the panorama.

Query (:meth:`Localizer.localize`)
    1. the query frame's signature over its field of view (the same elevations and bins);
    2. the squared distance to every lattice point's panorama at every circular shift by FFT,
       reduced to each point's best shift and cost in one fused pass
       (:meth:`navbench.localize.signature.Correlator.best`): best shift = heading; the
       ``truncate_top`` best points are re-ranked by a truncated L1 distance at that shift
       (:func:`~navbench.localize.signature.truncated_costs`: changed furniture costs at most
       ``truncate`` per bin; ``trim > 0`` also drops the worst columns);
    3. candidates, best first after non-maximum suppression (``nms_radius``, ``nms_deg``), are
       refined by the ``ours`` alignment (planar Gauss-Newton of eq. 7 against the map's render
       at the candidate, ``refine_rounds`` render + align rounds, no prior to speak of; point-to-
       plane residuals over ``geo_threshold`` are ignored: a truncated L1, so that furniture the
       map lacks does not pull the pose) and verified at every render
       (:func:`one_sided_confidence`): ``confidence`` = share of the query's sampled valid pixels
       whose depth (within ``inlier_abs + inlier_rel * depth``) and colour (mean RGB difference
       within ``inlier_colour``) the map predicts; the *score* weights pixels seen in front of or
       beyond the map's surface (what added, moved or removed furniture causes) by
       ``front_weight`` / ``beyond_weight`` against contradictions (right depth, wrong colour:
       walls never change), minus the inliers' mean colour difference. A refinement whose
       rounds lower the score is undone (the best rendered pose is kept). Once a hypothesis is
       verified (``confidence >= accept``), a later candidate whose score at its coarse pose
       (tolerances x ``screen_loose``) is more than ``screen_margin`` below the best is not
       aligned (screened). Refinement stops once ``min_candidates`` were tried and ``k``
       distinct hypotheses reach ``accept`` and the next coarse candidate's cost exceeds the best
       one's by more than ``close_margin`` (or ``close_max`` were refined: a near tie of the
       signatures is decided by verifying each), or after ``max_candidates``;
    4. the robust search (changed rooms): when the first ``robust_after`` refined candidates
       verify nothing, the rest of the ``max_candidates`` come from a truncated L1 over *every*
       lattice point at *every* shift (:func:`~navbench.localize.signature.exhaustive_truncated`:
       each channel value costs at most ``robust_tau``, depth channels weigh
       ``robust_depth_weight`` against the grey ones), skipping those already tried. The L2
       correlation lets the columns new furniture fills decide the heading and the ranking; the
       truncated cost lets the unchanged columns decide. Each robust candidate is first moved
       by correlative scan matching of the query's horizon row (:mod:`navbench.localize.scan`,
       within ``scan_radius`` m and ``scan_deg`` degrees: a basin eq. 7 does not have in a
       changed room) and refined from there and, with ``scan_both``, from where it was.

Hypotheses come back best first by ``score``; poses refined to the same place
(5 cm, 2 degrees) are reported once. An ambiguous view (a symmetric room) gives several
hypotheses with near-equal scores: ask for ``k >= 2`` to see them.

Tuning (coarse-candidate recall, 150 queries on the true map of ``tune-house``, a house
generated with seed 1234 and not among the reported levels): the clipped-range depth channel
beats inverse range (top-8 recall 96.7 vs 80.0 %), a 0.125 m lattice beats 0.25 m (top-3
99.3 vs 95.3 %), 192 heading bins do as well as 360 (top-3 99.3 %) at half the cost; grey
weight, elevations and clipping range mattered little. Up to 24 candidates (not 8) are refined
when none verifies: the verification of the right pose survives changed furniture (confidence
~0.9 at 6 % changed pixels) better than the coarse ranking does (OC1, 30 queries: 63 -> 70 %).
Re-ranking the 1000 points of best L2 cost by the truncated L1 cost (tau 0.1) at their best
shift brings the right place among the 24 first candidates for 84-92 % of OC1 queries (L2
alone: 72 %), 76-84 % of OC3 (52 %), and changes nothing on unchanged rooms (100 %; 25-40
queries each, tune-house).

Changed rooms and speed (issue 14 follow-up; ``docs/data/localisation/localize_diagnose.py`` on ``tune-house``
only): of the OC4 failures on its true map, 12 of 22 were the wrong place out-scoring the true
pose and 6 a refinement pulled off the true pose by the changed furniture. Most changed pixels
at the true pose were *beyond* the map's surface (removed or moved furniture), so both depth
signs are down-weighted (0.3), not only the in-front one. With the truncated point-to-plane
(0.3 m), the undo and the weights, OC4 on the true map went 26.7 -> 60.0 % (30 queries), OC1
76.7 -> 90.0 %; unchanged rooms stayed at 98-99 % (true) and 92-93 % (quick fit, 300 queries:
the failures are near-ties of views dominated by one nearby wall). Trimming columns and higher
elevations did not help the coarse ranking of OC4 views (the true place ranks ~1000th of ~3700:
the signature, not the search, is the limit there). ``accept`` 0.85 with 2 candidates at least
and screening: median query CPU ~0.85x of the former 0.8 / 3 / no screening at recall within a
query or four in 300 (quick fit); its p90 is higher (hard views now try up to 24 candidates),
``accept=0.8`` brings it back at ~1 % recall.

The robust search (issue 14, 2026-11-26; ``tune-house`` only, 40 OC4 queries): the true place
was among the first 24 candidates for 57 % of the queries on the quick fit under the L2
correlation and its re-ranking, 97 % under the exhaustive truncated L1 with grey weight 1,
depth 0.3, tau 0.05 (grey alone 90 %, tau 0.1: 82-90 %, depth alone 45 %: in changed rooms the
walls' colours say more than the furniture-cut ranges); recall within 50 cm 45 -> 67.5 % (fit),
55 -> 75 % (true map); on 100 OC4 queries 41 -> 64 % (fit). It runs only when nothing verifies (unchanged rooms, six houses: recall
within a query of 1000, median and p90 query time within 7 % of the code before). Re-scoring near-tied hypotheses on the full frame, all
strided pixels in the verification, 3 refinement rounds, ``geo_threshold`` 0.15 or
``photo_threshold`` 0.3 changed recall by at most a query or two of 40 and were not kept.

The scan matching (same day, tune-house only, 100 OC4 and 300 unchanged uniform queries on the
quick fit): without it, the candidate nearest the truth was 5-45 cm and up to 25 degrees off in
19 of the 36 failures and eq. 7 did not converge from there. Matched within 0.3 m / 15 deg: OC4
64 -> 71 %; 0.45 m / 25 deg: 78 % (coarse-to-fine: 77 % at 0.42x the time); but the moved start
alone cost unchanged rooms 93.0 -> 91.7 % (a more exhaustive search finds more look-alike places
that out-score the truth), gated by the verification the same; refining both the moved start
and the candidate (``scan_both``): OC4 72 %, unchanged 93.0 %. 34 candidates instead of 24:
75 % / 92.3 %, not kept.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, replace
from typing import NamedTuple

import numpy as np

from navbench.errors import NavbenchError
from navbench.geometry import Frame, Intrinsics, camera_pose, wrap_angle
from navbench.localize import signature as sig
from navbench.localize.bankrender import panoramas
from navbench.localize.candidates import _dedupe, _same_candidate, _suppress, candidates  # noqa: F401
from navbench.track.eq7 import (TrackerConfig, accumulate, linearization, pixel_table, prepare_reference,
                                prior_terms, retract, sample_observation, to_planar)
from navbench.track.lie import se3_inverse


class LocalizationError(NavbenchError):
    """A localiser input a user can get wrong (an empty map, a frame of the wrong size)."""


@dataclass(frozen=True)
class LocalizerConfig:
    """Every setting of the localiser; its hash (with the map's and the camera's) keys the bank."""

    lattice_step: float = 0.125    # m between lattice points
    clearance: float = 0.1         # m from any occupied cell (the agent radius)
    bins: int = 192                # heading bins of a panorama (1.875 deg)
    rows: int = 4                  # signature elevations y_c = row_top + j * row_step
    row_top: float = -0.3
    row_step: float = 0.15
    depth_feature: str = "range"   # signature depth channel: "range" (clipped) or "inverse"
    feature_range: float = 8.0     # m: ranges are clipped here ("range")
    grey_weight: float = 0.5       # weight of the grey channel against the depth channel
    truncate: float = 0.1          # > 0: re-rank the truncate_top points with the best L2 cost ...
    truncate_top: int = 1000       # ... at their best shift by the truncated L1 cost (robust)
    trim: float = 0.0              # re-ranking drops this share of the window's worst columns
    k: int = 1                     # hypotheses returned by default
    max_candidates: int = 24       # at most this many candidates are refined by eq. 7 ...
    min_candidates: int = 2        # ... at least this many ...
    accept: float = 0.85           # ... stopping once k of them reach this confidence
    nms_radius: float = 0.5        # m: candidates closer than this (and nms_deg) are one
    nms_deg: float = 30.0
    refine_rounds: int = 2         # render + Gauss-Newton rounds per candidate
    screen_margin: float = 0.3     # > 0: a candidate whose score at its coarse pose is more than
    #                                this below the best refined score is not aligned (screened out)
    screen_loose: float = 3.0      # ... its score taken with the inlier tolerances times this
    refine_stride: int = 2         # refine and verify on every n-th pixel (renders n^2 cheaper)
    gn_pixels: int = 800
    inlier_abs: float = 0.05       # m: depth agreement tolerance abs + rel * depth
    inlier_rel: float = 0.03
    inlier_colour: float = 0.1     # mean |RGB difference| tolerance of an inlier (colour units)
    geo_threshold: float = 0.3     # m: refinement ignores point-to-plane residuals above (truncated L1)
    photo_threshold: float = 1.0   # refinement ignores photometric L1 residuals above (colour units)
    front_weight: float = 0.3      # verification: weight of a pixel seen in front of the map's
    beyond_weight: float = 0.3     # ... and beyond it, against a contradiction (see one_sided_confidence)
    robust_after: int = 4          # > 0: once this many candidates are refined and none verified, the
    #                                rest come from the robust search (every point, every shift)
    robust_tau: float = 0.05       # robust search: truncated L1 per channel value ...
    robust_depth_weight: float = 0.3  # ... depth channels weighted this against the grey ones (1)
    scan_radius: float = 0.45      # > 0: each robust candidate first moved by correlative scan
    scan_deg: float = 25.0         # ... matching of the view's horizon row within this (m, deg)
    scan_trunc: float = 0.2        # ... on the map's likelihood field truncated here (m),
    scan_coarse: int = 2           # ... a grid this many times sparser first; with
    scan_both: bool = True         # ... the candidate itself refined too (each counts)
    close_margin: float = 1.0      # > 0: after the stop above, refine on while the next coarse candidate's
    close_max: int = 6             # ... cost exceeds the best one's by at most this, up to this many
    #                                refined (2026-11-26; 0: off, the search before that day)
    reverify: float = 0.01         # > 0: a refined pose the last round moved more than this (m, or
    #                                rad in heading) is rendered and verified again, so that every
    #                                hypothesis's score is its own pose's; 0: the last render's score
    #                                stands for it (before 2026-11-26: up to 0.6 m away in changed rooms)


def keyed_settings(cfg: LocalizerConfig) -> dict:
    """Every field of ``cfg`` as a dict, for the cache keys that hold a resolved localiser, less
    the fields added since those keys were first stored when they leave the search as it was
    (``close_margin = 0`` drops ``close_margin`` and ``close_max``): a new option at its neutral
    value keeps the stored results' keys."""
    d = asdict(cfg)
    if cfg.close_margin == 0:
        d.pop("close_margin")
        d.pop("close_max")
    return d


@dataclass(frozen=True)
class Hypothesis:
    """A pose the frame may have been taken from: ``pose`` (x, y, theta) in m, rad; ``score``
    (higher is better, the ranking key); ``confidence`` in [0, 1] from the depth residual."""

    pose: np.ndarray
    score: float
    confidence: float


class Bank(NamedTuple):
    """The cached part of a localiser: lattice ``points (N, 2)`` (m) and their panorama
    signatures ``pano (N, C, bins)`` float32."""

    points: np.ndarray
    pano: np.ndarray


class Localizer:
    """See the module docstring. ``last_timing``: the last query's component times (ms):
    ``signature``, ``correlate``, ``refine``, ``total`` (wall clock) and ``cpu`` (the process's
    CPU time for the whole query: the wall time it would take on an idle core);
    ``last_candidates`` and ``last_refined``: its coarse candidate poses and their refined
    hypotheses, in coarse order (what ``docs/data/localisation/localize_diagnose.py`` reads)."""

    def __init__(self, world_model, intrinsics: Intrinsics, camera_height: float,
                 config: LocalizerConfig, bank: Bank):
        if len(bank.points) == 0:
            raise LocalizationError("localizer: the map has no free lattice point (an empty or "
                                    "fully occupied map?)")
        if np.ptp(bank.pano[:, : config.rows]) == 0:
            raise LocalizationError("localizer: the map renders nothing from its free space (an "
                                    "empty map?)")
        self.world_model = world_model
        self.intrinsics = intrinsics
        self.camera_height = float(camera_height)
        self.config = config
        self.bank = bank
        self.last_timing: dict[str, float] = {}
        self.last_candidates: list[np.ndarray] = []   # the last query's coarse candidates
        self.last_refined: list[Hypothesis] = []      # ... and their refinements, coarse order
        self._ycs = sig.elevations(config.rows, config.row_top, config.row_step)
        self._R = sig.half_window(intrinsics, config.bins)
        self._corr = sig.Correlator(bank.pano, self._R)
        self._wrapped: np.ndarray | None = None  # the robust search's copy of the panoramas
        self._scan = None  # the likelihood field of the scan matching, made when first needed
        _check_search(config)
        n = int(config.refine_stride)
        if n < 1:
            raise LocalizationError(f"localizer: refine_stride must be >= 1, got {n}")
        # every n-th pixel of the query is the image of these intrinsics exactly
        self._rintr = Intrinsics(len(range(0, intrinsics.width, n)), len(range(0, intrinsics.height, n)),
                                 intrinsics.fx / n, intrinsics.fy / n, intrinsics.cx / n, intrinsics.cy / n)
        self._renderer = world_model.renderer(self._rintr, camera_height)
        H, W = self._rintr.shape
        self._idx = pixel_table(H, W, rows=1, cols=min(config.gn_pixels, H * W), seed=0)[0]
        self._gn = replace(TrackerConfig(), prior_sigma=(10.0, 10.0), yaw_search_deg=0.0,
                          gn_pixels=len(self._idx), geo_threshold=float(config.geo_threshold),
                          photo_threshold=float(config.photo_threshold))

    @classmethod
    def build(cls, world_model, intrinsics: Intrinsics, camera_height: float,
              config: LocalizerConfig = LocalizerConfig()) -> "Localizer":
        """Render the signature bank of ``world_model`` (any :class:`~navbench.worldmodel.base.WorldModel`)
        for a camera ``intrinsics`` at ``camera_height``; :class:`LocalizationError` for a map
        with no free lattice point."""
        _check_search(config)  # before the bank's seconds of rendering
        return cls(world_model, intrinsics, camera_height, config,
                   build_bank(world_model, camera_height, config))

    def localize(self, frame: Frame, k: int | None = None) -> list[Hypothesis]:
        """The ``k`` (default ``config.k``) best poses for ``frame`` (an RGB-D
        :class:`~navbench.geometry.Frame` of this localiser's intrinsics), best first."""
        cfg = self.config
        k = cfg.k if k is None else int(k)
        if k < 1:
            raise LocalizationError(f"localize: k must be >= 1, got {k}")
        shape = tuple(np.shape(frame.depth))
        if shape != self.intrinsics.shape or np.shape(frame.rgb)[:2] != shape \
                or np.shape(frame.valid) != shape:
            raise LocalizationError(f"localize: frame is {shape}, the localiser's intrinsics say "
                                    f"{self.intrinsics.shape}")
        t0, c0 = time.perf_counter(), time.process_time()
        Q = sig.query_signature(frame, self.intrinsics, self._ycs, cfg.grey_weight, cfg.bins,
                                cfg.depth_feature, cfg.feature_range)
        t1 = time.perf_counter()
        budget = max(k, cfg.max_candidates)
        # (pose, scan-match it first?): the fast path's candidates are refined as they are
        ccost: list[float] = []
        queue = [(c, False) for c in self.coarse_candidates(Q, budget, ccost)]
        t2 = time.perf_counter()
        small = self.strided(frame)
        hyps: list[Hypothesis] = []
        tried: list[np.ndarray] = []
        robust_ms = 0.0
        while queue and len(hyps) < budget:  # coarse order; stop once k are verified
            if 0 < cfg.robust_after == len(hyps) and not any(h.confidence >= cfg.accept for h in hyps):
                tr = time.perf_counter()  # nothing verified: a changed room? the robust search
                queue = [(c, cfg.scan_radius > 0) for c in self.robust_candidates(Q, budget)
                         if not any(_same_candidate(c, t, cfg) for t in tried)]
                ccost = []  # the coarse costs no longer describe the queue
                robust_ms = 1e3 * (time.perf_counter() - tr)
                if not queue:
                    break
            pose, match = queue.pop(0)
            if match:  # a robust candidate: widen the basin
                moved = self._scan_start(frame, pose)
                if cfg.scan_both and np.hypot(*(moved[:2] - pose[:2])) > 0.01:
                    queue.insert(0, (pose, False))  # refined next, as it is
                pose = moved
            top = max(hyps, key=lambda h: h.score) if hyps else None
            # screening only against a verified hypothesis (changed rooms verify none: all refined)
            floor = top.score - cfg.screen_margin if top is not None and cfg.screen_margin > 0 \
                and top.confidence >= cfg.accept else -np.inf
            tried.append(pose)
            hyps.append(self._refine(small, pose, floor))
            if len(hyps) >= cfg.min_candidates and \
                    len(_dedupe([h for h in hyps if h.confidence >= cfg.accept])) >= k \
                    and not self._close_next(queue, ccost, len(hyps)):
                break
        self.last_candidates = tried + [c for c, _ in queue]
        self.last_refined = list(hyps)
        hyps = _dedupe(sorted(hyps, key=lambda h: -h.score))
        t3 = time.perf_counter()
        self.last_timing = {"signature": 1e3 * (t1 - t0), "correlate": 1e3 * (t2 - t1),
                            "robust": robust_ms, "refine": 1e3 * (t3 - t2) - robust_ms,
                            "total": 1e3 * (t3 - t0), "cpu": 1e3 * (time.process_time() - c0)}
        return hyps[:k]

    def query_signature(self, frame: Frame) -> np.ndarray:
        """The query window of ``frame`` (:func:`navbench.localize.signature.query_signature`)."""
        cfg = self.config
        return sig.query_signature(frame, self.intrinsics, self._ycs, cfg.grey_weight, cfg.bins,
                                   cfg.depth_feature, cfg.feature_range)

    def _close_next(self, queue, ccost: list[float], refined: int) -> bool:
        """Whether the next queued candidate, ``ccost[refined]`` while the queue is the coarse
        search's (the robust search empties ``ccost``), has a coarse cost exceeding the best
        coarse cost by at most ``close_margin`` (the truncated L1 of the re-ranking), with
        fewer than ``close_max`` refined: the search goes on past ``k`` verified hypotheses for
        views the coarse costs do not decide (a near tie in the signatures; ``close_margin =
        0``: never). A difference, not a ratio: a changed room adds its changed columns' cost to
        every candidate, and a ratio then calls far more of them near ties."""
        cfg = self.config
        if cfg.close_margin <= 0 or refined >= cfg.close_max or not queue or refined >= len(ccost):
            return False
        return ccost[refined] - ccost[0] <= cfg.close_margin

    def coarse_candidates(self, Q: np.ndarray, count: int, costs: list | None = None) -> list[np.ndarray]:
        """The ``count`` best coarse poses for the query window ``Q``, best first: circular
        correlation over the bank, robust re-ranking, non-maximum suppression. ``costs``: a
        list the candidates' coarse costs are appended to, in the same order."""
        cfg = self.config
        best, cost = self._corr.best(Q)
        if cfg.truncate > 0:  # robust re-ranking of the best points at their best L2 shift
            top = np.arange(len(cost))
            if cfg.truncate_top < len(cost):
                top = np.argpartition(cost, cfg.truncate_top)[: cfg.truncate_top]
            if cfg.trim > 0:
                keep = max(1, int(round((1.0 - cfg.trim) * Q.shape[1])))
                rob = sig.trimmed_costs(self._pano_top(top), Q, best[top, None], cfg.truncate, keep)
            else:
                rob = sig.truncated_costs(self._pano_top(top), Q, best[top, None], cfg.truncate)
            cost = np.full_like(cost, np.inf)
            cost[top] = rob[:, 0]
        return candidates(best, cost, self.bank.points, count, cfg, costs)

    def robust_costs(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(best shift, cost)`` of every lattice point for the query window ``Q`` under the
        robust search (:func:`~navbench.localize.signature.exhaustive_truncated` over every
        shift: each channel value costs at most ``robust_tau``, depth channels weigh
        ``robust_depth_weight``, grey ones 1)."""
        cfg = self.config
        rows = cfg.rows
        weight = np.r_[np.full(rows, cfg.robust_depth_weight), np.ones(self.bank.pano.shape[1] - rows)]
        if self._wrapped is None:  # built at the first robust search (most maps never need it)
            self._wrapped = sig.wrapped_panorama(self.bank.pano, Q.shape[1])
        return sig.exhaustive_truncated(self.bank.pano, Q, weight, np.full(len(weight), cfg.robust_tau),
                                        self._wrapped)

    def robust_candidates(self, Q: np.ndarray, count: int) -> list[np.ndarray]:
        """The ``count`` best coarse poses for ``Q`` under the robust search
        (:meth:`robust_costs`), after non-maximum suppression, best first."""
        shift, cost = self.robust_costs(Q)
        return candidates(shift, cost, self.bank.points, count, self.config)

    def _scan_start(self, frame: Frame, pose: np.ndarray) -> np.ndarray:
        """``pose`` moved to where the horizon row of ``frame`` best fits the map's occupancy at
        the camera's height (:func:`navbench.localize.scan.match_scan` within ``scan_radius`` m
        and ``scan_deg`` degrees); ``pose`` itself when the row sees too little."""
        from navbench.localize import scan

        cfg = self.config
        if self._scan is None:
            occ, xs, ys = self.world_model.occupancy_slice("slice", height=self.camera_height)
            self._scan = (scan.likelihood_field(occ, xs, ys, cfg.scan_trunc), xs, ys)
        field, xs, ys = self._scan
        pts = scan.horizon_scan(frame, self.intrinsics, self.camera_height, cfg.feature_range,
                                stride=cfg.refine_stride)
        if len(pts) < 10 or len(xs) < 2 or len(ys) < 2:
            return pose
        return scan.match_scan(field, xs, ys, cfg.scan_trunc, pts, pose, cfg.scan_radius,
                               max_deg=cfg.scan_deg, coarse=cfg.scan_coarse)[0]

    def strided(self, frame: Frame) -> Frame:
        """Every ``refine_stride``-th pixel of ``frame``: what refinement and verification see."""
        n = self.config.refine_stride
        return Frame(frame.rgb[::n, ::n], frame.depth[::n, ::n], frame.valid[::n, ::n])

    def refine(self, frame: Frame, pose) -> Hypothesis:
        """Refine and verify a full-size ``frame`` from ``pose`` (what a query does per candidate)."""
        return self._refine(self.strided(frame), pose)

    def verify_at(self, frame: Frame, pose) -> Hypothesis:
        """Verify a full-size ``frame`` at ``pose`` as is (no refinement): the score a query
        would give a candidate refined exactly to ``pose``."""
        small = self.strided(frame)
        conf, score = self._verify(small, self._renderer.render(np.asarray(pose, np.float64)))
        return Hypothesis(np.asarray(pose, np.float64), score, conf)

    def _pano_top(self, top: np.ndarray) -> np.ndarray:
        return self.bank.pano[top]

    def _refine(self, frame: Frame, pose: np.ndarray, floor: float = -np.inf) -> Hypothesis:
        """Eq. 7 alignment of ``frame`` (the query's every ``refine_stride``-th pixel) against
        the map's renders from ``pose`` on, verified. Each round's render is verified (the
        pose it was rendered at scores that); the last round's refined pose is reported with
        the last render's score when that round moved it by at most ``reverify`` (m, rad), else
        with its own render's score, unless an earlier rendered pose scored better: then that
        one (a refinement that a changed room pulled away is undone). A
        candidate scoring below ``floor`` at its own pose is returned there unrefined."""
        cfg = self.config
        pose = np.asarray(pose, np.float64)
        best: tuple[float, float, np.ndarray] | None = None
        for _ in range(max(cfg.refine_rounds, 1)):
            pred = self._renderer.render(pose)
            conf, score = self._verify(frame, pred)
            if best is None:
                if floor > -np.inf and self._verify(frame, pred, cfg.screen_loose)[1] < floor:
                    return Hypothesis(pose.copy(), score, conf)
                best = (conf, score, pose)
            elif score > best[1]:
                best = (conf, score, pose)
            ref = prepare_reference(pred, self._rintr, camera_pose(pose, self.camera_height))
            new = align_planar(ref, frame, pose, self._gn, self._idx, self.camera_height)
            if not np.all(np.isfinite(new)):
                break
            last = (conf, score, new)  # the new pose, with the score of the render at ``pose``
            rendered, pose = pose, new
        else:  # the last refined pose: verified again if the last round moved it, else the
            #     last render's score stands for it (within reverify of where it was taken)
            moved = max(float(np.hypot(*(pose[:2] - rendered[:2]))), abs(float(wrap_angle(pose[2] - rendered[2]))))
            if cfg.reverify > 0 and moved > cfg.reverify:
                last = (*self._verify(frame, self._renderer.render(pose)), pose)
            if best[1] <= last[1]:
                best = last
        conf, score, pose = best
        pose = pose.copy()
        pose[2] = float(wrap_angle(pose[2]))
        return Hypothesis(pose, score, conf)

    def _verify(self, frame: Frame, pred: Frame, loose: float = 1.0) -> tuple[float, float]:
        """``(confidence, score)`` of the query ``frame`` against the map's render ``pred`` at a
        pose, on the sampled pixels. ``confidence``: the share of inliers among the valid query
        pixels (:func:`one_sided_confidence` with weights 1: what ``accept`` tests); ``score``:
        the change-tolerant share (``front_weight``, ``beyond_weight``) minus the inliers' mean
        colour difference (equally consistent poses rank by photometric fit). ``loose``
        scales the tolerances (screening: a coarse pose is up to ~9 cm and 1 degree off)."""
        cfg = self.config
        idx = self._idx
        dq = np.asarray(frame.depth).reshape(-1)[idx]
        vq = np.asarray(frame.valid).reshape(-1)[idx]
        dp = np.asarray(pred.depth).reshape(-1)[idx]
        vp = np.asarray(pred.valid).reshape(-1)[idx]
        dc = np.abs(np.asarray(frame.rgb).reshape(-1, 3)[idx]
                    - np.asarray(pred.rgb).reshape(-1, 3)[idx]).mean(axis=1)
        conf, robust, ok = one_sided_confidence(dq, vq, dp, vp, dc, loose * cfg.inlier_abs,
                                                loose * cfg.inlier_rel, loose * cfg.inlier_colour,
                                                cfg.front_weight, cfg.beyond_weight)
        return conf, robust - (float(dc[ok].mean()) if ok.any() else 0.0)


def one_sided_confidence(dq, vq, dp, vp, dc, tol_abs: float, tol_rel: float, tol_colour: float,
                         front_weight: float = 1.0, beyond_weight: float = 1.0
                         ) -> tuple[float, float, np.ndarray]:
    """``(confidence, weighted confidence, inlier mask)`` of query depths ``dq`` (valid ``vq``) against predicted
    depths ``dp`` (valid ``vp``) and colour differences ``dc``, per pixel. With ``tol = tol_abs +
    tol_rel * dq``, a valid query pixel is

    * an *inlier* when ``|dq - dp| <= tol`` and ``dc <= tol_colour``;
    * *in front* when ``dq < dp - tol``: something the map lacks stands before its surface (an
      added or moved piece of furniture does this at the true pose);
    * *beyond* when ``dq > dp + tol``: the camera sees through the map's surface (a removed or
      moved piece does this at the true pose);
    * a *contradiction* otherwise: the geometry agrees but the colour does not (walls and
      their textures never change), or the map has nothing where the query sees a surface.

    ``confidence = inliers / valid query pixels``; ``weighted confidence = inliers / (inliers +
    contradictions + front_weight * in front + beyond_weight * beyond)`` (the same with both
    weights 1; below 1, a depth change furniture can explain costs less than a contradiction). RNR-Map's changed
    rooms only add objects (in front); navbench's also move and remove them (beyond)."""
    dq = np.asarray(dq, np.float64)
    dp = np.asarray(dp, np.float64)
    vq = np.asarray(vq, bool) & np.isfinite(dq)
    both = vq & np.asarray(vp, bool) & np.isfinite(dp)
    tol = tol_abs + tol_rel * np.where(vq, dq, 0.0)
    diff = np.subtract(dq, dp, out=np.zeros_like(dq), where=both)  # no inf - inf where neither counts
    near = both & (np.abs(diff) <= tol)
    ok = near & (np.asarray(dc) <= tol_colour)
    n_ok = int(ok.sum())
    n_front = int((both & (diff < -tol)).sum())
    n_beyond = int((both & (diff > tol)).sum())
    n_bad = int(vq.sum()) - n_ok - n_front - n_beyond
    den = n_ok + n_bad + front_weight * n_front + beyond_weight * n_beyond
    n = int(vq.sum())
    return (n_ok / n if n else 0.0), (n_ok / den if den > 0 else 0.0), ok


def align_planar(ref, frame: Frame, pose: np.ndarray, cfg: TrackerConfig, idx: np.ndarray,
                 camera_height: float) -> np.ndarray:
    """The ``ours`` alignment (:func:`navbench.track.ours.align_gauss_newton`, planar, without
    its yaw search): iteratively reweighted Gauss-Newton of eq. 7 on the pixels ``idx`` from
    ``pose``, the first ``gn_geo_iters`` iterations point-to-plane only. Written on
    :mod:`navbench.track.eq7`'s pieces so that ``ours`` may call the localiser (kidnap
    recovery) without an import cycle."""
    obs = sample_observation(frame, ref.intr, idx)
    state = np.asarray(pose, np.float64).copy()
    scale = cfg.pixel_scale / max(len(idx), 1)
    T_ref_inv = se3_inverse(ref.T_wc)  # one reference for every iteration
    for it in range(cfg.gn_iters):
        geo_only = it < cfg.gn_geo_iters
        Trel, B, b = linearization("planar", state, ref.T_wc, camera_height, T_ref_inv)
        acc = accumulate(ref, obs, Trel, B, b, cfg, photometric=not geo_only)
        _, pg, pH = prior_terms("planar", state, pose, cfg, camera_height)
        try:
            delta = -np.linalg.solve(scale * acc.irls_H + pH, scale * acc.irls_g + pg)
        except np.linalg.LinAlgError:
            break
        state = retract("planar", state, delta)
        if not geo_only and np.abs(delta[:2]).max() < cfg.gn_tol[0] and abs(delta[2]) < cfg.gn_tol[1]:
            break
    return to_planar("planar", state)


def build_bank(world_model, camera_height: float, config: LocalizerConfig) -> Bank:
    """The lattice and its panoramas (:mod:`navbench.localize.signature`) for ``world_model``."""
    cfg = config
    if cfg.bins % 8 or cfg.bins < 8:
        raise LocalizationError(f"localizer: bins must be a positive multiple of 8, got {cfg.bins}")
    occ, xs, ys = world_model.occupancy_slice("band")
    points = sig.lattice_points(occ, xs, ys, cfg.lattice_step, cfg.clearance)
    ycs = sig.elevations(cfg.rows, cfg.row_top, cfg.row_step)
    quad = sig.quadrant_intrinsics(cfg.bins, cfg.rows, cfg.row_top, cfg.row_step)
    pano = panoramas(world_model.renderer(quad, camera_height), points, cfg.bins, ycs, cfg.grey_weight,
                     quad, cfg.depth_feature, cfg.feature_range)  # sig.panorama at every point
    return Bank(points.astype(np.float64), pano)


def _check_search(cfg: LocalizerConfig) -> None:
    """One-line errors for the settings of the robust search, the scan matching and ``reverify``."""
    if cfg.robust_after < 0 or not cfg.robust_tau > 0 or not cfg.robust_depth_weight >= 0:
        raise LocalizationError(f"localizer: robust_after must be >= 0 (0: off), robust_tau > 0 and "
                                f"robust_depth_weight >= 0; got {cfg.robust_after}, {cfg.robust_tau}, "
                                f"{cfg.robust_depth_weight}")
    if not (cfg.close_margin >= 0 and cfg.close_max >= 1):
        raise LocalizationError(f"localizer: close_margin must be >= 0 (0: off) and close_max >= 1; "
                                f"got {cfg.close_margin}, {cfg.close_max}")
    if not cfg.reverify >= 0:
        raise LocalizationError(f"localizer: reverify must be >= 0 (0: off), got {cfg.reverify}")
    if not (cfg.scan_radius >= 0 and cfg.scan_deg >= 0 and cfg.scan_trunc > 0 and cfg.scan_coarse >= 1):
        raise LocalizationError(f"localizer: scan_radius and scan_deg must be >= 0 (0: off), scan_trunc > 0 "
                                f"and scan_coarse >= 1; got {cfg.scan_radius}, {cfg.scan_deg}, "
                                f"{cfg.scan_trunc}, {cfg.scan_coarse}")
