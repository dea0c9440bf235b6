"""Prediction-to-observation tracking (paper eq. 7, section 4.2, appendix C): ``ours`` and ``no-map``.

At step ``t`` the estimator knows its previous MAP pose ``z*_{t-1}``, the control ``u_{t-1}`` and
the new RGB-D observation ``x_t``. It minimises over the current pose ``z_t``::

    E(z_t) = w_p S/K sum_k rho_1( || xhat^rgb_{t-1}[pi(T p^k_t)] - x^rgb_t[p^k_t] ||_1 )      photometric
           + w_g S/K sum_k rho_5( | < phat^k_{t-1} - T p^k_t , nhat^k_{t-1} > | )              point-to-plane
           - log N(z_t; predict(z*_{t-1}, u_{t-1}), Sigma)                                   dynamics prior

* ``p^k_t`` (m, current camera frame) is back-projected from the observed z-depth at sampled pixel
  ``k`` (valid pixels only); ``T = T_wc(z*_{t-1})^-1 T_wc(z_t)`` maps current-camera points into
  the previous camera frame (eq. 7's relative pose "going backward in time").
* ``xhat_{t-1}`` is the RGB-D image the map renders at ``z*_{t-1}`` (``ours``) or the previous
  observation ``x_{t-1}`` (``no-map``). Colour is sampled bilinearly at the projection
  ``pi(T p)`` (:mod:`navbench.geometry` pixel convention); ``phat`` and ``nhat`` come from the
  reference depth at the nearest pixel (projective association); normals are the cross product
  of the central differences of the back-projected reference depth.
* ``rho_c(e) = e if e <= c else 0``: the robust thresholds of appendix C (photometric L1 over the
  three channels ignored above 1.0, point-to-plane distance in metres ignored above 5.0).
* ``S/K``: the data terms are the paper's *sum over S = 1000 pixels* (``pixel_scale``); with
  ``K`` sampled pixels the sum is rescaled by ``S/K`` so that the balance against the prior does
  not depend on how many pixels an optimiser uses.
* ``w_p = photo_weight`` (1) and ``w_g = geo_weight`` (3 per metre). Eq. 7 adds colour
  differences (units of [0, 1] colour) and point-to-plane distances (metres) with weight 1; in
  metres the geometric term is ~100x smaller than the photometric one, and with an imperfect
  colour map (a voxel grid blurs the texture) the photometric term then dominates and biases
  the optimum (up to ~0.5 deg per step). ``geo_weight=3`` makes the terms comparable;
  ``geo_weight=1`` is eq. 7 literally. The thresholds act on the unweighted terms.
* The prior is a Gaussian around the noise-free prediction with standard deviations
  ``prior_sigma = (sigma_xy [m], sigma_theta [rad])``; its default is the tracking-study noise
  ``NOISE_LEVELS["tracking"] = (3 deg, 0.05 L)``, taken as ``(sigma_s, sigma_alpha)``. It is a
  Gaussian approximation of the true (clipped, sometimes noise-free) dynamics.

Parameterisations (option ``param``)
    ``planar``: ``z = (x, y, theta)`` directly. ``se3``: the camera pose ``T_wc`` on SE(3),
    updated by right perturbations ``T_wc exp(delta)`` (twist in the camera frame, see
    :mod:`navbench.track.lie`); the prior then is ``1/2 |log(T_pred^-1 T_wc) / sigma6|^2`` with
    ``sigma6`` built from ``prior_sigma`` for the in-plane components (camera x and z translation,
    rotation about camera y) and ``off_plane_sigma`` for the rest (gradient and Hessian to first
    order). The result is projected to the planar pose (:func:`navbench.track.lie.planar_from_camera`).

Optimisers (option ``optimizer``)
    ``adam``: the paper's setting, ``adam_steps`` (100) steps, a different row of a fixed
    ``100 x 1000`` pixel-index table (:func:`pixel_table`, seeded) per step, step sizes
    ``adam_lr = (translation, rotation) = (0.01, 0.01)`` (appendix E), analytic gradients.
    ``gauss-newton`` (default): the same objective by iteratively reweighted Gauss-Newton: L1
    residuals get weights ``1 / max(|r|, eps)``, thresholded ones weight 0, the prior enters as
    its exact quadratic; ``gn_iters`` (10) iterations on ``gn_pixels`` (3000) fixed random
    pixels, the first ``gn_geo_iters`` (5) on the point-to-plane term alone (a wider basin of
    convergence for rotation errors of several degrees, see :func:`align_gauss_newton`).
    Default because it is about as accurate and 3.5-4x faster (``maze``, 30 trajectories x
    100 steps, half camera, shared 2-core CPU): true map (``geo_weight=10``), Gauss-Newton
    loc RMSE median 1.4 mm, rot 0.026 deg, step (render + estimate) median 15 ms vs Adam
    1.8 mm, 0.062 deg, 54 ms; fitted map (defaults), Gauss-Newton 11.2 mm, 0.52 deg, 8 ms vs
    Adam 9.8 mm, 0.40 deg, 30 ms.
    ``irls_eps = (0.01, 0.01)`` (colour units, metres): below these the residuals are weighted
    quadratically (a Huber-like core), which averages the errors of a fitted map better than a
    tighter floor; tuned on 10 ``maze`` trajectories with a fitted map (1500 steps), checked on
    30 others: loc RMSE median 11 mm, rot 0.52 deg vs 20 mm, 0.74 deg with
    ``geo_weight=10, irls_eps=(0.01, 0.001)``.

The data terms are summed by a numba kernel (:func:`accumulate`), which also computes the
normals at the associated pixels; :func:`residuals`, :func:`depth_normals` and
:func:`objective` are the numpy reference it is tested against.

All arrays are float64 unless stated; pixel coordinates follow :mod:`navbench.geometry`.
"""

