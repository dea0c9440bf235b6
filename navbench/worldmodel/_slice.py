"""The compiled planning slice of :func:`navbench.worldmodel.grid.occupancy_slice` (apart from
``grid`` so that importing the map format does not import numba)."""

from __future__ import annotations

import numba as nb
import numpy as np

from navbench.worldmodel.fastrender import _cell  # the renderers' clamped index, the same floats


@nb.njit(cache=True)
def _slice_max(occ, lo, size, xs, ys, heights):
    """:func:`navbench.worldmodel.grid.slice_values_reference` compiled: per point the same
    expressions as :func:`~navbench.worldmodel.grid.trilinear` (``u = (p - lo) / size - 0.5``
    clipped, the 8 corners summed in the same order), so the same floats, without its ~20
    temporary arrays per height."""
    nx, ny, nz = occ.shape
    out = np.empty((xs.shape[0], ys.shape[0]))
    for a in range(xs.shape[0]):
        i, tx = _cell((xs[a] - lo[0]) / size[0] - 0.5, nx)
        for b in range(ys.shape[0]):
            j, ty = _cell((ys[b] - lo[1]) / size[1] - 0.5, ny)
            best = 0.0
            for h in range(heights.shape[0]):
                k, tz = _cell((heights[h] - lo[2]) / size[2] - 0.5, nz)
                f = 0.0
                for dx in range(2):
                    wx = tx if dx else 1 - tx
                    for dy in range(2):
                        wy = ty if dy else 1 - ty
                        for dz in range(2):
                            wz = tz if dz else 1 - tz
                            f = f + wx * wy * wz * np.float64(occ[i + dx, j + dy, k + dz])
                best = f if h == 0 else max(best, f)
            out[a, b] = best
    return out
