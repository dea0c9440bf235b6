"""The differentiable renderer of paper section 3.1 (eq. 1-2) in torch, and ``laplace_nll``.

Rays are given in the world frame: origins ``c (R, 3)`` and directions ``v (R, 3)`` with
``v = R_wc K^-1 [i j 1]^T`` (so ``k`` along the ray is the z-depth). Samples
``p_m = c + m Delta v`` for ``m = 1..n``; ``f`` and ``g`` are trilinear on the grids (the
convention of :mod:`navbench.worldmodel.grid`, border-clamped). Eq. 1: ``p+`` is the first
sample with ``f > tau``, ``p-`` the sample before it, ``alpha = (tau - f(p-)) / (f(p+) - f(p-))``,
``k* = alpha k+ + (1 - alpha) k-`` and the colour is ``g(p*)``, ``p* = c + k* v``.

Edge cases (identical in :mod:`navbench.worldmodel.fastrender`):

* crossing at ``m = 1``: ``p-`` is the camera centre ``c`` (``k- = 0``);
* ``f(c) > tau`` too, or no sample above ``tau`` within ``n Delta``: the ray has **no
  crossing** (``hit = False``). Eq. 1 gives it no depth and no gradient; in eq. 3 such rays
  contribute nothing (they are masked out of :func:`laplace_nll`). The fitting code may add a
  documented auxiliary term for them (see :mod:`navbench.worldmodel.fit`).

Gradients reach ``M_occ`` through ``f(p-)`` and ``f(p+)`` (the 16 cells around the two
bracketing samples) and ``M_col`` through ``g(p*)``. By default ``p*`` enters ``g`` with its
gradient stopped (colour does not move the surface); ``colour_moves_surface=True`` keeps the
full derivative (used by the finite-difference test).

Three implementations with the same values and gradients:

* :func:`render_rays_dense` — the reference: every sample evaluated with autograd;
* :func:`render_rays` — the CPU training path: the crossing search runs without gradients
  (numba, early termination), then only ``p-``, ``p+`` and ``p*`` are evaluated with autograd;
* :func:`render_rays_torch` — the device path (CUDA): the crossing search evaluates every
  sample in torch *without* autograd on the grids' device, then ``p-``, ``p+`` and ``p*`` with
  autograd, so the backward pass touches 24 cells per ray instead of ``8 (n + 1)``.
"""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np
import torch

from navbench.worldmodel.fastrender import DEFAULT_STEP, _cell, _f  # numba helpers shared with the renderer
from navbench.worldmodel.gridspec import GridSpec


class RayRender(NamedTuple):
    """Per-ray output of the renderer."""

    depth: torch.Tensor  # (R,) k*, metres (0 where hit is False)
    rgb: torch.Tensor  # (R, 3) g(p*) (0 where hit is False), not clipped
    hit: torch.Tensor  # (R,) bool: the ray has a crossing (eq. 1 defined)


def grid_tensors(spec: GridSpec, dtype=torch.float32, device=None) -> tuple[torch.Tensor, torch.Tensor]:
    """``lo (3,)`` and ``size (3,)`` of ``spec`` as tensors."""
    return (torch.tensor(spec.lo, dtype=dtype, device=device),
            torch.tensor(spec.size, dtype=dtype, device=device))


def _stencil(spec: GridSpec, points: torch.Tensor):
    """``(base, t)`` of the trilinear stencil at ``points (..., 3)``: the flat index
    ``(i ny + j) nz + k`` of the stencil's lowest cell and the in-cell offsets ``t (..., 3)``
    (border-clamped, ``0 <= i <= nx - 2``: the same cells as the numba ``_cell``)."""
    nx, ny, nz = spec.shape
    lo, size = grid_tensors(spec, points.dtype, points.device)
    u = (points - lo) / size - 0.5
    n = torch.tensor([nx - 1, ny - 1, nz - 1], dtype=points.dtype, device=points.device)
    u = torch.minimum(torch.clamp(u, min=0.0), n)
    i0 = torch.minimum(u.detach().floor().long(), (n - 1).long())
    t = u - i0.to(points.dtype)
    return (i0[..., 0] * ny + i0[..., 1]) * nz + i0[..., 2], t


