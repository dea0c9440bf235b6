"""A* on the world model's horizontal occupancy slice (paper section 4.1, appendix B).

The search runs on a square lattice anchored at the start, spacing ``step`` (0.8 L): from a
lattice point the 8 moves go to its 8 neighbours (straight moves of length ``step``, diagonal
moves of length ``step * sqrt 2``); a move costs its length and the heuristic is the Euclidean
distance to the goal. A move is allowed when

* none of ``edge_samples`` (100) points evenly spaced on it (end points included) lies in an
  occupied cell of ``occ2d`` (nearest-cell lookup; outside the grid counts as occupied), and
* the point stepped into is at least ``safety`` (1.2 L) from every occupied point of the slice:
  the occupied points are the occupied cells' centres, and the distance is read at the nearest
  cell from a Euclidean distance transform computed once per map (so it is exact at cell
  centres and within half a cell diagonal elsewhere). One addition (``escape``): from a point
  inside that margin (a start next to an inflated obstacle of a learned map) a move may also
  step into a point of strictly larger clearance, so the search can leave the margin; and
  lattice points within ``goal_tolerance`` of the goal need only ``goal_safety`` (0.5 L)
  clearance, so a target that the learned map puts just inside the margin stays reachable.
  Neither changes anything on a map whose start and goal keep the full margin.

The search stops at the first expanded lattice point within ``goal_tolerance`` (0.8 L) of the
goal. The waypoints are the lattice points after the start, followed by the goal itself when
the straight move from the last lattice point to it passes the edge check. Shortcut: when the
straight line start -> goal passes the same checks (every sample free and at least ``safety``
from occupied points, samples at most half a cell apart), the goal is the only waypoint.

Map convention: ``occ2d (nx, ny)`` bool, index ``[ix, iy]``, cell centres ``xs (nx,)``,
``ys (ny,)`` evenly spaced (world metres).
"""

from __future__ import annotations

import hashlib
import heapq
import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
from numba import njit

from navbench.errors import PlanningError
from navbench.geometry import AGENT_LENGTH


@dataclass(frozen=True)
class PlannerConfig:
    """A* settings (SPEC "Planning and control"); lengths in metres."""

    step: float = 0.8 * AGENT_LENGTH  # lattice spacing = straight move length (m)
    safety: float = 1.2 * AGENT_LENGTH  # min distance (m) of a stepped-into point from occupied points
    goal_tolerance: float = 0.8 * AGENT_LENGTH  # search stops within this distance (m) of the goal
    edge_samples: int = 100  # points checked on every move
    # tie-break (m added per change of move direction): among the many equally long lattice
    # paths, prefer the one with the fewest turns (a staircase of alternating straight and
    # diagonal moves costs the controller a turn in place at every step); small enough that it
    # never trades length for fewer turns by more than turn_penalty per turn
    turn_penalty: float = 1e-4
    shortcut: bool = True  # try the straight line first
    # an addition to the paper: from a point closer than ``safety`` to the map's obstacles (a
    # start inside the margin of an inflated learned map), moves that strictly increase the
    # clearance are allowed until the margin is left; False: such a start has no plan
    escape: bool = True
    # an addition to the paper: lattice points within goal_tolerance of the goal need only this
    # clearance (m), so a target that an inflated learned map puts a little inside the safety
    # margin stays reachable; set it to ``safety`` for the paper's strict rule
    goal_safety: float = 0.5 * AGENT_LENGTH
    max_expansions: int = 200_000  # give up ("no-plan") after this many expansions


@dataclass(frozen=True)
class Plan:
    """A plan: ``waypoints (K, 2)`` world metres (``None`` without a plan), ``status`` one of
    ``"shortcut"``, ``"astar"``, ``"no-plan"``, ``expansions`` the number of A* expansions."""

    waypoints: np.ndarray | None
    status: str
    expansions: int = 0

    @property
    def ok(self) -> bool:
        return self.waypoints is not None


@dataclass(frozen=True)
class PlannerMap:
    """Per-map precomputation reused across plans: the occupancy, the clearance (m) of every
    cell centre to the nearest occupied cell centre (``inf`` on a map without obstacles), the
    grid origin ``x0, y0`` (centre of cell 0) and the cell size ``cell`` (m)."""

    occ: np.ndarray  # (nx, ny) bool
    clearance: np.ndarray  # (nx, ny) float64, metres
    x0: float
    y0: float
    cell: float
    config: PlannerConfig


