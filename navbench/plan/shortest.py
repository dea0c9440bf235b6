"""Shortest feasible paths of the agent's disc in the TRUE geometry (the ``l_i`` of SPL).

The disc of radius ``r`` avoids a convex solid exactly when its centre stays out of the solid's
Minkowski sum with the disc: the polygon offset by ``r`` with rounded corners. Each rounded
corner is replaced by its *circumscribed* polygon (tangent lines every at most
``max_arc_step`` radians), so the inflated shapes contain the exact ones: a path through the
approximation is feasible, and its length exceeds the exact optimum by at most the factor
``tan(d / 2) / (d / 2)`` on the arc parts (1.0032 for the default ``d = 11.25 deg``).

The shortest path among polygons bends only at convex vertices of the free space, so it is
found on the *reduced visibility graph*: nodes are the inflated polygons' vertices that lie
outside every other inflated polygon, edges join mutually visible nodes along lines tangent to
both polygons (bitangents); start and goal connect to every visible node. Dijkstra
(``scipy.sparse.csgraph``) then gives the exact shortest path on the graph.

All coordinates are world-frame metres; polygons are ``(N, 2)`` counter-clockwise arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from navbench.errors import TaskError
from navbench.geometry import AGENT_RADIUS

#: Largest angle (rad) between two tangent lines of an approximated rounded corner.
DEFAULT_ARC_STEP = math.radians(11.25)
_EPS = 1e-7  # metres: touching counts as free


def inflate_convex(poly, radius: float, max_arc_step: float = DEFAULT_ARC_STEP) -> np.ndarray:
    """Outer approximation of ``poly (N, 2)`` (convex, CCW) offset by ``radius`` (m).

    Every corner's arc (from the outward normal of the incoming edge to that of the outgoing
    edge) is split into ``m = ceil(sweep / max_arc_step)`` equal parts of angle ``d``; the
    returned polygon's vertices are the intersections of consecutive tangent lines,
    ``v + radius / cos(d / 2) * (cos a, sin a)`` at the part mid-angles ``a``. Returns ``(M, 2)``
    CCW. ``radius = 0`` returns the polygon itself.
    """
    p = np.asarray(poly, dtype=np.float64)
    if radius <= 0:
        return p.copy()
    out = []
    n = len(p)
    for i in range(n):
        e_in = p[i] - p[i - 1]
        e_out = p[(i + 1) % n] - p[i]
        a0 = math.atan2(-e_in[0], e_in[1])  # outward normal (dy, -dx) of a CCW edge
        sweep = (math.atan2(-e_out[0], e_out[1]) - a0) % (2 * math.pi)
        if sweep > math.pi:  # collinear vertex with rounding noise
            sweep = 0.0
        m = max(1, math.ceil(sweep / max_arc_step - 1e-9))
        d = sweep / m
        scale = radius / math.cos(d / 2)
        for k in range(m):
            a = a0 + (k + 0.5) * d
            out.append((p[i, 0] + scale * math.cos(a), p[i, 1] + scale * math.sin(a)))
    return np.asarray(out, dtype=np.float64)


def box_walls(width: float, depth: float, thickness: float = 1.0) -> list[np.ndarray]:
    """Four CCW rectangles just outside the box ``[0, width] x [0, depth]`` (keep paths inside)."""
    t = thickness
    rects = [(-t, -t, width + t, 0.0), (-t, depth, width + t, depth + t),
             (-t, 0.0, 0.0, depth), (width, 0.0, width + t, depth)]
    return [np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], float) for x0, y0, x1, y1 in rects]


def level_polygons(level) -> list[np.ndarray]:
    """Every solid footprint of ``level`` (walls, obstacles of any height) plus the box walls."""
    from navbench.level import prisms

    pr = prisms(level)
    return [pr.polygon(p).copy() for p in range(len(pr))] + box_walls(level.width, level.depth)


# ----------------------------------------------------------------------------- numba kernels

@njit(cache=True)
def _seg_blocked_by(ax, ay, bx, by, verts, s, e, eps):
    """True when segment AB crosses the interior of the convex CCW polygon verts[s:e] (SAT)."""
    n = e - s
    for k in range(n):
        px, py = verts[s + k, 0], verts[s + k, 1]
        qx, qy = verts[s + (k + 1) % n, 0], verts[s + (k + 1) % n, 1]
        nx, ny = qy - py, -(qx - px)
        ln = math.sqrt(nx * nx + ny * ny)
        if ln == 0.0:
            continue
        nx /= ln
        ny /= ln
        lim = nx * px + ny * py
        if min(nx * ax + ny * ay, nx * bx + ny * by) >= lim - eps:
            return False
    dx, dy = bx - ax, by - ay
    ln = math.sqrt(dx * dx + dy * dy)
    if ln > 0.0:
        mx, my = -dy / ln, dx / ln
        c = mx * ax + my * ay
        lo, hi = 1e300, -1e300
        for k in range(n):
            v = mx * verts[s + k, 0] + my * verts[s + k, 1]
            lo = min(lo, v)
            hi = max(hi, v)
        if c >= hi - eps or c <= lo + eps:
            return False
    return True


@njit(cache=True)
def _seg_free(ax, ay, bx, by, verts, start, bbox, eps):
    """True when segment AB crosses no polygon interior (bbox (P, 4) prefilter)."""
    x0, x1 = min(ax, bx), max(ax, bx)
    y0, y1 = min(ay, by), max(ay, by)
    for p in range(len(start) - 1):
        if x1 <= bbox[p, 0] + eps or x0 >= bbox[p, 2] - eps or y1 <= bbox[p, 1] + eps or y0 >= bbox[p, 3] - eps:
            continue
        if _seg_blocked_by(ax, ay, bx, by, verts, start[p], start[p + 1], eps):
            return False
    return True


@njit(cache=True)
def _inside_any(x, y, verts, start, eps, skip):
    """True when (x, y) lies strictly inside a polygon other than ``skip``."""
    for p in range(len(start) - 1):
        if p == skip:
            continue
        s, e = start[p], start[p + 1]
        n = e - s
        inside = True
        for k in range(n):
            px, py = verts[s + k, 0], verts[s + k, 1]
            qx, qy = verts[s + (k + 1) % n, 0], verts[s + (k + 1) % n, 1]
            nx, ny = qy - py, -(qx - px)
            ln = math.sqrt(nx * nx + ny * ny)
            if ln == 0.0:
                continue
            if (nx * (x - px) + ny * (y - py)) / ln >= -eps:
                inside = False
                break
        if inside:
            return True
    return False


@njit(cache=True)
def _tangent_at(px, py, prx, pry, nxx, nxy, dx, dy, eps):
    """Line through P with direction d leaves the polygon's neighbours of P on one side."""
    s1 = dx * (pry - py) - dy * (prx - px)
    s2 = dx * (nxy - py) - dy * (nxx - px)
    return s1 * s2 >= -eps * eps


