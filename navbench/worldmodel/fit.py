"""Fitting the world model to pose-labelled views (paper eq. 3, appendix A) and scoring it.

Eq. 3 is minimised by Adam over ``M_occ``, ``M_col`` (lr 0.05) and the Laplace scale ``sigma2``
(its own Adam, lr 0.01; ``sigma1 = sigma2 / 5``), with Monte-Carlo batches of 25 images x 200
pixels drawn by a seeded generator. Each step renders the batch's rays with the sparse
bracketing path :func:`navbench.worldmodel.diffrender.render_rays_sparse` (numba crossing
search; autograd only on the values at ``p-``, ``p+`` and ``p*``, whose gradients are scattered
back to the grids through the trilinear weights — the same gradients as
:func:`~navbench.worldmodel.diffrender.render_rays`, tested) and takes the mean eq. 2 NLL over
the rays that have a crossing and a valid observed depth (rays without a crossing contribute
nothing, see :mod:`navbench.worldmodel.diffrender`).

Optimiser: ``optimizer="lazy-adam"`` (default) applies Adam to the cells a step touched
(``torch.optim.SparseAdam`` semantics: a cell's moments and value change only on steps whose
batch reaches it), which costs O(batch) instead of O(grid) per step — a dense update of the
3.2 M grid values is slower than the whole rest of a step on 2 CPU cores.
``optimizer="adam"`` is the paper's dense Adam (``torch.optim.Adam(fused=True)``).

Devices (``FitConfig.device``, default ``"auto"``: the CPU path on every machine, measured faster
than the device path even on an H100 (docs/notebook/gpu.md), and one map per cache key everywhere):

``"cpu"``
    the path above: numpy grids, numba crossing search and row updates, autograd on the
    bracket values only.
``"cuda"`` / ``"cuda:N"`` (and ``"torch-cpu"``, the same code on the CPU, for the tests)
    the device path: the grids are torch tensors on the device;
    :func:`~navbench.worldmodel.diffrender.render_rays_torch` searches every ray sample there
    without autograd and differentiates the bracket (the gradients of the dense reference,
    tested); :class:`MaskedAdam` applies lazy Adam to the cells the step's lookups touched
    (:func:`~navbench.worldmodel.diffrender.stencil_mask`: the CPU path's touched set, tested),
    or torch's fused Adam for ``optimizer="adam"``. Same batches (the sampler and the
    free-space points are drawn on the CPU by the same seeded generators), same objective, same
    optimiser semantics; the two paths part after a few steps only through float32 rounding
    (the CPU path places samples in float64), so their maps agree in quality, not bit for bit.

The paper does not say how the grids are initialised, and an empty grid has no crossing and so
no gradient. Two documented additions, both named :class:`FitConfig` options:

``init="box"``
    Cells whose centre lies outside the views' box (below the floor, above the ceiling, beyond
    the floor plan) start at ``init_solid``, the rest at ``init_free`` (both default to the
    free/solid levels 0 and 1 around ``tau = 0.5``). Every ray then crosses something from the
    first step; ``init="empty"`` starts every cell at ``init_free``.
``free_space_weight > 0`` (an auxiliary term added to eq. 3)
    For every batch ray with a valid observed depth ``d``: ``free_space_samples`` points at
    ``k ~ U(0, d - free_space_margin)`` are pushed below ``tau - free_space_delta`` and as many
    points at ``k ~ U(d, d + free_space_margin)`` above ``tau + free_space_delta``, by the mean
    hinge ``relu(f - (tau - delta)) + relu((tau + delta) - f)`` times ``free_space_weight``.
    This is the free-space / depth supervision of differentiable volumetric rendering work: it
    carves the free space every observed ray passes through, so surfaces appear where eq. 1 can
    then refine them. ``free_space_weight = 0`` is the paper's pure objective.

``docs/data/choices/fit_quality.py`` measures the variants on a level (held-out views, slice scores).
Measured with it (5000 ``half`` views, seed 1; 200 held-out views, seed 2; 10 000 steps; depth
MAE m / RGB L1 / slice precision / recall / fit seconds on the shared 2-core machine):

===================================  ===============================  ===============================
variant                              house-1                          maze
===================================  ===============================  ===============================
defaults (box init + free space, 1)  0.0149 / 0.038 / 0.999 / 1.000  0.0182 / 0.042 / 0.982 / 1.000
                                     / 187-196 s                      / 175 s
free space with 2 samples per ray    0.0147 / 0.038 / 0.999 / 0.999  0.0184 / 0.041 / 0.986 / 1.000
pure eq. 3 (box init)                0.0157 / 0.038 / 0.990 / 1.000  0.0197 / 0.042 / 0.892 / 1.000
                                     / 165 s CPU
pure eq. 3, empty init               no crossing ever: coverage 0, nothing learned
free space (2), empty init           0.0146 / 0.038 / 0.999 / 0.993
pure eq. 3, dense Adam (paper)       0.0157 / 0.084 / 0.984 / 1.000
===================================  ===============================  ===============================

The pure objective leaves spurious occupied cells in the maze (precision 0.89); the free-space
term removes them. Dense Adam keeps moving colour cells by momentum after the batch stops
reaching them, which doubles the colour error; lazy Adam does not.
"""

