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
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Callable, NamedTuple

import numba
import numpy as np

from navbench.errors import TrackingError
from navbench.geometry import (
    CAMERA_HEIGHT,
    HALF_CAMERA,
    Frame,
    Intrinsics,
    camera_pose,
    pixel_rays,
)
from navbench.sim.dynamics import NOISE_LEVELS, predict
from navbench.track.base import check_update, config_from_options, register_estimator
from navbench.track.lie import hat, planar_from_camera, se3_exp, se3_inverse, se3_log

#: Tracking-study noise ``(sigma_alpha [rad], sigma_s [m])`` = (3 deg, 0.05 L), the default prior.
_TRACKING_NOISE = NOISE_LEVELS["tracking"]

OPTIMIZERS = ("adam", "gauss-newton")
PARAMS = ("planar", "se3")


# ------------------------------------------------------------------------------ configuration

@dataclass(frozen=True)
class TrackerConfig:
    """Options of the prediction-to-observation trackers (all keyword options of the estimators)."""

    optimizer: str = "gauss-newton"  # "adam" (paper) or "gauss-newton"
    param: str = "planar"  # "planar" (x, y, theta) or "se3" (camera pose, projected to planar)
    # dynamics prior: (sigma_xy [m], sigma_theta [rad]) of the Gaussian around the prediction
    prior_sigma: tuple[float, float] = (_TRACKING_NOISE[1], _TRACKING_NOISE[0])
    # se3 only: sigmas of the off-plane components (vertical translation [m], roll/pitch [rad])
    off_plane_sigma: tuple[float, float] = (0.005, math.radians(0.5))
    photo_threshold: float = 1.0  # photometric L1 (sum over RGB, colour units) ignored above
    geo_threshold: float = 5.0  # |point-to-plane| (m) ignored above
    pixel_scale: float = 1000.0  # S: data terms are scaled to a sum over S pixels
    photo_weight: float = 1.0  # weight of the photometric term (eq. 7: 1)
    geo_weight: float = 3.0  # weight of the point-to-plane term per metre (eq. 7 literally: 1)
    # adam (appendix C/E)
    adam_steps: int = 100
    adam_pixels: int = 1000
    adam_lr: tuple[float, float] = (0.01, 0.01)  # (translation [m], rotation [rad]) step sizes
    adam_betas: tuple[float, float] = (0.9, 0.999)
    # gauss-newton (IRLS)
    gn_iters: int = 10
    gn_geo_iters: int = 5  # the first iterations use the point-to-plane term only
    gn_pixels: int = 3000
    gn_tol: tuple[float, float] = (1e-5, 1e-5)  # stop when |step| below (m, rad)
    # (photometric, geometric) IRLS weight floor: residuals below it are weighted quadratically
    irls_eps: tuple[float, float] = (0.01, 0.01)
    # normals: reject where inverse depth is not locally planar (relative second difference)
    normal_max_curvature: float = 0.05
    # heading search before the local optimiser (0 disables it): candidate headings
    # pred_theta + k * yaw_search_step_deg within +-yaw_search_deg are scored by the mean kept
    # data term of eq. 7 on yaw_search_pixels pixels, and the optimiser starts from the best
    # (the prior stays centred on the prediction). A turn in place at mid/high noise is off by up
    # to ~3 sigma = 18-27 deg, far outside the local optimisers' basin.
    yaw_search_deg: float = 24.0
    yaw_search_step_deg: float = 2.0
    yaw_search_pixels: int = 400

    def __post_init__(self):
        if self.optimizer not in OPTIMIZERS:
            raise TrackingError(f"unknown optimizer {self.optimizer!r}; choose one of {OPTIMIZERS}")
        if self.param not in PARAMS:
            raise TrackingError(f"unknown param {self.param!r}; choose one of {PARAMS}")
        for name in ("adam_steps", "adam_pixels", "gn_iters", "gn_pixels"):
            if int(getattr(self, name)) < 1:
                raise TrackingError(f"option {name} must be >= 1, got {getattr(self, name)!r}")
        if min(self.prior_sigma) <= 0 or min(self.off_plane_sigma) <= 0:
            raise TrackingError("prior sigmas must be > 0")


def make_config(options: dict[str, Any], base: TrackerConfig | None = None) -> TrackerConfig:
    """Build a :class:`TrackerConfig` from keyword options; unknown names raise TrackingError."""
    return config_from_options(base or TrackerConfig(), options, "tracker")


# ------------------------------------------------------------------------------ pixel tables

