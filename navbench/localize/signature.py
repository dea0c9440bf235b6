"""Panoramic signatures and their circular correlation (the localiser's coarse search).

A *signature* of an RGB-D image is, per image column, the inverse horizontal range ``1 / r``
(``r = z * sqrt(1 + x_c^2)`` for z-depth ``z`` and ``x_c = (i - cx) / fx``; 0 where nothing is
seen) and the grey level, each at ``rows`` elevations ``y_c = row_top + j * row_step``; columns
are resampled (linearly) to uniform heading bins of ``2 pi / bins``. Because the camera is
planar-mounted, a column's signature depends only on the camera position and the column's world
direction, so a 360-degree panorama of signatures per position holds every heading, and a query
with field of view ``+-R`` bins is a window of it: the squared distance at every circular shift
``s`` (heading ``2 pi s / bins``) is

    D[s] = sum_r |Q_r|^2 + sum_r |P_{s+r}|^2 - 2 sum_r <Q_r, P_{s+r}>,

whose last sum is a circular cross-correlation (one FFT product per position,
:func:`circular_costs`; :func:`circular_costs_direct` is the reference it is tested against).
Bin ``b`` of a panorama looks along world angle ``2 pi b / bins``; relative bin ``r`` of a query
looks ``2 pi r / bins`` counter-clockwise of the heading (image left).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from scipy import ndimage

from navbench.geometry import Frame, Intrinsics


def lattice_points(occ2d: np.ndarray, xs: np.ndarray, ys: np.ndarray, step: float,
                   clearance: float) -> np.ndarray:
    """Positions ``(N, 2)`` every ``step`` metres (a lattice through multiples of ``step``)
    inside the raster ``(xs, ys)`` whose cell is free and at least ``clearance`` metres (plus
    half a cell) from every occupied cell of ``occ2d (nx, ny)``."""
    occ2d = np.asarray(occ2d, bool)
    if occ2d.size == 0 or len(xs) < 2 or len(ys) < 2:
        return np.zeros((0, 2))
    dx, dy = float(xs[1] - xs[0]), float(ys[1] - ys[0])
    dist = ndimage.distance_transform_edt(~occ2d, sampling=(dx, dy))
    if not occ2d.any():  # nothing to keep away from: stay inside the raster
        dist = np.full(occ2d.shape, np.inf)
    gx = np.arange(math.ceil(xs[0] / step), math.floor(xs[-1] / step) + 1) * step
    gy = np.arange(math.ceil(ys[0] / step), math.floor(ys[-1] / step) + 1) * step
    X, Y = np.meshgrid(gx, gy, indexing="ij")
    ix = np.clip(np.rint((X - xs[0]) / dx).astype(int), 0, len(xs) - 1)
    iy = np.clip(np.rint((Y - ys[0]) / dy).astype(int), 0, len(ys) - 1)
    keep = dist[ix, iy] > clearance + 0.5 * max(dx, dy)
    return np.stack([X[keep], Y[keep]], axis=1)


def elevations(rows: int, row_top: float, row_step: float) -> np.ndarray:
    """The signature's ``y_c`` values (rows of the normalised image plane, down positive)."""
    return row_top + row_step * np.arange(rows)


def range_feature(r: np.ndarray, valid: np.ndarray, kind: str, max_range: float) -> np.ndarray:
    """The depth channel of a signature from horizontal ranges ``r`` (m): ``inverse`` ``1 / r``
    (0 where nothing is seen), ``range`` ``min(r, max_range) / max_range`` (1 where nothing is
    seen; a translation by ``d`` changes it by at most ``d / max_range``)."""
    if kind == "inverse":
        return np.where(valid, 1.0 / np.where(valid, r, 1.0), 0.0)
    return np.where(valid, np.minimum(np.where(valid, r, max_range), max_range), max_range) / max_range


