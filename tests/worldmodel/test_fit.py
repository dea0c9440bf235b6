"""Fitting: a tiny level reaches a depth bound, seeds are reproducible, lazy Adam is Adam."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from navbench.errors import ConfigError
from navbench.geometry import Intrinsics
from navbench.worldmodel.diffrender import Lookup
from navbench.worldmodel.fit import FitConfig, _SparseGrad, evaluate_map, fit_map, initial_grids
from navbench.worldmodel.grid import GridSpec
from navbench.worldmodel.grid import grid_for_level, voxelize_level
from navbench.worldmodel.views import collect_views

TINY = Intrinsics(40, 30, 18.75, 18.75, 20.0, 15.0)
QUICK = dict(steps=300, grid_shape=(80, 80, 20), images_per_batch=10, pixels_per_image=100)
#: The CPU (numba) path, whatever device "auto" would pick on this machine.
CPU = dict(QUICK, device="cpu")
#: Devices the torch (device) path is tested on: the CPU always, CUDA where torch sees a GPU
#: (so `make test` on a GPU machine checks the GPU fit against the CPU one).
DEVICES = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])


@pytest.fixture(scope="module")
def data(room):
    return collect_views(room, 100, TINY, seed=0), collect_views(room, 10, TINY, seed=1)


def test_tiny_level_fit_reaches_depth_bound(room, data):
    train, held = data
    vmap, m = fit_map(train, FitConfig(seed=7, **CPU), heldout=held, level=room)
    assert m["coverage"] > 0.99
    assert m["depth_mae_m"] < 0.05
    assert m["rgb_l1"] < 0.12
    assert m["slice_precision"] > 0.95 and m["slice_recall"] > 0.95
    assert vmap.meta["step"] == pytest.approx(0.1) and vmap.spec.shape == (80, 80, 20)
    assert len(m["loss_curve"]) == 3 and m["loss_curve"][-1] < m["loss_curve"][0]


def test_pure_objective_learns_from_box_init(room, data):
    train, held = data
    _, m = fit_map(train, FitConfig(seed=7, free_space_weight=0.0, **CPU), heldout=held)
    assert m["depth_mae_m"] < 0.06 and m["coverage"] > 0.99


def test_same_seed_same_map(data):
    train, _ = data
    cfg = FitConfig(seed=3, **{**CPU, "steps": 20})
    a, _ = fit_map(train, cfg)
    b, _ = fit_map(train, cfg)
    np.testing.assert_array_equal(a.occ, b.occ)
    np.testing.assert_array_equal(a.col, b.col)
    c, _ = fit_map(train, FitConfig(seed=4, **{**CPU, "steps": 20}))
    assert not np.array_equal(a.occ, c.occ)


def test_the_same_map_on_one_and_on_several_numba_threads(data):
    """The overlap's background process fits on one numba thread and the command beside it on
    the cores left (pipeline.executor.numba_threads): the map must not depend on the count."""
    import numba

    from navbench.pipeline.executor import numba_threads

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has one thread here (NUMBA_NUM_THREADS)")
    train, held = data
    cfg = FitConfig(seed=3, **{**CPU, "steps": 40})
    maps = []
    for n in (1, numba.config.NUMBA_NUM_THREADS):
        before = numba_threads(n)
        try:
            assert numba.get_num_threads() == n
            maps.append(fit_map(train, cfg, heldout=held))
        finally:
            numba_threads(before)
    (a, ma), (b, mb) = maps
    np.testing.assert_array_equal(a.occ, b.occ)
    np.testing.assert_array_equal(a.col, b.col)
    assert ma["depth_mae_m"] == mb["depth_mae_m"] and ma["rgb_l1"] == mb["rgb_l1"]


def test_progress_is_called(data):
    calls = []
    fit_map(data[0], FitConfig(**{**CPU, "steps": 20}), progress=lambda s, t, l: calls.append((s, t)))
    assert calls == [(10, 20), (20, 20)]


def test_lazy_adam_equals_adam_when_every_cell_is_touched():
    """Lookups at every cell centre touch every cell: lazy Adam must then be torch's Adam."""
    spec = GridSpec((0, 0, 0), (3, 4, 5), (3, 4, 5))
    X, Y, Z = np.meshgrid(spec.centres(0), spec.centres(1), spec.centres(2), indexing="ij")
    centres = np.stack([X, Y, Z], -1).reshape(-1, 3)
    rng = np.random.default_rng(0)
    p = rng.random(spec.shape).astype(np.float32)
    ref = torch.tensor(p.copy(), requires_grad=True)
    opt = torch.optim.Adam([ref], lr=0.05)
    acc = _SparseGrad(p, 0.05)
    for _ in range(5):
        target = torch.tensor(rng.random(len(centres)), dtype=torch.float32)
        lk = Lookup(p, spec, centres)
        ((lk.values - target) ** 2).sum().backward()
        acc.add(lk)
        np.testing.assert_allclose(acc.grad.ravel(), lk.values.grad.numpy(), rtol=1e-6, atol=1e-6)
        ref.grad = torch.tensor(acc.grad.copy())
        opt.step()
        acc.adam_step()
        assert not acc.grad.any()  # cleared for the next step
    np.testing.assert_allclose(p, ref.detach().numpy(), rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("device", DEVICES)
def test_masked_adam_equals_the_cpu_lazy_adam(device):
    """The device path's optimiser and the CPU path's numba rows update: same touched rows and
    gradients in, same moments and values out, over steps that touch different rows (some of
    them touched with a zero gradient, which still moves by momentum)."""
    from navbench.worldmodel.fit_device import MaskedAdam

    rng = np.random.default_rng(1)
    for shape in ((6, 5, 4), (6, 5, 4, 3)):
        p = rng.random(shape).astype(np.float32)
        t = torch.tensor(p.copy(), requires_grad=True, device=device)
        opt = MaskedAdam([t], lr=0.05)
        acc = _SparseGrad(p, 0.05)
        C = shape[3] if len(shape) == 4 else 1
        rows_total = 6 * 5 * 4
        for _ in range(8):
            rows = rng.choice(rows_total, size=40, replace=False)
            g = rng.normal(size=(40, C)).astype(np.float32)
            g[:5] = 0.0  # touched, zero gradient
            acc.g[rows] = g
            acc.touched[:40] = rows
            acc.count = 40
            acc.adam_step()
            full = np.zeros((rows_total, C), np.float32)
            full[rows] = g
            t.grad = torch.tensor(full.reshape(shape), device=device)
            mask = torch.zeros(rows_total, dtype=torch.bool, device=device)
            mask[torch.from_numpy(rows).to(device)] = True
            opt.step([mask])
            opt.zero_grad()
        np.testing.assert_allclose(t.detach().cpu().numpy(), p, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(opt.m[0].cpu().numpy(), acc.mv[..., 0].reshape(shape), rtol=1e-5, atol=1e-7)
        np.testing.assert_allclose(opt.v[0].cpu().numpy(), acc.mv[..., 1].reshape(shape), rtol=1e-5, atol=1e-9)
        # without masks, the rows with a nonzero gradient are the touched ones
        before = t.detach().clone()
        t.grad = torch.zeros(shape, device=device)
        t.grad.view(rows_total, C)[3] = 1.0
        opt.step()
        moved = (t.detach() != before).reshape(rows_total, C).any(dim=1)
        assert moved.nonzero().squeeze(1).cpu().tolist() == [3]


@pytest.mark.parametrize("device", DEVICES)
def test_device_path_touches_the_cells_of_the_cpu_path_with_its_gradients(room, data, device):
    """One batch through both fitting paths from the initial grids: the same rays hit, the same
    cells are touched, and the gradients agree to float32 rounding (the CPU path places samples
    in float64; where a stencil weight is ~1e-7 the two differ by that much)."""
    from navbench.worldmodel.diffrender import (
        laplace_nll, render_rays_sparse, render_rays_torch, stencil_mask,
    )
    from navbench.worldmodel.fit import BatchSampler

    train, _ = data
    cfg = FitConfig(seed=7, **QUICK)
    spec, occ, col = initial_grids(train, cfg)
    o, d, rgb, dep, valid = BatchSampler(train, 10, 100, 7).draw()
    s2 = torch.tensor(2.4)
    a = render_rays_sparse(occ, col, spec, cfg.tau, o.numpy(), d.numpy(), cfg.step, cfg.n_samples)
    laplace_nll(a.rgb, a.depth, rgb, dep, s2, mask=a.hit & valid).backward()
    g_occ, g_col = _SparseGrad(occ.copy(), 0.05), _SparseGrad(col.copy(), 0.05)
    g_occ.add(a.occ_lookup)
    g_col.add(a.col_lookup)
    occ_t = torch.tensor(occ, requires_grad=True, device=device)
    col_t = torch.tensor(col, requires_grad=True, device=device)
    on = lambda *ts: (t.to(device) for t in ts)  # noqa: E731
    o_d, d_d, rgb_d, dep_d, valid_d = on(o, d, rgb, dep, valid)
    b = render_rays_torch(occ_t, col_t, spec, cfg.tau, o_d, d_d, cfg.step, cfg.n_samples)
    laplace_nll(b.rgb, b.depth, rgb_d, dep_d, s2.to(device), mask=b.hit & valid_d).backward()
    assert torch.equal(a.hit, b.hit.cpu()) and a.hit.float().mean() > 0.9
    torch.testing.assert_close(a.depth, b.depth.cpu(), rtol=0, atol=1e-5)
    for acc, pts, grad in ((g_occ, b.occ_points, occ_t.grad), (g_col, b.col_points, col_t.grad)):
        cpu_rows = np.zeros(len(acc.g), bool)
        cpu_rows[acc.touched[:acc.count]] = True
        np.testing.assert_array_equal(stencil_mask(spec, pts).cpu().numpy(), cpu_rows)
        np.testing.assert_allclose(grad.cpu().numpy().reshape(acc.g.shape), acc.g, rtol=1e-3, atol=1e-4)


def _reference_draw(sampler):
    """BatchSampler.draw written plainly: (image, row, column) indexing, a lexsort, einsum."""
    rng, v = sampler.rng, sampler.views
    img = rng.integers(0, len(v), size=sampler.images)
    pix = rng.integers(0, len(sampler.cam_rays), size=(sampler.images, sampler.pixels))
    jj, ii = np.divmod(pix, v.intrinsics.width)
    ib = np.repeat(img, sampler.pixels)
    jj, ii, pix = jj.ravel(), ii.ravel(), pix.ravel()
    order = np.lexsort((ii, jj, ib))
    ib, jj, ii, pix = ib[order], jj[order], ii[order], pix[order]
    dirs = np.einsum("bij,bj->bi", sampler.R[ib], sampler.cam_rays[pix])
    origins = np.column_stack([v.poses[ib, 0], v.poses[ib, 1], np.full(len(ib), v.camera_height)])
    depth = np.asarray(v.depth)[ib, jj, ii].astype(np.float32)
    valid = np.asarray(v.valid)[ib, jj, ii] & np.isfinite(depth)
    return (origins, dirs, np.asarray(v.rgb)[ib, jj, ii] / 255.0,
            np.where(valid, depth, 0.0), valid)


def test_batch_sampler_equals_its_plain_reference(data):
    from navbench.worldmodel.fit import BatchSampler

    train, _ = data
    fast, ref = BatchSampler(train, 7, 50, 11), BatchSampler(train, 7, 50, 11)
    for _ in range(20):
        got = fast.draw()
        want = _reference_draw(ref)
        for g, w in zip(got, want):
            assert g.dtype in (torch.float32, torch.bool) and g.shape[0] == 350
            np.testing.assert_array_equal(g.numpy(), np.asarray(w, g.numpy().dtype))


def test_box_init_and_config_checks(data):
    train, _ = data
    spec, occ, col = initial_grids(train, FitConfig(grid_shape=(40, 40, 20)))
    zs = spec.centres(2)
    assert np.all(occ[:, :, zs < 0] == 1.0) and np.all(occ[:, :, (zs > 0) & (zs < 1.2)][:20, :15] == 0.0)
    with pytest.raises(ConfigError):
        FitConfig(init="random")
    with pytest.raises(ConfigError):
        FitConfig(optimizer="sgd")


def test_evaluate_true_map_is_near_perfect(room, data):
    _, held = data
    vm = voxelize_level(room, grid_for_level(room, shape=(100, 100, 20)))
    m = evaluate_map(vm, room, held, step=0.02)
    assert m["depth_mae_m"] < 0.01 and m["coverage"] > 0.999
    assert m["slice_precision"] > 0.99 and m["slice_recall"] > 0.99


@pytest.mark.parametrize("device", ["torch-cpu"] + DEVICES[1:])
def test_device_path_fits_the_tiny_level_as_well_as_the_cpu_path(room, data, device):
    """The device path (batches drawn on the device, masked lazy Adam; a CUDA graph on CUDA),
    run on the CPU as ``torch-cpu``: same objective and optimiser semantics, other (equally
    seeded) batches, so the map is as good as the CPU path's, compared by its quality."""
    train, held = data
    vmap, m = fit_map(train, FitConfig(seed=7, device=device, **QUICK), heldout=held, level=room)
    _, ref = fit_map(train, FitConfig(seed=7, device="cpu", **QUICK), heldout=held, level=room)
    want = "torch-cpu" if device == "torch-cpu" else "cuda:"
    assert m["device"].startswith(want) and vmap.meta["device"] == m["device"]
    assert ref["device"] == "cpu"
    assert m["coverage"] > 0.99
    assert m["depth_mae_m"] < 1.2 * ref["depth_mae_m"] and m["rgb_l1"] < 1.2 * ref["rgb_l1"]
    assert m["slice_precision"] > 0.95 and m["slice_recall"] > 0.95
    assert m["loss_curve"][-1] < m["loss_curve"][0]
    assert vmap.occ.dtype == np.float32 and vmap.occ.shape == (80, 80, 20)


def test_device_option_is_checked(monkeypatch):
    from navbench.worldmodel.fit import resolve_fit_device

    with pytest.raises(ConfigError, match="unknown device"):
        FitConfig(device="tpu")
    assert FitConfig().device == "auto"
    assert resolve_fit_device("cpu") == "cpu" and resolve_fit_device("torch-cpu") == "torch-cpu"
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert resolve_fit_device("auto") == "cpu"
    with pytest.raises(ConfigError, match="no CUDA"):
        resolve_fit_device("cuda:0")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)  # as on a GPU machine
    # "auto" stays the CPU path there (measured faster on an H100; one key, one map everywhere)
    assert resolve_fit_device("auto") == "cpu" and resolve_fit_device("cuda:1") == "cuda:1"