def _offsets(spec: GridSpec) -> list[int]:
    """Flat index offsets of the 8 stencil cells, in the order ``dx, dy, dz``."""
    _, ny, nz = spec.shape
    return [(dx * ny + dy) * nz + dz for dx in (0, 1) for dy in (0, 1) for dz in (0, 1)]


def trilinear_t(grid: torch.Tensor, spec: GridSpec, points: torch.Tensor) -> torch.Tensor:
    """``f``/``g`` in torch: trilinear lookup of ``grid (nx, ny, nz[, C])`` at ``points (..., 3)``.

    Differentiable w.r.t. ``grid`` and ``points``; border-clamped like the numpy reference.
    Returns ``(...)`` or ``(..., C)``.
    """
    nx, ny, nz = spec.shape
    base, t = _stencil(spec, points)
    C = grid.shape[3] if grid.dim() == 4 else 1
    flat = grid.reshape(nx * ny * nz, C)
    tx, ty, tz = t[..., 0:1], t[..., 1:2], t[..., 2:3]
    out = 0.0
    offs = iter(_offsets(spec))
    for dx in (0, 1):
        wx = tx if dx else 1 - tx
        for dy in (0, 1):
            wy = ty if dy else 1 - ty
            for dz in (0, 1):
                wz = tz if dz else 1 - tz
                out = out + (wx * wy * wz) * flat[base + next(offs)]
    return out if grid.dim() == 4 else out[..., 0]


def stencil_mask(spec: GridSpec, points: torch.Tensor, out: torch.Tensor | None = None) -> torch.Tensor:
    """Mark the cells :func:`trilinear_t` reads for ``points (..., 3)`` in ``out`` (bool,
    ``(nx ny nz,)``, on the points' device; a new one when ``None``) and return it: the rows a
    lazy optimiser treats as touched (all 8 stencil cells, weight zero or not, as the CPU
    path's lookups)."""
    if out is None:
        out = torch.zeros(int(np.prod(spec.shape)), dtype=torch.bool, device=points.device)
    with torch.no_grad():
        base, _ = _stencil(spec, points.detach().reshape(-1, 3))
        offs = torch.tensor(_offsets(spec), dtype=torch.long, device=points.device)
        out[(base[:, None] + offs).reshape(-1)] = True
    return out


def _crossing(f_minus, f_plus, k_minus, step, tau):
    alpha = (tau - f_minus) / (f_plus - f_minus)
    return k_minus + alpha * step


def render_rays_dense(occ: torch.Tensor, col: torch.Tensor, spec: GridSpec, tau: float,
                      origins: torch.Tensor, dirs: torch.Tensor, step: float, n: int,
                      colour_moves_surface: bool = False) -> RayRender:
    """Reference eq. 1 renderer: ``f`` at all ``n + 1`` samples (``m = 0..n``) with autograd.

    ``occ (nx, ny, nz)``, ``col (nx, ny, nz, 3)`` tensors; ``origins``, ``dirs`` ``(R, 3)``
    world metres; ``step`` Delta (m); ``n`` samples. Memory ``O(R n)``: for tests and small
    batches.
    """
    R = origins.shape[0]
    dev = origins.device
    ks = torch.arange(n + 1, dtype=origins.dtype, device=dev) * step  # (n + 1,)
    pts = origins[:, None, :] + ks[None, :, None] * dirs[:, None, :]
    f = trilinear_t(occ, spec, pts)  # (R, n + 1)
    above = (f[:, 1:] > tau).detach()
    any_above = above.any(dim=1)
    m = torch.where(any_above, above.float().argmax(dim=1) + 1,
                    torch.ones(R, dtype=torch.long, device=dev))
    rows = torch.arange(R, device=dev)
    f_plus, f_minus = f[rows, m], f[rows, m - 1]
    hit = any_above & (f_minus <= tau).detach()
    return _finish(col, spec, origins, dirs, f_minus, f_plus, (m - 1).to(origins.dtype) * step,
                   step, tau, hit, colour_moves_surface)


