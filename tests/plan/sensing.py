"""A perfect 2D range sensor for the exploration tests: it reveals the cells of a level's true
occupancy raster within a radius by line of sight (rays every 0.25 degrees, samples every half
cell, each ray stops at and includes its first occupied cell)."""

from __future__ import annotations

import math

import numpy as np


def reveal(known: np.ndarray, occ: np.ndarray, xs, ys, xy, radius: float) -> None:
    """Mark ``known`` (in place) every cell of ``occ`` visible from ``xy`` within ``radius`` m."""
    cell = float(xs[1] - xs[0])
    n = int(math.ceil(radius / (0.5 * cell)))
    t = np.arange(n + 1) * (radius / n)
    ang = np.arange(1440) * (2 * math.pi / 1440)
    px = xy[0] + np.cos(ang)[:, None] * t[None, :]
    py = xy[1] + np.sin(ang)[:, None] * t[None, :]
    ix = np.floor((px - xs[0]) / cell + 0.5).astype(int)
    iy = np.floor((py - ys[0]) / cell + 0.5).astype(int)
    inside = (ix >= 0) & (iy >= 0) & (ix < occ.shape[0]) & (iy < occ.shape[1])
    ixc, iyc = np.clip(ix, 0, occ.shape[0] - 1), np.clip(iy, 0, occ.shape[1] - 1)
    hit = ~inside | occ[ixc, iyc]
    before = np.cumsum(hit, axis=1) - hit  # hits strictly before each sample
    seen = inside & (before == 0)
    known[ixc[seen], iyc[seen]] = True