from __future__ import annotations

import math
import time
from typing import Callable

import numpy as np

from navbench.errors import ConfigError
from navbench.worldmodel.evaluate import evaluate_map
from navbench.worldmodel.fitconfig import (FIT_BYTES_PER_CELL, FitConfig, check_fit_memory,  # noqa: F401 - re-exported
                                           fit_memory_bytes, require_depth_within)
from navbench.worldmodel.grid import VoxelMap, grid_for_box
from navbench.worldmodel.sparse_adam import _adam_rows, _scatter_mark, _zero_touched
from navbench.worldmodel.views import Views


def initial_grids(views: Views, config: FitConfig):
    """The grid spec and initial ``occ``, ``col`` numpy arrays for ``views`` (see ``init``)."""
    spec = grid_for_box(views.box[0], views.box[1], config.grid_shape, config.margin_z)
    occ = np.full(spec.shape, config.init_free, np.float32)
    if config.init == "box":
        X, Y, Z = np.meshgrid(spec.centres(0), spec.centres(1), spec.centres(2), indexing="ij")
        lo, hi = views.box
        out = ((X < lo[0]) | (X > hi[0]) | (Y < lo[1]) | (Y > hi[1]) | (Z < lo[2]) | (Z > hi[2]))
        occ[out] = config.init_solid
    col = np.full(spec.shape + (3,), config.init_colour, np.float32)
    return spec, occ, col