def make_planner_map(occ2d, xs, ys, config: PlannerConfig = PlannerConfig()) -> PlannerMap:
    """Precompute the distance transform of ``occ2d`` (see :class:`PlannerMap`)."""
    from scipy.ndimage import distance_transform_edt

    occ = np.ascontiguousarray(np.asarray(occ2d, dtype=bool))
    xs = np.asarray(xs, dtype=np.float64)
    ys = np.asarray(ys, dtype=np.float64)
    if occ.ndim != 2 or occ.shape != (len(xs), len(ys)):
        raise PlanningError(f"occ2d shape {occ.shape} does not match xs ({len(xs)}) and ys ({len(ys)})")
    if len(xs) < 2 or len(ys) < 2:
        raise PlanningError("the occupancy map needs at least 2 x 2 cells")
    cell = float(xs[1] - xs[0])
    if cell <= 0 or abs(float(ys[1] - ys[0]) - cell) > 1e-9 * max(1.0, cell):
        raise PlanningError("the occupancy map needs square cells with increasing centres")
    if occ.any():
        clearance = distance_transform_edt(~occ) * cell
    else:
        clearance = np.full(occ.shape, np.inf)
    return PlannerMap(occ, np.ascontiguousarray(clearance, dtype=np.float64),
                      float(xs[0]), float(ys[0]), cell, config)


_CACHE: OrderedDict = OrderedDict()


def cached_planner_map(occ2d, xs, ys, config: PlannerConfig = PlannerConfig()) -> PlannerMap:
    """:func:`make_planner_map`, memoised on the map content and config (the last 8 maps)."""
    occ = np.asarray(occ2d, dtype=bool)
    h = hashlib.sha1(occ.tobytes())
    h.update(str(occ.shape).encode())
    h.update(np.asarray(xs, np.float64).tobytes())
    h.update(np.asarray(ys, np.float64).tobytes())
    key = (h.hexdigest(), config)
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    pm = make_planner_map(occ, xs, ys, config)
    _CACHE[key] = pm
    while len(_CACHE) > 8:
        _CACHE.popitem(last=False)
    return pm


# ----------------------------------------------------------------------------- numba kernels

@njit(cache=True)
def _cell(occ, x0, y0, cell, x, y):
    """Nearest-cell index (ix, iy), or (-1, -1) outside the grid."""
    ix = int(math.floor((x - x0) / cell + 0.5))
    iy = int(math.floor((y - y0) / cell + 0.5))
    if ix < 0 or iy < 0 or ix >= occ.shape[0] or iy >= occ.shape[1]:
        return -1, -1
    return ix, iy


@njit(cache=True)
def _line_ok(occ, clear, x0, y0, cell, ax, ay, bx, by, n, min_clear):
    """All ``n`` samples on A->B fall in free cells with clearance >= min_clear (0: no check)."""
    for k in range(n):
        t = k / (n - 1) if n > 1 else 1.0
        ix, iy = _cell(occ, x0, y0, cell, ax + t * (bx - ax), ay + t * (by - ay))
        if ix < 0 or occ[ix, iy]:
            return False
        if min_clear > 0.0 and clear[ix, iy] < min_clear:
            return False
    return True


