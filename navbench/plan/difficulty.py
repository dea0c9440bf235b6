"""How hard a level's navigation tasks are, measured on the TRUE geometry (issue 16, section 2).

Per task (start ``a``, target ``b``, its shortest feasible path ``l``, :mod:`navbench.plan.shortest`):

``geodesic_ratio``
    ``l / |b - a|``: 1 for a straight walk, larger for detours through doors and around obstacles.
``narrowest_passage`` (m)
    The narrowest passage the shortest path goes through: the minimum over points ``p`` of the
    path (sampled every ``path_step``, leaving out the first and last ``end_margin`` metres of
    path, where a chord would cut the corner of the room the task starts or ends in) of the
    *cross width* at ``p``: the shortest free chord through ``p`` across the path, ``w(p) =
    min_d t(p, d) + t(p, -d)`` over directions ``d`` within ``cross_spread`` (30 deg) of the
    path's normal, every ``cross_step`` (5 deg), with ``t`` the exact distance along the ray
    to the first solid edge (or the level's box). A path crossing a doorway at up to 30 deg
    from square measures the door's width (in its plane, to 0.4 % with 5 deg steps); passing
    between a box and a wall, the gap; in a corridor, its width; in a room, the room.
    A path shorter than ``2 end_margin`` is measured at its midpoint.
``length`` (m) and ``min_steps``
    ``l`` and ``ceil(l / MAX_STEP)``: the fewest controls that cover the path (turns not counted).

Per level: ``free_clearance`` (m), the mean distance to the nearest solid over the free space the
agent can reach (the cell centres of a ``resolution`` raster whose clearance is at least the
agent's radius, in the 4-connected components holding a task start), and ``planner_free``, the
fraction of that space at least :data:`navbench.plan.tasks.MIN_CLEARANCE` (1.2 L, the planner's
safety distance) from every solid. Pure: arrays and numbers out, nothing printed or stored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navbench.geometry import AGENT_RADIUS


@dataclass(frozen=True)
class LevelDifficulty:
    """Difficulty measures of one level and its tasks (arrays have one entry per task)."""

    level: str
    task_ids: np.ndarray            # (N,) int
    geodesic_ratio: np.ndarray      # (N,) shortest path / straight-line distance
    narrowest_passage: np.ndarray   # (N,) m, narrowest chord on the shortest path
    length: np.ndarray              # (N,) m, shortest path length
    min_steps: np.ndarray           # (N,) int, ceil(length / MAX_STEP)
    free_clearance: float           # m, mean clearance of the reachable free space
    planner_free: float             # fraction of the reachable free space >= 1.2 L from solids

    def summary(self) -> dict:
        """One row: task count, means, the narrowest passage's median and minimum."""
        return {"level": self.level, "tasks": int(len(self.task_ids)),
                "geodesic_ratio": float(np.mean(self.geodesic_ratio)),
                "narrowest_passage_median": float(np.median(self.narrowest_passage)),
                "narrowest_passage_min": float(np.min(self.narrowest_passage)),
                "length": float(np.mean(self.length)), "min_steps": float(np.mean(self.min_steps)),
                "free_clearance": self.free_clearance, "planner_free": self.planner_free}


def level_edges(level) -> tuple[np.ndarray, np.ndarray]:
    """Every solid's footprint edges and the level's box: ``(starts (E, 2), ends (E, 2))``."""
    from navbench.level import prisms

    pr = prisms(level)
    a, b = [], []
    for p in range(len(pr)):
        poly = pr.polygon(p)
        a.append(poly)
        b.append(np.roll(poly, -1, axis=0))
    w, d = float(level.width), float(level.depth)
    box = np.array([(0.0, 0.0), (w, 0.0), (w, d), (0.0, d)])
    a.append(box)
    b.append(np.roll(box, -1, axis=0))
    return np.concatenate(a), np.concatenate(b)


def ray_distances(points, dirs, starts, ends) -> np.ndarray:
    """Exact distance along each ray ``points[i] + t dirs[j]`` (t > 0) to the first of the
    segments ``starts[k] -> ends[k]``: ``(P, D)`` metres (``inf`` where none is hit)."""
    p = np.asarray(points, dtype=np.float64)[:, None, None, :]   # (P, 1, 1, 2)
    d = np.asarray(dirs, dtype=np.float64)[None, :, None, :]     # (1, D, 1, 2)
    a = np.asarray(starts, dtype=np.float64)[None, None]         # (1, 1, E, 2)
    e = np.asarray(ends, dtype=np.float64)[None, None] - a
    # p + t d = a + u e  ->  t = cross(a - p, e) / cross(d, e), u = cross(a - p, d) / cross(d, e)
    den = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
    ap = a - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ap[..., 0] * e[..., 1] - ap[..., 1] * e[..., 0]) / den
        u = (ap[..., 0] * d[..., 1] - ap[..., 1] * d[..., 0]) / den
    hit = (den != 0) & (t > 0) & (u >= 0) & (u <= 1)
    return np.where(hit, t, np.inf).min(axis=2)