def _finish(col, spec, origins, dirs, f_minus, f_plus, k_minus, step, tau, hit,
            colour_moves_surface):
    # keep the masked-out rays finite (their f_plus - f_minus may be 0)
    safe_plus = torch.where(hit, f_plus, f_minus.detach() + 1.0)
    k = _crossing(f_minus, safe_plus, k_minus, step, tau)
    k = torch.where(hit, k, torch.zeros_like(k))
    kc = k if colour_moves_surface else k.detach()
    p_star = origins + kc[:, None] * dirs
    rgb = trilinear_t(col, spec, p_star) * hit[:, None].to(col.dtype)
    return RayRender(k, rgb, hit)


class TorchRender(NamedTuple):
    """:class:`RayRender` plus the points whose grid cells the gradients reach."""

    depth: torch.Tensor
    rgb: torch.Tensor
    hit: torch.Tensor
    occ_points: torch.Tensor  # (2, R, 3): p- and p+ of every ray (M_occ is read there)
    col_points: torch.Tensor  # (R, 3): p* of every ray (M_col is read there)


def render_rays_torch(occ: torch.Tensor, col: torch.Tensor, spec: GridSpec, tau: float,
                      origins: torch.Tensor, dirs: torch.Tensor, step: float, n: int,
                      colour_moves_surface: bool = False, chunk: int = 256) -> TorchRender:
    """The device path of eq. 1: values and gradients of :func:`render_rays_dense`, all in torch.

    The ``n + 1`` samples of every ray are evaluated without autograd (in slices of ``chunk``
    samples, so memory stays ``O(R chunk)``) to find the first crossing; only the bracket
    ``f(p-)``, ``f(p+)`` and ``g(p*)`` enter the autograd graph. Runs wherever the tensors are
    (CPU or CUDA); the sample positions are computed exactly as in :func:`render_rays_dense`.
    """
    R = origins.shape[0]
    dev = origins.device
    m = torch.zeros(R, dtype=torch.long, device=dev)  # first sample above tau, 0 = none yet
    with torch.no_grad():
        grid = occ.detach()
        for a in range(0, n + 1, chunk):
            ks = torch.arange(a, min(n + 1, a + chunk), dtype=origins.dtype, device=dev) * step
            pts = origins[:, None, :] + ks[None, :, None] * dirs[:, None, :]
            above = trilinear_t(grid, spec, pts) > tau
            if a == 0:
                above[:, 0] = False  # m = 0 (the camera centre) is never p+
            first = above.float().argmax(dim=1) + a
            m = torch.where((m == 0) & above.any(dim=1), first, m)
    any_above = m > 0
    m1 = torch.clamp(m, min=1)
    rows_k = torch.stack([m1 - 1, m1]).to(origins.dtype) * step  # (2, R): k- and k+
    pts = origins[None] + rows_k[..., None] * dirs[None]
    f = trilinear_t(occ, spec, pts)  # (2, R)
    hit = any_above & (f[0] <= tau).detach()
    out = _finish(col, spec, origins, dirs, f[0], f[1], rows_k[0], step, tau, hit,
                  colour_moves_surface)
    p_star = origins + out.depth.detach()[:, None] * dirs
    return TorchRender(*out, pts, p_star)