@njit(cache=True)
def _astar(occ, clear, x0, y0, cell, sx, sy, gx, gy, step, safety, goal_tol, n_samples, max_exp, escape,
           turn_penalty, goal_safety):
    """Lattice A*; returns (path lattice offsets (K, 2) int64 from the start, expansions).

    K = 0 means no path. The lattice point (i, j) is at (sx + i * step, sy + j * step).
    """
    # lattice bounds covering the grid
    xlo, xhi = x0 - 0.5 * cell, x0 + (occ.shape[0] - 0.5) * cell
    ylo, yhi = y0 - 0.5 * cell, y0 + (occ.shape[1] - 0.5) * cell
    imin = int(math.floor((xlo - sx) / step))
    imax = int(math.ceil((xhi - sx) / step))
    jmin = int(math.floor((ylo - sy) / step))
    jmax = int(math.ceil((yhi - sy) / step))
    ni, nj = imax - imin + 1, jmax - jmin + 1
    g = np.full((ni, nj), np.inf)
    parent = np.full((ni, nj), -1, np.int64)
    move = np.full((ni, nj), -1, np.int64)  # direction of the move that reached a node
    closed = np.zeros((ni, nj), np.bool_)
    si, sj = -imin, -jmin
    g[si, sj] = 0.0
    h0 = math.sqrt((sx - gx) ** 2 + (sy - gy) ** 2)
    heap = [(h0, 0.0, si * nj + sj)]
    di = np.array([1, -1, 0, 0, 1, 1, -1, -1])
    dj = np.array([0, 0, 1, -1, 1, -1, 1, -1])
    expansions = 0
    goal = -1
    while len(heap) > 0:
        f, gc, node = heapq.heappop(heap)
        ci, cj = node // nj, node % nj
        if closed[ci, cj]:
            continue
        closed[ci, cj] = True
        expansions += 1
        px = sx + (ci + imin) * step
        py = sy + (cj + jmin) * step
        cx_, cy_ = _cell(occ, x0, y0, cell, px, py)
        here = clear[cx_, cy_] if cx_ >= 0 else 0.0
        if math.sqrt((px - gx) ** 2 + (py - gy) ** 2) <= goal_tol:
            goal = node
            break
        if expansions >= max_exp:
            break
        for k in range(8):
            ni_, nj_ = ci + di[k], cj + dj[k]
            if ni_ < 0 or nj_ < 0 or ni_ >= ni or nj_ >= nj or closed[ni_, nj_]:
                continue
            qx = sx + (ni_ + imin) * step
            qy = sy + (nj_ + jmin) * step
            ix, iy = _cell(occ, x0, y0, cell, qx, qy)
            if ix < 0 or occ[ix, iy]:
                continue
            need = safety
            if goal_safety < safety and math.sqrt((qx - gx) ** 2 + (qy - gy) ** 2) <= goal_tol:
                need = goal_safety
            if clear[ix, iy] < need and not (escape and here < need and clear[ix, iy] > here):
                continue
            cost = step if k < 4 else step * math.sqrt(2.0)
            if move[ci, cj] >= 0 and move[ci, cj] != k:
                cost += turn_penalty
            ng = gc + cost
            if ng >= g[ni_, nj_]:
                continue
            if not _line_ok(occ, clear, x0, y0, cell, px, py, qx, qy, n_samples, 0.0):
                continue
            g[ni_, nj_] = ng
            parent[ni_, nj_] = node
            move[ni_, nj_] = k
            h = math.sqrt((qx - gx) ** 2 + (qy - gy) ** 2)
            heapq.heappush(heap, (ng + h, ng, ni_ * nj + nj_))
    if goal < 0:
        return np.zeros((0, 2), np.int64), expansions
    count = 0
    node = goal
    while node >= 0:
        count += 1
        node = parent[node // nj, node % nj]
    out = np.empty((count, 2), np.int64)
    node = goal
    for k in range(count - 1, -1, -1):
        out[k, 0] = node // nj + imin
        out[k, 1] = node % nj + jmin
        node = parent[node // nj, node % nj]
    return out, expansions


# ----------------------------------------------------------------------------- public API

def straight_line_free(pmap: PlannerMap, a, b) -> bool:
    """The shortcut test: every sample on ``a -> b`` (``>= edge_samples``, at most half a cell
    apart) is in a free cell at least ``safety`` (m) from occupied points."""
    cfg = pmap.config
    length = math.dist(a, b)
    n = max(cfg.edge_samples, int(math.ceil(length / (0.5 * pmap.cell))) + 1)
    return bool(_line_ok(pmap.occ, pmap.clearance, pmap.x0, pmap.y0, pmap.cell,
                         float(a[0]), float(a[1]), float(b[0]), float(b[1]), n, cfg.safety))


def plan_on_map(pmap: PlannerMap, start_xy, goal_xy) -> Plan:
    """Plan from ``start_xy`` to ``goal_xy`` (world ``(2,)`` metres) on a precomputed map."""
    cfg = pmap.config
    s = np.asarray(start_xy, dtype=np.float64)[:2]
    t = np.asarray(goal_xy, dtype=np.float64)[:2]
    if cfg.shortcut and straight_line_free(pmap, s, t):
        return Plan(t[None, :].copy(), "shortcut", 0)
    path, expansions = _astar(pmap.occ, pmap.clearance, pmap.x0, pmap.y0, pmap.cell,
                              float(s[0]), float(s[1]), float(t[0]), float(t[1]),
                              float(cfg.step), float(cfg.safety), float(cfg.goal_tolerance),
                              int(cfg.edge_samples), int(cfg.max_expansions), bool(cfg.escape),
                              float(cfg.turn_penalty), float(cfg.goal_safety))
    if len(path) == 0:
        return Plan(None, "no-plan", int(expansions))
    pts = s[None, :] + path[1:].astype(np.float64) * cfg.step
    last = pts[-1] if len(pts) else s
    if not np.allclose(last, t) and _line_ok(pmap.occ, pmap.clearance, pmap.x0, pmap.y0, pmap.cell,
                                              float(last[0]), float(last[1]), float(t[0]), float(t[1]),
                                              int(cfg.edge_samples), 0.0):
        pts = np.vstack([pts, t[None, :]])
    if len(pts) == 0:
        pts = t[None, :].copy()
    return Plan(pts, "astar", int(expansions))


def plan_path(occ2d, xs, ys, start_xy, goal_xy, config: PlannerConfig = PlannerConfig(),
              planner_map: PlannerMap | None = None) -> Plan:
    """A* plan on the occupancy slice ``occ2d (nx, ny)`` with cell centres ``xs``, ``ys``.

    Returns a :class:`Plan`; no path is ``status == "no-plan"``, never an exception. The
    distance transform of the map is cached across calls (keyed by the map content), or pass
    ``planner_map`` from :func:`make_planner_map` to skip the cache lookup.
    """
    pm = planner_map if planner_map is not None else cached_planner_map(occ2d, xs, ys, config)
    return plan_on_map(pm, start_xy, goal_xy)