from __future__ import annotations

import math
import time
from functools import lru_cache
from typing import Callable

import numpy as np

from navbench.errors import TrackingError
from navbench.geometry import CAMERA_HEIGHT, HALF_CAMERA, Frame, Intrinsics, camera_pose
from navbench.track.odometry import predict_pose
from navbench.track.base import check_update
from navbench.track.lie import se3_inverse
from navbench.track.heading import _initial_state, yaw_search  # noqa: F401  (yaw_search re-exported)
from navbench.track.eq7 import (
    Reference,
    TrackerConfig,
    accumulate,
    linearization,
    make_config,
    pixel_table,
    prepare_reference,
    prior_terms,
    retract,
    sample_observation,
    to_planar,
)


#: Render the map's reference image of ``ours`` lazily: only the pixels eq. 7 reads, when it
#: first reads them (:class:`navbench.worldmodel.fastrender.LazyFrame`; the estimates are
#: bit-identical to rendering the whole image, tests/speed/test_fast_paths.py), where that is
#: faster: when the full render would run on one thread (a pool worker: numba has one) and the
#: image has at least :data:`LAZY_MIN_PIXELS` pixels (measured on 2 cores: at the paper camera
#: the lazy render reads ~44 % of the pixels and takes ~20 % less time than the serial full
#: render, but more than the parallel one on 2 threads; at the half camera the 3000 samples
#: touch most pixels and the lazy bookkeeping makes it slower). False renders every pixel first.
LAZY_REFERENCE = True
LAZY_MIN_PIXELS = 320 * 240
LAZY_PARALLEL = False


# ------------------------------------------------------------------------------ optimisers

def _param_lr(param: str, lr: tuple[float, float]) -> np.ndarray:
    if param == "planar":
        return np.array([lr[0], lr[0], lr[1]])
    return np.array([lr[0]] * 3 + [lr[1]] * 3)