def cross_widths(points, headings, starts, ends, spread: float = math.radians(30.0),
                 step: float = math.radians(5.0)) -> np.ndarray:
    """``(P,)`` the shortest free chord through each point (m), over the directions within
    ``spread`` of the normal to its path heading (rad), every ``step``: ``min_d t(p, d) + t(p, -d)``."""
    k = int(math.floor(spread / step + 1e-9))
    offsets = np.arange(-k, k + 1) * step
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    out = np.empty(len(pts))
    for i, (p, h) in enumerate(zip(pts, np.asarray(headings, dtype=np.float64).reshape(-1))):
        ang = h + math.pi / 2 + offsets
        dirs = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        t = ray_distances(p[None], np.concatenate([dirs, -dirs]), starts, ends)[0]
        out[i] = float((t[:len(dirs)] + t[len(dirs):]).min())
    return out


def sample_polyline(path, step: float, end_margin: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Points every at most ``step`` (m) along the polyline ``path (K, 2)``, with the heading (rad)
    of the segment each lies on: ``(points (P, 2), headings (P,))``. Points closer than
    ``end_margin`` (m, along the path) to either end are left out; when that leaves none, the
    path's midpoint is returned."""
    path = np.asarray(path, dtype=np.float64).reshape(-1, 2)
    seg = np.diff(path, axis=0)
    lengths = np.linalg.norm(seg, axis=1)
    total = float(lengths.sum())
    pts, heads, at = [], [], []
    s0 = 0.0
    for a, d, ln in zip(path[:-1], seg, lengths):
        if ln == 0.0:
            continue
        n = max(1, math.ceil(ln / step))
        f = np.arange(0, n + 1) / n
        pts.append(a + d * f[:, None])
        heads.append(np.full(n + 1, math.atan2(d[1], d[0])))
        at.append(s0 + ln * f)
        s0 += ln
    if not pts:
        return path[:1].copy(), np.zeros(1)
    pts_a, heads_a, at_a = np.concatenate(pts), np.concatenate(heads), np.concatenate(at)
    keep = (at_a >= end_margin - 1e-12) & (at_a <= total - end_margin + 1e-12)
    if not keep.any():
        keep = np.zeros(len(at_a), bool)
        keep[int(np.argmin(np.abs(at_a - total / 2)))] = True
    return pts_a[keep], heads_a[keep]


def free_space_clearance(level, starts, resolution: float = 0.05,
                         radius: float = AGENT_RADIUS) -> tuple[float, float]:
    """``(mean clearance (m), fraction >= MIN_CLEARANCE)`` over the reachable free space (see the
    module doc): raster cell centres with clearance >= ``radius`` in the components of ``starts``."""
    from scipy import ndimage

    from navbench.level import distance_to_solids
    from navbench.plan.tasks import MIN_CLEARANCE

    nx = int(math.ceil(level.width / resolution - 1e-9))
    ny = int(math.ceil(level.depth / resolution - 1e-9))
    xs, ys = (np.arange(nx) + 0.5) * resolution, (np.arange(ny) + 0.5) * resolution
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel()], axis=1)
    box = np.minimum.reduce([pts[:, 0], pts[:, 1], level.width - pts[:, 0], level.depth - pts[:, 1]])
    clear = np.minimum(distance_to_solids(level, pts), box).reshape(nx, ny)
    labels, _ = ndimage.label(clear >= radius)
    s = np.asarray(starts, dtype=np.float64).reshape(-1, 2)
    ix = np.clip((s[:, 0] / resolution).astype(int), 0, nx - 1)
    iy = np.clip((s[:, 1] / resolution).astype(int), 0, ny - 1)
    keep = np.isin(labels, np.setdiff1d(labels[ix, iy], [0]))
    c = clear[keep]
    if c.size == 0:
        return 0.0, 0.0
    return float(c.mean()), float(np.mean(c >= MIN_CLEARANCE))


def level_difficulty(level, tasks, path_step: float = 0.05, end_margin: float = 0.5,
                     cross_spread: float = math.radians(30.0), cross_step: float = math.radians(5.0),
                     resolution: float = 0.05, radius: float = AGENT_RADIUS) -> LevelDifficulty:
    """The measures of the module doc for ``level`` and its ``tasks`` (:class:`navbench.plan.tasks.Task`)."""
    from navbench.plan.shortest import graph_for_level, shortest_path
    from navbench.sim.dynamics import MAX_STEP

    graph = graph_for_level(level, radius)
    starts, ends = level_edges(level)
    ids, ratio, narrow, length = [], [], [], []
    for t in tasks:
        a = np.asarray(t.start, dtype=np.float64)[:2]
        b = np.asarray(t.target, dtype=np.float64)[:2]
        l, path = shortest_path(graph, a, b)
        ids.append(int(t.id))
        length.append(l)
        ratio.append(l / float(np.linalg.norm(b - a)))
        pts, heads = sample_polyline(path, path_step, end_margin)
        narrow.append(float(cross_widths(pts, heads, starts, ends, cross_spread, cross_step).min()))
    length_a = np.asarray(length, dtype=np.float64)
    clearance, planner_free = free_space_clearance(level, [t.start[:2] for t in tasks], resolution, radius)
    return LevelDifficulty(level.name, np.asarray(ids, dtype=np.int64), np.asarray(ratio), np.asarray(narrow),
                           length_a, np.ceil(length_a / MAX_STEP - 1e-9).astype(np.int64), clearance, planner_free)
