"""Eq. 1-2 renderer: analytic crossings, finite-difference gradients, fast path == reference."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from navbench.geometry import HALF_CAMERA, camera_pose, pixel_rays
from navbench.worldmodel.diffrender import (
    laplace_nll, render_rays, render_rays_dense, render_rays_torch, trilinear_t, world_rays,
)
from navbench.worldmodel.fastrender import FastRenderer
from navbench.worldmodel.grid import GridSpec, grid_for_level, trilinear, voxelize_level

TAU = 0.5
#: Devices the torch (device) path is tested on: the CPU always, CUDA where torch sees a GPU.
DEVICES = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])


def _ramp_grids(spec, x0, slope, dtype=torch.float64):
    """occ = tau + slope (x - x0) (a half-space occupied beyond x0); col affine in p."""
    X, Y, Z = np.meshgrid(spec.centres(0), spec.centres(1), spec.centres(2), indexing="ij")
    occ = TAU + slope * (X - x0)
    col = np.stack([0.2 + 0.1 * X, 0.5 - 0.05 * Y, 0.3 + 0.2 * Z], -1)
    return torch.tensor(occ, dtype=dtype), torch.tensor(col, dtype=dtype)


@pytest.mark.parametrize("render", [render_rays, render_rays_dense, render_rays_torch])
def test_crossing_of_linear_field_is_exact(render):
    spec = GridSpec((0, 0, 0), (4, 2, 2), (40, 10, 10))
    x0 = 2.537
    occ, col = _ramp_grids(spec, x0, slope=0.8)
    rng = np.random.default_rng(0)
    o = np.column_stack([rng.uniform(0.3, 1.0, 30), rng.uniform(0.5, 1.5, 30), rng.uniform(0.5, 1.5, 30)])
    d = np.column_stack([np.ones(30), rng.uniform(-0.15, 0.15, 30), rng.uniform(-0.15, 0.15, 30)])
    out = render(occ, col, spec, TAU, torch.tensor(o), torch.tensor(d), 0.07, 100)
    assert out.hit.all()
    k_true = (x0 - o[:, 0]) / d[:, 0]
    np.testing.assert_allclose(out.depth.numpy(), k_true, atol=1e-9)
    p = o + k_true[:, None] * d
    np.testing.assert_allclose(out.rgb.numpy(), np.column_stack(
        [0.2 + 0.1 * p[:, 0], 0.5 - 0.05 * p[:, 1], 0.3 + 0.2 * p[:, 2]]), atol=1e-9)


def test_no_crossing_and_camera_inside_are_masked():
    spec = GridSpec((0, 0, 0), (4, 2, 2), (40, 10, 10))
    occ, col = _ramp_grids(spec, 2.5, slope=0.8)
    o = torch.tensor([[1.0, 1.0, 1.0], [3.0, 1.0, 1.0], [1.0, 1.0, 1.0]], dtype=torch.float64)
    d = torch.tensor([[-1.0, 0, 0], [1.0, 0, 0], [1.0, 0, 0]], dtype=torch.float64)
    for render in (render_rays, render_rays_dense, render_rays_torch):
        out = render(occ, col, spec, TAU, o, d, 0.1, 10)  # range 1 m: the third ray falls short
        assert out.hit.tolist() == [False, False, False]
        nll = laplace_nll(out.rgb, out.depth, torch.zeros(3, 3, dtype=torch.float64),
                          torch.ones(3, dtype=torch.float64), torch.tensor(2.4, dtype=torch.float64),
                          mask=out.hit)
        assert nll.item() == 0.0


def _scene(dtype=torch.float64, seed=0):
    """A tiny random smooth grid with a wall-like ramp, and rays that cross it."""
    spec = GridSpec((0, 0, 0), (2, 1, 1), (8, 5, 4))
    g = torch.Generator().manual_seed(seed)
    X = torch.tensor(spec.centres(0), dtype=dtype)[:, None, None]
    occ = (TAU + 0.9 * (X - 1.3) + 0.15 * torch.rand(spec.shape, generator=g, dtype=dtype))
    col = torch.rand(spec.shape + (3,), generator=g, dtype=dtype)
    R = 12
    o = torch.stack([torch.full((R,), 0.3, dtype=dtype), 0.3 + 0.4 * torch.rand(R, generator=g, dtype=dtype),
                     0.3 + 0.4 * torch.rand(R, generator=g, dtype=dtype)], 1)
    d = torch.stack([torch.ones(R, dtype=dtype), 0.2 * torch.rand(R, generator=g, dtype=dtype) - 0.1,
                     0.2 * torch.rand(R, generator=g, dtype=dtype) - 0.1], 1)
    rgb_obs = torch.rand(R, 3, generator=g, dtype=dtype)
    depth_obs = 1.0 + 0.2 * torch.rand(R, generator=g, dtype=dtype)
    return spec, occ, col, o, d, rgb_obs, depth_obs


def _loss(render, spec, occ, col, sigma2, o, d, rgb_obs, depth_obs, cms):
    out = render(occ, col, spec, TAU, o, d, 0.05, 60, colour_moves_surface=cms)
    assert out.hit.all()
    return laplace_nll(out.rgb, out.depth, rgb_obs, depth_obs, sigma2, mask=out.hit, reduction="sum")


def test_gradients_match_finite_differences():
    """Full derivative (colour_moves_surface=True) of the summed eq. 2 NLL vs central differences."""
    spec, occ, col, o, d, rgb_obs, depth_obs = _scene()
    sigma2 = torch.tensor(0.7, dtype=torch.float64)
    occ_p, col_p, s_p = (t.clone().requires_grad_(True) for t in (occ, col, sigma2))
    _loss(render_rays, spec, occ_p, col_p, s_p, o, d, rgb_obs, depth_obs, True).backward()
    assert occ_p.grad.abs().sum() > 0 and col_p.grad.abs().sum() > 0

    def fd(name, idx, h=1e-6):
        def at(delta):
            args = {"occ": occ.clone(), "col": col.clone(), "sigma2": sigma2.clone()}
            args[name][idx] += delta
            return _loss(render_rays_dense, spec, args["occ"], args["col"], args["sigma2"],
                         o, d, rgb_obs, depth_obs, True).item()
        return (at(h) - at(-h)) / (2 * h)

    # every occupancy cell that received gradient, and a sample of colour cells
    for idx in map(tuple, torch.nonzero(occ_p.grad).tolist()):
        np.testing.assert_allclose(occ_p.grad[idx].item(), fd("occ", idx), rtol=1e-5, atol=1e-6)
    for idx in map(tuple, torch.nonzero(col_p.grad).tolist()[:40]):
        np.testing.assert_allclose(col_p.grad[idx].item(), fd("col", idx), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(s_p.grad.item(), fd("sigma2", ()), rtol=1e-6)


def test_colour_does_not_move_the_surface_by_default():
    spec, occ, col, o, d, rgb_obs, depth_obs = _scene()
    sigma2 = torch.tensor(0.7, dtype=torch.float64)
    grads = {}
    for cms in (True, False):
        occ_p, col_p = occ.clone().requires_grad_(True), col.clone().requires_grad_(True)
        _loss(render_rays, spec, occ_p, col_p, sigma2, o, d, rgb_obs, depth_obs, cms).backward()
        grads[cms] = (occ_p.grad, col_p.grad)
    torch.testing.assert_close(grads[True][1], grads[False][1])  # same colour gradient
    occ_q = occ.clone().requires_grad_(True)
    out = render_rays(occ_q, col, spec, TAU, o, d, 0.05, 60)
    ((depth_obs - out.depth).abs().sum() / sigma2).backward()  # the depth term alone
    torch.testing.assert_close(grads[False][0], occ_q.grad, rtol=0, atol=1e-12)
    assert not torch.allclose(grads[True][0], grads[False][0])


@pytest.mark.parametrize("render", [render_rays, render_rays_torch])
def test_fast_bracketing_gradients_equal_dense_autograd(render):
    spec, occ, col, o, d, rgb_obs, depth_obs = _scene(dtype=torch.float32, seed=3)
    grads = []
    for render in (render, render_rays_dense):
        occ_p, col_p = occ.clone().requires_grad_(True), col.clone().requires_grad_(True)
        s = torch.tensor(1.3, requires_grad=True)
        _loss(render, spec, occ_p, col_p, s, o, d, rgb_obs, depth_obs, False).backward()
        grads.append((occ_p.grad, col_p.grad, s.grad))
    for a, b in zip(*grads):
        torch.testing.assert_close(a, b, rtol=1e-5, atol=1e-6)


def test_trilinear_t_matches_numpy():
    spec = GridSpec((0, -1, 0), (2, 1, 1), (6, 7, 5))
    rng = np.random.default_rng(4)
    g = rng.random((6, 7, 5, 3))
    p = rng.uniform(-0.5, 2.5, (50, 3))
    np.testing.assert_allclose(trilinear_t(torch.tensor(g), spec, torch.tensor(p)).numpy(),
                               trilinear(g, spec, p), atol=1e-12)


def test_fast_renderer_equals_differentiable_renderer(room):
    vm = voxelize_level(room, grid_for_level(room, shape=(100, 80, 20)))
    step = 0.04
    fr = FastRenderer(vm, HALF_CAMERA, step=step)
    cam = pixel_rays(HALF_CAMERA).reshape(-1, 3)
    occ, col = torch.tensor(vm.occ), torch.tensor(vm.col)
    n = int(round(20.0 / step))
    for pose in [(0.5, 0.5, 0.3), (2.0, 1.0, 2.0), (3.5, 2.6, -2.5), (1.2, 2.0, -1.0)]:
        frame = fr.render(pose)
        o, d = world_rays(camera_pose(pose), cam, dtype=torch.float64)
        out = render_rays(occ.double(), col.double(), vm.spec, vm.tau, o, d, step, n)
        hit = out.hit.numpy().reshape(HALF_CAMERA.shape)
        assert (hit == frame.valid).mean() > 0.999
        both = hit & frame.valid
        assert both.mean() > 0.99
        np.testing.assert_allclose(frame.depth[both], out.depth.numpy().reshape(hit.shape)[both], atol=1e-3)
        rgb = np.clip(out.rgb.numpy().reshape(HALF_CAMERA.shape + (3,)), 0, 1)
        np.testing.assert_allclose(frame.rgb[both], rgb[both], atol=1e-3)


def test_sparse_fitting_path_gradients_equal_dense_autograd():
    from navbench.worldmodel.diffrender import render_rays_sparse

    spec, occ, col, o, d, rgb_obs, depth_obs = _scene(dtype=torch.float32, seed=5)
    s = torch.tensor(1.3, requires_grad=True)
    occ_p, col_p = occ.clone().requires_grad_(True), col.clone().requires_grad_(True)
    _loss(render_rays_dense, spec, occ_p, col_p, s, o, d, rgb_obs, depth_obs, False).backward()
    s2 = torch.tensor(1.3, requires_grad=True)
    occ_np, col_np = occ.numpy().copy(), col.numpy().copy()
    out = render_rays_sparse(occ_np, col_np, spec, TAU, o.numpy(), d.numpy(), 0.05, 60)
    assert out.hit.all()
    laplace_nll(out.rgb, out.depth, rgb_obs, depth_obs, s2, mask=out.hit, reduction="sum").backward()
    g_occ, g_col = np.zeros_like(occ_np), np.zeros_like(col_np)
    out.occ_lookup.scatter_grad(g_occ)
    out.col_lookup.scatter_grad(g_col)
    np.testing.assert_allclose(g_occ, occ_p.grad.numpy(), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(g_col, col_p.grad.numpy(), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(s2.grad.item(), s.grad.item(), rtol=1e-5)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("chunk", [1, 7, 64, 500])
def test_torch_path_is_bit_identical_to_the_dense_reference(room, chunk, device):
    """render_rays_torch computes the bracket from the same sample positions as the reference,
    so its values are identical (not merely close) whatever the search chunk; the gradients
    agree to float rounding (the scatter sums the same terms in another order)."""
    vm = voxelize_level(room, grid_for_level(room, shape=(60, 60, 20)))
    rng = np.random.default_rng(5)
    R = 300
    o = torch.tensor(np.column_stack([rng.uniform(0.4, 3.6, R), rng.uniform(0.4, 2.6, R), np.full(R, 0.6)]),
                     dtype=torch.float32, device=device)
    d = torch.tensor(np.column_stack([np.cos(a := rng.uniform(0, 6.3, R)), np.sin(a),
                                      rng.uniform(-0.4, 0.4, R)]), dtype=torch.float32, device=device)
    res = []
    for render, kw in ((render_rays_dense, {}), (render_rays_torch, {"chunk": chunk})):
        occ = torch.tensor(vm.occ, device=device).requires_grad_(True)
        col = torch.tensor(vm.col, device=device).requires_grad_(True)
        out = render(occ, col, vm.spec, vm.tau, o, d, 0.05, 150, **kw)
        (out.depth.sum() + out.rgb.sum()).backward()
        res.append((out.depth, out.rgb, out.hit, occ.grad, col.grad))
        assert all(t.device.type == device for t in res[-1])
    assert res[0][2].float().mean() > 0.5  # most rays cross something
    for a, b in zip(res[0][:3], res[1][:3]):
        assert torch.equal(a, b)
    for a, b in zip(res[0][3:], res[1][3:]):
        torch.testing.assert_close(a, b, rtol=1e-5, atol=1e-6)
