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


@pytest.fixture(scope="module")
def data(room):
    return collect_views(room, 100, TINY, seed=0), collect_views(room, 10, TINY, seed=1)


def test_tiny_level_fit_reaches_depth_bound(room, data):
    train, held = data
    vmap, m = fit_map(train, FitConfig(seed=7, **QUICK), heldout=held, level=room)
    assert m["coverage"] > 0.99
    assert m["depth_mae_m"] < 0.05
    assert m["rgb_l1"] < 0.12
    assert m["slice_precision"] > 0.95 and m["slice_recall"] > 0.95
    assert vmap.meta["step"] == pytest.approx(0.1) and vmap.spec.shape == (80, 80, 20)
    assert len(m["loss_curve"]) == 3 and m["loss_curve"][-1] < m["loss_curve"][0]


def test_pure_objective_learns_from_box_init(room, data):
    train, held = data
    _, m = fit_map(train, FitConfig(seed=7, free_space_weight=0.0, **QUICK), heldout=held)
    assert m["depth_mae_m"] < 0.06 and m["coverage"] > 0.99


def test_same_seed_same_map(data):
    train, _ = data
    cfg = FitConfig(seed=3, **{**QUICK, "steps": 20})
    a, _ = fit_map(train, cfg)
    b, _ = fit_map(train, cfg)
    np.testing.assert_array_equal(a.occ, b.occ)
    np.testing.assert_array_equal(a.col, b.col)
    c, _ = fit_map(train, FitConfig(seed=4, **{**QUICK, "steps": 20}))
    assert not np.array_equal(a.occ, c.occ)


def test_progress_is_called(data):
    calls = []
    fit_map(data[0], FitConfig(**{**QUICK, "steps": 20}), progress=lambda s, t, l: calls.append((s, t)))
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


def test_dense_torch_path_fits_the_tiny_level_too(room, data):
    """The GPU path (dense eq. 1 through autograd, torch Adam) run on the CPU: same objective,
    so it reaches the same kind of map as the sparse path on the same data and budget."""
    train, held = data
    vmap, m = fit_map(train, FitConfig(seed=7, device="torch-cpu", **QUICK), heldout=held, level=room)
    assert m["device"] == "cpu" and vmap.meta["device"] == "cpu"
    assert m["coverage"] > 0.99
    assert m["depth_mae_m"] < 0.05
    assert m["slice_precision"] > 0.9 and m["slice_recall"] > 0.9
    assert m["loss_curve"][-1] < m["loss_curve"][0]
    assert vmap.occ.dtype == np.float32 and vmap.occ.shape == (80, 80, 20)


def test_device_option_is_checked():
    with pytest.raises(ConfigError, match="unknown device"):
        FitConfig(device="tpu")
    if not torch.cuda.is_available():
        from navbench.worldmodel.fit import resolve_fit_device

        assert resolve_fit_device("auto") == "cpu"
        with pytest.raises(ConfigError, match="no CUDA"):
            resolve_fit_device("cuda")
