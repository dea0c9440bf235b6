"""The compiled planning slice of :func:`navbench.worldmodel.grid.occupancy_slice` (apart from
``grid`` so that importing the map format does not import numba)."""

from __future__ import annotations

import math

import numba as nb
import numpy as np


@nb.njit(cache=True)
def _slice_max(occ, lo, size, xs, ys, heights):
    """:func:`navbench.worldmodel.grid.slice_values_reference` compiled: per point the same
    expressions as :func:`~navbench.worldmodel.grid.trilinear` (``u = (p - lo) / size - 0.5``
    clipped, the 8 corners summed in the same order), so the same floats, without its ~20
    temporary arrays per height."""
    nx, ny, nz = occ.shape
    out = np.empty((xs.shape[0], ys.shape[0]))
    for a in range(xs.shape[0]):
        ux = min(max((xs[a] - lo[0]) / size[0] - 0.5, 0.0), nx - 1)
        i = min(np.int64(math.floor(ux)), nx - 2)
        tx = ux - i
        for b in range(ys.shape[0]):
            uy = min(max((ys[b] - lo[1]) / size[1] - 0.5, 0.0), ny - 1)
            j = min(np.int64(math.floor(uy)), ny - 2)
            ty = uy - j
            best = 0.0
            for h in range(heights.shape[0]):
                uz = min(max((heights[h] - lo[2]) / size[2] - 0.5, 0.0), nz - 1)
                k = min(np.int64(math.floor(uz)), nz - 2)
                tz = uz - k
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