@lru_cache(maxsize=16)
def pixel_table(height: int, width: int, rows: int = 100, cols: int = 1000, seed: int = 0) -> np.ndarray:
    """The fixed pixel-index table of appendix C: ``(rows, cols)`` int64 flat indices into ``H*W``.

    Row ``i`` is the pixel sample of optimisation step ``i``; the table depends only on the
    image size and ``seed``, so it is the same for every invocation of an estimator.
    Read-only.
    """
    rng = np.random.default_rng([int(seed), int(height), int(width), 0x7AB1E])
    t = rng.integers(0, height * width, size=(rows, cols), dtype=np.int64)
    t.setflags(write=False)
    return t


@lru_cache(maxsize=16)
def _rays_flat(intr: Intrinsics) -> np.ndarray:
    r = pixel_rays(intr).reshape(-1, 3)
    r.setflags(write=False)
    return r


# ------------------------------------------------------------------------------ reference image

class Reference(NamedTuple):
    """The previous image ``xhat_{t-1}`` prepared for alignment."""

    rgb: np.ndarray  # (H, W, 3) float64 colour
    depth: np.ndarray  # (H, W) float64 z-depth (m), 0 where invalid
    valid: np.ndarray  # (H, W) bool
    T_wc: np.ndarray  # (4, 4) camera pose the reference was seen from
    intr: Intrinsics


def prepare_reference(frame: Frame, intr: Intrinsics, T_wc: np.ndarray) -> Reference:
    """Wrap a reference frame seen from camera pose ``T_wc`` (float64 copies, invalid depth 0)."""
    H, W = intr.shape
    if frame.depth.shape != (H, W):
        raise TrackingError(f"reference image is {frame.depth.shape}, intrinsics say {(H, W)}")
    depth = np.asarray(frame.depth, dtype=np.float64)
    valid = np.asarray(frame.valid, bool) & np.isfinite(depth) & (depth > 0)
    return Reference(np.ascontiguousarray(frame.rgb, dtype=np.float64),
                     np.where(valid, depth, 0.0), valid, np.asarray(T_wc, dtype=np.float64), intr)


def depth_normals(depth: np.ndarray, valid: np.ndarray, intr: Intrinsics,
                  max_curvature: float = 0.05) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points and normals from a z-depth image by image gradients (reference implementation).

    ``depth (H, W)`` z-depth (m), ``valid (H, W)``. Returns camera-frame ``points (H, W, 3)``
    (0 where invalid), unit ``normals (H, W, 3)`` = normalised cross product of the central
    differences of the back-projected points along ``v`` and ``u`` (facing the camera), and
    ``ok (H, W)``: all four neighbours valid and inverse depth locally affine (a plane has affine
    inverse depth) to within ``max_curvature`` (relative second difference), which rejects depth
    edges and creases. Border pixels are never ``ok``. The fast kernel computes the same normal
    on the fly at the associated pixel.
    """
    H, W = depth.shape
    d = np.where(valid, depth, 0.0).astype(np.float64)
    P = pixel_rays(intr) * d[..., None]
    n = np.zeros((H, W, 3))
    ok = np.zeros((H, W), bool)
    if H < 3 or W < 3:
        return P, n, ok
    du = P[1:-1, 2:] - P[1:-1, :-2]
    dv = P[2:, 1:-1] - P[:-2, 1:-1]
    c = np.cross(dv, du)  # for a fronto-parallel plane: (0, 0, -), towards the camera
    norm = np.linalg.norm(c, axis=-1)
    inv = np.where(valid, 1.0 / np.where(valid, depth, 1.0), 0.0)
    ic = inv[1:-1, 1:-1]
    curv_u = np.abs(inv[1:-1, 2:] - 2 * ic + inv[1:-1, :-2])
    curv_v = np.abs(inv[2:, 1:-1] - 2 * ic + inv[:-2, 1:-1])
    nb = valid[1:-1, 1:-1] & valid[1:-1, 2:] & valid[1:-1, :-2] & valid[2:, 1:-1] & valid[:-2, 1:-1]
    good = nb & (norm > 0) & (curv_u <= max_curvature * ic) & (curv_v <= max_curvature * ic)
    n[1:-1, 1:-1] = c / np.where(norm > 0, norm, 1.0)[..., None]
    ok[1:-1, 1:-1] = good
    n[~ok] = 0.0
    return P, n, ok


class Observation(NamedTuple):
    """Sampled pixels of the new observation ``x_t``."""

    points: np.ndarray  # (K, 3) current-camera-frame points p^k_t (m); 0 where invalid
    rgb: np.ndarray  # (K, 3) observed colour
    ok: np.ndarray  # (K,) bool: observed depth valid


def sample_observation(frame: Frame, intr: Intrinsics, idx: np.ndarray) -> Observation:
    """Back-project the observed pixels with flat indices ``idx (K,)``."""
    depth = np.asarray(frame.depth).reshape(-1)[idx].astype(np.float64)
    ok = np.asarray(frame.valid).reshape(-1)[idx] & np.isfinite(depth) & (depth > 0)
    depth = np.where(ok, depth, 0.0)
    pts = _rays_flat(intr)[idx] * depth[:, None]
    rgb = np.asarray(frame.rgb).reshape(-1, 3)[idx].astype(np.float64)
    return Observation(pts, rgb, ok)


# ------------------------------------------------------------------------------ parameterisations

def _camera_rotation_dtheta(theta: float) -> np.ndarray:
    """d R_wc / d theta of :func:`navbench.geometry.camera_rotation`."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, 0.0, -s], [s, 0.0, c], [0.0, 0.0, 0.0]])