def align_adam(ref: Reference, frame: Frame, pred: np.ndarray, cfg: TrackerConfig,
               table: np.ndarray, camera_height: float = CAMERA_HEIGHT) -> np.ndarray:
    """Minimise eq. 7 with Adam (appendix C/E); returns the planar pose ``(3,)``.

    Step ``i`` evaluates the pixels ``table[i % rows]`` of the observation. Updates are applied on
    the parameterisation's manifold (planar addition or ``T exp(delta)``).
    """
    param = cfg.param
    start = yaw_search(ref, frame, pred, cfg, table[0], camera_height)
    state = _initial_state(param, start, camera_height)
    lr = _param_lr(param, cfg.adam_lr)
    b1, b2 = cfg.adam_betas
    m = np.zeros_like(lr)
    v = np.zeros_like(lr)
    Ti = se3_inverse(ref.T_wc)
    for i in range(cfg.adam_steps):
        row = table[i % len(table), : cfg.adam_pixels]
        obs = sample_observation(frame, ref.observed, row)
        Trel, B, b = linearization(param, state, ref.T_wc, camera_height, Ti)
        acc = accumulate(ref, obs, Trel, B, b, cfg)
        _, pg, _ = prior_terms(param, state, pred, cfg, camera_height)
        g = cfg.pixel_scale / len(row) * acc.grad + pg
        m = b1 * m + (1 - b1) * g
        v = b2 * v + (1 - b2) * g * g
        mh = m / (1 - b1 ** (i + 1))
        vh = v / (1 - b2 ** (i + 1))
        state = retract(param, state, -lr * mh / (np.sqrt(vh) + 1e-8))
    return to_planar(param, state)


def align_gauss_newton(ref: Reference, frame: Frame, pred: np.ndarray, cfg: TrackerConfig,
                       idx: np.ndarray, camera_height: float = CAMERA_HEIGHT,
                       info: dict | None = None, turn: float | None = None) -> np.ndarray:
    """Minimise eq. 7 by iteratively reweighted Gauss-Newton on the pixels ``idx``; planar pose out.

    Each iteration linearises the residuals, weights L1 residuals by ``1 / max(|r|, eps)`` (zero
    where a robust threshold drops them), adds the prior's quadratic and solves the normal
    equations; it stops after ``gn_iters`` iterations or when the step is below ``gn_tol``.
    The first ``gn_geo_iters`` iterations use the point-to-plane term only: projective ICP has
    a much wider basin of convergence than the photometric term (whose linearisation only
    sees the texture within a pixel or two), so it brings a rotation error of several degrees
    within reach; the remaining iterations minimise the full eq. 7. With ``gn_geo_tol`` above 0
    the point-to-plane phase ends at the first step below it (the iterations it saves are not
    run: the full eq. 7 keeps its own ``gn_iters - gn_geo_iters``). ``turn``: the predicted
    turn for the heading search's gate (:func:`yaw_search`). ``info`` (optional dict) gets
    ``"gn_iters"`` (iterations run), ``"gn_steps"`` (each iteration's largest translation and
    rotation step, m and rad) and the heading search's entries (:func:`yaw_search`).
    """
    param = cfg.param
    obs = sample_observation(frame, ref.observed, idx)
    start = yaw_search(ref, frame, pred, cfg, idx, camera_height, obs, info, turn)
    state = _initial_state(param, start, camera_height)
    scale = cfg.pixel_scale / max(len(idx), 1)
    ntr = 2 if param == "planar" else 3
    Ti = se3_inverse(ref.T_wc)
    n_geo = min(cfg.gn_geo_iters, cfg.gn_iters)
    run = 0
    # (photometric, iterations, tolerance) of the two phases
    for photometric, n, tol in ((False, n_geo, cfg.gn_geo_tol), (True, cfg.gn_iters - n_geo, cfg.gn_tol)):
        for _ in range(n):
            run += 1
            Trel, B, b = linearization(param, state, ref.T_wc, camera_height, Ti)
            acc = accumulate(ref, obs, Trel, B, b, cfg, photometric=photometric)
            _, pg, pH = prior_terms(param, state, pred, cfg, camera_height)
            try:
                delta = -np.linalg.solve(scale * acc.irls_H + pH, scale * acc.irls_g + pg)
            except np.linalg.LinAlgError:
                return _gn_done(param, state, info, run)
            state = retract(param, state, delta)
            step_tr, step_rot = np.abs(delta[:ntr]).max(), np.abs(delta[ntr:]).max()
            if info is not None:
                info.setdefault("gn_steps", []).append((float(step_tr), float(step_rot)))
            if step_tr < tol[0] and step_rot < tol[1]:
                break
    return _gn_done(param, state, info, run)