@njit(cache=True)
def _graph_edges(nodes, prev, nxt, verts, start, bbox, eps):
    """Bitangent visibility edges between nodes: returns (i, j) arrays and lengths."""
    n = len(nodes)
    cap = 1024
    ii = np.empty(cap, np.int64)
    jj = np.empty(cap, np.int64)
    ww = np.empty(cap, np.float64)
    m = 0
    for i in range(n):
        ax, ay = nodes[i, 0], nodes[i, 1]
        for j in range(i + 1, n):
            bx, by = nodes[j, 0], nodes[j, 1]
            dx, dy = bx - ax, by - ay
            ln = math.sqrt(dx * dx + dy * dy)
            if ln < 1e-12:
                continue
            ux, uy = dx / ln, dy / ln
            if not _tangent_at(ax, ay, prev[i, 0], prev[i, 1], nxt[i, 0], nxt[i, 1], ux, uy, eps):
                continue
            if not _tangent_at(bx, by, prev[j, 0], prev[j, 1], nxt[j, 0], nxt[j, 1], ux, uy, eps):
                continue
            if not _seg_free(ax, ay, bx, by, verts, start, bbox, eps):
                continue
            if m == cap:
                cap *= 2
                ii2 = np.empty(cap, np.int64)
                jj2 = np.empty(cap, np.int64)
                ww2 = np.empty(cap, np.float64)
                ii2[:m] = ii
                jj2[:m] = jj
                ww2[:m] = ww
                ii, jj, ww = ii2, jj2, ww2
            ii[m] = i
            jj[m] = j
            ww[m] = ln
            m += 1
    return ii[:m], jj[:m], ww[:m]


