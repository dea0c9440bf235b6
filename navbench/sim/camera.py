"""The ground-truth RGB-D camera: exact ray casting against the level's convex prisms.

The camera is planar-mounted (pitch 0, ``camera_height`` above the floor, see
:mod:`navbench.geometry`), so every image column is one vertical plane through the camera. For
column ``i`` the horizontal ray direction is ``d = forward + x_c * right`` with
``x_c = (i - cx) / fx``; because ``d`` has unit forward component, the 2D ray parameter ``t`` of a
hit **is** its z-depth. Each prism (convex footprint, extruded from the floor to its height) is
clipped against that 2D ray (Cyrus-Beck), giving the entry ``t_in`` through a known edge and the
exit ``t_out``. Along row ``j`` (``y_c = (j - cy) / fy``) the 3D ray height is
``z(t) = camera_height - y_c * t``; the pixel sees the nearest of

* the floor ``z = 0`` at ``t = camera_height / y_c`` (``y_c > 0``),
* the ceiling ``z = level.height`` at ``t = (camera_height - level.height) / y_c`` (``y_c < 0``),
* a prism's side face at ``t_in`` when ``0 <= z(t_in) <= prism height``,
* a prism's top face at ``t = (camera_height - h) / y_c`` when that lies in ``[t_in, t_out]``
  (so the camera sees the top of a low box and, above it, the wall behind).

Colours are the level's view-independent textures (:func:`navbench.level.surface_colour`):
side faces use ``u`` = distance along the entered edge from its first vertex and ``v = z``;
floor, ceiling and prism tops use ``u = x``, ``v = y``. The camera's ``texture`` setting says how
they are evaluated (per pixel, from texel tables, or with a polynomial sine; see
:mod:`navbench.sim.texels`); the default is ``navbench-1``'s per-pixel procedural colour. Pixels farther than ``max_range``
(z-depth) are invalid: depth ``+inf``, colour 0.

:class:`RaycastCamera` renders with a compiled kernel (numba; one thread, or parallel over columns);
:func:`render_reference` is a slow, independent pure-numpy implementation that the tests compare
it against. ``RaycastCamera.render(pose, pixels)`` casts only the listed pixels, each with the
full render's exact numbers (the other pixels: NaN, not valid), for estimators that declare the
pixels they read (:func:`navbench.track.base.observed_pixels`): ``ours`` reads 3000 of the
paper camera's 76 800.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from navbench.geometry import CAMERA_HEIGHT, MAX_RANGE, Frame, Intrinsics
from navbench.level import Level, prisms, surface_colour, texture_table
from navbench.sim.texels import (DEFAULT_TEXTURE, check_texture, pattern_poly, surface_pattern, table_pattern,
                                 texel_tables, texture_code)

#: Images with at least this many pixels render in parallel by default (320 x 240).
PARALLEL_MIN_PIXELS = 320 * 240
#: ... and only with at least this many numba threads.
PARALLEL_MIN_THREADS = 4

# surface kinds of a pixel's hit
_NONE, _FLOOR, _CEIL, _SIDE, _TOP = 0, 1, 2, 3, 4


# ------------------------------------------------------------------------------ compiled kernel

@njit(cache=True, inline="always")
def _texel(t, u, v, kind, base, amp, waves):
    """Colour ``(r, g, b)`` of texture ``t`` at surface coordinates ``(u, v)`` (see surface_colour)."""
    two_pi = 2.0 * math.pi
    if kind[t] == 0:  # waves: mean of 3 sines
        p = 0.0
        for k in range(3):
            p += math.sin(two_pi * (waves[t, k, 0] * u + waves[t, k, 1] * v) + waves[t, k, 2])
        p = p / 3.0
    else:  # tiles
        p = 0.7 * math.sin(two_pi * waves[t, 0, 0] * u + waves[t, 0, 2]) * \
            math.sin(two_pi * waves[t, 0, 1] * v + waves[t, 0, 2])
        p += 0.3 * math.sin(two_pi * (waves[t, 1, 0] * u + waves[t, 1, 1] * v) + waves[t, 1, 2])
    r = min(max(base[t, 0] + amp[t, 0] * p, 0.0), 1.0)
    g = min(max(base[t, 1] + amp[t, 1] * p, 0.0), 1.0)
    b = min(max(base[t, 2] + amp[t, 2] * p, 0.0), 1.0)
    return r, g, b


@njit(cache=True)
def _render_column(i, ox, oy, c, s, cam_h, level_h, fx, fy, cx, cy, max_range,
                   verts, start, pheight, ptex, floor_tex, ceil_tex,
                   tkind, tbase, tamp, twaves, tmode, ttab, tin, tout, hedge, hprism, rgb, depth, valid,
                   rows, r0, r1):
    """Ray-cast rows ``rows[r0:r1]`` of image column ``i`` into ``rgb``, ``depth``, ``valid``
    (scratch: ``(W, P)`` arrays); every row gets the same numbers whichever others are cast."""
    P = pheight.shape[0]
    xc = (i - cx) / fx
    dx = c + xc * s  # forward (c, s) + x_c * right (s, -c)
    dy = s - xc * c
    n = 0
    tfull = np.inf
    for p in range(P):
        t0 = -np.inf
        t1 = np.inf
        e_in = -1
        inside = True
        k0 = start[p]
        k1 = start[p + 1]
        for k in range(k0, k1):
            kn = k + 1 if k + 1 < k1 else k0
            ax = verts[k, 0]
            ay = verts[k, 1]
            ex = verts[kn, 0] - ax
            ey = verts[kn, 1] - ay
            # outward normal of a CCW edge: (ey, -ex); inside: t * den <= num
            den = ey * dx - ex * dy
            num = ey * (ax - ox) - ex * (ay - oy)
            if den < 0.0:
                t = num / den
                if t > t0:
                    t0 = t
                    e_in = k
            elif den > 0.0:
                t = num / den
                if t < t1:
                    t1 = t
            elif num < 0.0:
                inside = False
                break
        if not inside or t0 > t1 or t0 <= 0.0 or e_in < 0:
            continue
        # stable insertion by entry distance
        m = n
        while m > 0 and tin[i, m - 1] > t0:
            tin[i, m] = tin[i, m - 1]
            tout[i, m] = tout[i, m - 1]
            hedge[i, m] = hedge[i, m - 1]
            hprism[i, m] = hprism[i, m - 1]
            m -= 1
        tin[i, m] = t0
        tout[i, m] = t1
        hedge[i, m] = e_in
        hprism[i, m] = p
        n += 1
        if pheight[p] >= level_h and t0 < tfull:
            tfull = t0
    # a full-height prism hides everything entered behind it
    nk = 0
    while nk < n and tin[i, nk] <= tfull:
        nk += 1
    for r in range(r0, r1):
        j = rows[r]
        yc = (j - cy) / fy
        best = np.inf
        kind = _NONE
        bh = -1
        if yc > 0.0:
            best = cam_h / yc
            kind = _FLOOR
        elif yc < 0.0:
            best = (cam_h - level_h) / yc
            kind = _CEIL
        for h in range(nk):
            t0 = tin[i, h]
            if t0 >= best:
                break
            hp = pheight[hprism[i, h]]
            z = cam_h - yc * t0
            if z >= 0.0 and z <= hp:
                best = t0
                kind = _SIDE
                bh = h
                break
            if yc > 0.0:
                tt = (cam_h - hp) / yc
                if tt >= t0 and tt <= tout[i, h] and tt < best:
                    best = tt
                    kind = _TOP
                    bh = h
        if kind == _NONE or best > max_range:
            depth[j, i] = np.inf
            valid[j, i] = False
            rgb[j, i, 0] = 0.0
            rgb[j, i, 1] = 0.0
            rgb[j, i, 2] = 0.0
            continue
        px = ox + best * dx
        py = oy + best * dy
        if kind == _SIDE:
            k = hedge[i, bh]
            p = hprism[i, bh]
            kn = k + 1 if k + 1 < start[p + 1] else start[p]
            ex = verts[kn, 0] - verts[k, 0]
            ey = verts[kn, 1] - verts[k, 1]
            t = ptex[p]
            u = ((px - verts[k, 0]) * ex + (py - verts[k, 1]) * ey) / math.sqrt(ex * ex + ey * ey)
            v = cam_h - yc * best
            surf = 2 + P + k
        elif kind == _TOP:
            t = ptex[hprism[i, bh]]
            u = px
            v = py
            surf = 2 + hprism[i, bh]
        elif kind == _FLOOR:
            t = floor_tex
            u = px
            v = py
            surf = 0
        else:
            t = ceil_tex
            u = px
            v = py
            surf = 1
        if tmode == 0:
            r, g, b = _texel(t, u, v, tkind, tbase, tamp, twaves)
        else:
            if tmode == 1:
                pat = table_pattern(surf, t, u, v, tkind, twaves, ttab[0], ttab[1], ttab[2], ttab[3])
            else:
                pat = pattern_poly(t, u, v, tkind, twaves)
            r = min(max(tbase[t, 0] + tamp[t, 0] * pat, 0.0), 1.0)
            g = min(max(tbase[t, 1] + tamp[t, 1] * pat, 0.0), 1.0)
            b = min(max(tbase[t, 2] + tamp[t, 2] * pat, 0.0), 1.0)
        depth[j, i] = best
        valid[j, i] = True
        rgb[j, i, 0] = r
        rgb[j, i, 1] = g
        rgb[j, i, 2] = b


@njit(cache=True)
def _scratch(W, P):
    """Per-column scratch of the kernels: each column's hits sorted by entry (entry, exit,
    entered edge, prism), ``(W, P)`` each."""
    return (np.empty((W, P)), np.empty((W, P)), np.empty((W, P), np.int64),
            np.empty((W, P), np.int64))


@njit(cache=True, parallel=True)
def _render_parallel(ox, oy, theta, cam_h, level_h, fx, fy, cx, cy, max_range,
                     verts, start, pheight, ptex, floor_tex, ceil_tex,
                     tkind, tbase, tamp, twaves, tmode, ttab, rgb, depth, valid):
    """Fill ``rgb (H, W, 3) float32``, ``depth (H, W) float32``, ``valid (H, W) bool``; columns in parallel."""
    H, W = depth.shape
    all_rows = np.arange(H)
    c = math.cos(theta)
    s = math.sin(theta)
    tin, tout, hedge, hprism = _scratch(W, pheight.shape[0])
    for i in prange(W):
        _render_column(i, ox, oy, c, s, cam_h, level_h, fx, fy, cx, cy, max_range,
                       verts, start, pheight, ptex, floor_tex, ceil_tex,
                       tkind, tbase, tamp, twaves, tmode, ttab, tin, tout, hedge, hprism, rgb, depth, valid,
                       all_rows, 0, H)


@njit(cache=True)
def _render_serial(ox, oy, theta, cam_h, level_h, fx, fy, cx, cy, max_range,
                   verts, start, pheight, ptex, floor_tex, ceil_tex,
                   tkind, tbase, tamp, twaves, tmode, ttab, rgb, depth, valid):
    """Same as :func:`_render_parallel` on one thread (small images, busy machines)."""
    H, W = depth.shape
    all_rows = np.arange(H)
    c = math.cos(theta)
    s = math.sin(theta)
    tin, tout, hedge, hprism = _scratch(W, pheight.shape[0])
    for i in range(W):
        _render_column(i, ox, oy, c, s, cam_h, level_h, fx, fy, cx, cy, max_range,
                       verts, start, pheight, ptex, floor_tex, ceil_tex,
                       tkind, tbase, tamp, twaves, tmode, ttab, tin, tout, hedge, hprism, rgb, depth, valid,
                       all_rows, 0, H)


@njit(cache=True)
def _render_pixels(ox, oy, theta, cam_h, level_h, fx, fy, cx, cy, max_range,
                   verts, start, pheight, ptex, floor_tex, ceil_tex,
                   tkind, tbase, tamp, twaves, tmode, ttab, col_ptr, rows, rgb, depth, valid):
    """Only rows ``rows[col_ptr[i]:col_ptr[i + 1]]`` of every column ``i`` (one thread); the other
    pixels are left as they are (:meth:`RaycastCamera.render` with ``pixels``)."""
    W = depth.shape[1]
    c = math.cos(theta)
    s = math.sin(theta)
    tin, tout, hedge, hprism = _scratch(W, pheight.shape[0])
    for i in range(W):
        if col_ptr[i] < col_ptr[i + 1]:
            _render_column(i, ox, oy, c, s, cam_h, level_h, fx, fy, cx, cy, max_range,
                           verts, start, pheight, ptex, floor_tex, ceil_tex,
                           tkind, tbase, tamp, twaves, tmode, ttab, tin, tout, hedge, hprism, rgb, depth, valid,
                           rows, col_ptr[i], col_ptr[i + 1])


def pixel_columns(pixels, height: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Flat pixel indices (row-major, ``row * width + column``) grouped by column for
    :func:`_render_pixels`: ``col_ptr (W + 1,)`` and ``rows``, the rows of column ``i`` being
    ``rows[col_ptr[i]:col_ptr[i + 1]]`` (sorted, duplicates dropped)."""
    idx = np.unique(np.asarray(pixels, dtype=np.int64).reshape(-1))
    if idx.size and (idx[0] < 0 or idx[-1] >= height * width):
        raise ValueError(f"pixel indices must lie in [0, {height * width}), got "
                         f"{idx[0]}..{idx[-1]}")
    cols, rows = idx % width, idx // width
    order = np.lexsort((rows, cols))
    col_ptr = np.zeros(width + 1, np.int64)
    np.cumsum(np.bincount(cols, minlength=width), out=col_ptr[1:])
    return col_ptr, np.ascontiguousarray(rows[order])