def _gn_done(param: str, state, info: dict | None, iterations: int) -> np.ndarray:
    if info is not None:
        info["gn_iters"] = iterations
    return to_planar(param, state)


def gn_pixels(height: int, width: int, count: int, seed: int = 0) -> np.ndarray:
    """Fixed random flat pixel indices (without replacement) for Gauss-Newton, ``(min(count, H*W),)``."""
    return _gn_pixels(int(height), int(width), int(count), int(seed))


@lru_cache(maxsize=16)
def _gn_pixels(height: int, width: int, count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng([seed, height, width, 0x6A55])
    n = min(count, height * width)
    idx = np.sort(rng.choice(height * width, size=n, replace=False))
    idx.setflags(write=False)
    return idx


def align(ref: Reference, frame: Frame, pred: np.ndarray, cfg: TrackerConfig,
          seed: int = 0, camera_height: float = CAMERA_HEIGHT, info: dict | None = None,
          turn: float | None = None) -> np.ndarray:
    """Eq. 7 minimised by the configured optimiser; returns the planar pose ``(3,)``.
    ``info`` and ``turn``: Gauss-Newton's (:func:`align_gauss_newton`)."""
    H, W = ref.observed.shape
    pred = np.asarray(pred, dtype=np.float64)
    if cfg.optimizer == "adam":
        table = pixel_table(H, W, 100, cfg.adam_pixels, seed)
        return align_adam(ref, frame, pred, cfg, table, camera_height)
    return align_gauss_newton(ref, frame, pred, cfg, gn_pixels(H, W, cfg.gn_pixels, seed),
                              camera_height, info, turn)


# ------------------------------------------------------------------------------ estimators

def default_renderer(vmap, intrinsics: Intrinsics, camera_height: float) -> Callable:
    """``pose -> Frame`` rendering the world model ``vmap`` (:meth:`WorldModel.renderer
    <navbench.worldmodel.base.WorldModel.renderer>`; for a voxel map the fast numba renderer)."""
    if vmap is None:
        raise TrackingError("this estimator needs a map (vmap=...) or a renderer (renderer=...)")
    if not callable(getattr(vmap, "renderer", None)):
        raise TrackingError(f"this estimator needs a world model with a renderer; got a "
                            f"{type(vmap).__name__}")
    return vmap.renderer(intrinsics, camera_height).render


class _PredictionToObservation:
    """Shared shell of ``ours`` and ``no-map``: state, timing, the reference image."""

    name = "ours"
    uses_frames = True
    uses_map = True  # False: the reference is the previous observation, not the map's rendering
    options = TrackerConfig  # keyword options, see make_config

    def __init__(self, vmap=None, intrinsics: Intrinsics = HALF_CAMERA,
                 camera_height: float = CAMERA_HEIGHT, renderer: Callable | None = None,
                 seed: int = 0, relocalizer=None, health_threshold: float | None = None,
                 **options):
        self.config = make_config(options, self.options())
        # the alarm threshold: health_min_inliers, or with health_min_inliers="auto" the map's
        # calibrated one, given by the caller (navbench.pipeline.stages.health)
        self.health_threshold = _health_threshold(self.config, health_threshold)
        if self.config.recover and not self.uses_map:
            raise TrackingError(f"estimator {self.name!r}: recover needs a map-based tracker")
        self._vmap = vmap
        # an object with localize(frame) -> hypotheses (navbench.track.relocalize); None: built
        # by name (option relocalizer_name) from vmap the first time the health test fires
        self._relocalizer = relocalizer
        if self.config.recover and relocalizer is None:
            from navbench.track.relocalize import check_relocalizer

            check_relocalizer(self.config.relocalizer_name)
        self.intrinsics = intrinsics
        self.camera_height = float(camera_height)
        self.seed = int(seed)
        scale = float(self.config.reference_scale)
        if scale != 1 and renderer is not None:
            raise TrackingError(f"estimator {self.name!r}: option reference_scale renders the map itself; "
                                f"it cannot be combined with renderer=")
        # the reference image's camera: the observations' own, or scaled (option reference_scale)
        self._ref_intr = intrinsics if scale == 1 else intrinsics.scaled(scale)
        if self.uses_map:
            self._render = renderer if renderer is not None else default_renderer(
                vmap, self._ref_intr, camera_height)
        else:
            self._render = None
        self.pose = None
        self.last_timing: dict[str, float] = {}
        # with option health or recover: {"inliers": float, "alarm": bool, "relocalized": bool}
        self.last_health: dict | None = None
        # the last update's optimiser counts: "gn_iters", "yaw_searched", "yaw_score" (align)
        self.last_info: dict = {}
        self._ref: Reference | None = None
        self._ref_pose: np.ndarray | None = None
        self._prev_frame: Frame | None = None
        # option relocalize_keep: {"poses": [(3,)], "sums": [float], "main": float, "left": int}
        self._runners: dict | None = None

    def reset(self, pose0, frame0: Frame) -> None:
        self.pose = np.asarray(pose0, dtype=np.float64).copy()
        self._ref = None
        self._ref_pose = None
        self._prev_frame = frame0
        self.last_timing = {}
        self.last_health = None
        self._runners = None

    def _lazy_renderer(self):
        """The fast map renderer behind ``self._render`` when the reference is rendered lazily
        (:data:`LAZY_REFERENCE`; the renderer is a serial ``FastRenderer.render`` of this
        camera, of at least :data:`LAZY_MIN_PIXELS` pixels), else None. Never with the health
        test: it reads reference pixels the alignment did not fill."""
        from navbench.worldmodel.fastrender import FastRenderer, render_kernel_serial

        fr = getattr(self._render, "__self__", None)
        if (LAZY_REFERENCE and not (self.config.health or self.config.recover)
                and isinstance(fr, FastRenderer)
                and getattr(self._render, "__func__", None) is FastRenderer.render
                and fr.intrinsics == self._ref_intr and (fr._kernel is render_kernel_serial or LAZY_PARALLEL)
                and self._ref_intr.width * self._ref_intr.height >= LAZY_MIN_PIXELS):
            return fr
        return None

    def observed_pixels(self) -> np.ndarray | None:
        """The pixels ``update`` reads (:func:`navbench.track.base.observed_pixels`): the
        Gauss-Newton sample of eq. 7 (:func:`gn_pixels`; the heading search reads its first
        rows), for a map-based tracker without the health test or recovery (those read other
        pixels and hand whole frames to the relocaliser); else None."""
        c = self.config
        if not self.uses_map or c.optimizer != "gauss-newton" or c.health or c.recover:
            return None
        H, W = self.intrinsics.shape
        return gn_pixels(H, W, c.gn_pixels, self.seed)

    def _obs_intr(self):
        """``Reference.obs_intr``: the observations' intrinsics when the reference has others."""
        return None if self._ref_intr == self.intrinsics else self.intrinsics

    def _reference(self) -> tuple[Reference, float]:
        """The reference for the current ``z*_{t-1}`` (rendered at most once per pose)."""
        t0 = time.perf_counter()
        if self._ref is None or not np.array_equal(self._ref_pose, self.pose):
            fr = self._lazy_renderer() if self.uses_map else None
            if fr is not None:  # only the pixels eq. 7 reads, rendered as it reads them
                from navbench.worldmodel.fastrender import LazyFrame

                lazy = LazyFrame(fr, camera_pose(self.pose, fr.camera_height))
                self._ref = Reference(lazy.rgb, lazy.depth, lazy.valid,
                                      camera_pose(self.pose, self.camera_height), self._ref_intr, lazy,
                                      self._obs_intr())
                self._ref_pose = self.pose.copy()
                return self._ref, (time.perf_counter() - t0) * 1e3
            if self.uses_map:
                frame = self._render(self.pose)
            else:
                frame = self._prev_frame
            ms_render = (time.perf_counter() - t0) * 1e3 if self.uses_map else 0.0
            self._ref = prepare_reference(frame, self._ref_intr,
                                          camera_pose(self.pose, self.camera_height))
            if self._ref_intr != self.intrinsics:
                self._ref = self._ref._replace(obs_intr=self.intrinsics)
            self._ref_pose = self.pose.copy()
            return self._ref, ms_render
        return self._ref, 0.0

    def update(self, control, frame: Frame, true_pose=None) -> np.ndarray:
        check_update(self, frame)
        t0 = time.perf_counter()
        ref, ms_render = self._reference()
        t1 = time.perf_counter()
        lazy_s = ref.lazy.seconds if ref.lazy is not None else 0.0
        pred = np.asarray(predict_pose(self.pose, control), dtype=np.float64)
        self.last_info = {}
        turn = (float(pred[2]) - float(self.pose[2]) + math.pi) % (2 * math.pi) - math.pi
        est = align(ref, frame, pred, self.config, self.seed, self.camera_height, self.last_info, turn)
        t2 = time.perf_counter()
        extra: dict[str, float] = {}
        if self.config.health or self.config.recover:
            est = self._health(ref, frame, est, extra, control)
            t2 = time.perf_counter()
        self.pose = est
        self._prev_frame = frame
        prep_ms = (t1 - t0) * 1e3 - ms_render
        if ref.lazy is not None:  # the lazy reference rendered during the alignment
            lazy_ms = (ref.lazy.seconds - lazy_s) * 1e3
            ms_render += lazy_ms
            t2 -= lazy_ms / 1e3
        self.last_timing = {"render": ms_render, "estimate": prep_ms + (t2 - t1) * 1e3, **extra}
        return est.copy()

    def _inliers(self, ref: Reference, frame: Frame, pose: np.ndarray) -> float:
        from navbench.track.health import inlier_fraction

        c = self.config
        H, W = self.intrinsics.shape
        return inlier_fraction(ref, frame, pose, gn_pixels(H, W, c.health_pixels, self.seed + 1),
                               c.health_tol, c.health_band, self.camera_height,
                               photo_tol=c.health_photo_tol, tol_abs=c.health_tol_abs)

    def _health(self, ref: Reference, frame: Frame, est: np.ndarray, timing: dict,
                control=None) -> np.ndarray:
        """The health test at ``est`` (:mod:`navbench.track.health`); on an alarm with option
        ``recover``, relocalise: verify the relocaliser's best ``relocalize_top`` hypotheses by
        one tracking step against the map's rendering there and keep the one with the highest
        inlier fraction if it passes the test and beats ``est``. With ``relocalize_keep = K``
        the other verified hypotheses that pass the test are tracked for K more steps beside
        it (:meth:`_follow_runners`). Fills ``last_health``; the relocaliser's build (once),
        query and runner-up times go to ``timing`` (ms, within "estimate")."""
        c = self.config
        f = self._inliers(ref, frame, est)
        alarm = bool(f < self.health_threshold)  # nan (no evidence) is no alarm
        relocalized = False
        if self._runners is not None and not alarm:
            t0 = time.perf_counter()
            est, switched = self._follow_runners(frame, est, f, control)
            relocalized = switched
            timing["runners"] = (time.perf_counter() - t0) * 1e3
        elif alarm:
            self._runners = None
        if alarm and c.recover:
            t0 = time.perf_counter()
            if self._relocalizer is None:
                from navbench.track.relocalize import build_relocalizer

                self._relocalizer = build_relocalizer(c.relocalizer_name, self._vmap, self.intrinsics,
                                                      self.camera_height, align)
                timing["relocalizer_build"] = (time.perf_counter() - t0) * 1e3
            t1 = time.perf_counter()
            best, best_f = None, (f if not math.isnan(f) else -math.inf)
            passed = []
            # with runner-ups the relocaliser must report its ambiguity: ask for relocalize_top
            # hypotheses (navbench.localize returns its config.k = 1 by default)
            hyps = (self._relocalizer.localize(frame, k=c.relocalize_top) if c.relocalize_keep > 0
                    else self._relocalizer.localize(frame))
            for hyp in list(hyps)[: c.relocalize_top]:
                pose = np.asarray(hyp.pose, dtype=np.float64).reshape(3)
                cand, fc = self._track_one(frame, pose, pose)
                if fc >= self.health_threshold:
                    passed.append((cand, fc))
                if fc >= self.health_threshold and fc > best_f:
                    best, best_f = cand, fc
            if best is not None:
                est, relocalized = best, True
                others = [(p, fc) for p, fc in passed if p is not best]
                if c.relocalize_keep > 0 and others:
                    self._runners = {"poses": [p for p, _ in others], "sums": [fc for _, fc in others],
                                     "main": best_f, "left": int(c.relocalize_keep)}
            timing["relocalize"] = (time.perf_counter() - t1) * 1e3
        self.last_health = {"inliers": f, "alarm": alarm, "relocalized": relocalized}
        return est

    def _track_one(self, frame: Frame, ref_pose: np.ndarray, pred: np.ndarray):
        """One tracking step of a hypothesis: eq. 7 against the map's render at ``ref_pose``
        from the prediction ``pred``; ``(pose, inlier fraction)``."""
        href = prepare_reference(self._render(ref_pose), self.intrinsics,
                                 camera_pose(ref_pose, self.camera_height))
        cand = align(href, frame, pred, self.config, self.seed, self.camera_height)
        return cand, self._inliers(href, frame, cand)

    def _follow_runners(self, frame: Frame, est: np.ndarray, f: float, control):
        """One step of the runner-up hypotheses of the last relocalisation (option
        ``relocalize_keep``): each is tracked with the control re-expressed at its own heading
        and dropped when it fails the test; the inlier fractions are summed per track. After
        the last step the track with the largest sum wins; returns ``(pose, switched)``."""
        r = self._runners
        r["main"] += 0.0 if math.isnan(f) else f
        keep_p, keep_s = [], []
        for pose, total in zip(r["poses"], r["sums"]):
            pred = predict_pose(pose, _control_at(control, self.pose, pose))
            cand, fc = self._track_one(frame, pose, pred)
            if fc >= self.health_threshold:
                keep_p.append(cand)
                keep_s.append(total + fc)
        r["poses"], r["sums"], r["left"] = keep_p, keep_s, r["left"] - 1
        if r["left"] > 0 and keep_p:
            return est, False
        self._runners = None
        if keep_s and max(keep_s) > r["main"]:
            return keep_p[int(np.argmax(keep_s))], True
        return est, False


def _control_at(control, from_pose: np.ndarray, to_pose: np.ndarray):
    """``control`` given to an estimator at ``from_pose`` as it applies at ``to_pose``: an
    absolute direction keeps its offset from the heading; a body-frame increment is unchanged."""
    from navbench.sim.dynamics import Control
    from navbench.track.odometry import OdometryIncrement

    if isinstance(control, OdometryIncrement):
        return control
    turn, direction, speed = ((control.turn, control.direction, control.speed)
                              if isinstance(control, Control) else tuple(control))
    return Control(float(turn), float(direction) - float(from_pose[2]) + float(to_pose[2]), float(speed))


def _health_threshold(cfg: TrackerConfig, given: float | None) -> float:
    """The alarm threshold of ``cfg`` (``given``: the calibrated one for ``"auto"``)."""
    if cfg.health_min_inliers != "auto":
        return float(cfg.health_min_inliers)
    if given is None or not 0 <= float(given) <= 1:
        if not (cfg.health or cfg.recover):
            return math.nan  # never read
        raise TrackingError("health_min_inliers='auto' needs the map's calibrated threshold "
                            "(health_threshold=, navbench.pipeline.stages.health; track-eval "
                            f"computes it), got {given!r}")
    return float(given)


class PredictionToObservationTracker(_PredictionToObservation):
    """Eq. 7 against the image the map renders at the previous estimate (the paper's tracker)."""

    name = "ours"
    uses_map = True


class FrameToFrameConfig(TrackerConfig):
    """The options of ``no-map``: :class:`TrackerConfig`, whose ``reference_scale`` only a map
    can serve (its reference is the previous observation)."""

    def __post_init__(self):
        super().__post_init__()
        if self.reference_scale != 1:
            raise TrackingError("option reference_scale needs a map-based tracker (ours); "
                                "no-map's reference is the previous observation")


class FrameToFrameTracker(_PredictionToObservation):
    """The "no map" ablation: eq. 7 against the previous observation ``x_{t-1}``."""

    name = "no-map"
    uses_map = False
    options = FrameToFrameConfig
