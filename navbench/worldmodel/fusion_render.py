"""Rendering an online map (:mod:`navbench.worldmodel.fusion`) while it is being built.

The fast renderer (:class:`~navbench.worldmodel.fastrender.FastRenderer`) skips empty space with
two distance tables that cost ~100 ms to build exactly on the paper grid; an online map changes
every frame, so :class:`FusedRenderer` rebuilds cheaper lower bounds of them
(:func:`block_skip_tables`, a few ms) whenever the map changed. Lower bounds skip only samples
that cannot cross, so the images are identical to those of the exact tables (tested).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from navbench.errors import ConfigError
from navbench.geometry import CAMERA_HEIGHT, MAX_RANGE, Frame, Intrinsics

#: Block size (cells) of the online map's skip tables (:func:`block_skip_tables`).
SKIP_BLOCK = 4


@nb.njit(cache=True)
def _block_flags(occ, tau, b):
    """``(BX, BY, BZ)`` bool: blocks of ``b^3`` interpolation cells that hold a cell where ``f``
    may exceed ``tau`` (an interpolation cell with a corner ``> tau``)."""
    nx, ny, nz = occ.shape
    bx, by, bz = (nx - 2) // b + 1, (ny - 2) // b + 1, (nz - 2) // b + 1
    flags = np.zeros((bx, by, bz), np.bool_)
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                if occ[i, j, k] > tau:
                    for ii in range(max(i - 1, 0), min(i, nx - 2) + 1):
                        for jj in range(max(j - 1, 0), min(j, ny - 2) + 1):
                            for kk in range(max(k - 1, 0), min(k, nz - 2) + 1):
                                flags[ii // b, jj // b, kk // b] = True
    return flags


def _chebyshev(full: np.ndarray, structure: np.ndarray, cap: int) -> np.ndarray:
    """Chessboard distance (blocks) to the nearest ``full`` block along ``structure``; 0 on full
    blocks, ``cap`` where there is none (as :func:`~navbench.worldmodel.fastrender.skip_distance`)."""
    from scipy.ndimage import distance_transform_cdt

    empty = ~full
    if empty.all():
        return np.full(full.shape, cap, np.int64)
    if not empty.any():
        return np.zeros(full.shape, np.int64)
    d = distance_transform_cdt(empty, metric=structure).astype(np.int64)
    d[d < 0] = cap
    return np.minimum(d, cap)


def block_skip_tables(occ: np.ndarray, tau: float, block: int = SKIP_BLOCK,
                      cap: int = 1000) -> tuple[np.ndarray, np.ndarray]:
    """Lower bounds of :func:`~navbench.worldmodel.fastrender.skip_distance`'s two tables
    (``slab=None`` and ``slab=SLAB``), from ``block^3`` blocks of interpolation cells: a cell in a
    block at Chebyshev distance ``d >= 1`` (blocks) from every non-empty block is at least
    ``(d - 1) * block + 1`` cells from every non-empty cell. The slab table counts the blocks of
    the layers within one block of the cell's (``block >= SLAB``, so they cover its ``SLAB``
    layers). The renderer skips only samples that cannot cross with any lower bound, so images
    are identical to those of the exact tables; building these costs a few milliseconds
    instead of the exact tables' ~100 (the online map changes every frame).
    """
    from navbench.worldmodel.fastrender import SLAB

    if block < SLAB:
        raise ConfigError(f"block_skip_tables: block {block} < SLAB {SLAB}")
    occ = np.ascontiguousarray(occ, np.float32)
    flags = _block_flags(occ, float(tau), int(block))
    cube = np.ones((3, 3, 3), bool)
    d = _chebyshev(flags, cube, cap)
    near = flags.copy()
    near[:, :, 1:] |= flags[:, :, :-1]
    near[:, :, :-1] |= flags[:, :, 1:]
    layer = np.zeros((3, 3, 3), bool)
    layer[:, :, 1] = True
    d2 = _chebyshev(near, layer, cap)
    shape = np.array([n - 1 for n in occ.shape], np.int64)
    out = []
    for t in (d, d2):
        cells = np.where(t > 0, (t - 1) * block + 1, 0).clip(0, cap).astype(np.int32)
        out.append(_expand_blocks(cells, shape, int(block)))
    return out[0], out[1]


@nb.njit(cache=True)
def _expand_blocks(cells, shape, b):
    """``(shape)`` int32: every cell takes the value of its block in ``cells``."""
    out = np.empty((shape[0], shape[1], shape[2]), np.int32)
    for i in range(shape[0]):
        for j in range(shape[1]):
            for k in range(shape[2]):
                out[i, j, k] = cells[i // b, j // b, k // b]
    return out


class FusedRenderer:
    """``render(pose) -> Frame`` of the current state of an online map ``fused`` (a
    :class:`~navbench.worldmodel.fusion.FusedMap`; the world model's
    :class:`~navbench.worldmodel.fastrender.FastRenderer`, with :func:`block_skip_tables` rebuilt
    whenever the map changed since the last render). Same arguments as ``FastRenderer``."""

    def __init__(self, fused, intrinsics: Intrinsics, camera_height: float = CAMERA_HEIGHT,
                 max_range: float = MAX_RANGE, step: float | None = None,
                 parallel: bool | None = None):
        self.fused = fused
        self.intrinsics = intrinsics
        self.camera_height = float(camera_height)
        self._args = (max_range, step, parallel)
        self._fr = None
        self._version = -1

    def renderer(self):
        """The :class:`FastRenderer` of the map as it is now."""
        from navbench.worldmodel.fastrender import FastRenderer

        f = self.fused
        if self._fr is None or self._version != f.version:
            tables = block_skip_tables(f.vmap.occ, f.vmap.tau)
            max_range, step, parallel = self._args
            self._fr = FastRenderer(f.vmap, self.intrinsics, self.camera_height, max_range, step,
                                    parallel, skip_tables=tables)
            self._version = f.version
        return self._fr

    def render(self, pose) -> Frame:
        return self.renderer().render(pose)
