"""Rendering an online map (:mod:`navbench.worldmodel.fusion`) while it is being built.

The fast renderer (:class:`~navbench.worldmodel.fastrender.FastRenderer`) skips empty space with
two distance tables that cost ~100 ms to build exactly on the paper grid; an online map changes
every frame, so :class:`FusedRenderer` keeps cheaper lower bounds of them
(:func:`block_skip_tables`, a few ms) up to date whenever the map changed: around the cells one
fusion wrote (:class:`BlockSkipTables`), or whole. Lower bounds skip only samples that cannot
cross, so the images are identical to those of the exact tables (tested).
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
    return BlockSkipTables(occ, tau, block, cap).tables


def _check_block(block: int) -> None:
    from navbench.worldmodel.fastrender import SLAB

    if block < SLAB:
        raise ConfigError(f"block_skip_tables: block {block} < SLAB {SLAB}")


def _block_cells(flags: np.ndarray, block: int, cap: int) -> tuple[np.ndarray, np.ndarray]:
    """The two tables of :func:`block_skip_tables` per block (cells, int32) from the block flags."""
    cube = np.ones((3, 3, 3), bool)
    d = _chebyshev(flags, cube, cap)
    near = flags.copy()
    near[:, :, 1:] |= flags[:, :, :-1]
    near[:, :, :-1] |= flags[:, :, 1:]
    layer = np.zeros((3, 3, 3), bool)
    layer[:, :, 1] = True
    d2 = _chebyshev(near, layer, cap)
    return tuple(np.where(t > 0, (t - 1) * block + 1, 0).clip(0, cap).astype(np.int32) for t in (d, d2))


@nb.njit(cache=True)
def _expand_blocks(cells, shape, b):
    """``(shape)`` int32: every cell takes the value of its block in ``cells``."""
    out = np.empty((shape[0], shape[1], shape[2]), np.int32)
    for i in range(shape[0]):
        for j in range(shape[1]):
            for k in range(shape[2]):
                out[i, j, k] = cells[i // b, j // b, k // b]
    return out


@nb.njit(cache=True)
def _block_flags_region(occ, tau, b, flags, lo, hi):
    """:func:`_block_flags` again for the blocks ``lo .. hi`` (inclusive, per axis) only, in
    place: every cell whose value can flag one of them is read (a block's interpolation cells
    have corners up to one cell past the block), the others are left as they are."""
    nx, ny, nz = occ.shape
    for bi in range(lo[0], hi[0] + 1):
        for bj in range(lo[1], hi[1] + 1):
            for bk in range(lo[2], hi[2] + 1):
                flags[bi, bj, bk] = False
    for i in range(lo[0] * b, min(hi[0] * b + b, nx - 1) + 1):
        for j in range(lo[1] * b, min(hi[1] * b + b, ny - 1) + 1):
            for k in range(lo[2] * b, min(hi[2] * b + b, nz - 1) + 1):
                if occ[i, j, k] > tau:
                    for ii in range(max(i - 1, 0), min(i, nx - 2) + 1):
                        if ii // b < lo[0] or ii // b > hi[0]:
                            continue
                        for jj in range(max(j - 1, 0), min(j, ny - 2) + 1):
                            if jj // b < lo[1] or jj // b > hi[1]:
                                continue
                            for kk in range(max(k - 1, 0), min(k, nz - 2) + 1):
                                if lo[2] <= kk // b <= hi[2]:
                                    flags[ii // b, jj // b, kk // b] = True


@nb.njit(cache=True)
def _expand_changed(new, old, out, b):
    """Write into ``out`` (the expansion of ``old``, :func:`_expand_blocks`) the cells of every
    block whose value differs in ``new``, so that ``out`` becomes the expansion of ``new``."""
    n0, n1, n2 = out.shape
    for bi in range(new.shape[0]):
        for bj in range(new.shape[1]):
            for bk in range(new.shape[2]):
                v = new[bi, bj, bk]
                if v == old[bi, bj, bk]:
                    continue
                for i in range(bi * b, min(bi * b + b, n0)):
                    for j in range(bj * b, min(bj * b + b, n1)):
                        for k in range(bk * b, min(bk * b + b, n2)):
                            out[i, j, k] = v


class BlockSkipTables:
    """:func:`block_skip_tables` of an online map kept up to date by its changes: after a
    change that wrote occupancy only inside a box of cells (:attr:`FusedMap.dirty
    <navbench.worldmodel.fusion.FusedMap.dirty>`), :meth:`update` reads the block flags again
    only around it, recomputes the (small) block tables, and rewrites the cells of the blocks
    whose value changed. ``tables`` equals ``block_skip_tables(occ, tau)`` after every update
    (tested against it frame by frame); it is rewritten in place."""

    def __init__(self, occ: np.ndarray, tau: float, block: int = SKIP_BLOCK, cap: int = 1000):
        _check_block(block)
        self.block, self.cap, self.tau = int(block), int(cap), float(tau)
        occ = np.ascontiguousarray(occ, np.float32)
        self.flags = _block_flags(occ, self.tau, self.block)
        self.cells = _block_cells(self.flags, self.block, self.cap)
        shape = np.array([n - 1 for n in occ.shape], np.int64)
        self.tables = tuple(_expand_blocks(c, shape, self.block) for c in self.cells)

    def update(self, occ: np.ndarray, box: tuple) -> None:
        """Bring the tables up to ``occ`` after a change that wrote occupancy only inside the
        cells ``box = (i0, i1, j0, j1, k0, k1)`` (inclusive; empty when ``i1 < i0``)."""
        i0, i1, j0, j1, k0, k1 = box
        if i1 < i0 or j1 < j0 or k1 < k0:
            return
        b = self.block
        top = np.array(self.flags.shape, np.int64) - 1
        # a cell i flags the interpolation cells i - 1 and i
        lo = np.maximum(np.array([i0 - 1, j0 - 1, k0 - 1]), 0) // b
        hi = np.minimum(np.array([i1, j1, k1]) // b, top)
        _block_flags_region(occ, self.tau, b, self.flags, lo.astype(np.int64), hi.astype(np.int64))
        cells = _block_cells(self.flags, b, self.cap)
        for new, old, out in zip(cells, self.cells, self.tables):
            _expand_changed(new, old, out, b)
        self.cells = cells


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
        self._skip = None

    def renderer(self):
        """The :class:`FastRenderer` of the map as it is now."""
        from navbench.worldmodel.fastrender import FastRenderer

        f = self.fused
        if self._fr is None or self._version != f.version:
            if self._skip is not None and f.version == self._version + 1 and f.dirty is not None:
                self._skip.update(f.vmap.occ, f.dirty)  # one fusion since: only around what it wrote
            else:
                self._skip = BlockSkipTables(f.vmap.occ, f.vmap.tau)
            max_range, step, parallel = self._args
            self._fr = FastRenderer(f.vmap, self.intrinsics, self.camera_height, max_range, step,
                                    parallel, skip_tables=self._skip.tables)
            self._version = f.version
        return self._fr

    def render(self, pose) -> Frame:
        return self.renderer().render(pose)