@njit(cache=True)
def _point_edges(px, py, nodes, prev, nxt, verts, start, bbox, eps):
    """Indices of nodes visible from a free point (tangent at the node) and their distances."""
    n = len(nodes)
    idx = np.empty(n, np.int64)
    dist = np.empty(n, np.float64)
    m = 0
    for j in range(n):
        bx, by = nodes[j, 0], nodes[j, 1]
        dx, dy = bx - px, by - py
        ln = math.sqrt(dx * dx + dy * dy)
        if ln < 1e-12:
            continue
        if not _tangent_at(bx, by, prev[j, 0], prev[j, 1], nxt[j, 0], nxt[j, 1], dx / ln, dy / ln, eps):
            continue
        if not _seg_free(px, py, bx, by, verts, start, bbox, eps):
            continue
        idx[m] = j
        dist[m] = ln
        m += 1
    return idx[:m], dist[:m]


# ----------------------------------------------------------------------------- the graph

@dataclass
class VisibilityGraph:
    """Reduced visibility graph of inflated convex obstacles, reusable across queries.

    ``verts (V, 2)`` / ``start (P + 1,)`` the inflated polygons (CCW), ``bbox (P, 4)``
    ``(xmin, ymin, xmax, ymax)``; ``nodes (N, 2)`` the free vertices with their polygon
    neighbours ``prev``/``nxt (N, 2)``; ``edges`` ``(i, j, length)`` arrays; ``radius`` (m).
    """

    verts: np.ndarray
    start: np.ndarray
    bbox: np.ndarray
    nodes: np.ndarray
    prev: np.ndarray
    nxt: np.ndarray
    edges: tuple[np.ndarray, np.ndarray, np.ndarray]
    radius: float

    def is_free(self, xy) -> bool:
        """True when the disc centred at ``xy`` overlaps no solid (touching allowed)."""
        return not _inside_any(float(xy[0]), float(xy[1]), self.verts, self.start, _EPS, -1)

    def segment_free(self, a, b) -> bool:
        """True when the disc can slide straight from ``a`` to ``b``."""
        return bool(_seg_free(float(a[0]), float(a[1]), float(b[0]), float(b[1]),
                              self.verts, self.start, self.bbox, _EPS))


def build_visibility_graph(polygons, radius: float = AGENT_RADIUS,
                           max_arc_step: float = DEFAULT_ARC_STEP) -> VisibilityGraph:
    """Inflate ``polygons`` (list of convex CCW ``(N, 2)``, metres) by ``radius`` and build the graph."""
    infl = [inflate_convex(np.asarray(p, float), radius, max_arc_step) for p in polygons]
    if not infl:
        infl = []
    start = np.zeros(len(infl) + 1, np.int64)
    start[1:] = np.cumsum([len(p) for p in infl])
    verts = np.concatenate(infl) if infl else np.zeros((0, 2))
    bbox = np.array([[p[:, 0].min(), p[:, 1].min(), p[:, 0].max(), p[:, 1].max()] for p in infl]).reshape(-1, 4)
    nodes, prev, nxt = [], [], []
    for pi, p in enumerate(infl):
        for k in range(len(p)):
            if _inside_any(p[k, 0], p[k, 1], verts, start, _EPS, pi):
                continue
            nodes.append(p[k]); prev.append(p[k - 1]); nxt.append(p[(k + 1) % len(p)])
    nodes = np.asarray(nodes, float).reshape(-1, 2)
    prev = np.asarray(prev, float).reshape(-1, 2)
    nxt = np.asarray(nxt, float).reshape(-1, 2)
    edges = _graph_edges(nodes, prev, nxt, verts, start, bbox, _EPS)
    return VisibilityGraph(verts, start, bbox, nodes, prev, nxt, edges, float(radius))