@nb.njit(cache=True)
def first_crossing_index(occ, u_o, du, n, tau):
    """Eq. 1 crossing search without gradients: ``m`` of ``p+`` per ray, 0 when none.

    ``u_o (R, 3)``: ray origins in continuous cell indices; ``du (R, 3)``: ``Delta v`` in cell
    units. Returns ``(R,)`` int64: the first ``m`` in ``1..n`` with ``f(p_m) > tau`` provided
    ``f(p_{m-1}) <= tau``, else 0.
    """
    nx, ny, nz = occ.shape
    R = u_o.shape[0]
    out = np.zeros(R, np.int64)
    for r in range(R):  # serial: training batches are small, threads cost more than they save
        for m in range(1, n + 1):
            fv = _f(occ, u_o[r, 0] + m * du[r, 0], u_o[r, 1] + m * du[r, 1],
                    u_o[r, 2] + m * du[r, 2], nx, ny, nz)
            if fv > tau:
                if m == 1 and _f(occ, u_o[r, 0], u_o[r, 1], u_o[r, 2], nx, ny, nz) > tau:
                    break  # the camera is inside occupied space
                out[r] = m
                break
    return out


def render_rays(occ: torch.Tensor, col: torch.Tensor, spec: GridSpec, tau: float,
                origins: torch.Tensor, dirs: torch.Tensor, step: float, n: int,
                colour_moves_surface: bool = False) -> RayRender:
    """Training path of eq. 1: numba crossing search, then autograd at ``p-``, ``p+``, ``p*`` only.

    Same arguments, values and gradients as :func:`render_rays_dense` (up to float rounding of
    the sample positions when a sample lies exactly on ``tau``).
    """
    size = spec.size
    lo = np.asarray(spec.lo)
    o = origins.detach().double().numpy()
    d = dirs.detach().double().numpy()
    m = first_crossing_index(occ.detach().numpy(), (o - lo) / size - 0.5, d * step / size,
                             int(n), float(tau))
    m = torch.from_numpy(m)
    hit = m > 0
    m1 = torch.clamp(m, min=1)
    k_minus = (m1 - 1).to(origins.dtype) * step
    k_plus = m1.to(origins.dtype) * step
    pts = torch.stack([origins + k_minus[:, None] * dirs, origins + k_plus[:, None] * dirs], 0)
    f = trilinear_t(occ, spec, pts)  # (2, R)
    # the search ran in float64 positions: re-check the bracket in the working precision
    hit = hit & (f[1] > tau).detach() & (f[0] <= tau).detach()
    return _finish(col, spec, origins, dirs, f[0], f[1], k_minus, step, tau, hit,
                   colour_moves_surface)


class GridRayRenderer:
    """:func:`render_rays` bound to one map: ``(origins, dirs) -> RayRender`` with gradients
    w.r.t. the rays (the emission tracker differentiates it w.r.t. the camera pose).

    ``occ``, ``col``: the map's numpy grids, wrapped as torch tensors once (sharing memory);
    ``step`` (m): sample spacing Delta, default ``meta['step']`` or 0.1 m (as
    :func:`navbench.worldmodel.fastrender.map_step`); ``n = round(max_range / step)`` samples.
    """

    def __init__(self, occ: np.ndarray, col: np.ndarray, spec: GridSpec, tau: float, meta: dict,
                 step: float | None = None, max_range: float = 20.0):
        self.occ = torch.from_numpy(np.ascontiguousarray(occ, dtype=np.float32))
        self.col = torch.from_numpy(np.ascontiguousarray(col, dtype=np.float32))
        self.spec = spec
        self.tau = float(tau)
        self.step = float(step) if step is not None else float(meta.get("step", DEFAULT_STEP))
        self.n = int(round(max_range / self.step))

    def __call__(self, origins: torch.Tensor, dirs: torch.Tensor,
                 colour_moves_surface: bool = False) -> RayRender:
        return render_rays(self.occ, self.col, self.spec, self.tau, origins, dirs, self.step,
                           self.n, colour_moves_surface=colour_moves_surface)