class RaycastCamera:
    """Exact RGB-D camera for a level (see the module docstring).

    ``render(pose)`` takes a planar pose ``(x, y, theta)`` (world metres, radians) and returns a
    :class:`~navbench.geometry.Frame`: rgb ``(H, W, 3)`` float32 in [0, 1], depth ``(H, W)``
    float32 z-depth in metres (``+inf`` where invalid), valid ``(H, W)`` bool.

    ``parallel``: spread the columns over numba's threads. ``None`` (default) does so only for
    images of at least :data:`PARALLEL_MIN_PIXELS` pixels and with at least
    :data:`PARALLEL_MIN_THREADS` numba threads: with two cores shared by other processes, the
    parallel region often waits a whole scheduler slice for a descheduled thread (measured median
    8 ms against 6.7 ms on one thread for 320 x 240 on a loaded 2-core machine).

    ``texture``: how colours are evaluated (:mod:`navbench.sim.texels`): ``procedural`` (the
    default, libm sines per pixel: every ``navbench-1`` image), ``table`` (texel tables looked
    up bilinearly, built once per level) or ``polynomial``. Depth and validity are the same in
    every mode.
    """

    def __init__(self, level: Level, intrinsics: Intrinsics, camera_height: float = CAMERA_HEIGHT,
                 max_range: float = MAX_RANGE, parallel: bool | None = None,
                 texture: str = DEFAULT_TEXTURE):
        self.level = level
        self.texture = check_texture(texture, "RaycastCamera texture")
        if parallel is None:
            import numba

            parallel = (intrinsics.width * intrinsics.height >= PARALLEL_MIN_PIXELS
                        and numba.get_num_threads() >= PARALLEL_MIN_THREADS)
        self.parallel = bool(parallel)
        self.intrinsics = intrinsics
        self.camera_height = float(camera_height)
        self.max_range = float(max_range)
        pr = prisms(level)
        self._verts = np.ascontiguousarray(pr.verts, dtype=np.float64)
        self._start = np.ascontiguousarray(pr.start, dtype=np.int64)
        self._height = np.ascontiguousarray(pr.height, dtype=np.float64)
        self._tex = np.ascontiguousarray(pr.texture, dtype=np.int64)
        self._tables = tuple(np.ascontiguousarray(a) for a in texture_table(level))
        if self.texture == "table":
            tb = texel_tables(level)
            self._texels = (tb.origin, tb.shape, tb.values, 1.0 / tb.h)
        else:
            self._texels = (np.zeros((0, 2)), np.zeros((0, 3), np.int64), np.zeros(0), 1.0)

    def render(self, pose, pixels=None) -> Frame:
        """Render the view from planar ``pose``; a fresh :class:`Frame` each call.

        ``pixels``: flat indices (``row * width + column``) of the only pixels to cast (one
        thread), each with exactly the numbers a full render gives it; every other pixel is
        marked unseen: colour and depth NaN, ``valid`` False. For an estimator that reads
        those pixels alone (:func:`navbench.track.base.observed_pixels`): the same estimates
        for a fraction of the camera's cost.
        """
        intr = self.intrinsics
        H, W = intr.height, intr.width
        x, y, th = (float(v) for v in pose)
        kind, base, amp, waves = self._tables
        args = (x, y, th, self.camera_height, float(self.level.height),
                float(intr.fx), float(intr.fy), float(intr.cx), float(intr.cy), self.max_range,
                self._verts, self._start, self._height, self._tex,
                int(self.level.floor_texture), int(self.level.ceiling_texture),
                kind, base, amp, waves, texture_code(self.texture), self._texels)
        if pixels is not None:
            col_ptr, rows = self._columns(pixels)
            rgb = np.full((H, W, 3), np.nan, np.float32)
            depth = np.full((H, W), np.nan, np.float32)
            valid = np.zeros((H, W), np.bool_)
            _render_pixels(*args, col_ptr, rows, rgb, depth, valid)
            return Frame(rgb, depth, valid)
        rgb = np.empty((H, W, 3), np.float32)
        depth = np.empty((H, W), np.float32)
        valid = np.empty((H, W), np.bool_)
        kernel = _render_parallel if self.parallel else _render_serial
        kernel(*args, rgb, depth, valid)
        return Frame(rgb, depth, valid)

    def _columns(self, pixels) -> tuple[np.ndarray, np.ndarray]:
        """:func:`pixel_columns` of ``pixels``, kept for the last array given (an estimator
        reads the same pixels every step)."""
        memo = getattr(self, "_columns_memo", None)
        if memo is not None and memo[0] is pixels:
            return memo[1]
        cols = pixel_columns(pixels, self.intrinsics.height, self.intrinsics.width)
        self._columns_memo = (pixels, cols)
        return cols


