"""Emission-based tracking (paper section 3.2 / 4.2, appendix E): gradients through the renderer.

At step ``t`` the pose ``z_t`` minimises::

    E(z_t) = S/K sum_k -log Laplace([x^rgb_k; x^d_k] | [g(p*_k); k*_k], [sigma1; sigma2])
             - log N(z_t; predict(z*_{t-1}, u_{t-1}), Sigma)

over ``K`` pixels of the observation ``x_t`` (eq. 2-3 through the differentiable renderer of
:mod:`navbench.worldmodel.diffrender`, rays whose crossing is missing or whose observed depth is
invalid are masked out), with the same Gaussian prior as :mod:`navbench.track.ours`. The
renderer's fast bracketing path is used: the crossing search runs without gradients, then
``f(p-)``, ``f(p+)`` and ``g(p*)`` are evaluated with autograd at positions that depend on the
ray origins and directions, i.e. on the pose (``colour_moves_surface=True`` so that colour
follows the surface point ``p* = c + k* v`` as the pose moves).

Optimiser: Adam with step sizes ``lr = (0.001, 0.002)`` for translation and rotation (appendix
E), ``steps`` (100) steps, step ``i`` on row ``i`` of the same fixed ``100 x pixels`` index
table as ``ours`` (:func:`navbench.track.eq7.pixel_table`); the paper's budget is
``steps=100, pixels=1000``. Parameterisations as in ``ours``: ``planar`` ``(x, y, theta)`` or
``se3`` (right perturbations of the camera pose, result projected to planar).

Laplace scales: ``sigma2`` (m) is the map's learned ``meta["sigma2"]`` when present, else
``default_sigma2`` (0.1 m); ``sigma1 = sigma2 / 5`` (SPEC). ``S = pixel_scale`` (1000): the
negative log-likelihood is the sum over ``S`` pixels, as in ``ours``.
"""

from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from navbench.errors import TrackingError
from navbench.geometry import CAMERA_HEIGHT, HALF_CAMERA, MAX_RANGE, MIN_RAY_RANGE, MIN_RAY_STEP, Frame, Intrinsics, camera_pose
from navbench.track.base import check_update, config_from_options
from navbench.track.lie import planar_from_camera, se3_exp
from navbench.track.eq7 import _TRACKING_NOISE, PARAMS, _rays_flat, pixel_table


@dataclass(frozen=True)
class EmissionConfig:
    """Options of the emission tracker (keyword options of the estimator)."""

    steps: int = 100  # Adam steps per update (paper: 100)
    pixels: int = 1000  # pixels per step (paper: 1000)
    lr: tuple[float, float] = (0.001, 0.002)  # (translation [m], rotation [rad]) step sizes
    betas: tuple[float, float] = (0.9, 0.999)
    param: str = "planar"  # "planar" or "se3"
    prior_sigma: tuple[float, float] = (_TRACKING_NOISE[1], _TRACKING_NOISE[0])  # (m, rad)
    off_plane_sigma: tuple[float, float] = (0.005, math.radians(0.5))  # se3 only (m, rad)
    sigma2: float | None = None  # depth Laplace scale (m); None: map meta["sigma2"] or default
    default_sigma2: float = 0.1
    pixel_scale: float = 1000.0
    step: float | None = None  # ray sample spacing (m); None: the map's meta["step"] or 0.1
    max_range: float = MAX_RANGE
    # torch/numba threads during an update (None: leave the process setting). One thread is
    # fastest for 1000-ray batches and avoids thread oversubscription on a shared CPU.
    threads: int | None = 1

    def __post_init__(self):
        if self.param not in PARAMS:
            raise TrackingError(f"unknown param {self.param!r}; choose one of {PARAMS}")
        if int(self.steps) < 1 or int(self.pixels) < 1:
            raise TrackingError("steps and pixels must be >= 1")
        # a ray with no sample renders nothing: a tracker that sees nothing is not scored (issue 34)
        if not float(self.max_range) >= MIN_RAY_RANGE:
            raise TrackingError(f"max_range must be >= {MIN_RAY_RANGE:g} m (the nearest a depth camera "
                                f"reads), got {self.max_range!r}")
        if self.step is not None and not MIN_RAY_STEP <= float(self.step) <= float(self.max_range):
            raise TrackingError(f"step must be in [{MIN_RAY_STEP:g}, max_range = {self.max_range:g}] m "
                                f"(a ray of no sample renders nothing), got {self.step!r}")