def world_rays(T_wc: torch.Tensor | np.ndarray, cam_rays: np.ndarray, dtype=torch.float32):
    """World origins and directions for camera-frame rays ``(R, 3)`` (``K^-1 [i j 1]``).

    ``T_wc``: ``(4, 4)`` or ``(B, 4, 4)`` with ``cam_rays (B, R, 3)``. Returns ``(..., 3)`` each.
    """
    T = torch.as_tensor(np.asarray(T_wc), dtype=dtype)
    r = torch.as_tensor(np.asarray(cam_rays), dtype=dtype)
    dirs = r @ T[..., :3, :3].transpose(-1, -2)
    origins = T[..., None, :3, 3].expand(dirs.shape)
    return origins, dirs


def laplace_nll(rgb_pred: torch.Tensor, depth_pred: torch.Tensor, rgb_obs: torch.Tensor,
                depth_obs: torch.Tensor, sigma2: torch.Tensor, mask: torch.Tensor | None = None,
                reduction: str = "mean") -> torch.Tensor:
    """Negative log-likelihood of eq. 2 per pixel: Laplace on ``[rgb; depth]``.

    ``rgb_* (R, 3)`` in ``[0, 1]``, ``depth_* (R,)`` metres; scales ``sigma1 = sigma2 / 5``
    (colour) and ``sigma2`` (depth, m); ``mask (R,)`` bool selects the pixels that count
    (rays with a crossing and a valid observation). Per pixel:
    ``sum_c (|x_c - g_c| / s1 + log 2 s1) + |x_d - k*| / s2 + log 2 s2``.
    ``reduction``: ``"mean"`` over the masked pixels (0 when none), ``"sum"``, or ``"none"``
    (``(R,)``, 0 where masked out).
    """
    s2 = sigma2
    s1 = sigma2 / 5.0
    per = ((rgb_obs - rgb_pred).abs().sum(-1) / s1 + 3 * torch.log(2 * s1)
           + (depth_obs - depth_pred).abs() / s2 + torch.log(2 * s2))
    if mask is not None:
        per = torch.where(mask, per, torch.zeros_like(per))
    if reduction == "none":
        return per
    if reduction == "sum":
        return per.sum()
    count = per.numel() if mask is None else mask.sum()
    return per.sum() / torch.clamp(torch.as_tensor(count, dtype=per.dtype), min=1.0)


# ------------------------------------------------------------------------------ sparse path
#
# The fitting loop never materialises a dense gradient through autograd: the grids stay numpy
# arrays, the few looked-up values become small leaf tensors, autograd runs on the per-ray graph
# only, and the leaf gradients are scattered back through the trilinear weights (the chain rule
# of ``f(p) = sum_a w_a(p) M[cell_a(p)]``). Gradients are exactly those of render_rays.


@nb.njit(cache=True, parallel=True)
def gather_cells(grid, u):
    """Trilinear lookup with its stencil: ``grid (nx, ny, nz, C)`` at cell indices ``u (P, 3)``.

    Returns ``idx (P, 8)`` int64 flat cell indices (``(i ny + j) nz + k``), ``w (P, 8)`` float64
    weights and ``vals (P, C)`` float64 (border-clamped like every renderer here).
    """
    nx, ny, nz, C = grid.shape
    P = u.shape[0]
    idx = np.empty((P, 8), np.int64)
    w = np.empty((P, 8))
    vals = np.zeros((P, C))
    for p in nb.prange(P):  # every p writes only its own row: parallel, same result
        i, tx = _cell(u[p, 0], nx)
        j, ty = _cell(u[p, 1], ny)
        k, tz = _cell(u[p, 2], nz)
        a = 0
        for dx in range(2):
            wx = tx if dx else 1.0 - tx
            for dy in range(2):
                wy = ty if dy else 1.0 - ty
                for dz in range(2):
                    wz = tz if dz else 1.0 - tz
                    ww = wx * wy * wz
                    idx[p, a] = ((i + dx) * ny + (j + dy)) * nz + (k + dz)
                    w[p, a] = ww
                    for c in range(C):
                        vals[p, c] += ww * grid[i + dx, j + dy, k + dz, c]
                    a += 1
    return idx, w, vals


