"""The fit on a torch device (CUDA, or the CPU as ``"torch-cpu"``): eq. 1-3 of the paper as in
:func:`navbench.worldmodel.fit.fit_map`, with every step's work on the device.

A step of the CPU path is a few hundred small operations; on a GPU each is a kernel launch and
the first device path (2026-11-23: batches drawn on the host, 25 host tensors built and 15 moved
per step, a boolean ``nonzero`` and two reads of the loss per step) ran 1.7x *slower* than the
CPU path beside it on an H100 (docs/notebook/gpu.md). This path removes each of those costs:

* **The batch is drawn on the device.** The views (colour as ``uint8``, depth, validity, the
  poses' rotations and the camera's pixel rays) are moved to the device once; the random
  numbers of ``chunk`` steps (image and pixel indices, the free-space term's uniforms) are drawn
  at once by a seeded device generator, and a step gathers its rays with index operations.
* **Fixed shapes, no host synchronisation.** The free-space term is evaluated for every batch
  ray and masked to the rays with a valid depth (the same mean as the CPU path's, which drops the
  invalid rays first); lazy Adam updates *all* cells with a mask (``torch.where``) instead of
  gathering the touched rows (which needs ``nonzero``: a host synchronisation); the Laplace
  scale's Adam step is applied where the batch has a hit, counted on the device. The loss and
  hit fraction of each step are copied into device buffers and read once per ``progress`` call.
* **A CUDA graph.** Because a step has fixed shapes and no synchronisation, the whole step
  (draw, render, loss, backward, optimiser) is captured once as a CUDA graph and replayed: one
  launch per step instead of hundreds. ``NAVBENCH_CUDA_GRAPH=0`` turns the graph off (the same
  step, launched op by op), for measuring what the graph buys.

Same objective, same initialisation, same optimiser arithmetic as the CPU path; the batches are
drawn by torch's generator instead of numpy's, so a device fit is a different (equally seeded)
Monte-Carlo run of the same fit, and on CUDA its gradient sums are not bit-reproducible (atomic
adds). Its cache key therefore names the device (``navbench.pipeline.stages.maps``).
"""

from __future__ import annotations

import math
import os
import time

import numpy as np
import torch

from navbench.worldmodel.gridspec import GridSpec
from navbench.worldmodel.views import Views

#: Steps whose random numbers are drawn at once (bounded memory: ~12 bytes per ray a step).
RANDOM_CHUNK = 256