class BatchSampler:
    """Seeded Monte-Carlo batches of pixels: world rays and their observations.

    ``draw()`` returns ``origins (B, 3)``, ``dirs (B, 3)`` (world frame, ``v = R K^-1 [i j 1]``),
    ``rgb (B, 3)`` in [0, 1], ``depth (B,)`` metres, ``valid (B,)`` bool, as torch float32
    tensors, with ``B = images_per_batch * pixels_per_image``.
    """

    def __init__(self, views: Views, images: int, pixels: int, seed: int):
        from navbench.geometry import camera_rotation, pixel_rays

        self.views = views
        self.rng = np.random.default_rng(seed)
        self.images, self.pixels = images, pixels
        self.cam_rays = pixel_rays(views.intrinsics).reshape(-1, 3)
        th = np.asarray(views.poses[:, 2])
        self.R = np.stack([camera_rotation(t) for t in th]) if len(th) else np.zeros((0, 3, 3))
        # plain ndarray views of (possibly memory-mapped) arrays: no copy, no memmap overhead
        self.rgb, self.depth, self.valid = (np.asarray(a) for a in (views.rgb, views.depth, views.valid))
        self.poses = np.asarray(views.poses)
        # flat per-pixel views for single-index gathers (no copy for C-contiguous arrays)
        self.HW = views.intrinsics.height * views.intrinsics.width
        self.rgb_flat = self.rgb.reshape(-1, 3)
        self.depth_flat, self.valid_flat = self.depth.reshape(-1), self.valid.reshape(-1)

    def draw(self):
        import torch

        v = self.views
        img = self.rng.integers(0, len(v), size=self.images)
        pix = self.rng.integers(0, len(self.cam_rays), size=(self.images, self.pixels))
        ib = np.repeat(img, self.pixels)
        flat = ib * self.HW + pix.ravel()  # image-major pixel index: sorting it sorts (image, row, column)
        order = np.argsort(flat, kind="stable")  # sorted reads from memory-mapped arrays
        ib, flat = ib[order], flat[order]
        pix = flat - ib * self.HW
        R, c = self.R[ib], self.cam_rays[pix]
        dirs = np.stack([R[:, k, 0] * c[:, 0] + R[:, k, 1] * c[:, 1] + R[:, k, 2] * c[:, 2]
                         for k in range(3)], axis=1)
        origins = np.column_stack([self.poses[ib, 0], self.poses[ib, 1], np.full(len(ib), v.camera_height)])
        rgb = self.rgb_flat[flat].astype(np.float32) / 255.0
        depth = self.depth_flat[flat].astype(np.float32)
        valid = self.valid_flat[flat] & np.isfinite(depth)
        depth = np.where(valid, depth, 0.0).astype(np.float32)
        t = lambda a: torch.from_numpy(np.ascontiguousarray(a, np.float32))  # noqa: E731
        return t(origins), t(dirs), t(rgb), t(depth), torch.from_numpy(valid)


def free_space_points(origins, dirs, depth, valid, rng, samples, margin):
    """Points of the auxiliary term: ``(free (Rv S, 3), solid (Rv S, 3))`` world metres.

    For each valid ray, ``samples`` depths ``k ~ U(0, d - margin)`` (free) and
    ``k ~ U(d, d + margin)`` (just behind the observed surface); ``rng`` a numpy Generator.
    """
    o, d, dep = origins[valid], dirs[valid], depth[valid]
    R = len(dep)
    k_free = rng.random((R, samples)) * np.maximum(dep - margin, 0.0)[:, None]
    k_solid = dep[:, None] + margin * rng.random((R, samples))
    free = o[:, None, :] + k_free[..., None] * d[:, None, :]
    solid = o[:, None, :] + k_solid[..., None] * d[:, None, :]
    return free.reshape(-1, 3), solid.reshape(-1, 3)


def free_space_hinge(f_free, f_solid, tau: float, delta: float):
    """Mean hinge ``relu(f_free - (tau - delta)) + relu((tau + delta) - f_solid)`` (torch)."""
    import torch

    if f_free.numel() == 0:
        return f_free.sum()
    return torch.relu(f_free - (tau - delta)).mean() + torch.relu((tau + delta) - f_solid).mean()