@nb.njit(cache=True)
def scatter_add(idx, w, g, out):
    """``out[idx[p, a], c] += w[p, a] g[p, c]``: the gradient of a lookup w.r.t. its grid.

    ``out (N, C)`` float32 (the grid flattened over cells); serial, so sums are deterministic.
    """
    P = idx.shape[0]
    C = g.shape[1]
    for p in range(P):
        for a in range(8):
            n = idx[p, a]
            for c in range(C):
                out[n, c] += w[p, a] * g[p, c]


class Lookup:
    """Values of a grid at points as a leaf tensor, with the stencil to scatter its gradient."""

    def __init__(self, grid: np.ndarray, spec: GridSpec, points: np.ndarray, dtype=torch.float32):
        g = grid if grid.ndim == 4 else grid[..., None]
        u = (np.asarray(points, np.float64) - np.asarray(spec.lo)) / spec.size - 0.5
        self.idx, self.w, vals = gather_cells(g, np.ascontiguousarray(u.reshape(-1, 3)))
        self.squeeze = grid.ndim == 3
        v = torch.from_numpy(vals).to(dtype)
        self.values = (v[:, 0] if self.squeeze else v).requires_grad_(True)

    def scatter_grad(self, out: np.ndarray) -> None:
        """Add ``d loss / d grid`` (from ``values.grad``) into ``out`` (``grid``-shaped, float32)."""
        if self.values.grad is None:
            return
        g = self.values.grad.detach().double().numpy()
        g = g[:, None] if self.squeeze else g
        flat = out.reshape(-1, g.shape[1])
        if not np.shares_memory(flat, out):
            raise ValueError("scatter_grad needs a C-contiguous gradient array")
        scatter_add(self.idx, self.w, np.ascontiguousarray(g), flat)


class SparseRender(NamedTuple):
    """:class:`RayRender` plus the lookups whose gradients go back to the grids."""

    depth: torch.Tensor
    rgb: torch.Tensor
    hit: torch.Tensor
    occ_lookup: Lookup  # f(p-) then f(p+) for every ray: values (2R,)
    col_lookup: Lookup  # g(p*): values (R, 3)


def render_rays_sparse(occ: np.ndarray, col: np.ndarray, spec: GridSpec, tau: float,
                       origins: np.ndarray, dirs: np.ndarray, step: float, n: int,
                       dtype=torch.float32) -> SparseRender:
    """The fitting path of eq. 1 on numpy grids: values and gradients of :func:`render_rays`.

    After ``loss.backward()`` call ``occ_lookup.scatter_grad(grad_occ)`` and
    ``col_lookup.scatter_grad(grad_col)`` to obtain ``d loss / d M_occ`` and ``d loss / d M_col``
    (``colour_moves_surface`` is False on this path).
    """
    o = np.asarray(origins, np.float64)
    d = np.asarray(dirs, np.float64)
    size = spec.size
    lo = np.asarray(spec.lo)
    m = first_crossing_index(occ, (o - lo) / size - 0.5, d * step / size, int(n), float(tau))
    m1 = np.maximum(m, 1)
    k_minus = (m1 - 1) * step
    k_plus = m1 * step
    pts = np.concatenate([o + k_minus[:, None] * d, o + k_plus[:, None] * d])
    occ_l = Lookup(occ, spec, pts, dtype)
    R = len(o)
    f_minus, f_plus = occ_l.values[:R], occ_l.values[R:]
    hit = torch.from_numpy(m > 0) & (f_plus > tau).detach() & (f_minus <= tau).detach()
    safe_plus = torch.where(hit, f_plus, f_minus.detach() + 1.0)
    k = _crossing(f_minus, safe_plus, torch.from_numpy(k_minus).to(dtype), step, tau)
    k = torch.where(hit, k, torch.zeros_like(k))
    p_star = o + k.detach().double().numpy()[:, None] * d
    col_l = Lookup(col, spec, p_star, dtype)
    rgb = col_l.values * hit[:, None].to(dtype)
    return SparseRender(k, rgb, hit, occ_l, col_l)