class GridConsts:
    """The grid's constants as device tensors, made once (a CUDA graph may not copy host data):
    ``lo``, ``size``, the clamp bound ``n`` and the 8 stencil offsets."""

    def __init__(self, spec: GridSpec, device, dtype=torch.float32):
        nx, ny, nz = spec.shape
        self.spec = spec
        self.lo = torch.tensor(spec.lo, dtype=dtype, device=device)
        self.size = torch.tensor(np.asarray(spec.size), dtype=dtype, device=device)
        self.n = torch.tensor([nx - 1, ny - 1, nz - 1], dtype=dtype, device=device)
        self.n_long = self.n.long() - 1
        self.strides = torch.tensor([ny * nz, nz, 1], dtype=torch.long, device=device)
        self.offsets = torch.tensor([(dx * ny + dy) * nz + dz for dx in (0, 1) for dy in (0, 1)
                                     for dz in (0, 1)], dtype=torch.long, device=device)
        self.cells = nx * ny * nz

    def stencil(self, points: torch.Tensor):
        """``(base, t)`` as :func:`navbench.worldmodel.diffrender._stencil` (the same cells)."""
        u = (points - self.lo) / self.size - 0.5
        u = torch.minimum(torch.clamp(u, min=0.0), self.n)
        i0 = torch.minimum(u.detach().floor().long(), self.n_long)
        t = u - i0.to(points.dtype)
        return (i0 * self.strides).sum(-1), t

    def trilinear(self, grid: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
        """:func:`~navbench.worldmodel.diffrender.trilinear_t` by ``index_select`` (its
        backward is ``index_add``: no sort, no synchronisation). Same values and gradients."""
        base, t = self.stencil(points)
        C = grid.shape[3] if grid.dim() == 4 else 1
        flat = grid.reshape(self.cells, C)
        idx = (base.unsqueeze(-1) + self.offsets).reshape(-1)
        vals = flat.index_select(0, idx).reshape(*base.shape, 8, C)
        tx, ty, tz = t[..., 0:1], t[..., 1:2], t[..., 2:3]
        wx = torch.stack([1 - tx, tx], -2)  # (..., 2, 1)
        wy = torch.stack([1 - ty, ty], -2)
        wz = torch.stack([1 - tz, tz], -2)
        w = (wx[..., :, None, None, :] * wy[..., None, :, None, :] * wz[..., None, None, :, :])
        out = (w.reshape(*base.shape, 8, 1) * vals).sum(-2)
        return out if grid.dim() == 4 else out[..., 0]

    def mark(self, points: torch.Tensor, out: torch.Tensor) -> None:
        """Set the 8 stencil cells of ``points`` in the bool mask ``out`` (the touched rows)."""
        with torch.no_grad():
            base, _ = self.stencil(points.detach().reshape(-1, 3))
            out.index_fill_(0, (base[:, None] + self.offsets).reshape(-1), True)


def render_rays_graphed(g: GridConsts, occ: torch.Tensor, col: torch.Tensor, tau: float,
                        origins: torch.Tensor, dirs: torch.Tensor, step: float, n: int):
    """Eq. 1 as :func:`~navbench.worldmodel.diffrender.render_rays_torch` (all ``n + 1``
    samples searched without autograd in one slice, the bracket and ``g(p*)`` with it), with
    fixed shapes and no host data. Returns ``depth, rgb, hit, occ_points (2, R, 3), p_star``."""
    with torch.no_grad():
        ks = torch.arange(n + 1, dtype=origins.dtype, device=origins.device) * step
        pts = origins[:, None, :] + ks[None, :, None] * dirs[:, None, :]
        above = g.trilinear(occ.detach(), pts) > tau
        above[:, 0] = False  # m = 0 (the camera centre) is never p+
        any_above = above.any(dim=1)
        m = torch.where(any_above, above.float().argmax(dim=1), torch.zeros_like(any_above, dtype=torch.long))
    m1 = torch.clamp(m, min=1)
    rows_k = torch.stack([m1 - 1, m1]).to(origins.dtype) * step  # (2, R): k- and k+
    bracket = origins[None] + rows_k[..., None] * dirs[None]
    f = g.trilinear(occ, bracket)  # (2, R)
    hit = any_above & (f[0] <= tau).detach()
    f_minus, f_plus = f[0], f[1]
    safe_plus = torch.where(hit, f_plus, f_minus.detach() + 1.0)
    k = rows_k[0] + (tau - f_minus) / (safe_plus - f_minus) * step
    k = torch.where(hit, k, torch.zeros_like(k))
    p_star = origins + k.detach()[:, None] * dirs
    rgb = g.trilinear(col, p_star) * hit[:, None].to(col.dtype)
    return k, rgb, hit, bracket, p_star


class DeviceViews:
    """The training views on the device and the batch gather of one step.

    ``draw(img, pix)``: ``img (images,)`` view indices, ``pix (images, pixels)`` pixel indices
    (long, on the device) -> ``origins, dirs (B, 3)`` (world frame, ``v = R K^-1 [i j 1]``),
    ``rgb (B, 3)`` in [0, 1], ``depth (B,)`` (0 where invalid), ``valid (B,)`` bool: what
    :class:`navbench.worldmodel.fit.BatchSampler` draws, gathered on the device."""

    def __init__(self, views: Views, device):
        from navbench.geometry import camera_rotation, pixel_rays

        f32 = lambda a: torch.as_tensor(np.ascontiguousarray(a, np.float32), device=device)  # noqa: E731
        self.n = len(views)
        self.HW = views.intrinsics.height * views.intrinsics.width
        self.cam_rays = f32(pixel_rays(views.intrinsics).reshape(-1, 3))
        th = np.asarray(views.poses[:, 2])
        self.R = f32(np.stack([camera_rotation(t) for t in th]))
        poses = np.asarray(views.poses)
        self.origins = f32(np.column_stack([poses[:, 0], poses[:, 1],
                                            np.full(len(poses), views.camera_height)]))
        # a copy (torch.tensor): the views may be a read-only memory map
        self.rgb = torch.tensor(np.asarray(views.rgb).reshape(-1, 3), device=device)
        depth = np.asarray(views.depth, np.float32).reshape(-1)
        valid = np.asarray(views.valid).reshape(-1) & np.isfinite(depth)
        self.depth = f32(np.where(valid, depth, 0.0))
        self.valid = torch.as_tensor(valid, device=device)

    def draw(self, img: torch.Tensor, pix: torch.Tensor):
        ib = img[:, None].expand_as(pix).reshape(-1)
        p = pix.reshape(-1)
        flat = ib * self.HW + p
        c = self.cam_rays.index_select(0, p)
        R = self.R.index_select(0, ib)
        dirs = (R * c[:, None, :]).sum(-1)
        origins = self.origins.index_select(0, ib)
        rgb = self.rgb.index_select(0, flat).to(torch.float32) / 255.0
        return origins, dirs, rgb, self.depth.index_select(0, flat), self.valid.index_select(0, flat)


def masked_adam_(p, grad, m, v, mask, t, lr, b1, b2, eps) -> None:
    """Lazy Adam on every row of ``p`` with fixed shapes: rows where ``mask (rows,)`` is set
    take the step of :class:`MaskedAdam` (same arithmetic), the others
    keep their value and moments. ``t``: the step count as a device scalar (already advanced);
    the bias corrections are computed in float64, as MaskedAdam's Python floats."""
    C = p.shape[-1] if p.dim() == 4 else 1
    pv, gv, mv, vv = (x.view(-1, C) for x in (p, grad, m, v))
    mk = mask[:, None]
    t64 = t.to(torch.float64)  # 1 - 0.999^t in float32 loses 4 digits at small t
    bc1 = (1.0 - torch.pow(b1, t64)).to(p.dtype)
    bc2 = (1.0 - torch.pow(b2, t64)).to(p.dtype)
    m_new = mv * b1 + gv * (1.0 - b1)
    v_new = vv * b2 + gv * gv * (1.0 - b2)
    mv.copy_(torch.where(mk, m_new, mv))
    vv.copy_(torch.where(mk, v_new, vv))
    upd = (m_new / bc1) / ((v_new / bc2).sqrt() + eps) * lr
    pv.sub_(torch.where(mk, upd, torch.zeros_like(upd)))


def graphs_enabled() -> bool:
    """``NAVBENCH_CUDA_GRAPH`` is not ``0``: capture the step as a CUDA graph on CUDA."""
    return os.environ.get("NAVBENCH_CUDA_GRAPH", "1").strip() != "0"


def fit_map_device(views: Views, config, device: str, log, spec, occ0, col0):
    """Run ``config.steps`` steps of the fit on ``device`` (a torch device string or
    ``"torch-cpu"``) from the initial grids ``occ0``, ``col0``; ``log`` is the fit's
    :class:`~navbench.worldmodel.fit._FitLog` (fed every 10 steps). Returns ``occ``, ``col``
    (numpy float32), ``sigma2``, the elapsed seconds and a dict of what ran (device, graph)."""
    dev = torch.device("cpu" if device == "torch-cpu" else device)
    cuda = dev.type == "cuda"
    g = GridConsts(spec, dev)
    data = DeviceViews(views, dev)
    occ = torch.tensor(occ0, device=dev, requires_grad=True)
    col = torch.tensor(col0, device=dev, requires_grad=True)
    sigma2 = torch.tensor(float(config.sigma2_init), device=dev, requires_grad=True)
    lazy = config.optimizer == "lazy-adam"
    b1, b2, eps, lr = 0.9, 0.999, 1e-8, float(config.lr)
    if lazy:
        moments = [(torch.zeros_like(occ), torch.zeros_like(occ)),
                   (torch.zeros_like(col), torch.zeros_like(col))]
        touched = [torch.zeros(g.cells, dtype=torch.bool, device=dev) for _ in range(2)]
    else:
        dense = torch.optim.Adam([occ, col], lr=lr, fused=cuda, capturable=cuda)
    t = torch.zeros((), device=dev)  # step count of the grids' Adam
    s_m, s_v, s_t = (torch.zeros((), device=dev) for _ in range(3))  # sigma2's Adam
    images, pixels = config.images_per_batch, config.pixels_per_image
    S = config.free_space_samples if config.free_space_weight > 0 else 0
    B = images * pixels
    # the step's random inputs: static buffers a graph reads, refilled from a drawn chunk
    img_s = torch.zeros(images, dtype=torch.long, device=dev)
    pix_s = torch.zeros((images, pixels), dtype=torch.long, device=dev)
    u_s = torch.zeros((2, B, max(S, 1)), device=dev)
    loss_s, hit_s = torch.zeros((), device=dev), torch.zeros((), device=dev)
    gen = torch.Generator(device=dev)
    gen.manual_seed(int(config.seed))
    step_m, n = config.step, config.n_samples
    tau, s2_lr = float(config.tau), float(config.sigma2_lr)

    def one_step():
        o, d, rgb, dep, valid = data.draw(img_s, pix_s)
        k, rgb_p, hit, bracket, p_star = render_rays_graphed(g, occ, col, tau, o, d, step_m, n)
        mask = hit & valid
        s1 = sigma2 / 5.0
        per = ((rgb - rgb_p).abs().sum(-1) / s1 + 3 * torch.log(2 * s1)
               + (dep - k).abs() / sigma2 + torch.log(2 * sigma2))
        per = torch.where(mask, per, torch.zeros_like(per))
        loss = per.sum() / torch.clamp(mask.sum().to(per.dtype), min=1.0)
        total = loss
        if S:
            span = torch.clamp(dep - config.free_space_margin, min=0.0)
            k_free = u_s[0, :, :S] * span[:, None]
            k_solid = dep[:, None] + config.free_space_margin * u_s[1, :, :S]
            free = o[:, None, :] + k_free[..., None] * d[:, None, :]
            solid = o[:, None, :] + k_solid[..., None] * d[:, None, :]
            fs = g.trilinear(occ, torch.stack([free, solid]).reshape(2, B * S, 3))
            total = total + config.free_space_weight * free_space_hinge_masked(
                fs[0], fs[1], valid[:, None].expand(B, S).reshape(-1), tau, config.free_space_delta)
        total.backward()
        with torch.no_grad():
            t.add_(1.0)
            if lazy:
                for tm in touched:
                    tm.zero_()
                g.mark(bracket, touched[0])
                if S:
                    g.mark(free, touched[0])
                    g.mark(solid, touched[0])
                g.mark(p_star, touched[1])
                for p, (m_, v_), tm in zip((occ, col), moments, touched):
                    masked_adam_(p, p.grad, m_, v_, tm, t, lr, b1, b2, eps)
            else:
                dense.step()
            # sigma2's Adam (torch.optim.Adam's arithmetic), on steps whose batch has a hit
            anyhit = mask.any()
            s_t.add_(anyhit.to(s_t.dtype))
            gs = sigma2.grad
            s_m.copy_(torch.where(anyhit, s_m * b1 + gs * (1 - b1), s_m))
            s_v.copy_(torch.where(anyhit, s_v * b2 + gs * gs * (1 - b2), s_v))
            tt = torch.clamp(s_t, min=1.0)
            denom = s_v.sqrt() / torch.sqrt(1.0 - torch.pow(b2, tt)) + eps
            upd = s2_lr / (1.0 - torch.pow(b1, tt)) * s_m / denom
            sigma2.sub_(torch.where(anyhit, upd, torch.zeros_like(upd)))
            sigma2.clamp_(min=config.min_sigma2)
            loss_s.copy_(loss.detach())
            hit_s.copy_(mask.float().mean())

    def zero_grads():
        for p in (occ, col, sigma2):
            p.grad = None

    losses = torch.zeros(max(config.steps, 1), device=dev)
    hits = torch.zeros(max(config.steps, 1), device=dev)
    use_graph = cuda and graphs_enabled()
    graph = None
    warm = 3  # eager steps before capture (on a side stream, as torch's CUDA-graph recipe)
    ran = {"device_path": "device-batch", "cuda_graph": False}
    old_threads = torch.get_num_threads()
    if not cuda:
        torch.set_num_threads(max(1, config.threads))
    stream = torch.cuda.Stream(dev) if cuda else None
    try:
        t0 = time.perf_counter()
        pool = None
        for it in range(config.steps):
            c = it % RANDOM_CHUNK
            if c == 0:  # the next chunk of random numbers, drawn on the device
                K = min(RANDOM_CHUNK, config.steps - it)
                pool = (torch.randint(0, data.n, (K, images), generator=gen, device=dev),
                        torch.randint(0, data.HW, (K, images, pixels), generator=gen, device=dev),
                        torch.rand((K, 2, B, max(S, 1)), generator=gen, device=dev))
            img_s.copy_(pool[0][c])
            pix_s.copy_(pool[1][c])
            u_s.copy_(pool[2][c])
            if graph is not None:
                graph.replay()
            elif use_graph and it == warm:
                try:
                    stream.wait_stream(torch.cuda.current_stream(dev))
                    with torch.cuda.stream(stream):
                        zero_grads()
                        graph = torch.cuda.CUDAGraph()
                        with torch.cuda.graph(graph, stream=stream):
                            one_step()
                    torch.cuda.current_stream(dev).wait_stream(stream)
                except RuntimeError as e:  # a capture that fails records nothing and ran nothing
                    graph, use_graph = None, False
                    ran["graph_error"] = (str(e).strip().splitlines() or ["?"])[0][:200]
                    torch.cuda.synchronize(dev)
                    zero_grads()
                    one_step()  # this step, op by op; the rest of the fit too
                else:
                    graph.replay()  # capture records, it does not run: this is step `warm`
                    ran["cuda_graph"] = True
            elif use_graph:
                stream.wait_stream(torch.cuda.current_stream(dev))
                with torch.cuda.stream(stream):
                    zero_grads()
                    one_step()
                torch.cuda.current_stream(dev).wait_stream(stream)
            else:
                zero_grads()
                one_step()
            losses[it].copy_(loss_s)
            hits[it].copy_(hit_s)
            if (it + 1) % 10 == 0 or it + 1 == config.steps:
                log.progress_at(it + 1, float(loss_s))  # one synchronisation per 10 steps
        if cuda:
            torch.cuda.synchronize(dev)
        elapsed = time.perf_counter() - t0
    finally:
        torch.set_num_threads(old_threads)
    log.bulk(losses[: config.steps].cpu().numpy(), hits[: config.steps].cpu().numpy())
    if cuda:
        idx = dev.index if dev.index is not None else torch.cuda.current_device()
        ran.update(device=f"cuda:{idx}", device_name=torch.cuda.get_device_name(idx))
    else:
        ran.update(device="torch-cpu")
    out = (occ.detach().to("cpu").numpy().astype(np.float32),
           col.detach().to("cpu").numpy().astype(np.float32))
    return out[0], out[1], float(sigma2.detach()), elapsed, ran


def device_memory_bytes(views: Views, config) -> int:
    """Device memory the path holds: the views (colour bytes, depth, validity), the grids with
    their gradients and two moments (64 bytes a cell), one step's samples and a chunk of
    random numbers."""
    pixels = len(views) * views.intrinsics.height * views.intrinsics.width
    cells = math.prod(int(v) for v in config.grid_shape)
    rays = config.images_per_batch * config.pixels_per_image
    return (pixels * 8 + cells * 64 + rays * (config.n_samples + 1) * 200
            + RANDOM_CHUNK * rays * 24 + (64 << 20))


def check_device_memory(views: Views, config, device: str) -> None:
    """Refuse (:class:`~navbench.errors.ConfigError`) a device fit that does not fit in the
    GPU's free memory (:func:`device_memory_bytes`), before anything is moved there."""
    from navbench.errors import ConfigError
    from navbench.worldmodel.memory import format_bytes

    if not device.startswith("cuda"):
        return
    dev = torch.device(device)
    free, _total = torch.cuda.mem_get_info(dev)
    need = device_memory_bytes(views, config)
    if need > free:
        raise ConfigError(f"fit: {len(views)} views and grid_shape {list(config.grid_shape)} need "
                          f"{format_bytes(need)} of GPU memory on {dev}, only "
                          f"{format_bytes(free)} is free")


def free_space_hinge_masked(f_free, f_solid, valid, tau: float, delta: float):
    """:func:`navbench.worldmodel.fit.free_space_hinge` over the points where ``valid`` is set,
    with fixed shapes: ``sum(valid * hinge) / max(count, 1)`` per term (0 when none)."""
    w = valid.to(f_free.dtype)
    count = torch.clamp(w.sum(), min=1.0)
    return ((torch.relu(f_free - (tau - delta)) * w).sum() / count
            + (torch.relu((tau + delta) - f_solid) * w).sum() / count)


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
