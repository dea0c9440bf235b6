"""Emission-based tracking through the differentiable renderer."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.errors import TrackingError
from navbench.geometry import HALF_CAMERA, Intrinsics
from navbench.sim.dynamics import Control, predict
from navbench.track import emission
from navbench.track.registry import make_estimator

from .synth import small_level

SMALL = Intrinsics(80, 60, 37.5, 37.5, 40.0, 30.0)


@pytest.fixture(scope="module")
def room_map():
    from navbench.worldmodel.grid import grid_for_level, voxelize_level

    return voxelize_level(small_level(), grid_for_level(small_level(), shape=(100, 80, 24)))


@pytest.mark.parametrize("param", ["planar", "se3"])
def test_emission_recovers_a_known_offset(room_map, param):
    """The map is the world: observations rendered by the map itself at the true pose."""
    from navbench.worldmodel.fastrender import FastRenderer

    world = FastRenderer(room_map, SMALL)
    z0 = np.array([1.2, 1.0, 0.5])
    u = Control(math.radians(5.0), 0.5, 0.12)
    true = predict(z0, u) + np.array([0.03, -0.04, math.radians(2.0)])  # 5 cm, 2 deg
    est = make_estimator("emission", vmap=room_map, intrinsics=SMALL, param=param)
    est.reset(z0, world.render(z0))
    out = est.update(u, world.render(true))
    loc = math.hypot(*(out[:2] - true[:2]))
    rot = abs(math.degrees(out[2] - true[2]))
    assert loc < 0.005 and rot < 0.2, (loc, rot)
    assert est.last_timing["render"] == 0.0 and est.last_timing["estimate"] > 0


def test_emission_gradient_equals_finite_differences(room_map):
    """The planar pose gradient of the emission NLL against central differences (float32 renderer)."""
    from navbench.worldmodel.fastrender import FastRenderer

    world = FastRenderer(room_map, SMALL)
    true = np.array([1.5, 1.2, 0.4])
    frame = world.render(true + np.array([0.02, 0.01, 0.03]))
    cfg = emission.EmissionConfig(sigma2=0.5)
    obj = emission.EmissionObjective(room_map, SMALL, 0.5, cfg)
    idx = np.arange(0, SMALL.width * SMALL.height, 7)
    _, g = obj.value_and_grad("planar", true, frame, idx)
    eps = np.array([1e-4, 1e-4, 1e-4])
    for c in range(3):
        d = np.zeros(3)
        d[c] = eps[c]
        fp, _ = obj.value_and_grad("planar", true + d, frame, idx)
        fm, _ = obj.value_and_grad("planar", true - d, frame, idx)
        fd = (fp - fm) / (2 * eps[c])
        assert abs(fd - g[c]) <= 0.03 * abs(g[c]) + 20.0, (c, fd, g[c])


def test_emission_needs_a_map_and_known_options(room_map):
    with pytest.raises(TrackingError):
        make_estimator("emission", intrinsics=HALF_CAMERA)
    with pytest.raises(TrackingError):
        make_estimator("emission", vmap=room_map, intrinsics=SMALL, learning_rate=1)
    cfg = make_estimator("emission", vmap=room_map, intrinsics=SMALL).config
    assert (cfg.steps, cfg.pixels, cfg.lr) == (100, 1000, (0.001, 0.002))
    from navbench.worldmodel.fastrender import FastRenderer

    est = make_estimator("emission", vmap=room_map, intrinsics=SMALL)
    frame = FastRenderer(room_map, SMALL).render(np.array([1.2, 1.0, 0.5]))
    with pytest.raises(TrackingError, match="before reset"):
        est.update(Control(0.0, 0.5, 0.1), frame)
    est.reset(np.array([1.2, 1.0, 0.5]), frame)
    wrong = FastRenderer(room_map, HALF_CAMERA).render(np.array([1.2, 1.0, 0.5]))
    with pytest.raises(TrackingError, match="intrinsics say"):
        est.update(Control(0.0, 0.5, 0.1), wrong)
