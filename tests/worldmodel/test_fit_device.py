"""The device fit path (navbench.worldmodel.fit_device) against its references: the lookup and
renderer against diffrender's (values and gradients), the batch gather against the host
sampler's arithmetic, the masked Adam against the row Adam, the masked hinge against the
hinge; on CUDA, the graphed step against the same step launched op by op."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from navbench.geometry import Intrinsics, camera_rotation, pixel_rays
from navbench.worldmodel.diffrender import render_rays_torch, stencil_mask, trilinear_t
from navbench.worldmodel.fit import FitConfig, fit_map, free_space_hinge, initial_grids
from navbench.worldmodel.fit_device import (
    DeviceViews, GridConsts, MaskedAdam, free_space_hinge_masked, masked_adam_, render_rays_graphed,
)
from navbench.worldmodel.views import collect_views

TINY = Intrinsics(40, 30, 18.75, 18.75, 20.0, 15.0)
QUICK = dict(steps=300, grid_shape=(80, 80, 20), images_per_batch=10, pixels_per_image=100)
DEVICES = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])


@pytest.fixture(scope="module")
def data(room):
    return collect_views(room, 60, TINY, seed=0), collect_views(room, 10, TINY, seed=1)


@pytest.fixture(scope="module")
def grids(data):
    spec, occ, col = initial_grids(data[0], FitConfig(**QUICK))
    rng = np.random.default_rng(0)
    occ = (occ + 0.3 * rng.random(occ.shape)).astype(np.float32)  # not piecewise constant
    col = rng.random(col.shape).astype(np.float32)
    return spec, occ, col


def _rays(data, n, seed):
    train = data[0]
    rng = np.random.default_rng(seed)
    img = rng.integers(0, len(train), n)
    pix = rng.integers(0, TINY.width * TINY.height, n)
    R = np.stack([camera_rotation(t) for t in train.poses[img, 2]])
    dirs = np.einsum("bij,bj->bi", R, pixel_rays(TINY).reshape(-1, 3)[pix])
    o = np.column_stack([train.poses[img, 0], train.poses[img, 1], np.full(n, train.camera_height)])
    return torch.tensor(o, dtype=torch.float32), torch.tensor(dirs, dtype=torch.float32)


@pytest.mark.parametrize("device", DEVICES)
def test_lookup_equals_trilinear_t_with_its_gradients(grids, device):
    spec, occ, col = grids
    g = GridConsts(spec, device)
    pts = (torch.tensor(spec.lo) + torch.rand(500, 3) * torch.tensor(np.asarray(spec.size) * spec.shape)
           * 1.1 - 0.05).to(device)  # inside and a little outside (border clamping)
    for grid in (occ, col):
        a = torch.tensor(grid, device=device, requires_grad=True)
        b = torch.tensor(grid, device=device, requires_grad=True)
        pa, pb = pts.clone().requires_grad_(True), pts.clone().requires_grad_(True)
        va, vb = trilinear_t(a, spec, pa), g.trilinear(b, pb)
        # the 8 weighted values are summed in another order: float32 rounding of values ~1
        torch.testing.assert_close(vb, va, rtol=0, atol=4e-6)
        w = torch.rand_like(va)
        (va * w).sum().backward()
        (vb * w).sum().backward()
        torch.testing.assert_close(b.grad, a.grad, rtol=0, atol=4e-6)
        torch.testing.assert_close(pb.grad, pa.grad, rtol=0, atol=1e-4)  # d/dp scales by 1/cell = 20
    mask = torch.zeros(g.cells, dtype=torch.bool, device=device)
    g.mark(pts, mask)
    assert torch.equal(mask, stencil_mask(spec, pts))


@pytest.mark.parametrize("device", DEVICES)
def test_graphable_renderer_equals_render_rays_torch(data, grids, device):
    spec, occ, col = grids
    cfg = FitConfig(**QUICK)
    o, d = (t.to(device) for t in _rays(data, 400, 1))
    ref_o, ref_c = (torch.tensor(x, device=device, requires_grad=True) for x in (occ, col))
    new_o, new_c = (torch.tensor(x, device=device, requires_grad=True) for x in (occ, col))
    a = render_rays_torch(ref_o, ref_c, spec, cfg.tau, o, d, cfg.step, cfg.n_samples)
    k, rgb, hit, bracket, p_star = render_rays_graphed(GridConsts(spec, device), new_o, new_c,
                                                       cfg.tau, o, d, cfg.step, cfg.n_samples)
    assert torch.equal(hit, a.hit) and 0.3 < hit.float().mean() < 1.0
    torch.testing.assert_close(k, a.depth, rtol=0, atol=1e-5)
    torch.testing.assert_close(rgb, a.rgb, rtol=0, atol=1e-5)
    torch.testing.assert_close(bracket, a.occ_points)
    torch.testing.assert_close(p_star, a.col_points)
    w = torch.rand_like(k)
    ((a.depth * w).sum() + a.rgb.sum()).backward()
    ((k * w).sum() + rgb.sum()).backward()
    torch.testing.assert_close(new_o.grad, ref_o.grad, rtol=1e-4, atol=1e-5)
    torch.testing.assert_close(new_c.grad, ref_c.grad, rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("device", DEVICES)
def test_device_gather_equals_the_host_arithmetic(data, device):
    train = data[0]
    dv = DeviceViews(train, device)
    rng = np.random.default_rng(3)
    img = rng.integers(0, len(train), 7)
    pix = rng.integers(0, TINY.width * TINY.height, (7, 50))
    o, d, rgb, dep, valid = (t.cpu().numpy() for t in dv.draw(torch.tensor(img, device=device),
                                                                torch.tensor(pix, device=device)))
    ib, p = np.repeat(img, 50), pix.ravel()
    jj, ii = np.divmod(p, TINY.width)
    R = np.stack([camera_rotation(t) for t in train.poses[ib, 2]])
    want_d = np.einsum("bij,bj->bi", R, pixel_rays(TINY).reshape(-1, 3)[p])
    np.testing.assert_allclose(d, want_d, rtol=0, atol=1e-6)
    np.testing.assert_allclose(o[:, :2], train.poses[ib, :2], rtol=0, atol=1e-6)
    np.testing.assert_array_equal(o[:, 2], np.float32(train.camera_height))
    # CUDA divides by a scalar as a product with its reciprocal: within 1 ulp of numpy's quotient
    np.testing.assert_allclose(rgb, np.asarray(train.rgb)[ib, jj, ii].astype(np.float32) / 255.0,
                               rtol=1.2e-7 if device == "cuda" else 0, atol=0)
    want_valid = np.asarray(train.valid)[ib, jj, ii] & np.isfinite(np.asarray(train.depth)[ib, jj, ii])
    np.testing.assert_array_equal(valid, want_valid)
    np.testing.assert_array_equal(dep, np.where(want_valid, np.asarray(train.depth)[ib, jj, ii], 0))


@pytest.mark.parametrize("device", DEVICES)
def test_masked_adam_equals_the_row_adam(device):
    """Ten steps with random gradients and random touched rows: every row's value and moments
    equal MaskedAdam's (which is tested against the CPU path's numba row update)."""
    rng = np.random.default_rng(5)
    for shape in ((6, 5, 4), (6, 5, 4, 3)):
        p0 = rng.random(shape).astype(np.float32)
        a = torch.tensor(p0, device=device, requires_grad=True)
        b = torch.tensor(p0, device=device)
        opt = MaskedAdam([a], lr=0.05)
        m, v, t = torch.zeros_like(b), torch.zeros_like(b), torch.zeros((), device=device)
        for _ in range(10):
            grad = torch.tensor(rng.standard_normal(shape).astype(np.float32), device=device)
            rows = torch.tensor(rng.random(120) < 0.3, device=device)
            a.grad = grad.clone()
            opt.step([rows])
            t.add_(1.0)
            masked_adam_(b, grad, m, v, rows, t, 0.05, 0.9, 0.999, 1e-8)
            torch.testing.assert_close(b, a.detach(), rtol=1e-6, atol=1e-7)
            torch.testing.assert_close(m, opt.m[0], rtol=1e-6, atol=1e-8)


def test_masked_hinge_is_the_hinge_of_the_valid_points():
    rng = np.random.default_rng(2)
    f_free, f_solid = (torch.tensor(rng.random(200), dtype=torch.float32) for _ in range(2))
    valid = torch.tensor(rng.random(200) < 0.6)
    want = free_space_hinge(f_free[valid], f_solid[valid], 0.5, 0.25)
    torch.testing.assert_close(free_space_hinge_masked(f_free, f_solid, valid, 0.5, 0.25), want)
    none = torch.zeros(200, dtype=torch.bool)
    assert float(free_space_hinge_masked(f_free, f_solid, none, 0.5, 0.25)) == 0.0


def test_device_fit_is_seeded_and_reads_its_device(data):
    cfg = FitConfig(seed=3, device="torch-cpu", **{**QUICK, "steps": 20})
    a, ma = fit_map(data[0], cfg)
    b, _ = fit_map(data[0], cfg)
    np.testing.assert_array_equal(a.occ, b.occ)
    np.testing.assert_array_equal(a.col, b.col)
    c, _ = fit_map(data[0], FitConfig(seed=4, device="torch-cpu", **{**QUICK, "steps": 20}))
    assert not np.array_equal(a.occ, c.occ)
    assert ma["device"] == "torch-cpu" and ma["cuda_graph"] is False and len(ma["loss_curve"]) == 0


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_cuda_graph_replays_the_eager_step(data, monkeypatch):
    """The captured step and the step launched op by op, from the same random numbers: the
    same fit up to the order of the atomic gradient sums (compared by loss and quality)."""
    train, held = data
    cfg = FitConfig(seed=7, device="cuda", **QUICK)
    g_map, g = fit_map(train, cfg, heldout=held)
    monkeypatch.setenv("NAVBENCH_CUDA_GRAPH", "0")
    e_map, e = fit_map(train, cfg, heldout=held)
    assert g["cuda_graph"] is True and e["cuda_graph"] is False
    np.testing.assert_allclose(g["loss_curve"], e["loss_curve"], rtol=0.02)
    assert abs(g["depth_mae_m"] - e["depth_mae_m"]) < 0.1 * e["depth_mae_m"]
    assert np.mean(np.abs(g_map.occ - e_map.occ)) < 0.01