# ------------------------------------------------------------------------------ reference

def render_reference(level: Level, intrinsics: Intrinsics, pose, camera_height: float = CAMERA_HEIGHT,
                     max_range: float = MAX_RANGE, texture: str = DEFAULT_TEXTURE) -> Frame:
    """Slow pure-numpy renderer with the same semantics as :class:`RaycastCamera` (for tests).

    Vectorised over pixels, looping over prisms; colours come from
    :func:`navbench.level.surface_colour` itself (``texture="procedural"``) or from the
    same texel tables or polynomial sine as the camera's (:func:`navbench.sim.texels.surface_pattern`).
    """
    check_texture(texture, "render_reference texture")
    intr = intrinsics
    H, W = intr.height, intr.width
    x, y, th = (float(v) for v in pose)
    c, s = math.cos(th), math.sin(th)
    xc = (np.arange(W, dtype=np.float64) - intr.cx) / intr.fx  # (W,)
    yc = (np.arange(H, dtype=np.float64) - intr.cy) / intr.fy  # (H,)
    d = np.stack([c + xc * s, s - xc * c], axis=1)  # (W, 2) horizontal ray directions
    origin = np.array([x, y])
    YC = np.broadcast_to(yc[:, None], (H, W))

    best = np.full((H, W), np.inf)
    kind = np.full((H, W), _NONE, np.int64)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where(YC > 0, camera_height / YC, np.inf)
        t_ceil = np.where(YC < 0, (camera_height - level.height) / YC, np.inf)
    best = np.where(YC > 0, t_floor, best)
    kind = np.where(YC > 0, _FLOOR, kind)
    best = np.where(YC < 0, t_ceil, best)
    kind = np.where(YC < 0, _CEIL, kind)
    which = np.full((H, W), -1, np.int64)  # prism index
    edge_a = np.zeros((H, W, 2))
    edge_dir = np.zeros((H, W, 2))
    edge_k = np.zeros((H, W), np.int64)  # global index of the entered edge

    pr = prisms(level)
    for p in range(len(pr)):
        poly = pr.polygon(p)
        a = poly
        e = np.roll(poly, -1, axis=0) - poly  # (E, 2)
        nrm = np.stack([e[:, 1], -e[:, 0]], axis=1)  # outward normals (CCW)
        den = d @ nrm.T  # (W, E)
        num = ((a - origin) * nrm).sum(axis=1)[None, :]  # (1, E)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = num / den
        enter = den < 0
        leave = den > 0
        t0 = np.where(enter, t, -np.inf).max(axis=1)
        e_in = np.where(enter, t, -np.inf).argmax(axis=1)
        t1 = np.where(leave, t, np.inf).min(axis=1)
        outside_par = np.any((den == 0) & (num < 0), axis=1)
        hit = ~outside_par & (t0 <= t1) & (t0 > 0) & np.any(enter, axis=1)  # (W,)
        h = pr.height[p]
        T0 = np.broadcast_to(t0[None, :], (H, W))
        T1 = np.broadcast_to(t1[None, :], (H, W))
        z_in = camera_height - YC * T0
        side = hit[None, :] & (z_in >= 0) & (z_in <= h)
        with np.errstate(divide="ignore", invalid="ignore"):
            t_top = np.where(YC > 0, (camera_height - h) / YC, np.inf)
        top = hit[None, :] & ~side & (YC > 0) & (t_top >= T0) & (t_top <= T1)
        cand = np.where(side, T0, np.where(top, t_top, np.inf))
        better = cand < best
        best = np.where(better, cand, best)
        kind = np.where(better, np.where(side, _SIDE, _TOP), kind)
        which = np.where(better, p, which)
        ea = a[e_in]  # (W, 2)
        ed = e[e_in]
        edge_a = np.where(better[..., None], ea[None], edge_a)
        edge_dir = np.where(better[..., None], ed[None], edge_dir)
        edge_k = np.where(better, pr.start[p] + e_in[None, :], edge_k)

    invalid = (kind == _NONE) | (best > max_range)
    tt = np.where(invalid, 0.0, best)
    px = x + tt * d[None, :, 0]
    py = y + tt * d[None, :, 1]
    pz = camera_height - YC * tt
    rgb = np.zeros((H, W, 3))
    P = len(pr)
    tex_of = {_FLOOR: level.floor_texture, _CEIL: level.ceiling_texture}

    def colour(m, t, surf, u, v):
        if texture == "procedural":
            rgb[m] = surface_colour(level.textures[t], u, v)
            return
        pat = surface_pattern(level, texture, surf, np.full(len(u), t), u, v)
        tex = level.textures[t]
        rgb[m] = np.clip(np.asarray(tex.base) + np.asarray(tex.amp) * pat[:, None], 0.0, 1.0)

    for k in (_FLOOR, _CEIL):
        m = (kind == k) & ~invalid
        if m.any():
            colour(m, tex_of[k], np.full(int(m.sum()), 0 if k == _FLOOR else 1), px[m], py[m])
    for p in range(P):
        t = int(pr.texture[p])
        m = (kind == _TOP) & (which == p) & ~invalid
        if m.any():
            colour(m, t, np.full(int(m.sum()), 2 + p), px[m], py[m])
        m = (kind == _SIDE) & (which == p) & ~invalid
        if m.any():
            ed = edge_dir[m]
            u = ((px[m] - edge_a[m][:, 0]) * ed[:, 0] + (py[m] - edge_a[m][:, 1]) * ed[:, 1]) \
                / np.linalg.norm(ed, axis=1)
            colour(m, t, 2 + P + edge_k[m], u, pz[m])
    depth = np.where(invalid, np.inf, best).astype(np.float32)
    return Frame(rgb.astype(np.float32), depth, ~invalid)
