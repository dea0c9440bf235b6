"""The localiser's candidate bookkeeping: the coarse candidates after non-maximum suppression
(:func:`candidates`, its compiled suppression :func:`_suppress`), when two coarse poses are one
candidate, and the de-duplication of refined hypotheses (``cfg``: a
:class:`~navbench.localize.localizer.LocalizerConfig`; ``hyps``: its ``Hypothesis`` objects).
Arrays in, arrays out."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from navbench.geometry import wrap_angle


def candidates(best_s: np.ndarray, best: np.ndarray, points: np.ndarray, k: int,
               cfg, costs: list | None = None) -> list[np.ndarray]:
    """The ``k`` best (lattice point, heading) given each point's best heading bin ``best_s (N,)``
    and its cost ``best (N,)`` (``inf``: not a candidate), each a local minimum over the others
    within ``nms_radius`` m and ``nms_deg`` degrees (non-maximum suppression), best first, as
    poses ``(x, y, theta)``. The suppression is :func:`_suppress` (compiled; the numpy loop it
    replaced is its reference in the tests, equal bit for bit). ``costs``: a list the kept
    candidates' costs are appended to."""
    bins = cfg.bins
    idx = np.flatnonzero(np.isfinite(best))
    idx = idx[np.argsort(best[idx], kind="stable")]
    heads = best_s[idx] * (2 * math.pi / bins)
    xy = np.ascontiguousarray(points[idx], dtype=np.float64)
    keep = _suppress(xy, np.ascontiguousarray(heads, dtype=np.float64), int(k),
                     float(cfg.nms_radius), math.radians(cfg.nms_deg))
    if costs is not None:
        costs.extend(float(best[idx[p]]) for p in keep)
    return [np.array([xy[p, 0], xy[p, 1], float(wrap_angle(heads[p]))]) for p in keep]


@njit(cache=True)
def _suppress(xy, heads, k, radius, max_dh):
    """Greedy non-maximum suppression over points sorted best first: the positions kept (at most
    ``k``); each kept point removes every still-alive point (itself included) within ``radius``
    (``hypot``) and ``max_dh`` (wrapped heading difference, as :func:`wrap_angle`)."""
    n = heads.shape[0]
    alive = np.ones(n, np.bool_)
    out = np.empty(max(k, 0), np.int64)
    m = 0
    pos = 0
    while m < k:
        while pos < n and not alive[pos]:
            pos += 1
        if pos >= n:
            break
        out[m] = pos
        m += 1
        x0, y0, h0 = xy[pos, 0], xy[pos, 1], heads[pos]
        for j in range(n):
            if alive[j] and math.hypot(xy[j, 0] - x0, xy[j, 1] - y0) < radius:
                if abs((heads[j] - h0 + math.pi) % (2 * math.pi) - math.pi) < max_dh:
                    alive[j] = False
        pos += 1
    return out[:m]


def _same_candidate(a: np.ndarray, b: np.ndarray, cfg) -> bool:
    """Whether coarse poses ``a`` and ``b`` are one candidate for the non-maximum suppression
    (closer than ``nms_radius`` and ``nms_deg``)."""
    return bool(math.hypot(a[0] - b[0], a[1] - b[1]) < cfg.nms_radius
                and abs(float(wrap_angle(a[2] - b[2]))) < math.radians(cfg.nms_deg))


def _dedupe(hyps: list) -> list:
    """Drop a hypothesis within 5 cm and 2 degrees of a better one (refined to the same pose)."""
    out: list = []
    for h in hyps:
        if not any(np.hypot(*(h.pose[:2] - o.pose[:2])) < 0.05
                   and abs(float(wrap_angle(h.pose[2] - o.pose[2]))) < math.radians(2) for o in out):
            out.append(h)
    return out
