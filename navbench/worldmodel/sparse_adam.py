"""Lazy Adam on the grid rows a step touched (numba): the CPU fit's optimiser kernels.

Eq. 3's gradient touches only the cells around the sampled rays, so the fit accumulates the
gradient of those rows (:func:`_scatter_mark`, which also lists each touched row once), applies
Adam to them alone (:func:`_adam_rows`: the rows are distinct, so they update in parallel with
the same result as one thread), and clears them (:func:`_zero_touched`). The torch device path
(:class:`navbench.worldmodel.fit_device.MaskedAdam`) has the same semantics and is tested against it.
"""

from __future__ import annotations

import math

import numba as nb


@nb.njit(cache=True)
def _scatter_mark(idx, w, g, grad, stamp, t, touched, count):
    """``grad[idx] += w g`` (as :func:`~navbench.worldmodel.diffrender.scatter_add`), listing
    each newly touched row once in ``touched`` (``stamp[row] == t`` marks it); returns the count."""
    C = g.shape[1]
    for q in range(idx.shape[0]):
        for a in range(8):
            r = idx[q, a]
            for c in range(C):
                grad[r, c] += w[q, a] * g[q, c]
            if stamp[r] != t:
                stamp[r] = t
                touched[count] = r
                count += 1
    return count


@nb.njit(cache=True, parallel=True)
def _adam_rows(p, g, mv, touched, count, t, lr, b1, b2, eps):
    """One Adam update of the rows ``touched[:count]`` of ``p``, zeroing ``g`` there.

    The touched rows are distinct, so the rows update in parallel with no race (and the same
    result as one thread)."""
    bc1 = 1.0 - b1 ** t
    bc2 = 1.0 - b2 ** t
    C = p.shape[1]
    for q in nb.prange(count):
        r = touched[q]
        for c in range(C):
            gg = g[r, c]
            m = b1 * mv[r, c, 0] + (1.0 - b1) * gg
            v = b2 * mv[r, c, 1] + (1.0 - b2) * gg * gg
            mv[r, c, 0] = m
            mv[r, c, 1] = v
            p[r, c] -= lr * (m / bc1) / (math.sqrt(v / bc2) + eps)
            g[r, c] = 0.0


@nb.njit(cache=True)
def _zero_touched(g, touched, count):
    for q in range(count):
        for c in range(g.shape[1]):
            g[touched[q], c] = 0.0
