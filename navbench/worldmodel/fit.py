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

Devices (``FitConfig.device``, default ``"auto"``: the CPU path on every machine, and one map per
cache key everywhere; docs/notebook/gpu.md has the measurements):

``"cpu"``
    the path above: numpy grids, numba crossing search and row updates, autograd on the
    bracket values only.
``"cuda"`` / ``"cuda:N"`` (and ``"torch-cpu"``, the same code on the CPU, for the tests)
    the device path, :mod:`navbench.worldmodel.fit_device`: the views and grids on the device,
    the batch drawn there by a seeded torch generator, fixed shapes and no host
    synchronisation, so that on CUDA the whole step is captured once as a CUDA graph and
    replayed. Same objective, initialisation and optimiser arithmetic (lazy Adam as a masked
    update of every cell, tested against the CPU path's row update); different (equally seeded)
    batches, so its maps agree with the CPU path's in quality, not bit for bit.

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
        if (it + 1) % 10 == 0 or it + 1 == self.steps:
            self.progress_at(it + 1, lv)

    def progress_at(self, done: int, loss: float) -> None:
        """Call ``progress(done, steps, loss)`` (the device path calls it every 10 steps)."""
        if self.progress is not None:
            self.progress(done, self.steps, loss)

    def bulk(self, losses: np.ndarray, hits: np.ndarray) -> None:
        """Every step's NLL and hit fraction at once (the device path, read back at the end)."""
        self.recent = [float(v) for v in losses]
        self.hits = [float(v) for v in hits]
        self.curve = [float(np.mean(self.recent[k - 100:k]))
                      for k in range(100, len(self.recent) + 1, 100)]


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
    :class:`FitConfig` ``device``. ``"auto"`` is the CPU path whatever torch sees here: a key
    that meant a GPU fit on one machine and a CPU fit on another would name two different maps.
    The stages resolve ``"auto"`` per machine before keying (:mod:`navbench.pipeline.devices`:
    CUDA where that machine's bench measured it faster), so the key names what ran."""
    import torch

    if device == "auto":
        return "cpu"
    if device == "torch-cpu":
        return "torch-cpu"
    if device.startswith("cuda") and not torch.cuda.is_available():
        raise ConfigError(f"fit: device {device!r} asked for, but torch sees no CUDA device")
    return device


def _fit_map_torch(views: Views, config: FitConfig, device: str, progress, heldout, level):
    """The fit on a torch device: :func:`navbench.worldmodel.fit_device.fit_map_device` (the
    batch drawn on the device, fixed shapes, a CUDA graph on CUDA) between this module's
    initialisation and finish."""
    from navbench.worldmodel.fit_device import check_device_memory, fit_map_device

    check_device_memory(views, config, device)
    spec, occ0, col0 = initial_grids(views, config)
    log = _FitLog(config.steps, progress)
    occ, col, sigma2, elapsed, ran = fit_map_device(views, config, device, log, spec, occ0, col0)
    return _finish_fit(views, config, spec, occ, col, sigma2, elapsed, log, heldout, level, ran)