class _SparseGrad:
    """The gradient of one grid, accumulated from lookups, with the list of touched cells.

    ``grad`` is dense (grid-shaped, zero outside the touched cells); ``adam_step`` applies
    Adam to the touched cells only (``torch.optim.SparseAdam`` semantics: moments and values
    of a cell change on the steps that touch it) and ``clear`` zeroes the touched rows.
    """

    def __init__(self, param: np.ndarray, lr: float, betas=(0.9, 0.999), eps=1e-8):
        C = param.shape[-1] if param.ndim == 4 else 1
        self.p = param.reshape(-1, C)  # a view of the grid
        self.grad = np.zeros(param.shape, np.float32)
        self.g = self.grad.reshape(-1, C)
        self.mv = np.zeros(self.p.shape + (2,), np.float32)  # first and second moments
        self.stamp = np.zeros(len(self.p), np.int32)
        self.touched = np.zeros(1 << 16, np.int64)
        self.count = 0
        self.lr, self.b1, self.b2, self.eps = lr, betas[0], betas[1], eps
        self.t = 0

    def add(self, lookup) -> None:
        """Scatter ``d loss / d values`` of a :class:`~navbench.worldmodel.diffrender.Lookup`."""
        if lookup.values.grad is None:
            return
        g = lookup.values.grad.detach().double().numpy()
        g = np.ascontiguousarray(g[:, None] if lookup.squeeze else g)
        need = self.count + lookup.idx.size
        if need > len(self.touched):
            self.touched = np.concatenate([self.touched, np.zeros(need, np.int64)])
        self.count = _scatter_mark(lookup.idx, lookup.w, g, self.g, self.stamp, self.t + 1,
                                   self.touched, self.count)

    def adam_step(self) -> None:
        self.t += 1
        _adam_rows(self.p, self.g, self.mv, self.touched, self.count, self.t, self.lr,
                   self.b1, self.b2, self.eps)
        self.count = 0

    def clear(self) -> None:
        self.t += 1
        _zero_touched(self.g, self.touched, self.count)
        self.count = 0


def fit_map(views: Views, config: FitConfig = FitConfig(),
            progress: Callable[[int, int, float], None] | None = None,
            heldout: Views | None = None, level=None) -> tuple[VoxelMap, dict]:
    """Fit ``M_occ``, ``M_col`` (and ``sigma2``) to ``views`` by eq. 3 (+ the configured additions).

    ``progress(step, total, loss)`` is called every 10 steps and at the end. Returns the
    :class:`VoxelMap` (``meta``: step, max_range, sigma2, config) and metrics: ``fit_time_s``,
    ``ms_per_step``, ``final_loss`` (mean NLL of the last 100 steps), ``sigma2``,
    ``hit_fraction`` (batch rays with a crossing, last 100 steps), ``loss_curve`` (every 100
    steps), plus :func:`evaluate_map` of ``heldout`` (and ``level``) when given.
    """
    import torch

    from navbench.worldmodel.diffrender import Lookup, laplace_nll, render_rays_sparse

    if len(views) == 0:
        raise ConfigError("fit: no views")
    require_depth_within(views, config.max_range, "fit: the views")
    check_fit_memory(config)
    device = resolve_fit_device(config.device)
    if device != "cpu":
        return _fit_map_torch(views, config, device, progress, heldout, level)
    old_threads = torch.get_num_threads()
    torch.set_num_threads(max(1, config.threads))
    try:
        spec, occ, col = initial_grids(views, config)
        acc_occ, acc_col = _SparseGrad(occ, config.lr), _SparseGrad(col, config.lr)
        sigma2 = torch.tensor(float(config.sigma2_init), requires_grad=True)
        opt_s = torch.optim.Adam([sigma2], lr=config.sigma2_lr)
        if config.optimizer == "adam":
            occ_t, col_t = torch.from_numpy(occ), torch.from_numpy(col)  # share memory
            occ_t.grad, col_t.grad = torch.from_numpy(acc_occ.grad), torch.from_numpy(acc_col.grad)
            dense = torch.optim.Adam([occ_t, col_t], lr=config.lr, fused=True)
        sampler = BatchSampler(views, config.images_per_batch, config.pixels_per_image, config.seed)
        rng = np.random.default_rng([int(config.seed), 1])
        step, n = config.step, config.n_samples
        log = _FitLog(config.steps, progress)
        t0 = time.perf_counter()
        for it in range(config.steps):
            o, d, rgb, dep, valid, free, solid = _draw(sampler, rng, config)
            out = render_rays_sparse(occ, col, spec, config.tau, o.numpy(), d.numpy(), step, n)
            mask = out.hit & valid
            loss = laplace_nll(out.rgb, out.depth, rgb, dep, sigma2, mask=mask)
            total = loss
            occ_lookups = [out.occ_lookup]
            if free is not None:
                fs = Lookup(occ, spec, np.concatenate([free, solid]))
                nf = len(free)
                total = total + config.free_space_weight * free_space_hinge(
                    fs.values[:nf], fs.values[nf:], config.tau, config.free_space_delta)
                occ_lookups.append(fs)
            opt_s.zero_grad()
            total.backward()
            for lk in occ_lookups:
                acc_occ.add(lk)
            acc_col.add(out.col_lookup)
            if config.optimizer == "adam":
                dense.step()
                acc_occ.clear()
                acc_col.clear()
            else:
                acc_occ.adam_step()
                acc_col.adam_step()
            if bool(mask.any()):
                opt_s.step()
            with torch.no_grad():
                sigma2.clamp_(min=config.min_sigma2)
            log.record(it, loss, mask)
        elapsed = time.perf_counter() - t0
    finally:
        torch.set_num_threads(old_threads)
    return _finish_fit(views, config, spec, occ, col, float(sigma2.detach()), elapsed, log,
                       heldout, level, {"device": "cpu"})