_HATS = np.stack([hat(e) for e in np.eye(3)])


def linearization(param: str, state, T_ref: np.ndarray,
                  camera_height: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``T_rel = T_ref^-1 T_wc(state)`` and the affine point Jacobian ``dq/dparam_c = B[c] p + b[c]``.

    ``q = T_rel p`` maps current-camera points ``p`` into the reference camera.
    ``param="planar"``: ``state`` is ``(x, y, theta)``; 3 parameters.
    ``param="se3"``: ``state`` is ``T_wc`` (4x4); 6 parameters, a right perturbation
    ``T_wc exp(delta)`` with ``delta = (rho, phi)`` in the current camera frame, so
    ``dq/drho_j = R_rel e_j`` and ``dq/dphi_j = R_rel (e_j x p)``.
    Returns ``T_rel (4, 4)``, ``B (P, 3, 3)``, ``b (P, 3)``.
    """
    Ti = se3_inverse(T_ref)
    if param == "planar":
        Trel = Ti @ camera_pose(state, camera_height)
        Rp = Ti[:3, :3]
        B = np.zeros((3, 3, 3))
        b = np.zeros((3, 3))
        b[0], b[1] = Rp[:, 0], Rp[:, 1]
        B[2] = Rp @ _camera_rotation_dtheta(float(state[2]))
        return Trel, B, b
    Trel = Ti @ state
    R = Trel[:3, :3]
    B = np.zeros((6, 3, 3))
    b = np.zeros((6, 3))
    b[:3] = R.T
    B[3:] = R @ _HATS
    return Trel, B, b


def transform_and_jacobian(param: str, state, T_ref: np.ndarray, points: np.ndarray,
                           camera_height: float) -> tuple[np.ndarray, np.ndarray]:
    """``q = T_ref^-1 T_wc(state) p`` for points ``p (K, 3)`` and ``dq/dparams (K, 3, P)``."""
    Trel, B, b = linearization(param, state, T_ref, camera_height)
    q = points @ Trel[:3, :3].T + Trel[:3, 3]
    J = np.einsum("cij,kj->kic", B, points) + b.T[None]
    return q, J


def retract(param: str, state, delta: np.ndarray):
    """Apply a parameter step: planar addition, or ``T_wc exp(delta)`` for se3."""
    if param == "planar":
        return np.asarray(state, dtype=np.float64) + delta
    return state @ se3_exp(delta)


def to_planar(param: str, state) -> np.ndarray:
    """Planar pose ``(3,)`` (heading wrapped) of an optimiser state."""
    if param == "planar":
        s = np.asarray(state, dtype=np.float64).copy()
        s[2] = (s[2] + math.pi) % (2 * math.pi) - math.pi
        return s
    return planar_from_camera(state)


def prior_terms(param: str, state, pred: np.ndarray, cfg: TrackerConfig,
                camera_height: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Negative log prior (up to a constant), its gradient and Hessian in the optimiser's parameters.

    planar: ``1/2 sum ((z - z_pred) / sigma)^2`` with the heading difference wrapped (exact).
    se3: ``1/2 |xi / sigma6|^2`` with ``xi = log(T_pred^-1 T_wc)``; gradient ``xi / sigma6^2`` and
    Hessian ``diag(1 / sigma6^2)`` to first order (``J_r(xi)`` taken as identity).
    """
    sxy, sth = cfg.prior_sigma
    if param == "planar":
        d = np.asarray(state, dtype=np.float64) - pred
        d[2] = (d[2] + math.pi) % (2 * math.pi) - math.pi
        w = np.array([1 / sxy**2, 1 / sxy**2, 1 / sth**2])
        return 0.5 * float(np.sum(w * d * d)), w * d, np.diag(w)
    sz, srp = cfg.off_plane_sigma
    # camera frame: x right (horizontal), y down (vertical), z forward (horizontal); yaw = about y
    sig = np.array([sxy, sz, sxy, srp, sth, srp])
    w = 1.0 / sig**2
    xi = se3_log(se3_inverse(camera_pose(pred, camera_height)) @ state)
    return 0.5 * float(np.sum(w * xi * xi)), w * xi, np.diag(w)


# ------------------------------------------------------------------------------ residuals

class Residuals(NamedTuple):
    """Per-pixel residuals of eq. 7 and their Jacobians w.r.t. the optimiser's parameters."""

    photo: np.ndarray  # (K, 3) colour difference xhat[pi(T p)] - x (colour units); 0 if dropped
    photo_ok: np.ndarray  # (K,) bool: in image, valid, and ||photo||_1 <= threshold
    geo: np.ndarray  # (K,) point-to-plane <phat - T p, nhat> (m); 0 if dropped
    geo_ok: np.ndarray  # (K,) bool: associated, normal valid, |geo| <= threshold
    J_photo: np.ndarray | None  # (K, 3, P)
    J_geo: np.ndarray | None  # (K, P)


def residuals(ref: Reference, obs: Observation, q: np.ndarray, dq: np.ndarray | None,
              photo_threshold: float = 1.0, geo_threshold: float = 5.0,
              max_curvature: float = 0.05) -> Residuals:
    """Photometric and point-to-plane residuals for transformed points ``q (K, 3)`` (numpy reference).

    ``q`` are the observed points in the reference camera frame (``T p``); ``dq (K, 3, P)`` their
    Jacobian (or None to skip Jacobians). Colour is sampled bilinearly at ``pi(q)`` (its
    derivative is the analytic derivative of the bilinear interpolant); ``phat``/``nhat`` are
    taken at the nearest pixel ``floor(u + 1/2), floor(v + 1/2)`` (projective association), so
    ``d geo / d q = -nhat``. :func:`accumulate` is the fast equivalent.
    """
    intr = ref.intr
    H, W = intr.shape
    K = len(q)
    z = q[:, 2]
    front = obs.ok & (z > 1e-6)
    zs = np.where(front, z, 1.0)
    u = intr.fx * q[:, 0] / zs + intr.cx
    v = intr.fy * q[:, 1] / zs + intr.cy
    inside = front & (u >= 0) & (u <= W - 1) & (v >= 0) & (v <= H - 1)
    u = np.where(inside, u, 0.0)
    v = np.where(inside, v, 0.0)

    # bilinear colour
    rgb = ref.rgb.reshape(-1, 3)
    vf = ref.valid.reshape(-1)
    u0 = np.minimum(np.floor(u).astype(np.int64), max(W - 2, 0))
    v0 = np.minimum(np.floor(v).astype(np.int64), max(H - 2, 0))
    a = (u - u0)[:, None]
    b = (v - v0)[:, None]
    i00 = v0 * W + u0
    i10, i01, i11 = i00 + 1, i00 + W, i00 + W + 1
    c00, c10, c01, c11 = rgb[i00], rgb[i10], rgb[i01], rgb[i11]
    col = (1 - a) * (1 - b) * c00 + a * (1 - b) * c10 + (1 - a) * b * c01 + a * b * c11
    photo = col - obs.rgb
    cok = vf[i00] & vf[i10] & vf[i01] & vf[i11]
    photo_ok = inside & cok & (np.abs(photo).sum(axis=1) <= photo_threshold)

    # projective association at the nearest pixel
    P, N, nok = depth_normals(ref.depth, ref.valid, intr, max_curvature)
    ni = np.floor(v + 0.5).astype(np.int64) * W + np.floor(u + 0.5).astype(np.int64)
    phat = P.reshape(-1, 3)[ni]
    nhat = N.reshape(-1, 3)[ni]
    geo = np.einsum("kj,kj->k", phat - q, nhat)
    geo_ok = inside & nok.reshape(-1)[ni] & (np.abs(geo) <= geo_threshold)
    photo = np.where(photo_ok[:, None], photo, 0.0)
    geo = np.where(geo_ok, geo, 0.0)

    if dq is None:
        return Residuals(photo, photo_ok, geo, geo_ok, None, None)
    dIdu = (1 - b) * (c10 - c00) + b * (c11 - c01)  # (K, 3)
    dIdv = (1 - a) * (c01 - c00) + a * (c11 - c10)
    iz = 1.0 / zs
    dudq = np.stack([intr.fx * iz, np.zeros(K), -intr.fx * q[:, 0] * iz * iz], axis=1)  # (K, 3)
    dvdq = np.stack([np.zeros(K), intr.fy * iz, -intr.fy * q[:, 1] * iz * iz], axis=1)
    dudp = np.einsum("kj,kjp->kp", dudq, dq)  # (K, P)
    dvdp = np.einsum("kj,kjp->kp", dvdq, dq)
    J_photo = dIdu[:, :, None] * dudp[:, None, :] + dIdv[:, :, None] * dvdp[:, None, :]
    J_geo = -np.einsum("kj,kjp->kp", nhat, dq)
    J_photo[~photo_ok] = 0.0
    J_geo[~geo_ok] = 0.0
    return Residuals(photo, photo_ok, geo, geo_ok, J_photo, J_geo)


def objective(ref: Reference, obs: Observation, param: str, state, pred: np.ndarray,
              cfg: TrackerConfig, camera_height: float = CAMERA_HEIGHT,
              with_grad: bool = True) -> tuple[float, np.ndarray | None]:
    """Eq. 7's value at ``state`` and its L1 subgradient w.r.t. the optimiser's parameters (numpy)."""
    q, dq = transform_and_jacobian(param, state, ref.T_wc, obs.points, camera_height)
    r = residuals(ref, obs, q, dq if with_grad else None, cfg.photo_threshold, cfg.geo_threshold,
                  cfg.normal_max_curvature)
    scale = cfg.pixel_scale / max(len(obs.points), 1)
    pv, pg, _ = prior_terms(param, state, pred, cfg, camera_height)
    wp, wg = cfg.photo_weight, cfg.geo_weight
    val = scale * (wp * float(np.abs(r.photo).sum()) + wg * float(np.abs(r.geo).sum())) + pv
    if not with_grad:
        return val, None
    g = scale * (wp * np.einsum("kc,kcp->p", np.sign(r.photo), r.J_photo)
                 + wg * np.sign(r.geo) @ r.J_geo) + pg
    return val, g


@numba.njit(cache=True, nogil=True)
def _accumulate_kernel(rgb, depth, valid, fx, fy, cx, cy, pts, orgb, ook, Trel, B, b,
                       photo_thr, geo_thr, max_curv, eps_p, eps_g, w_photo, w_geo):
    H, W = depth.shape
    P = b.shape[0]
    val = 0.0
    gsub = np.zeros(P)
    girls = np.zeros(P)
    Hm = np.zeros((P, P))
    counts = np.zeros(2, np.int64)
    dqc = np.zeros((3, P))
    dudp = np.zeros(P)
    dvdp = np.zeros(P)
    Jr = np.zeros(P)
    for k in range(pts.shape[0]):
        if not ook[k]:
            continue
        p0, p1, p2 = pts[k, 0], pts[k, 1], pts[k, 2]
        q0 = Trel[0, 0] * p0 + Trel[0, 1] * p1 + Trel[0, 2] * p2 + Trel[0, 3]
        q1 = Trel[1, 0] * p0 + Trel[1, 1] * p1 + Trel[1, 2] * p2 + Trel[1, 3]
        q2 = Trel[2, 0] * p0 + Trel[2, 1] * p1 + Trel[2, 2] * p2 + Trel[2, 3]
        if q2 <= 1e-6:
            continue
        iz = 1.0 / q2
        u = fx * q0 * iz + cx
        v = fy * q1 * iz + cy
        if not (u >= 0.0 and u <= W - 1 and v >= 0.0 and v <= H - 1):
            continue
        for c in range(P):
            for i in range(3):
                dqc[i, c] = B[c, i, 0] * p0 + B[c, i, 1] * p1 + B[c, i, 2] * p2 + b[c, i]
            dudp[c] = fx * iz * dqc[0, c] - fx * q0 * iz * iz * dqc[2, c]
            dvdp[c] = fy * iz * dqc[1, c] - fy * q1 * iz * iz * dqc[2, c]
        # photometric: bilinear colour of the reference at (u, v)
        u0 = min(int(math.floor(u)), W - 2)
        v0 = min(int(math.floor(v)), H - 2)
        if valid[v0, u0] and valid[v0, u0 + 1] and valid[v0 + 1, u0] and valid[v0 + 1, u0 + 1]:
            a = u - u0
            bb = v - v0
            l1 = 0.0
            for ch in range(3):
                c00 = rgb[v0, u0, ch]
                c10 = rgb[v0, u0 + 1, ch]
                c01 = rgb[v0 + 1, u0, ch]
                c11 = rgb[v0 + 1, u0 + 1, ch]
                col = (1 - a) * (1 - bb) * c00 + a * (1 - bb) * c10 + (1 - a) * bb * c01 + a * bb * c11
                l1 += abs(col - orgb[k, ch])
            if l1 <= photo_thr:
                counts[0] += 1
                val += w_photo * l1
                for ch in range(3):
                    c00 = rgb[v0, u0, ch]
                    c10 = rgb[v0, u0 + 1, ch]
                    c01 = rgb[v0 + 1, u0, ch]
                    c11 = rgb[v0 + 1, u0 + 1, ch]
                    col = (1 - a) * (1 - bb) * c00 + a * (1 - bb) * c10 + (1 - a) * bb * c01 + a * bb * c11
                    r = col - orgb[k, ch]
                    didu = (1 - bb) * (c10 - c00) + bb * (c11 - c01)
                    didv = (1 - a) * (c01 - c00) + a * (c11 - c10)
                    w = w_photo / max(abs(r), eps_p)
                    sg = w_photo if r > 0 else (-w_photo if r < 0 else 0.0)
                    for c in range(P):
                        Jr[c] = didu * dudp[c] + didv * dvdp[c]
                    for c in range(P):
                        gsub[c] += sg * Jr[c]
                        girls[c] += w * r * Jr[c]
                        for e in range(P):
                            Hm[c, e] += w * Jr[c] * Jr[e]
        # point-to-plane at the nearest pixel (projective association)
        ui = int(math.floor(u + 0.5))
        vi = int(math.floor(v + 0.5))
        if ui < 1 or ui > W - 2 or vi < 1 or vi > H - 2:
            continue
        if not (valid[vi, ui] and valid[vi, ui + 1] and valid[vi, ui - 1]
                and valid[vi + 1, ui] and valid[vi - 1, ui]):
            continue
        d = depth[vi, ui]
        ic = 1.0 / d
        cu = abs(1.0 / depth[vi, ui + 1] - 2 * ic + 1.0 / depth[vi, ui - 1])
        cv = abs(1.0 / depth[vi + 1, ui] - 2 * ic + 1.0 / depth[vi - 1, ui])
        if cu > max_curv * ic or cv > max_curv * ic:
            continue
        # back-projected neighbours
        dr = depth[vi, ui + 1]
        dl = depth[vi, ui - 1]
        dd = depth[vi + 1, ui]
        du_ = depth[vi - 1, ui]
        xu = (ui - cx) / fx
        yv = (vi - cy) / fy
        # du = P[v, u+1] - P[v, u-1], dv = P[v+1, u] - P[v-1, u]
        du0 = dr * (ui + 1 - cx) / fx - dl * (ui - 1 - cx) / fx
        du1 = (dr - dl) * yv
        du2 = dr - dl
        dv0 = (dd - du_) * xu
        dv1 = dd * (vi + 1 - cy) / fy - du_ * (vi - 1 - cy) / fy
        dv2 = dd - du_
        n0 = dv1 * du2 - dv2 * du1
        n1 = dv2 * du0 - dv0 * du2
        n2 = dv0 * du1 - dv1 * du0
        nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if nn <= 0.0:
            continue
        n0 /= nn
        n1 /= nn
        n2 /= nn
        r = n0 * (xu * d - q0) + n1 * (yv * d - q1) + n2 * (d - q2)
        if abs(r) > geo_thr:
            continue
        counts[1] += 1
        val += w_geo * abs(r)
        w = w_geo / max(abs(r), eps_g)
        sg = w_geo if r > 0 else (-w_geo if r < 0 else 0.0)
        for c in range(P):
            Jr[c] = -(n0 * dqc[0, c] + n1 * dqc[1, c] + n2 * dqc[2, c])
        for c in range(P):
            gsub[c] += sg * Jr[c]
            girls[c] += w * r * Jr[c]
            for e in range(P):
                Hm[c, e] += w * Jr[c] * Jr[e]
    return val, gsub, Hm, girls, counts


class Accumulated(NamedTuple):
    """Sums over the sampled pixels of the data terms of eq. 7 (unscaled)."""

    value: float  # weighted sum of the kept L1 terms
    grad: np.ndarray  # (P,) L1 subgradient
    irls_H: np.ndarray  # (P, P) sum of w J^T J with IRLS weights w = weight / max(|r|, eps)
    irls_g: np.ndarray  # (P,) sum of w r J (equals ``grad`` where |r| >= eps)
    counts: np.ndarray  # (2,) kept photometric pixels, kept point-to-plane pixels


def accumulate(ref: Reference, obs: Observation, Trel: np.ndarray, B: np.ndarray, b: np.ndarray,
               cfg: TrackerConfig, photometric: bool = True) -> Accumulated:
    """Fast (numba) data terms of eq. 7 for ``q = T_rel p`` with point Jacobian ``B p + b``.

    Same residuals, thresholds and normals as :func:`residuals` and :func:`depth_normals`.
    ``photometric=False`` drops the photometric term (point-to-plane only).
    """
    i = ref.intr
    out = _accumulate_kernel(ref.rgb, ref.depth, ref.valid, float(i.fx), float(i.fy),
                             float(i.cx), float(i.cy), obs.points, obs.rgb, obs.ok,
                             np.ascontiguousarray(Trel), np.ascontiguousarray(B),
                             np.ascontiguousarray(b),
                             float(cfg.photo_threshold) if photometric else -1.0,
                             float(cfg.geo_threshold), float(cfg.normal_max_curvature),
                             float(cfg.irls_eps[0]), float(cfg.irls_eps[1]),
                             float(cfg.photo_weight), float(cfg.geo_weight))
    return Accumulated(*out)


# ------------------------------------------------------------------------------ optimisers

def _param_lr(param: str, lr: tuple[float, float]) -> np.ndarray:
    if param == "planar":
        return np.array([lr[0], lr[0], lr[1]])
    return np.array([lr[0]] * 3 + [lr[1]] * 3)


def _initial_state(param: str, pred: np.ndarray, camera_height: float):
    return pred.copy() if param == "planar" else camera_pose(pred, camera_height)


def yaw_search(ref: Reference, frame: Frame, pred: np.ndarray, cfg: TrackerConfig,
               idx: np.ndarray, camera_height: float = CAMERA_HEIGHT) -> np.ndarray:
    """The planar start pose for the local optimiser: the best heading around the prediction.

    Scores ``pred`` with its heading offset by ``k * yaw_search_step_deg`` (``|offset| <=
    yaw_search_deg``) by the mean kept data term of eq. 7 per kept photometric pixel on the first
    ``yaw_search_pixels`` of ``idx``; candidates that keep fewer than 30 % of those pixels are
    skipped. Returns ``pred`` itself when the search is disabled or no candidate qualifies.
    """
    pred = np.asarray(pred, dtype=np.float64)
    if cfg.yaw_search_deg <= 0 or cfg.yaw_search_step_deg <= 0:
        return pred.copy()
    sub = idx[: cfg.yaw_search_pixels]
    obs = sample_observation(frame, ref.intr, sub)
    n_half = int(math.floor(cfg.yaw_search_deg / cfg.yaw_search_step_deg + 1e-9))
    best, best_cost = pred.copy(), np.inf
    for k in range(-n_half, n_half + 1):
        cand = pred.copy()
        cand[2] += math.radians(k * cfg.yaw_search_step_deg)
        state = _initial_state(cfg.param, cand, camera_height)
        Trel, B, b = linearization(cfg.param, state, ref.T_wc, camera_height)
        acc = accumulate(ref, obs, Trel, B, b, cfg)
        kept = acc.counts[0]
        if kept < 0.3 * len(sub):
            continue
        cost = acc.value / kept
        if cost < best_cost:
            best, best_cost = cand, cost
    return best


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
    for i in range(cfg.adam_steps):
        row = table[i % len(table), : cfg.adam_pixels]
        obs = sample_observation(frame, ref.intr, row)
        Trel, B, b = linearization(param, state, ref.T_wc, camera_height)
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
                       idx: np.ndarray, camera_height: float = CAMERA_HEIGHT) -> np.ndarray:
    """Minimise eq. 7 by iteratively reweighted Gauss-Newton on the pixels ``idx``; planar pose out.

    Each iteration linearises the residuals, weights L1 residuals by ``1 / max(|r|, eps)`` (zero
    where a robust threshold drops them), adds the prior's quadratic and solves the normal
    equations; it stops after ``gn_iters`` iterations or when the step is below ``gn_tol``.
    The first ``gn_geo_iters`` iterations use the point-to-plane term only: projective ICP has
    a much wider basin of convergence than the photometric term (whose linearisation only
    sees the texture within a pixel or two), so it brings a rotation error of several degrees
    within reach; the remaining iterations minimise the full eq. 7.
    """
    param = cfg.param
    obs = sample_observation(frame, ref.intr, idx)
    start = yaw_search(ref, frame, pred, cfg, idx, camera_height)
    state = _initial_state(param, start, camera_height)
    scale = cfg.pixel_scale / max(len(idx), 1)
    ntr = 2 if param == "planar" else 3
    for it in range(cfg.gn_iters):
        geo_only = it < cfg.gn_geo_iters
        Trel, B, b = linearization(param, state, ref.T_wc, camera_height)
        acc = accumulate(ref, obs, Trel, B, b, cfg, photometric=not geo_only)
        _, pg, pH = prior_terms(param, state, pred, cfg, camera_height)
        try:
            delta = -np.linalg.solve(scale * acc.irls_H + pH, scale * acc.irls_g + pg)
        except np.linalg.LinAlgError:
            break
        state = retract(param, state, delta)
        if (not geo_only and np.abs(delta[:ntr]).max() < cfg.gn_tol[0]
                and np.abs(delta[ntr:]).max() < cfg.gn_tol[1]):
            break
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
          seed: int = 0, camera_height: float = CAMERA_HEIGHT) -> np.ndarray:
    """Eq. 7 minimised by the configured optimiser; returns the planar pose ``(3,)``."""
    H, W = ref.intr.shape
    pred = np.asarray(pred, dtype=np.float64)
    if cfg.optimizer == "adam":
        table = pixel_table(H, W, 100, cfg.adam_pixels, seed)
        return align_adam(ref, frame, pred, cfg, table, camera_height)
    return align_gauss_newton(ref, frame, pred, cfg, gn_pixels(H, W, cfg.gn_pixels, seed),
                              camera_height)


