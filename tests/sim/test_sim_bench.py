"""Timing helpers: shapes and bookkeeping only (no timing asserts)."""

import math

import numpy as np

from navbench.geometry import AGENT_LENGTH, Intrinsics
from navbench.level import distance_to_solids
from navbench.sim.bench import bench_poses, summarise, time_render, time_step

from .fixtures import rooms


def test_bench_functions_return_one_time_per_repeat():
    level = rooms()
    t = time_render(level, Intrinsics(16, 12, 8.0, 8.0, 8.0, 6.0), repeats=5, warmup=1)
    assert len(t) == 5 and all(x > 0 for x in t)
    t = time_step(level, repeats=20, warmup=2)
    assert len(t) == 20 and all(x > 0 for x in t)
    p = bench_poses(level, 10, seed=1)
    assert p.shape == (10, 3) and distance_to_solids(level, p[:, :2]).min() >= 1.2 * AGENT_LENGTH
    np.testing.assert_array_equal(p, bench_poses(level, 10, seed=1))


def test_summarise():
    s = summarise([3.0, 1.0, 2.0])
    assert s["n"] == 3 and s["median"] == 2.0 and s["min"] == 1.0
    assert math.isnan(summarise([])["median"])