def _draw(sampler: BatchSampler, rng, config: FitConfig):
    """One step's data, the same for both paths: the batch (:meth:`BatchSampler.draw`) and the
    free-space term's ``free, solid`` points (``None, None`` when ``free_space_weight`` is 0)."""
    o, d, rgb, dep, valid = sampler.draw()
    free = solid = None
    if config.free_space_weight > 0:
        free, solid = free_space_points(o.numpy(), d.numpy(), dep.numpy(), valid.numpy(), rng,
                                        config.free_space_samples, config.free_space_margin)
    return o, d, rgb, dep, valid, free, solid


class _FitLog:
    """Per-step bookkeeping shared by both fit paths: the NLL, the hit fraction, the loss curve
    (mean of every 100 steps) and the ``progress`` callback (every 10 steps and at the end)."""

    def __init__(self, steps: int, progress):
        self.steps, self.progress = steps, progress
        self.recent: list[float] = []
        self.hits: list[float] = []
        self.curve: list[float] = []

    def record(self, it: int, loss, mask) -> None:
        lv = float(loss.detach())
        self.recent.append(lv)
        self.hits.append(float(mask.float().mean()))
        if (it + 1) % 100 == 0:
            self.curve.append(float(np.mean(self.recent[-100:])))
        if self.progress is not None and ((it + 1) % 10 == 0 or it + 1 == self.steps):
            self.progress(it + 1, self.steps, lv)


def _finish_fit(views: Views, config: FitConfig, spec, occ: np.ndarray, col: np.ndarray,
                sigma2: float, elapsed: float, log: _FitLog, heldout, level,
                extra: dict | None = None) -> tuple[VoxelMap, dict]:
    """The :class:`VoxelMap` and metrics of a finished fit (see :func:`fit_map`); ``extra`` is
    added to both the map's meta and the metrics."""
    from navbench.config import to_jsonable

    extra = extra or {}
    meta = {"source": "fit_map", "level": views.level, "step": config.step,
            "max_range": config.max_range, "sigma2": sigma2, "config": to_jsonable(config),
            "views": len(views), **extra}
    vmap = VoxelMap(spec, occ, col, config.tau, meta)
    metrics = {
        "fit_time_s": elapsed, "steps": config.steps,
        "ms_per_step": 1000 * elapsed / max(1, config.steps),
        "final_loss": float(np.mean(log.recent[-100:])) if log.recent else math.nan,
        "hit_fraction": float(np.mean(log.hits[-100:])) if log.hits else math.nan,
        "sigma2": sigma2, "loss_curve": log.curve, **extra,
    }
    if heldout is not None:
        metrics.update(evaluate_map(vmap, level, heldout))
    return vmap, metrics