def graph_for_level(level, radius: float = AGENT_RADIUS) -> VisibilityGraph:
    """The visibility graph of every solid of ``level`` (plus its box) for a disc of ``radius``."""
    return build_visibility_graph(level_polygons(level), radius)


def shortest_path(level_or_obstacles, a, b, radius: float = AGENT_RADIUS) -> tuple[float, np.ndarray]:
    """Shortest path of a disc of ``radius`` (m) from ``a`` to ``b`` (world ``(2,)`` metres).

    ``level_or_obstacles``: a :class:`navbench.level.Level` (all its solids, kept inside its
    box), a list of convex CCW polygons ``(N, 2)``, or a prebuilt :class:`VisibilityGraph`
    (whose own radius is used). Returns ``(length [m], polyline (K, 2))`` from ``a`` to ``b``.
    Raises :class:`TaskError` when ``a`` or ``b`` is not free for the disc or ``b`` is
    unreachable from ``a``.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    if isinstance(level_or_obstacles, VisibilityGraph):
        g = level_or_obstacles
    elif hasattr(level_or_obstacles, "walls"):
        g = graph_for_level(level_or_obstacles, radius)
    else:
        g = build_visibility_graph(list(level_or_obstacles), radius)
    a = np.asarray(a, dtype=np.float64)[:2]
    b = np.asarray(b, dtype=np.float64)[:2]
    for name, p in (("start", a), ("target", b)):
        if not g.is_free(p):
            raise TaskError(f"{name} ({p[0]:.3f}, {p[1]:.3f}) is not free for a disc of radius {g.radius:g} m")
    if g.segment_free(a, b):
        return float(np.linalg.norm(b - a)), np.stack([a, b])
    n = len(g.nodes)
    ia, da = _point_edges(a[0], a[1], g.nodes, g.prev, g.nxt, g.verts, g.start, g.bbox, _EPS)
    ib, db = _point_edges(b[0], b[1], g.nodes, g.prev, g.nxt, g.verts, g.start, g.bbox, _EPS)
    i0, j0, w0 = g.edges
    S, T = n, n + 1
    rows = np.concatenate([i0, np.full(len(ia), S), np.full(len(ib), T)])
    cols = np.concatenate([j0, ia, ib])
    w = np.maximum(np.concatenate([w0, da, db]), 1e-12)  # zero weights would vanish from the matrix
    m = coo_matrix((w, (rows, cols)), shape=(n + 2, n + 2)).tocsr()
    dist, pred = dijkstra(m, directed=False, indices=S, return_predecessors=True)
    if not np.isfinite(dist[T]):
        raise TaskError(f"target ({b[0]:.3f}, {b[1]:.3f}) is unreachable from ({a[0]:.3f}, {a[1]:.3f})")
    pts = np.vstack([g.nodes, a, b])
    path = [T]
    while path[-1] != S:
        path.append(pred[path[-1]])
    return float(dist[T]), pts[path[::-1]]


def shortest_path_length(level, a, b, radius: float = AGENT_RADIUS) -> float:
    """Length (m) of :func:`shortest_path` (the name in the architecture's module table)."""
    return shortest_path(level, a, b, radius)[0]