def make_emission_config(options: dict) -> EmissionConfig:
    """Build an :class:`EmissionConfig` from keyword options; unknown names raise TrackingError."""
    return config_from_options(EmissionConfig(), options, "emission")


def _camera_rotation_t(theta):
    import torch

    c, s = torch.cos(theta), torch.sin(theta)
    z, o = torch.zeros_like(c), torch.ones_like(c)
    return torch.stack([torch.stack([s, z, c]), torch.stack([-c, z, s]), torch.stack([z, -o, z])])


def _hat_t(w):
    import torch

    z = torch.zeros_like(w[0])
    return torch.stack([torch.stack([z, -w[2], w[1]]), torch.stack([w[2], z, -w[0]]),
                        torch.stack([-w[1], w[0], z])])


class EmissionObjective:
    """The emission negative log-likelihood of one observation as a function of the pose.

    ``vmap``: a :class:`~navbench.worldmodel.base.DifferentiableWorldModel` (a voxel map); its
    :meth:`ray_renderer` (the map's tensors) is built once.
    :meth:`value_and_grad` returns the scaled NLL over the pixels ``idx`` and its gradient w.r.t.
    the parameters (planar ``(x, y, theta)``, or a right perturbation ``(rho, phi)`` of the
    camera pose at ``delta = 0`` for se3).
    """

    def __init__(self, vmap, intrinsics: Intrinsics, camera_height: float, cfg: EmissionConfig):
        import torch

        if not callable(getattr(vmap, "ray_renderer", None)):
            raise TrackingError(f"the 'emission' estimator needs a differentiable world model "
                                f"(one with ray_renderer, e.g. a voxel map); got a {type(vmap).__name__}")
        self.vmap = vmap
        self.intr = intrinsics
        self.camera_height = float(camera_height)
        self.cfg = cfg
        self.render_rays = vmap.ray_renderer(cfg.step, cfg.max_range)
        self.step = self.render_rays.step
        self.n = self.render_rays.n
        if self.n < 1:  # the map's own step (meta['step']) is longer than max_range
            raise TrackingError(f"the 'emission' estimator: max_range = {cfg.max_range:g} m is shorter "
                                f"than the map's ray step ({self.step:g} m): its rays render nothing")
        s2 = cfg.sigma2 if cfg.sigma2 is not None else vmap.meta.get("sigma2", cfg.default_sigma2)
        self.sigma2 = torch.tensor(float(s2), dtype=torch.float32)

    def value_and_grad(self, param: str, state, frame: Frame, idx: np.ndarray) -> tuple[float, np.ndarray]:
        import torch

        from navbench.worldmodel.diffrender import laplace_nll

        rays = torch.from_numpy(_rays_flat(self.intr)[idx].astype(np.float32))
        if param == "planar":
            z = torch.tensor(np.asarray(state, dtype=np.float32), requires_grad=True)
            R = _camera_rotation_t(z[2])
            t = torch.stack([z[0], z[1], torch.tensor(self.camera_height, dtype=torch.float32)])
            var = z
        else:
            T0 = torch.from_numpy(np.asarray(state, dtype=np.float32))
            d = torch.zeros(6, dtype=torch.float32, requires_grad=True)
            # first order in delta: exact gradient at delta = 0
            R = T0[:3, :3] @ (torch.eye(3) + _hat_t(d[3:]))
            t = T0[:3, 3] + T0[:3, :3] @ d[:3]
            var = d
        dirs = rays @ R.T
        origins = t.expand_as(dirs)
        out = self.render_rays(origins, dirs, colour_moves_surface=True)
        depth_obs = np.asarray(frame.depth).reshape(-1)[idx]
        ok = np.asarray(frame.valid).reshape(-1)[idx] & np.isfinite(depth_obs)
        d_obs = torch.from_numpy(np.where(ok, depth_obs, 0.0).astype(np.float32))
        rgb_obs = torch.from_numpy(np.asarray(frame.rgb).reshape(-1, 3)[idx].astype(np.float32))
        mask = out.hit & torch.from_numpy(ok)
        nll = laplace_nll(out.rgb, out.depth, rgb_obs, d_obs, self.sigma2, mask=mask, reduction="sum")
        loss = nll * (self.cfg.pixel_scale / len(idx))
        loss.backward()
        return float(loss.detach()), var.grad.detach().double().numpy()