def resolve_fit_device(device: str) -> str:
    """``"cpu"`` (sparse numba path), a torch device string for the dense path, from a
    :class:`FitConfig` ``device``. ``"auto"`` is the CPU path whatever torch sees: the device
    path is slower even on an H100 (module docstring), and a key that meant a GPU fit on one
    machine and a CPU fit on another would name two different maps."""
    import torch

    if device == "auto":
        return "cpu"
    if device == "torch-cpu":
        return "torch-cpu"
    if device.startswith("cuda") and not torch.cuda.is_available():
        raise ConfigError(f"fit: device {device!r} asked for, but torch sees no CUDA device")
    return device


class MaskedAdam:
    """Lazy Adam on torch tensors, on any device: the device path's ``optimizer="lazy-adam"``.

    ``step(touched)`` updates the rows (cells: an occupancy, or the three colour channels)
    marked in the boolean ``touched`` mask of each parameter, and only those: their moments
    decay and their values move on the steps that touch them (``torch.optim.SparseAdam``
    semantics, bias correction by the global step count) -- the arithmetic of the CPU path's
    :class:`_SparseGrad`, and the same touched rows when the masks come from
    :func:`~navbench.worldmodel.diffrender.stencil_mask` of the looked-up points. Without
    masks, the rows with a nonzero gradient are the touched ones. Dense Adam instead keeps
    moving every cell the batches once reached by its momentum, which doubles the colour error
    of a fit (module docstring). Cost: O(touched rows) per step plus one pass over the mask.
    """

    def __init__(self, params, lr: float, betas=(0.9, 0.999), eps: float = 1e-8):
        import torch

        self.params = list(params)
        self.lr, self.b1, self.b2, self.eps = float(lr), float(betas[0]), float(betas[1]), float(eps)
        self.m = [torch.zeros_like(p) for p in self.params]
        self.v = [torch.zeros_like(p) for p in self.params]
        self.t = 0

    def zero_grad(self) -> None:
        for p in self.params:
            p.grad = None

    def step(self, touched=None) -> None:
        """One step; ``touched``: a bool ``(rows,)`` mask per parameter (or ``None``: rows
        with a nonzero gradient). A touched row without a gradient counts as gradient 0."""
        import torch

        self.t += 1
        bc1 = 1.0 - self.b1 ** self.t
        bc2 = 1.0 - self.b2 ** self.t
        with torch.no_grad():
            for k, (p, m, v) in enumerate(zip(self.params, self.m, self.v)):
                C = p.shape[-1] if p.dim() == 4 else 1
                g = p.grad.reshape(-1, C) if p.grad is not None else None
                if touched is None:
                    if g is None:
                        continue
                    mask = (g != 0).any(dim=1)
                else:
                    mask = touched[k]
                rows = mask.nonzero().squeeze(1)
                if rows.numel() == 0:
                    continue
                gr = g.index_select(0, rows) if g is not None else p.new_zeros((rows.numel(), C))
                mr = m.view(-1, C).index_select(0, rows).mul_(self.b1).add_(gr, alpha=1.0 - self.b1)
                vr = v.view(-1, C).index_select(0, rows).mul_(self.b2).addcmul_(gr, gr, value=1.0 - self.b2)
                m.view(-1, C).index_copy_(0, rows, mr)
                v.view(-1, C).index_copy_(0, rows, vr)
                upd = (mr / bc1).div_((vr / bc2).sqrt_().add_(self.eps)).mul_(self.lr)
                p.view(-1, C).index_add_(0, rows, upd, alpha=-1.0)