def column_signature(frame: Frame, intr: Intrinsics, ycs: np.ndarray,
                     grey_weight: float, kind: str = "range", max_range: float = 8.0) -> np.ndarray:
    """Per-column signature ``(2 * len(ycs), W)`` float64 of ``frame``: the depth channel
    (:func:`range_feature` of the horizontal range) at each elevation, then ``grey_weight`` x
    grey level at each (rows interpolated linearly)."""
    j0, j1, w = row_weights(intr, ycs)
    w = w[:, None]
    valid = np.asarray(frame.valid, bool) & np.isfinite(frame.depth)
    r = np.where(valid, frame.depth, 1.0) * range_scale(intr)
    inv = range_feature(r, valid, kind, max_range)
    grey = np.asarray(frame.rgb, np.float64).mean(axis=2) * grey_weight
    out = np.empty((2 * len(ycs), intr.width))
    out[: len(ycs)] = (1 - w) * inv[j0] + w * inv[j1]
    out[len(ycs):] = (1 - w) * grey[j0] + w * grey[j1]
    return out


def row_weights(intr: Intrinsics, ycs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(j0, j1, w)``: the image rows below and above each elevation ``ycs`` and the weight of
    the second (:func:`column_signature` interpolates rows linearly)."""
    H = intr.height
    v = np.clip(intr.cy + np.asarray(ycs) * intr.fy, 0.0, H - 1.0)
    j0 = np.floor(v).astype(int)
    return j0, np.minimum(j0 + 1, H - 1), v - j0


def range_scale(intr: Intrinsics) -> np.ndarray:
    """``sqrt(1 + x_c^2)`` per column: z-depth to horizontal range."""
    xc = (np.arange(intr.width) - intr.cx) / intr.fx
    return np.sqrt(1.0 + xc * xc)


def column_weights(intr: Intrinsics, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(i0, w)``: the columns left of ``u = cx - fx tan(angle)`` for relative headings
    ``angles`` and the weight of the next one (:func:`resample_columns`)."""
    u = np.clip(intr.cx - intr.fx * np.tan(angles), 0.0, intr.width - 1.0)
    i0 = np.minimum(np.floor(u).astype(int), intr.width - 2)
    return i0, u - i0


def resample_columns(sig: np.ndarray, intr: Intrinsics, angles: np.ndarray) -> np.ndarray:
    """``sig (C, W)`` at relative headings ``angles`` (rad, counter-clockwise = image left),
    interpolated linearly between the columns ``u = cx - fx tan(angle)``."""
    i0, w = column_weights(intr, angles)
    return sig[:, i0] * (1 - w) + sig[:, i0 + 1] * w


def half_window(intr: Intrinsics, bins: int) -> int:
    """``R``: the query window is relative bins ``-R .. R``, all inside the image."""
    half_fov = min(math.atan(intr.cx / intr.fx), math.atan((intr.width - 1 - intr.cx) / intr.fx))
    return max(int(math.floor(half_fov / (2 * math.pi / bins) + 1e-9)), 0)


def query_signature(frame: Frame, intr: Intrinsics, ycs: np.ndarray, grey_weight: float,
                    bins: int, kind: str = "range", max_range: float = 8.0) -> np.ndarray:
    """The query window ``(C, 2R + 1)``: relative bins ``-R .. R`` (:func:`half_window`)."""
    R = half_window(intr, bins)
    angles = np.arange(-R, R + 1) * (2 * math.pi / bins)
    return resample_columns(column_signature(frame, intr, ycs, grey_weight, kind, max_range), intr, angles)


def quadrant_intrinsics(bins: int, rows: int, row_top: float, row_step: float) -> Intrinsics:
    """A thin 90-degree camera whose rows are the signature's elevations exactly (two columns
    per heading bin)."""
    W = bins // 2 + 1
    c = (W - 1) / 2.0
    return Intrinsics(W, rows, c, 1.0 / row_step, c, -row_top / row_step)


def panorama(render, xy, bins: int, ycs: np.ndarray, grey_weight: float,
             quad: Intrinsics, kind: str = "range", max_range: float = 8.0) -> np.ndarray:
    """The 360-degree signature ``(C, bins)`` at position ``xy``: four renders
    ``render(pose) -> Frame`` (camera ``quad``) at headings 0, 90, 180, 270 degrees."""
    out = np.empty((2 * len(ycs), bins))
    for q in range(4):
        head, sel, angles = quadrant_bins(bins, q)
        sig = column_signature(render((xy[0], xy[1], head)), quad, ycs, grey_weight, kind, max_range)
        out[:, sel] = resample_columns(sig, quad, angles)
    return out


def quadrant_bins(bins: int, q: int) -> tuple[float, np.ndarray, np.ndarray]:
    """``(heading, selected, angles)`` of quadrant render ``q`` of :func:`panorama`: its heading
    ``q pi / 2``, the bins it fills (within 45 degrees of it; a later quadrant overwrites a shared
    boundary bin) and their angles relative to it."""
    head = q * math.pi / 2
    rel = (np.arange(bins) * 2 * math.pi / bins - head + math.pi) % (2 * math.pi) - math.pi
    sel = np.abs(rel) <= math.pi / 4 + 1e-12
    return head, sel, rel[sel]


@njit(cache=True, fastmath=True)
def _channel_products(Fr, Fi, Qr, Qi, out_r, out_i):
    """``out[n, k] = sum_c F[n, c, k] * FQ[c, k]`` in real arithmetic (float32, one thread: no
    BLAS thread pool to oversubscribe a busy CPU)."""
    N, C, K = Fr.shape
    for n in range(N):
        for k in range(K):
            out_r[n, k] = 0.0
            out_i[n, k] = 0.0
        for c in range(C):
            for k in range(K):
                a = Fr[n, c, k]
                b = Fi[n, c, k]
                out_r[n, k] += a * Qr[c, k] - b * Qi[c, k]
                out_i[n, k] += a * Qi[c, k] + b * Qr[c, k]


@njit(cache=True, fastmath=True)
def truncated_costs(pano, Q, shifts, tau):
    """``out (N, S)``: ``sum_{c, r} min(|Q[c, r] - pano[n, c, (shifts[n, j] + r - R) % bins]|, tau)``,
    a robust window distance (changed columns cost at most ``tau`` each) at given shifts."""
    N, C, A = pano.shape
    S = shifts.shape[1]
    W = Q.shape[1]
    R = (W - 1) // 2
    out = np.empty((N, S))
    for n in range(N):
        for j in range(S):
            s0 = (shifts[n, j] - R) % A
            acc = 0.0
            for c in range(C):
                for r in range(W):
                    i = s0 + r
                    if i >= A:
                        i -= A
                    d = abs(Q[c, r] - pano[n, c, i])
                    acc += min(d, tau)
            out[n, j] = acc
    return out


def wrapped_panorama(pano: np.ndarray, W: int) -> np.ndarray:
    """``ext (N, C, bins + W - 1)`` float32 with ``ext[..., k] = pano[..., (k - R) % bins]``
    (``R = (W - 1) // 2``): the window's column ``r`` at shift ``s`` is ``ext[..., s + r]``, so
    the robust search reads every column's bins contiguously (its inner loop runs in SIMD)."""
    R = (W - 1) // 2
    A = pano.shape[-1]
    return np.ascontiguousarray(pano[..., (np.arange(A + 2 * R) - R) % A], np.float32)


def exhaustive_truncated(pano: np.ndarray, Q: np.ndarray, weight: np.ndarray, tau: np.ndarray,
                         wrapped: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(shift (N,), cost (N,))``: for every lattice point the best circular shift and its cost
    ``sum_{c, r} weight[c] * min(|Q[c, r] - pano[n, c, (s + r - R) % bins]|, tau[c])`` over
    *every* shift ``s`` (the first of equal minima), the robust search of changed rooms: unlike
    the L2 correlation, a column that new furniture fills costs at most ``weight . tau``, so the
    unchanged columns decide both the place and the heading. Channels of weight 0 are skipped.
    Sums are float32, all shifts of a point at once (a column's term for every shift is one
    contiguous SIMD loop: 3.6x the speed of a shift-by-shift loop on tune-house's 5978 points,
    the same argmins). ``wrapped``: :func:`wrapped_panorama` of ``pano`` if the caller keeps one. Points
    are spread over numba's threads; each point's sums run in one fixed order, so the result
    does not depend on the thread count."""
    Q = np.ascontiguousarray(Q, np.float32)
    if wrapped is None:
        wrapped = wrapped_panorama(pano, Q.shape[1])
    return _exhaustive(wrapped, Q, np.ascontiguousarray(weight, np.float32),
                       np.ascontiguousarray(tau, np.float32), pano.shape[-1])


@njit(cache=True, fastmath=True, parallel=True)
def _exhaustive(ext, Q, weight, tau, A):
    """:func:`exhaustive_truncated` on the wrapped panoramas ``ext (N, C, A + W - 1)``."""
    N, C, _ = ext.shape
    W = Q.shape[1]
    shift = np.empty(N, np.int64)
    cost = np.empty(N)
    for n in prange(N):
        acc = np.zeros(A, np.float32)
        for c in range(C):
            wc = weight[c]
            if wc == 0.0:
                continue
            tc = tau[c]
            for r in range(W):
                q = Q[c, r]
                row = ext[n, c, r:r + A]
                for s in range(A):
                    d = abs(q - row[s])
                    acc[s] += wc * (d if d < tc else tc)
        mb = 0
        m = acc[0]
        for s in range(1, A):
            if acc[s] < m:
                m = acc[s]
                mb = s
        shift[n] = mb
        cost[n] = m
    return shift, cost


@njit(cache=True, fastmath=True)
def _row_minima(qq, energy, corr, shift, cost):
    """``shift[n], cost[n]``: argmin and min over ``s`` of ``qq + energy[n, s] - 2 corr[n, s]``
    (one pass, no ``(N, bins)`` temporaries)."""
    N, A = corr.shape
    for n in range(N):
        b = 0
        m = qq + energy[n, 0] - 2.0 * corr[n, 0]
        for s in range(1, A):
            v = qq + energy[n, s] - 2.0 * corr[n, s]
            if v < m:
                m = v
                b = s
        shift[n] = b
        cost[n] = m


@njit(cache=True, fastmath=True)
def trimmed_costs(pano, Q, shifts, tau, keep):
    """``out (N, S)``: per column ``r`` of the window the truncated L1 ``c_r = sum_c min(|Q[c, r]
    - pano[n, c, (shifts[n, j] + r - R) % bins]|, tau)``, summed over the ``keep`` smallest
    ``c_r`` (the other columns, e.g. those new furniture fills, are dropped: a trimmed sum over
    columns). ``keep >= W`` is :func:`truncated_costs`."""
    N, C, A = pano.shape
    S = shifts.shape[1]
    W = Q.shape[1]
    R = (W - 1) // 2
    out = np.empty((N, S))
    col = np.empty(W)
    for n in range(N):
        for j in range(S):
            s0 = (shifts[n, j] - R) % A
            for r in range(W):
                i = s0 + r
                if i >= A:
                    i -= A
                acc = 0.0
                for c in range(C):
                    d = abs(Q[c, r] - pano[n, c, i])
                    acc += min(d, tau)
                col[r] = acc
            if keep >= W:
                out[n, j] = col.sum()
            else:
                out[n, j] = np.sort(col)[:keep].sum()
    return out


#: Lattice points per block of :meth:`Correlator.best` (house-1's 6408 points: 5.6 -> 5.1 ms a
#: query at 512, measured alternating; 64 is slower than one block, 256-1024 alike).
BEST_BLOCK = 512


class Correlator:
    """The FFT form of the panoramas ``pano (N, C, bins)`` for windows of ``-R .. R`` bins."""

    def __init__(self, pano: np.ndarray, R: int):
        self.bins = pano.shape[-1]
        self.R = R
        A = self.bins
        F = np.fft.rfft(pano, axis=-1)  # (N, C, k)
        self.Fr = np.ascontiguousarray(F.real, dtype=np.float32)
        self.Fi = np.ascontiguousarray(F.imag, dtype=np.float32)
        box = np.zeros(A)
        box[np.arange(-R, R + 1) % A] = 1.0
        e = np.fft.irfft(np.conj(np.fft.rfft(box)) * np.fft.rfft((pano.astype(np.float64) ** 2).sum(1), axis=-1),
                         n=A, axis=-1)
        self.energy = e.astype(np.float32)  # (N, bins): sum_r |P_{s+r}|^2

    def costs(self, Q: np.ndarray) -> np.ndarray:
        """``D (N, bins)``: squared distance of the window ``Q (C, 2R + 1)`` at every shift."""
        A = self.bins
        qpad = np.zeros((Q.shape[0], A))
        qpad[:, np.arange(-self.R, self.R + 1) % A] = Q
        FQ = np.conj(np.fft.rfft(qpad, axis=-1))  # (C, k)
        Qr = np.ascontiguousarray(FQ.real, dtype=np.float32)
        Qi = np.ascontiguousarray(FQ.imag, dtype=np.float32)
        N, _, K = self.Fr.shape
        pr, pi = np.empty((N, K), np.float32), np.empty((N, K), np.float32)
        _channel_products(self.Fr, self.Fi, Qr, Qi, pr, pi)
        corr = np.fft.irfft(pr + 1j * pi, n=A, axis=-1)
        return float((Q ** 2).sum()) + self.energy - 2.0 * corr

    def best(self, Q: np.ndarray, block: int = BEST_BLOCK) -> tuple[np.ndarray, np.ndarray]:
        """``(shift (N,) int, cost (N,))``: each point's best shift and its cost, the row minima
        of :meth:`costs` (float32 FFTs through :mod:`scipy.fft`, minima in one fused pass),
        ``block`` lattice points at a time so that a block's products, correlations and minima
        stay in cache (each row's arithmetic is the same: the result does not depend on
        ``block``, tested)."""
        from scipy import fft as sfft

        A = self.bins
        qpad = np.zeros((Q.shape[0], A), np.float32)
        qpad[:, np.arange(-self.R, self.R + 1) % A] = Q
        FQ = np.conj(sfft.rfft(qpad, axis=-1))
        Qr = np.ascontiguousarray(FQ.real, dtype=np.float32)
        Qi = np.ascontiguousarray(FQ.imag, dtype=np.float32)
        N, _, K = self.Fr.shape
        qq = float((np.asarray(Q, np.float64) ** 2).sum())
        shift, cost = np.empty(N, np.int64), np.empty(N, np.float64)
        B = max(1, min(int(block), N))
        prod = np.empty((B, K), np.complex64)
        pr, pi = np.empty((B, K), np.float32), np.empty((B, K), np.float32)
        for a in range(0, N, B):
            b = min(a + B, N)
            m = b - a
            _channel_products(self.Fr[a:b], self.Fi[a:b], Qr, Qi, pr[:m], pi[:m])
            prod.real[:m], prod.imag[:m] = pr[:m], pi[:m]
            corr = sfft.irfft(prod[:m], n=A, axis=-1, workers=1)
            _row_minima(qq, self.energy[a:b], corr, shift[a:b], cost[a:b])
        return shift, cost


def circular_costs(pano: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """``D (N, bins)`` by FFT (:class:`Correlator`) for panoramas ``(N, C, bins)``."""
    R = (Q.shape[1] - 1) // 2
    return Correlator(pano, R).costs(Q)


def circular_costs_direct(pano: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Reference for :func:`circular_costs`: the sums written out."""
    N, C, A = pano.shape
    R = (Q.shape[1] - 1) // 2
    out = np.zeros((N, A))
    for s in range(A):
        idx = (s + np.arange(-R, R + 1)) % A
        out[:, s] = ((pano[:, :, idx] - Q[None]) ** 2).sum(axis=(1, 2))
    return out
