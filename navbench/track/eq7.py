"""Eq. 7's terms for the prediction-to-observation trackers (:mod:`navbench.track.ours`): the
options (:class:`TrackerConfig`, defined in :mod:`navbench.track.trackconfig`), the pixel tables,
the reference image and the observation, the pose parameterisations, the dynamics prior, the
robust photometric and point-to-plane residuals, and the numba kernel that sums them with their
Gauss-Newton normal equations.

:func:`residuals`, :func:`depth_normals` and :func:`objective` are the numpy reference that
:func:`accumulate` (numba) is tested against. The objective itself is documented in
:mod:`navbench.track.ours`. All arrays are float64 unless stated; pixel coordinates follow
:mod:`navbench.geometry`.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any, NamedTuple

import numba
import numpy as np

from navbench.errors import TrackingError
from navbench.geometry import CAMERA_HEIGHT, Frame, Intrinsics, camera_pose, pixel_rays
from navbench.track.lie import hat, planar_from_camera, se3_exp, se3_inverse, se3_log
from navbench.track.trackconfig import (  # noqa: F401  (re-exported: eq. 7's options)
    _TRACKING_NOISE, OPTIMIZERS, PARAMS, TrackerConfig, make_config)


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
    # a lazy reference (navbench.worldmodel.fastrender.LazyFrame) whose fill(points, ok, Trels)
    # renders the pixels the kernel will read before it reads them; None: rgb/depth/valid are full
    lazy: Any = None
    # the observation's intrinsics when they differ from the reference's (option
    # reference_scale); None: the same as ``intr``
    obs_intr: Any = None

    @property
    def observed(self) -> Intrinsics:
        """The intrinsics of the observations aligned to this reference."""
        return self.intr if self.obs_intr is None else self.obs_intr


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


def linearization(param: str, state, T_ref: np.ndarray, camera_height: float,
                  T_ref_inv: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``T_rel = T_ref^-1 T_wc(state)`` and the affine point Jacobian ``dq/dparam_c = B[c] p + b[c]``.

    ``q = T_rel p`` maps current-camera points ``p`` into the reference camera.
    ``param="planar"``: ``state`` is ``(x, y, theta)``; 3 parameters.
    ``param="se3"``: ``state`` is ``T_wc`` (4x4); 6 parameters, a right perturbation
    ``T_wc exp(delta)`` with ``delta = (rho, phi)`` in the current camera frame, so
    ``dq/drho_j = R_rel e_j`` and ``dq/dphi_j = R_rel (e_j x p)``.
    Returns ``T_rel (4, 4)``, ``B (P, 3, 3)``, ``b (P, 3)``. ``T_ref_inv``: ``se3_inverse(T_ref)``
    when the caller has it (an optimiser linearises many times against one reference).
    """
    Ti = se3_inverse(T_ref) if T_ref_inv is None else T_ref_inv
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
    colv = np.zeros(3)
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
        # photometric: bilinear colour of the reference at (u, v); a negative threshold keeps
        # no pixel (l1 >= 0), so the term is skipped without reading the colours
        u0 = min(int(math.floor(u)), W - 2)
        v0 = min(int(math.floor(v)), H - 2)
        if photo_thr >= 0.0 and (valid[v0, u0] and valid[v0, u0 + 1] and valid[v0 + 1, u0]
                                 and valid[v0 + 1, u0 + 1]):
            a = u - u0
            bb = v - v0
            l1 = 0.0
            for ch in range(3):
                c00 = rgb[v0, u0, ch]
                c10 = rgb[v0, u0 + 1, ch]
                c01 = rgb[v0 + 1, u0, ch]
                c11 = rgb[v0 + 1, u0 + 1, ch]
                col = (1 - a) * (1 - bb) * c00 + a * (1 - bb) * c10 + (1 - a) * bb * c01 + a * bb * c11
                colv[ch] = col
                l1 += abs(col - orgb[k, ch])
            if l1 <= photo_thr:
                counts[0] += 1
                val += w_photo * l1
                for c in range(P):
                    dudp[c] = fx * iz * dqc[0, c] - fx * q0 * iz * iz * dqc[2, c]
                    dvdp[c] = fy * iz * dqc[1, c] - fy * q1 * iz * iz * dqc[2, c]
                for ch in range(3):
                    c00 = rgb[v0, u0, ch]
                    c10 = rgb[v0, u0 + 1, ch]
                    c01 = rgb[v0 + 1, u0, ch]
                    c11 = rgb[v0 + 1, u0 + 1, ch]
                    r = colv[ch] - orgb[k, ch]
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


@numba.njit(cache=True, nogil=True)
def _accumulate_many(rgb, depth, valid, fx, fy, cx, cy, pts, orgb, ook, Trels, Bs, bs,
                     photo_thr, geo_thr, max_curv, eps_p, eps_g, w_photo, w_geo):
    """:func:`_accumulate_kernel` for each of ``N`` linearisations ``Trels (N, 4, 4)``, ``Bs
    (N, P, 3, 3)``, ``bs (N, P, 3)``: the values ``(N,)`` and counts ``(N, 2)`` (one call instead
    of ``N``: the heading search scores its candidates with it)."""
    n = Trels.shape[0]
    vals = np.empty(n)
    counts = np.empty((n, 2), np.int64)
    for c in range(n):
        out = _accumulate_kernel(rgb, depth, valid, fx, fy, cx, cy, pts, orgb, ook, Trels[c], Bs[c], bs[c],
                                 photo_thr, geo_thr, max_curv, eps_p, eps_g, w_photo, w_geo)
        vals[c] = out[0]
        counts[c, 0] = out[4][0]
        counts[c, 1] = out[4][1]
    return vals, counts


def accumulate_values(ref: Reference, obs: Observation, lins: list, cfg: TrackerConfig) -> tuple[np.ndarray, np.ndarray]:
    """The ``value`` and ``counts`` of :func:`accumulate` (photometric term on) for every
    ``(Trel, B, b)`` of ``lins`` in one compiled call: ``(N,)`` values, ``(N, 2)`` counts."""
    i = ref.intr
    Trels = np.ascontiguousarray(np.stack([t for t, _, _ in lins]))
    if ref.lazy is not None:
        ref.lazy.fill(obs.points, obs.ok, Trels)
    return _accumulate_many(ref.rgb, ref.depth, ref.valid, float(i.fx), float(i.fy),
                            float(i.cx), float(i.cy), obs.points, obs.rgb, obs.ok, Trels,
                            np.ascontiguousarray(np.stack([B for _, B, _ in lins])),
                            np.ascontiguousarray(np.stack([b for _, _, b in lins])),
                            float(cfg.photo_threshold), float(cfg.geo_threshold),
                            float(cfg.normal_max_curvature), float(cfg.irls_eps[0]),
                            float(cfg.irls_eps[1]), float(cfg.photo_weight), float(cfg.geo_weight))


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
    if ref.lazy is not None:
        ref.lazy.fill(obs.points, obs.ok, np.ascontiguousarray(Trel)[None])
    out = _accumulate_kernel(ref.rgb, ref.depth, ref.valid, float(i.fx), float(i.fy),
                             float(i.cx), float(i.cy), obs.points, obs.rgb, obs.ok,
                             np.ascontiguousarray(Trel), np.ascontiguousarray(B),
                             np.ascontiguousarray(b),
                             float(cfg.photo_threshold) if photometric else -1.0,
                             float(cfg.geo_threshold), float(cfg.normal_max_curvature),
                             float(cfg.irls_eps[0]), float(cfg.irls_eps[1]),
                             float(cfg.photo_weight), float(cfg.geo_weight))
    return Accumulated(*out)