def _fit_map_torch(views: Views, config: FitConfig, device: str, progress, heldout, level):
    """The fit on a torch device (CUDA, or the CPU as ``torch-cpu``): eq. 1 by
    :func:`~navbench.worldmodel.diffrender.render_rays_torch` (every ray sample searched on the
    device without autograd, the bracket with it; the gradients of the dense reference), eq. 2-3
    and the free-space term as in :func:`fit_map`, and :class:`MaskedAdam`
    (``optimizer="lazy-adam"``) or torch's Adam (``"adam"``, ``fused=True`` on CUDA). Same
    config, same batches, same outputs as the CPU path."""
    import torch

    from navbench.worldmodel.diffrender import laplace_nll, render_rays_torch, stencil_mask, trilinear_t

    dev = torch.device("cpu" if device == "torch-cpu" else device)
    if dev.type == "cuda":
        # the grids, gradients and Adam moments live on the GPU (64 bytes per cell): check its
        # free memory as fit_map checked the host's
        from navbench.worldmodel.memory import format_bytes

        free, _total = torch.cuda.mem_get_info(dev)
        cells = math.prod(int(v) for v in config.grid_shape)
        need = cells * 64 + (fit_memory_bytes(config) - cells * FIT_BYTES_PER_CELL)
        if need > free:
            raise ConfigError(f"fit: grid_shape {list(config.grid_shape)} ({cells} cells) needs "
                              f"{format_bytes(need)} of GPU memory on {dev}, only "
                              f"{format_bytes(free)} is free")
    spec, occ0, col0 = initial_grids(views, config)
    occ = torch.tensor(occ0, device=dev, requires_grad=True)
    col = torch.tensor(col0, device=dev, requires_grad=True)
    sigma2 = torch.tensor(float(config.sigma2_init), device=dev, requires_grad=True)
    lazy = config.optimizer == "lazy-adam"
    if lazy:
        opt = MaskedAdam([occ, col], lr=config.lr)
    else:
        opt = torch.optim.Adam([occ, col], lr=config.lr, fused=dev.type == "cuda")
    opt_s = torch.optim.Adam([sigma2], lr=config.sigma2_lr)
    sampler = BatchSampler(views, config.images_per_batch, config.pixels_per_image, config.seed)
    rng = np.random.default_rng([int(config.seed), 1])
    step, n = config.step, config.n_samples
    log = _FitLog(config.steps, progress)
    old_threads = torch.get_num_threads()
    if dev.type == "cpu":
        torch.set_num_threads(max(1, config.threads))
    try:
        t0 = time.perf_counter()
        for it in range(config.steps):
            o, d, rgb, dep, valid, free, solid = _draw(sampler, rng, config)
            o_d, d_d = o.to(dev), d.to(dev)
            rgb_d, dep_d, valid_d = rgb.to(dev), dep.to(dev), valid.to(dev)
            out = render_rays_torch(occ, col, spec, config.tau, o_d, d_d, step, n)
            mask = out.hit & valid_d
            loss = laplace_nll(out.rgb, out.depth, rgb_d, dep_d, sigma2, mask=mask)
            total = loss
            occ_points = [out.occ_points]
            if free is not None:
                pts = torch.from_numpy(np.concatenate([free, solid]).astype(np.float32)).to(dev)
                f = trilinear_t(occ, spec, pts)
                total = total + config.free_space_weight * free_space_hinge(
                    f[: len(free)], f[len(free):], config.tau, config.free_space_delta)
                occ_points.append(pts)
            opt.zero_grad()
            opt_s.zero_grad(set_to_none=True)
            total.backward()
            if lazy:
                t_occ = None
                for pts in occ_points:
                    t_occ = stencil_mask(spec, pts, t_occ)
                opt.step([t_occ, stencil_mask(spec, out.col_points)])
            else:
                opt.step()
            if bool(mask.any()):
                opt_s.step()
            with torch.no_grad():
                sigma2.clamp_(min=config.min_sigma2)
            log.record(it, loss, mask)  # reads the loss back: the step has finished on the device
        elapsed = time.perf_counter() - t0
    finally:
        torch.set_num_threads(old_threads)
    where = {"device": "torch-cpu"}
    if dev.type == "cuda":
        idx = dev.index if dev.index is not None else torch.cuda.current_device()
        where = {"device": f"cuda:{idx}", "device_name": torch.cuda.get_device_name(idx)}
    return _finish_fit(views, config, spec, occ.detach().to("cpu").numpy().astype(np.float32),
                       col.detach().to("cpu").numpy().astype(np.float32), float(sigma2.detach()),
                       elapsed, log, heldout, level, where)
