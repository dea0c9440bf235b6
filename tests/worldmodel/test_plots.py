"""Map drawings: they draw what the map holds into the given axes."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from navbench.level import occupancy_raster  # noqa: E402
from navbench.worldmodel.grid import grid_for_level, occupancy_slice, voxelize_level  # noqa: E402
from navbench.worldmodel.plots import draw_isometric, draw_slice, occupied_voxels  # noqa: E402


def test_draw_slice_and_isometric(room):
    vm = voxelize_level(room, grid_for_level(room, shape=(60, 60, 20)))
    fig = plt.figure()
    ax = fig.add_subplot(1, 2, 1)
    true, _, _ = occupancy_raster(room, vm.spec.size[0], z_low=0.05)
    im = draw_slice(ax, vm, true_occ=true)
    occ2d, _, _ = occupancy_slice(vm)
    np.testing.assert_array_equal(np.asarray(im.get_array()).T.astype(bool), occ2d)
    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    sc = draw_isometric(ax3, vm, max_points=500)
    assert len(sc.get_offsets()) == 500
    pts, cols = occupied_voxels(vm, max_points=10**9)
    assert np.all(pts[:, 2] > 0.02) and np.all((cols >= 0) & (cols <= 1))
    plt.close(fig)