# ------------------------------------------------------------------------------ estimators

def default_renderer(vmap, intrinsics: Intrinsics, camera_height: float) -> Callable:
    """``pose -> Frame`` rendering ``vmap`` with the fast numba renderer (``render_map``'s engine)."""
    if vmap is None:
        raise TrackingError("this estimator needs a map (vmap=...) or a renderer (renderer=...)")
    from navbench.worldmodel.fastrender import FastRenderer

    return FastRenderer(vmap, intrinsics, camera_height).render


class _PredictionToObservation:
    """Shared shell of ``ours`` and ``no-map``: state, timing, the reference image."""

    name = "ours"
    uses_map = True

    def __init__(self, vmap=None, intrinsics: Intrinsics = HALF_CAMERA,
                 camera_height: float = CAMERA_HEIGHT, renderer: Callable | None = None,
                 seed: int = 0, **options):
        self.config = make_config(options)
        self.intrinsics = intrinsics
        self.camera_height = float(camera_height)
        self.seed = int(seed)
        if self.uses_map:
            self._render = renderer if renderer is not None else default_renderer(
                vmap, intrinsics, camera_height)
        else:
            self._render = None
        self.pose = None
        self.last_timing: dict[str, float] = {}
        self._ref: Reference | None = None
        self._ref_pose: np.ndarray | None = None
        self._prev_frame: Frame | None = None

    def reset(self, pose0, frame0: Frame) -> None:
        self.pose = np.asarray(pose0, dtype=np.float64).copy()
        self._ref = None
        self._ref_pose = None
        self._prev_frame = frame0
        self.last_timing = {}

    def _reference(self) -> tuple[Reference, float]:
        """The reference for the current ``z*_{t-1}`` (rendered at most once per pose)."""
        t0 = time.perf_counter()
        if self._ref is None or not np.array_equal(self._ref_pose, self.pose):
            if self.uses_map:
                frame = self._render(self.pose)
            else:
                frame = self._prev_frame
            ms_render = (time.perf_counter() - t0) * 1e3 if self.uses_map else 0.0
            self._ref = prepare_reference(frame, self.intrinsics,
                                          camera_pose(self.pose, self.camera_height))
            self._ref_pose = self.pose.copy()
            return self._ref, ms_render
        return self._ref, 0.0

    def update(self, control, frame: Frame, true_pose=None) -> np.ndarray:
        check_update(self, frame)
        t0 = time.perf_counter()
        ref, ms_render = self._reference()
        t1 = time.perf_counter()
        pred = np.asarray(predict(self.pose, control), dtype=np.float64)
        est = align(ref, frame, pred, self.config, self.seed, self.camera_height)
        t2 = time.perf_counter()
        self.pose = est
        self._prev_frame = frame
        prep_ms = (t1 - t0) * 1e3 - ms_render
        self.last_timing = {"render": ms_render, "estimate": prep_ms + (t2 - t1) * 1e3}
        return est.copy()


@register_estimator("ours")
class PredictionToObservationTracker(_PredictionToObservation):
    """Eq. 7 against the image the map renders at the previous estimate (the paper's tracker)."""

    uses_map = True


@register_estimator("no-map")
class FrameToFrameTracker(_PredictionToObservation):
    """The "no map" ablation: eq. 7 against the previous observation ``x_{t-1}``."""

    uses_map = False
