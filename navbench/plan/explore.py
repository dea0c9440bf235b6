"""Exploration of an unknown house (issue 15 section 3; RNR-Map supplementary D and G).

Math layer: arrays in, arrays out. The map is two boolean grids on the planning grid (the cells
the world model's ``occupancy_slice`` gives, index ``[ix, iy]``, cell centres ``xs``, ``ys``):
``known`` (the cell has been seen) and ``occupied`` (seen and solid; read only where known).

**Unknown space is an obstacle (pessimistic planning).** In navbench a collision ends the
episode (``Simulator``: "once True, further movement is prohibited"), so the agent never plans
through space it has not seen: the planner's occupancy is ``~(known & ~occupied)``. The price
is that a target can only be a seen free cell with the planner's full clearance; the explorer
therefore aims at a *viewpoint* of each frontier, not at the frontier itself (below), and an
optimistic planner's shorter detours through unseen rooms are given up.

Candidates (``candidates = "frontier"``, the default)
    *Frontier cells* are seen free cells with an unseen 4-neighbour
    (:func:`frontier_cells`); 8-connected clusters of at least ``min_frontier_cells`` cells are
    the candidates. A cluster's *viewpoint* is the safe reachable cell (see
    :func:`reachable_distances`) closest to the cluster (ties: the shortest geodesic distance);
    a cluster with no safe reachable cell within ``view_distance`` is not a candidate (it lies
    behind a gap the agent cannot pass). Frontiers give the same two ingredients as RNR-Map's
    graph: places at the edge of the seen space, and a score of how much is unseen around them.

Candidates (``candidates = "voronoi"``, RNR-Map's kind)
    The *generalised Voronoi diagram* (GVD) of the seen free space, every cell that is not seen
    free (occupied or unseen) counting as an obstacle: a seen free cell lies on it when its
    nearest obstacle cell and a 4-neighbour's nearest obstacle cell are at least
    :data:`VORONOI_SEPARATION` cells apart (the two sides of a passage, not one wall;
    :func:`voronoi_cells`, from ``scipy.ndimage``'s exact distance transform). Its safe, reachable
    cells with something unseen in reach (exploration score > 0) are scored as below; then, best
    first, a cell closer than :data:`VORONOI_SPACING` m to a better one is dropped, so the
    candidates are places along the graph's branches (RNR-Map scores the graph's nodes). The
    viewpoint is the cell itself; ``"done"`` when no such cell is left that is not exhausted.
    Unseen space counts as an obstacle, so the graph's branches run toward the unseen rooms.

Scores (RNR-Map supplementary G, "Exploration Score")
    * exploration score: the share of unseen cells on ``rays`` rays of ``ray_length`` metres
      from the viewpoint, each ray cut at its first occupied cell (:func:`exploration_score`),
      in [0, 1];
    * nearness: ``1 / (1 + d)`` with ``d`` the geodesic distance (m) from the agent on the safe
      seen free space (RNR-Map adds the inverse distance "to encourage greedy exploration");
    * goal score: a function passed in, viewpoints ``(C, 2)`` -> ``(C,)`` (RNR-Map's latent score,
      its localisation heat map). ``None`` leaves it out.

    ``score = explore_weight * exploration + near_weight * nearness + goal_weight * goal``. RNR-Map's
    ablations are weight settings: "exploration without goal scoring" (``goal_weight = 0`` or no
    goal function), "goal scoring without exploration" (``explore_weight = near_weight = 0``).

Termination. The caller reports every target it reached (:meth:`Explorer.reached`); a candidate
whose viewpoint lies within ``visited_radius`` of a reached target is *exhausted* (its frontier
cannot be seen better from there: a slit, the far side of a thin gap). Each decision either
returns a new, not exhausted viewpoint (a grid cell) or ``"done"``, so on a finite grid the loop
ends; ``"done"`` means no seen free cell reachable by the agent borders unseen space that some
reachable viewpoint has not already looked at.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy import ndimage
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from navbench.errors import PlanningError
from navbench.plan.astar import Plan, PlannerConfig, plan_path

#: A goal-similarity hook: viewpoints ``(C, 2)`` world metres -> scores ``(C,)`` (higher: more
#: like the goal; RNR-Map's latent score is in [0, 1]).
GoalScore = Callable[[np.ndarray], np.ndarray]

#: The candidate kinds (module docstring).
CANDIDATE_KINDS = ("frontier", "voronoi")
#: Voronoi candidates: the least distance, in cells, between the nearest obstacle cells of two
#: 4-neighbours for them to lie on the graph (1 to 1.5 along one straight or slanted wall).
VORONOI_SEPARATION = 3.0
#: Voronoi candidates: m; a graph cell this close to a better-scored one is not a candidate.
VORONOI_SPACING = 0.5


@dataclass(frozen=True)
class ExplorerConfig:
    """Explorer settings; lengths in metres."""

    candidates: str = "frontier"      # "frontier" or "voronoi" (see the module docstring)
    min_frontier_cells: int = 3       # smaller frontier clusters are ignored (sensing speckle)
    view_distance: float = 1.0        # a viewpoint lies at most this far from its frontier cluster
    visited_radius: float = 0.3       # a viewpoint this close to a reached target is exhausted
    rays: int = 36                    # exploration-score rays per viewpoint
    ray_length: float = 2.0           # m, exploration-score ray length
    explore_weight: float = 1.0       # weight of the exploration score
    near_weight: float = 1.0          # weight of 1 / (1 + geodesic distance)
    goal_weight: float = 1.0          # weight of the goal score (when a goal function is given)
    planner: PlannerConfig = field(default_factory=PlannerConfig)

    def __post_init__(self):
        if self.candidates not in CANDIDATE_KINDS:
            raise PlanningError(f"explorer: candidates must be one of {', '.join(CANDIDATE_KINDS)}, "
                                f"got {self.candidates!r}")
        if min(self.view_distance, self.visited_radius, self.ray_length) <= 0 or self.rays < 1:
            raise PlanningError("explorer: view_distance, visited_radius, ray_length and rays must be positive")
        if min(self.explore_weight, self.near_weight, self.goal_weight) < 0:
            raise PlanningError("explorer: score weights must be >= 0")


@dataclass(frozen=True)
class Candidate:
    """One frontier cluster or Voronoi place: its ``viewpoint (2,)`` (m, a safe reachable cell
    centre), ``cells`` (cluster size; graph cells it stands for), ``distance`` (geodesic m from the agent), the scores and their weighted sum."""

    viewpoint: np.ndarray
    cells: int
    distance: float
    exploration: float
    goal: float
    score: float


@dataclass(frozen=True)
class Decision:
    """``status``: ``"target"`` (go to ``target`` along ``plan``) or ``"done"`` (nothing reachable
    is unexplored; ``target`` and ``plan`` are ``None``). ``candidates``: all scored, best first."""

    status: str
    target: np.ndarray | None
    plan: Plan | None
    candidates: tuple[Candidate, ...]


# ----------------------------------------------------------------------------- grid pieces

def _check(known, occupied, xs, ys) -> tuple[np.ndarray, np.ndarray, float]:
    known = np.asarray(known, bool)
    occupied = np.asarray(occupied, bool)
    if known.ndim != 2 or known.shape != occupied.shape or known.shape != (len(xs), len(ys)):
        raise PlanningError(f"explorer: known {known.shape} and occupied {occupied.shape} must both be "
                            f"(len(xs), len(ys)) = ({len(xs)}, {len(ys)})")
    if len(xs) < 2 or len(ys) < 2:
        raise PlanningError("explorer: the grid needs at least 2 x 2 cells")
    return known, occupied, float(xs[1] - xs[0])


def seen_free(known, occupied) -> np.ndarray:
    """Cells seen and free: ``known & ~occupied``."""
    return np.asarray(known, bool) & ~np.asarray(occupied, bool)


def frontier_cells(known, occupied) -> np.ndarray:
    """Seen free cells with at least one unseen 4-neighbour (cells off the grid count as seen:
    the grid's edge is not a frontier)."""
    known = np.asarray(known, bool)
    unknown = np.pad(~known, 1, constant_values=False)
    nb = unknown[:-2, 1:-1] | unknown[2:, 1:-1] | unknown[1:-1, :-2] | unknown[1:-1, 2:]
    return seen_free(known, occupied) & nb


def voronoi_cells(free, separation: float = VORONOI_SEPARATION) -> np.ndarray:
    """Cells of the generalised Voronoi diagram of ``free`` (bool grid): free cells whose nearest
    non-free cell (cells off the grid count as non-free) lies at least ``separation`` cells from
    the nearest non-free cell of the next free cell along +x or +y. A band between two walls gives
    a line about one cell wide along its middle; a single straight wall gives none."""
    free = np.asarray(free, bool)
    pad = np.pad(free, 1, constant_values=False)
    out = np.zeros(pad.shape, bool)
    if not pad.any():
        return out[1:-1, 1:-1]
    _, (nx, ny) = ndimage.distance_transform_edt(pad, return_indices=True)
    for dx, dy in ((1, 0), (0, 1)):
        a = (slice(0, pad.shape[0] - dx), slice(0, pad.shape[1] - dy))
        b = (slice(dx, None), slice(dy, None))
        apart = np.hypot(nx[a] - nx[b], ny[a] - ny[b]) >= separation
        out[a] |= pad[a] & pad[b] & apart
    return out[1:-1, 1:-1]


def safe_cells(known, occupied, cell: float, safety: float) -> np.ndarray:
    """Seen free cells whose centre is at least ``safety`` m from every cell centre that is not
    seen free (occupied or unseen: the pessimistic planner's obstacles, its clearance rule)."""
    free = seen_free(known, occupied)
    if free.all():
        return free.copy()
    return free & (ndimage.distance_transform_edt(free) * cell >= safety - 1e-9)


def _cell_of(xs, ys, xy) -> tuple[int, int]:
    cell = float(xs[1] - xs[0])
    ix = int(math.floor((float(xy[0]) - xs[0]) / cell + 0.5))
    iy = int(math.floor((float(xy[1]) - ys[0]) / cell + 0.5))
    return min(max(ix, 0), len(xs) - 1), min(max(iy, 0), len(ys) - 1)


def reachable_distances(safe: np.ndarray, source: tuple[int, int], cell: float) -> np.ndarray:
    """Geodesic distance (m) from ``source`` to every cell over the ``safe`` cells, 8-connected
    moves of ``cell`` and ``cell * sqrt 2`` (Dijkstra, ``scipy.sparse.csgraph``); ``inf`` where
    not reachable or not safe. A diagonal move needs both cells it cuts past safe."""
    nx, ny = safe.shape
    out = np.full(safe.shape, np.inf)
    if not safe[source]:
        return out
    ids = -np.ones(safe.shape, np.int64)
    n = int(safe.sum())
    ids[safe] = np.arange(n)
    rows, cols, w = [], [], []
    for dx, dy in ((1, 0), (0, 1), (1, 1), (1, -1)):  # cell (i, j) of a pairs with (i + dx, j + dy)
        sax, sbx = slice(max(0, -dx), nx - max(0, dx)), slice(max(0, dx), nx - max(0, -dx))
        say, sby = slice(max(0, -dy), ny - max(0, dy)), slice(max(0, dy), ny - max(0, -dy))
        ia, ib = ids[sax, say], ids[sbx, sby]
        ok = (ia >= 0) & (ib >= 0)
        if dx and dy:  # no corner cutting: (i + dx, j) and (i, j + dy) safe too
            ok &= safe[sbx, say] & safe[sax, sby]
        rows.append(ia[ok])
        cols.append(ib[ok])
        w.append(np.full(int(ok.sum()), cell * (math.sqrt(2.0) if dx and dy else 1.0)))
    r, c, ww = np.concatenate(rows), np.concatenate(cols), np.concatenate(w)
    graph = csr_matrix((np.concatenate([ww, ww]), (np.concatenate([r, c]), np.concatenate([c, r]))), shape=(n, n))
    d = dijkstra(graph, directed=True, indices=int(ids[source]))
    out[safe] = d
    return out


def exploration_score(known, occupied, xs, ys, points, rays: int = 36, ray_length: float = 2.0) -> np.ndarray:
    """RNR-Map's exploration score of ``points (C, 2)`` (m): the share of unseen cells on ``rays``
    rays of ``ray_length`` m around each point, sampled every half cell; a ray stops at its first
    seen occupied cell or at the grid's edge (later samples count as seen). ``(C,)`` in [0, 1]."""
    known, occupied, cell = _check(known, occupied, xs, ys)
    pts = np.atleast_2d(np.asarray(points, np.float64))
    if len(pts) == 0:
        return np.zeros(0)
    n = max(1, int(math.ceil(ray_length / (0.5 * cell))))
    t = (np.arange(n) + 1) * (ray_length / n)
    ang = np.arange(rays) * (2 * math.pi / rays)
    px = pts[:, None, None, 0] + np.cos(ang)[None, :, None] * t[None, None, :]
    py = pts[:, None, None, 1] + np.sin(ang)[None, :, None] * t[None, None, :]
    ix = np.floor((px - xs[0]) / cell + 0.5).astype(np.int64)
    iy = np.floor((py - ys[0]) / cell + 0.5).astype(np.int64)
    inside = (ix >= 0) & (iy >= 0) & (ix < known.shape[0]) & (iy < known.shape[1])
    ixc, iyc = np.clip(ix, 0, known.shape[0] - 1), np.clip(iy, 0, known.shape[1] - 1)
    blocked = ~inside | (known[ixc, iyc] & occupied[ixc, iyc])
    alive = np.cumsum(blocked, axis=2) == 0
    unseen = alive & ~known[ixc, iyc]
    return unseen.sum(axis=(1, 2)) / float(rays * n)


class Explorer:
    """The explorer (module docstring: frontier or Voronoi candidates). Stateful only in the targets it was told it
    reached (:meth:`reached`); :meth:`decide` is otherwise a function of its arguments."""

    def __init__(self, config: ExplorerConfig = ExplorerConfig()):
        self.config = config
        self.visited: list[np.ndarray] = []

    def reached(self, xy) -> None:
        """Record that the agent reached a target at ``xy`` (m): viewpoints near it are exhausted."""
        self.visited.append(np.asarray(xy, np.float64)[:2].copy())

    def _exhausted(self, points: np.ndarray) -> np.ndarray:
        """Which of ``points (C, 2)`` (m) lie within ``visited_radius`` of a reached target."""
        points = np.asarray(points, np.float64).reshape(-1, 2)
        if not self.visited:
            return np.zeros(len(points), bool)
        v = np.asarray(self.visited)
        d = np.hypot(points[:, None, 0] - v[None, :, 0], points[:, None, 1] - v[None, :, 1])
        return (d <= self.config.visited_radius).any(axis=1)

    def candidates(self, known, occupied, xs, ys, robot_xy, goal_score: GoalScore | None = None
                   ) -> list[Candidate]:
        """The scored, not exhausted candidates, best first (ties by position, so deterministic)."""
        cfg = self.config
        xs, ys = np.asarray(xs, np.float64), np.asarray(ys, np.float64)
        known, occupied, cell = _check(known, occupied, xs, ys)
        safe = safe_cells(known, occupied, cell, cfg.planner.safety)
        geo = reachable_distances(safe, self._source(safe, xs, ys, robot_xy), cell)
        reach = np.isfinite(geo)
        if not reach.any():
            return []
        if cfg.candidates == "voronoi":
            return self._voronoi_candidates(known, occupied, xs, ys, geo, reach, goal_score)
        labels, count = ndimage.label(frontier_cells(known, occupied), structure=np.ones((3, 3), bool))
        if count == 0:
            return []
        sizes = np.bincount(labels.ravel(), minlength=count + 1)
        views, cells, dists = [], [], []
        for lab in range(1, count + 1):
            if sizes[lab] < cfg.min_frontier_cells:
                continue
            d = ndimage.distance_transform_edt(labels != lab) * cell
            d = np.where(reach, d, np.inf)
            best = float(d.min())
            if not best <= cfg.view_distance:
                continue
            # the closest reachable cells to the cluster; among them the geodesically nearest
            tie = np.flatnonzero((d <= best + 1e-9).ravel())
            k = tie[np.argmin(geo.ravel()[tie])]
            ix, iy = np.unravel_index(k, safe.shape)
            xy = np.array([xs[ix], ys[iy]])
            if self._exhausted(xy)[0]:
                continue
            views.append(xy)
            cells.append(int(sizes[lab]))
            dists.append(float(geo[ix, iy]))
        if not views:
            return []
        pts = np.array(views)
        expl = exploration_score(known, occupied, xs, ys, pts, cfg.rays, cfg.ray_length)
        goal, score = self._scores(pts, expl, np.asarray(dists), goal_score)
        out = [Candidate(pts[i], cells[i], dists[i], float(expl[i]), float(goal[i]), float(score[i]))
               for i in range(len(pts))]
        return sorted(out, key=lambda c: (-c.score, c.distance, c.viewpoint[0], c.viewpoint[1]))

    def _scores(self, pts, expl, dists, goal_score) -> tuple[np.ndarray, np.ndarray]:
        """The goal scores and the weighted sums of candidates at ``pts``."""
        cfg = self.config
        goal = np.zeros(len(pts))
        if goal_score is not None:
            goal = np.asarray(goal_score(pts), np.float64).reshape(-1)
            if goal.shape != (len(pts),) or not np.all(np.isfinite(goal)):
                raise PlanningError(f"explorer: the goal score must return {len(pts)} finite values")
        near = 1.0 / (1.0 + dists)
        gw = cfg.goal_weight if goal_score is not None else 0.0
        return goal, cfg.explore_weight * expl + cfg.near_weight * near + gw * goal

    def _voronoi_candidates(self, known, occupied, xs, ys, geo, reach, goal_score) -> list[Candidate]:
        """Candidates on the seen free space's Voronoi graph (module docstring), best first."""
        cfg = self.config
        graph = voronoi_cells(seen_free(known, occupied)) & reach
        ix, iy = np.nonzero(graph)
        if len(ix) == 0:
            return []
        pts = np.stack([xs[ix], ys[iy]], axis=1)
        expl = exploration_score(known, occupied, xs, ys, pts, cfg.rays, cfg.ray_length)
        keep = (expl > 0) & ~self._exhausted(pts)
        if not keep.any():
            return []
        pts, expl, dists = pts[keep], expl[keep], geo[ix[keep], iy[keep]]
        goal, score = self._scores(pts, expl, dists, goal_score)
        order = np.lexsort((pts[:, 1], pts[:, 0], dists, -score))  # best first, ties by distance, position
        chosen: list[int] = []
        cells: list[int] = []
        taken = np.empty((0, 2))
        for i in order:
            d = np.hypot(taken[:, 0] - pts[i, 0], taken[:, 1] - pts[i, 1])
            if len(d) and d.min() < VORONOI_SPACING:
                cells[int(np.argmin(d))] += 1
            else:
                chosen.append(int(i))
                cells.append(1)
                taken = np.vstack([taken, pts[i]])
        return [Candidate(pts[i].copy(), cells[k], float(dists[i]), float(expl[i]), float(goal[i]), float(score[i]))
                for k, i in enumerate(chosen)]

    def decide(self, known, occupied, xs, ys, robot_xy, goal_score: GoalScore | None = None) -> Decision:
        """The best candidate the A* planner (``config.planner``, on ``~(known & ~occupied)``)
        reaches from ``robot_xy``: ``Decision("target", viewpoint, plan, candidates)``, or
        ``"done"`` when there is none."""
        cands = tuple(self.candidates(known, occupied, xs, ys, robot_xy, goal_score))
        blocked = ~seen_free(known, occupied)
        for c in cands:
            plan = plan_path(blocked, xs, ys, robot_xy, c.viewpoint, self.config.planner)
            if plan.ok:
                return Decision("target", c.viewpoint.copy(), plan, cands)
        return Decision("done", None, None, cands)

    def _source(self, safe: np.ndarray, xs, ys, robot_xy) -> tuple[int, int]:
        """The robot's cell, or the nearest safe cell within ``2 * safety`` when the robot stands
        inside the margin (the planner's ``escape``); the robot's cell (unsafe: nothing
        reachable) otherwise."""
        src = _cell_of(xs, ys, robot_xy)
        if safe[src] or not safe.any():
            return src
        d, idx = ndimage.distance_transform_edt(~safe, return_indices=True)
        cell = float(xs[1] - xs[0])
        if d[src] * cell <= 2 * self.config.planner.safety:
            return int(idx[0][src]), int(idx[1][src])
        return src