def _prior(param, state, pred, cfg: EmissionConfig, camera_height):
    from navbench.track.eq7 import TrackerConfig, prior_terms

    tc = TrackerConfig(prior_sigma=cfg.prior_sigma, off_plane_sigma=cfg.off_plane_sigma)
    return prior_terms(param, state, pred, tc, camera_height)


def align_emission(objective: EmissionObjective, frame: Frame, pred: np.ndarray,
                   table: np.ndarray) -> np.ndarray:
    """Adam on the emission objective + prior from the prediction ``pred``; planar pose ``(3,)``."""
    cfg = objective.cfg
    h = objective.camera_height
    param = cfg.param
    state = pred.copy() if param == "planar" else camera_pose(pred, h)
    if param == "planar":
        lr = np.array([cfg.lr[0], cfg.lr[0], cfg.lr[1]])
    else:
        lr = np.array([cfg.lr[0]] * 3 + [cfg.lr[1]] * 3)
    b1, b2 = cfg.betas
    m = np.zeros_like(lr)
    v = np.zeros_like(lr)
    for i in range(cfg.steps):
        idx = table[i % len(table), : cfg.pixels]
        _, g = objective.value_and_grad(param, state, frame, idx)
        g = g + _prior(param, state, pred, cfg, h)[1]
        m = b1 * m + (1 - b1) * g
        v = b2 * v + (1 - b2) * g * g
        step = -lr * (m / (1 - b1 ** (i + 1))) / (np.sqrt(v / (1 - b2 ** (i + 1))) + 1e-8)
        state = state + step if param == "planar" else state @ se3_exp(step)
    if param == "planar":
        out = np.asarray(state, dtype=np.float64).copy()
        out[2] = (out[2] + math.pi) % (2 * math.pi) - math.pi
        return out
    return planar_from_camera(state)


@contextlib.contextmanager
def _threads(n: int | None):
    """Temporarily set the torch and numba thread counts (restored afterwards)."""
    if n is None:
        yield
        return
    import numba
    import torch

    t_old, n_old = torch.get_num_threads(), numba.get_num_threads()
    torch.set_num_threads(int(n))
    numba.set_num_threads(min(int(n), numba.config.NUMBA_NUM_THREADS))
    try:
        yield
    finally:
        torch.set_num_threads(t_old)
        numba.set_num_threads(n_old)


class EmissionTracker:
    """Emission-based tracking through the differentiable renderer (needs ``vmap``).

    ``renderer`` is accepted for the uniform constructor and ignored: this tracker renders the
    sampled rays itself, with gradients.
    """

    name = "emission"
    uses_frames = True
    uses_map = True
    options = EmissionConfig

    def __init__(self, vmap=None, intrinsics: Intrinsics = HALF_CAMERA,
                 camera_height: float = CAMERA_HEIGHT, renderer: Callable | None = None,
                 seed: int = 0, **options):
        if vmap is None:
            raise TrackingError("the 'emission' estimator needs a map (vmap=...)")
        self.config = make_emission_config(options)
        self.intrinsics = intrinsics
        self.camera_height = float(camera_height)
        self.seed = int(seed)
        self.objective = EmissionObjective(vmap, intrinsics, camera_height, self.config)
        self.pose = None
        self.last_timing: dict[str, float] = {}

    def reset(self, pose0, frame0: Frame | None = None) -> None:
        self.pose = np.asarray(pose0, dtype=np.float64).reshape(3).copy()
        self.last_timing = {}

    def update(self, control, frame: Frame, true_pose=None) -> np.ndarray:
        from navbench.track.odometry import predict_pose

        check_update(self, frame)
        t0 = time.perf_counter()
        H, W = self.intrinsics.shape
        table = pixel_table(H, W, 100, self.config.pixels, self.seed)
        pred = np.asarray(predict_pose(self.pose, control), dtype=np.float64)
        with _threads(self.config.threads):
            self.pose = align_emission(self.objective, frame, pred, table)
        self.last_timing = {"render": 0.0, "estimate": (time.perf_counter() - t0) * 1e3}
        return self.pose.copy()
