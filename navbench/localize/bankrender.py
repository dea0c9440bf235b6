"""The bank's panoramas in one compiled pass (the fast path of :func:`~navbench.localize.signature.panorama`).

:func:`~navbench.localize.signature.panorama` renders four thin quadrant images per lattice point
through the renderer's Python interface and turns each into a signature with numpy: for the
localiser's default camera (97 x 4 pixels) the Python and numpy around each render cost about
half as much as the render itself, and the unknown-house loop builds a bank of thousands of
points at every goal match. :func:`panoramas` does the same per point inside one numba kernel
when the renderer is a :class:`~navbench.worldmodel.fastrender.FastRenderer`: the same ray
marcher (``_render_pixel``), and the signature's and the resampling's arithmetic in the same
order, with every quantity that does not depend on the point (row and column weights, which
bins each quadrant fills) computed once by the numpy code of the reference. The result is
bit-identical to the reference loop (tested on fitted, true and partly seen maps); any other
renderer takes the reference loop.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from navbench.geometry import Intrinsics, camera_rotation
from navbench.localize import signature as sig
from navbench.worldmodel.fastrender import FastRenderer, _render_pixel


def _quadrant_tables(quad: Intrinsics, bins: int, ycs: np.ndarray):
    """What :func:`~navbench.localize.signature.column_signature` and
    :func:`~navbench.localize.signature.resample_columns` compute without the image (the same
    helpers): row indices and weights, the per-column range factor, and per quadrant the bins it
    writes (in the reference's order, a later quadrant overwriting a shared boundary bin) with
    their column indices and weights, and its rotation."""
    j0, j1, wr = sig.row_weights(quad, ycs)
    qbins = np.full((4, bins), -1, np.int64)
    qi0 = np.zeros((4, bins), np.int64)
    qw = np.zeros((4, bins))
    counts = np.zeros(4, np.int64)
    rots = np.empty((4, 3, 3))
    for q in range(4):
        head, sel, angles = sig.quadrant_bins(bins, q)
        i0, w = sig.column_weights(quad, angles)
        n = len(angles)
        counts[q] = n
        qbins[q, :n] = np.flatnonzero(sel)
        qi0[q, :n] = i0
        qw[q, :n] = w
        rots[q] = camera_rotation(head)
    return j0, j1, wr, sig.range_scale(quad), qbins, qi0, qw, counts, rots


@nb.njit(cache=True, parallel=True)
def _panoramas_kernel(occ, col, dist, dist2, centres, inv_size, rots, rays, step, n, tau,
                      j0, j1, wr, scale, qbins, qi0, qw, counts, grey_weight, inverse, max_range, pano):
    """``pano (N, 2 * rows, bins)`` float32 of the points whose camera centres (continuous cell
    indices) are ``centres (N, 3)``: per point and quadrant, the render of ``rays`` at rotation
    ``rots[q]`` (``_render_pixel``), its column signature and its resampling to the quadrant's
    bins, each expression as the reference writes it."""
    nx, ny, nz = occ.shape
    H, W = rays.shape[0], rays.shape[1]
    rows = j0.shape[0]
    C = 2 * rows
    bins = pano.shape[2]
    for p in nb.prange(centres.shape[0]):
        depth = np.empty((H, W), np.float32)
        rgb = np.empty((H, W, 3), np.float32)
        valid = np.empty((H, W), np.bool_)
        feat = np.empty((H, W))
        grey = np.empty((H, W))
        sg = np.empty((C, W))
        out = np.empty((C, bins))
        u_c = centres[p]
        for q in range(4):
            R = rots[q]
            for r in range(H):
                for c in range(W):
                    _render_pixel(occ, col, dist, dist2, u_c, inv_size, R, rays, step, n, tau, r, c,
                                  nx, ny, nz, depth, rgb, valid)
            for r in range(H):
                for c in range(W):
                    d = depth[r, c]
                    ok = valid[r, c] and np.isfinite(d)
                    if inverse:
                        feat[r, c] = 1.0 / (np.float64(d) * scale[c]) if ok else 0.0
                    else:
                        feat[r, c] = (min(np.float64(d) * scale[c], max_range) if ok else max_range) / max_range
                    grey[r, c] = ((np.float64(rgb[r, c, 0]) + np.float64(rgb[r, c, 1]))
                                  + np.float64(rgb[r, c, 2])) / 3.0 * grey_weight
            for e in range(rows):
                a, b1, w = j0[e], j1[e], wr[e]
                for c in range(W):
                    sg[e, c] = (1 - w) * feat[a, c] + w * feat[b1, c]
                    sg[rows + e, c] = (1 - w) * grey[a, c] + w * grey[b1, c]
            for t in range(counts[q]):
                i0, w = qi0[q, t], qw[q, t]
                for ch in range(C):
                    out[ch, qbins[q, t]] = sg[ch, i0] * (1 - w) + sg[ch, i0 + 1] * w
        for ch in range(C):
            for b in range(bins):
                pano[p, ch, b] = out[ch, b]


def panoramas(render, points: np.ndarray, bins: int, ycs: np.ndarray, grey_weight: float,
              quad: Intrinsics, kind: str = "range", max_range: float = 8.0) -> np.ndarray:
    """``(N, 2 * len(ycs), bins)`` float32: :func:`~navbench.localize.signature.panorama` at every
    point of ``points (N, 2)``. ``render``: the quadrant camera's renderer (``.render(pose) ->
    Frame``); a :class:`~navbench.worldmodel.fastrender.FastRenderer` takes the compiled pass
    (identical output), anything else the reference loop."""
    points = np.asarray(points)
    pano = np.empty((len(points), 2 * len(ycs), bins), np.float32)
    if not isinstance(render, FastRenderer) or kind not in ("range", "inverse"):
        for i, xy in enumerate(points):
            pano[i] = sig.panorama(render.render, xy, bins, ycs, grey_weight, quad, kind, max_range)
        return pano
    if len(points) == 0:
        return pano
    j0, j1, wr, scale, qbins, qi0, qw, counts, rots = _quadrant_tables(quad, bins, ycs)
    t = np.empty((len(points), 3))  # camera_pose's translations
    t[:, :2] = points
    t[:, 2] = render.camera_height
    _panoramas_kernel(render.vmap.occ, render._col, render.dist, render.dist2, render.centre_index(t),
                      render._inv, rots,
                      render.rays, render.step, render.n, render.vmap.tau, j0, j1, wr, scale, qbins,
                      qi0, qw, counts, float(grey_weight), kind == "inverse", float(max_range), pano)
    return pano
