"""The fast inference renderer: eq. 1 of the paper in numba, no gradients.

For every pixel ``(i, j)`` the world ray ``r = c + k v``, ``v = R K^-1 [i j 1]^T`` is sampled at
``k = Delta, 2 Delta, ..., n Delta`` (``n = round(max_range / Delta)``); the first sample
``p+`` with ``f > tau`` and the one before it, ``p-``, give ``k* = alpha k+ + (1 - alpha) k-``
with ``alpha = (tau - f(p-)) / (f(p+) - f(p-))``, and the colour is ``g(p*)``. Because the
third component of ``K^-1 [i j 1]`` is 1, ``k*`` is the z-depth of :mod:`navbench.geometry`.

Edge cases (shared with :mod:`navbench.worldmodel.diffrender`):

* crossing at the first sample: ``p-`` is the camera centre ``c`` (``k- = 0``);
* ``f(c) > tau`` as well (the camera is inside occupied space): no valid crossing;
* no sample above ``tau`` within ``max_range``: no crossing.

Pixels without a crossing have ``valid = False``, depth ``+inf`` and colour 0. Colours are
clipped to ``[0, 1]`` in the returned frame.

Speed: rows may run in parallel (``numba.prange``); each ray stops at its first crossing; and
empty space is skipped exactly: a precomputed table (:func:`skip_distance`) gives, for every
interpolation cell, the Chebyshev distance to the nearest cell where ``f`` could exceed
``tau``, so a ray jumps over the samples that provably cannot cross (the first crossing found
is the one the sample-by-sample march finds, so the images are identical). :class:`FastRenderer` keeps that
table and the ray directions between frames; :func:`render_map` reuses one per map object.

The ``vmap`` arguments are :class:`~navbench.worldmodel.grid.VoxelMap` objects (anything with
``occ``, ``col``, ``spec``, ``tau`` and ``meta``); this module does not import that class, which
delegates its ``renderer`` method here.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numba as nb
import numpy as np

from navbench.geometry import CAMERA_HEIGHT, MAX_RANGE, Frame, Intrinsics, camera_pose, pixel_rays

#: Default ray sample spacing Delta (m) when the map does not record one: the paper's 20 m / 200.
DEFAULT_STEP = MAX_RANGE / 200


def map_step(vmap, step: float | None) -> float:
    """The sample spacing to render ``vmap`` with: ``step``, else ``vmap.meta['step']``, else 0.1 m."""
    if step is not None:
        return float(step)
    return float(vmap.meta.get("step", DEFAULT_STEP))


@lru_cache(maxsize=16)
def _rays(intr: Intrinsics) -> np.ndarray:
    return np.ascontiguousarray(pixel_rays(intr))


@nb.njit(cache=True, parallel=True)
def cell_max(occ):
    """Maximum of the 8 cell centres around every interpolation cell, ``(nx-1, ny-1, nz-1)``."""
    nx, ny, nz = occ.shape
    out = np.empty((nx - 1, ny - 1, nz - 1), np.float32)
    for i in nb.prange(nx - 1):
        for j in range(ny - 1):
            for k in range(nz - 1):
                m = occ[i, j, k]
                for a in range(2):
                    for b in range(2):
                        for c in range(2):
                            v = occ[i + a, j + b, k + c]
                            if v > m:
                                m = v
                out[i, j, k] = m
    return out


#: z half-width (cells) of the slab skip table.
SLAB = 2


def skip_distance(occ: np.ndarray, tau: float, slab: int | None = None, cap: int = 1000) -> np.ndarray:
    """Empty-space skip table ``(nx-1, ny-1, nz-1)`` int32 over the interpolation cells.

    An interpolation cell (the box between 8 neighbouring cell centres) is *empty* when the
    maximum of its 8 values is ``<= tau``: trilinear ``f`` inside it cannot exceed ``tau``.
    ``slab=None``: the Chebyshev distance (cells) from every cell to the nearest non-empty
    cell, so all cells closer than that are empty. ``slab=s``: the Chebyshev distance in
    ``x, y`` only, to the nearest non-empty cell of the layers ``k - s .. k + s`` (for the
    nearly horizontal rays of a level, whose room is wide but low in cells). 0 for a
    non-empty cell, ``cap`` when there is none.
    """
    from scipy.ndimage import distance_transform_cdt

    empty = cell_max(np.ascontiguousarray(occ, np.float32)) <= tau
    structure = np.ones((3, 3, 3), bool)
    if slab is not None:
        full = ~empty
        near = full.copy()
        for dz in range(1, slab + 1):
            near[:, :, dz:] |= full[:, :, :-dz]
            near[:, :, :-dz] |= full[:, :, dz:]
        empty = ~near
        structure = np.zeros((3, 3, 3), bool)
        structure[:, :, 1] = True  # distances within a layer
    if empty.all():
        return np.full(empty.shape, cap, np.int32)
    if not empty.any():
        return np.zeros(empty.shape, np.int32)
    d = distance_transform_cdt(empty, metric=structure).astype(np.int32)
    d[d < 0] = cap  # a layer with no non-empty cell
    return np.minimum(d, cap)


def exact_skip_tables(occ: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
    """The renderer's two exact tables, :func:`skip_distance` without and with ``slab=SLAB``."""
    return skip_distance(occ, tau), skip_distance(occ, tau, slab=SLAB)


@nb.njit(cache=True, inline="always")
def _cell(u, n):
    """Clamped continuous index -> (i0, t) with ``0 <= i0 <= n - 2``."""
    if u < 0.0:
        u = 0.0
    elif u > n - 1:
        u = n - 1.0
    i0 = int(u)
    if i0 > n - 2:
        i0 = n - 2
    return i0, u - i0


@nb.njit(cache=True, inline="always")
def _tri(g, i, j, k, tx, ty, tz):
    c00 = g[i, j, k] * (1 - tx) + g[i + 1, j, k] * tx
    c10 = g[i, j + 1, k] * (1 - tx) + g[i + 1, j + 1, k] * tx
    c01 = g[i, j, k + 1] * (1 - tx) + g[i + 1, j, k + 1] * tx
    c11 = g[i, j + 1, k + 1] * (1 - tx) + g[i + 1, j + 1, k + 1] * tx
    c0 = c00 * (1 - ty) + c10 * ty
    c1 = c01 * (1 - ty) + c11 * ty
    return c0 * (1 - tz) + c1 * tz


@nb.njit(cache=True, inline="always")
def _tri3(col, i, j, k, tx, ty, tz, out):
    """Trilinear RGB of ``col (nx, ny, nz, 3)`` clipped to [0, 1] into ``out (3,)``."""
    w000 = (1 - tx) * (1 - ty) * (1 - tz)
    w100 = tx * (1 - ty) * (1 - tz)
    w010 = (1 - tx) * ty * (1 - tz)
    w110 = tx * ty * (1 - tz)
    w001 = (1 - tx) * (1 - ty) * tz
    w101 = tx * (1 - ty) * tz
    w011 = (1 - tx) * ty * tz
    w111 = tx * ty * tz
    for ch in range(3):
        v = (w000 * col[i, j, k, ch] + w100 * col[i + 1, j, k, ch]
             + w010 * col[i, j + 1, k, ch] + w110 * col[i + 1, j + 1, k, ch]
             + w001 * col[i, j, k + 1, ch] + w101 * col[i + 1, j, k + 1, ch]
             + w011 * col[i, j + 1, k + 1, ch] + w111 * col[i + 1, j + 1, k + 1, ch])
        out[ch] = min(1.0, max(0.0, v))


@nb.njit(cache=True, inline="always")
def _f(occ, ux, uy, uz, nx, ny, nz):
    i, tx = _cell(ux, nx)
    j, ty = _cell(uy, ny)
    k, tz = _cell(uz, nz)
    return _tri(occ, i, j, k, tx, ty, tz)


@nb.njit(cache=True, inline="always")
def _no_hit(depth, valid, rgb, r, c):
    """Pixel ``(r, c)`` sees nothing (no crossing, or the camera is inside occupied space):
    infinite depth, invalid, black."""
    depth[r, c] = np.inf
    valid[r, c] = False
    rgb[r, c, 0] = 0.0
    rgb[r, c, 1] = 0.0
    rgb[r, c, 2] = 0.0


@nb.njit(cache=True, inline="always")
def _render_pixel(occ, col, dist, dist2, u_c, inv_size, R, rays, step, n, tau, r, c,
                  nx, ny, nz, depth, rgb, valid):
    """Render pixel ``(r, c)`` into ``depth``, ``rgb``, ``valid`` (one ray of :func:`_render_kernel`;
    :func:`render_list` renders single pixels with it)."""
    a0, a1, a2 = rays[r, c, 0], rays[r, c, 1], rays[r, c, 2]
    # world direction times step, in cell units
    dx = (R[0, 0] * a0 + R[0, 1] * a1 + R[0, 2] * a2) * inv_size[0] * step
    dy = (R[1, 0] * a0 + R[1, 1] * a1 + R[1, 2] * a2) * inv_size[1] * step
    dz = (R[2, 0] * a0 + R[2, 1] * a1 + R[2, 2] * a2) * inv_size[2] * step
    hit = 0
    fp = 0.0
    # reciprocal per-sample displacement (cells): all axes, xy only, z only
    # (capped at n samples so the int conversions below never overflow)
    amax = max(abs(dx), max(abs(dy), abs(dz)))
    inv_amax = min(1.0 / amax, float(n)) if amax > 0 else float(n)
    axy = max(abs(dx), abs(dy))
    inv_axy = min(1.0 / axy, float(n)) if axy > 0 else float(n)
    zlim = min(SLAB / abs(dz), float(n)) if dz != 0 else float(n)
    m = 1
    while m <= n:
        ux = u_c[0] + m * dx
        uy = u_c[1] + m * dy
        uz = u_c[2] + m * dz
        i, tx = _cell(ux, nx)
        j, ty = _cell(uy, ny)
        k, tz = _cell(uz, nz)
        D = dist[i, j, k]
        if D > 0:
            # every interpolation cell within Chebyshev distance D - 1 has max <= tau:
            # the next floor((D - 1) / amax) samples stay inside them (clamping is
            # 1-Lipschitz), so none of them can cross. The slab table does the same
            # for the box of xy half-width D2 - 1 and z half-width SLAB.
            skip = int((D - 1) * inv_amax)
            s2 = min(int((dist2[i, j, k] - 1) * inv_axy), int(zlim))
            if s2 > skip:
                skip = s2
            m += 1 + skip
            continue
        fp = _tri(occ, i, j, k, tx, ty, tz)
        if fp > tau:
            hit = m
            break
        m += 1
    if hit == 0:
        _no_hit(depth, valid, rgb, r, c)
        return
    mm = hit - 1
    fm = _f(occ, u_c[0] + mm * dx, u_c[1] + mm * dy, u_c[2] + mm * dz, nx, ny, nz)
    if fm > tau:  # only possible for mm == 0: the camera is inside occupied space
        _no_hit(depth, valid, rgb, r, c)
        return
    alpha = (tau - fm) / (fp - fm)
    ms = mm + alpha  # k* / step
    depth[r, c] = ms * step
    valid[r, c] = True
    i, tx = _cell(u_c[0] + ms * dx, nx)
    j, ty = _cell(u_c[1] + ms * dy, ny)
    k, tz = _cell(u_c[2] + ms * dz, nz)
    _tri3(col, i, j, k, tx, ty, tz, rgb[r, c])


def _render_kernel(occ, col, dist, dist2, u_c, inv_size, R, rays, step, n, tau, depth, rgb, valid):
    """Fill ``depth (H, W)``, ``rgb (H, W, 3)``, ``valid (H, W)`` in place.

    ``col (nx, ny, nz, 3)``; ``dist (nx-1, ny-1, nz-1)``: the skip
    table of :func:`skip_distance` and ``dist2`` its slab version (``slab=SLAB``). ``u_c (3,)``: camera centre in continuous cell indices; ``inv_size (3,)``: 1 / cell size;
    ``R (3, 3)``: camera-to-world rotation; ``rays (H, W, 3)``: camera-frame ``K^-1 [i j 1]``.
    """
    nx, ny, nz = occ.shape
    H, W = rays.shape[0], rays.shape[1]
    half = (H + 1) // 2
    for rr in nb.prange(H):
        # interleave rows (even rows first, then odd ones): numba splits the prange into equal
        # contiguous chunks per thread, and the cost of a row depends on what it sees (upper rows
        # march to far walls, lower rows stop at the floor), so contiguous halves are unbalanced
        r = 2 * rr if rr < half else 2 * (rr - half) + 1
        for c in range(W):
            _render_pixel(occ, col, dist, dist2, u_c, inv_size, R, rays, step, n, tau, r, c,
                          nx, ny, nz, depth, rgb, valid)


@nb.njit(cache=True, nogil=True)
def collect_projected(done, fx, fy, cx, cy, pts, ook, Trels, todo):
    """The reference pixels the eq. 7 kernel will read, for a lazy reference (step 1 of 2).

    For every linearisation ``Trels[t] (4, 4)`` and every valid point ``pts[k]`` it projects
    ``q = Trel p`` exactly as :func:`navbench.track.eq7._accumulate_kernel` does (the same
    expressions, so the same floats) and lists the pixels the kernel reads there that are not
    yet ``done``: the 4 bilinear corners and, when inside the border, the nearest pixel and its
    4 neighbours (the normal and curvature). It marks them ``done`` and writes their flat
    indices ``r * W + c`` to ``todo`` (at least ``H * W`` long); returns their number.
    :func:`render_list` renders them (step 2): collecting first and rendering in a separate
    loop is ~15 % faster than rendering inside this loop, and the rendering may use threads.
    """
    H, W = done.shape
    count = 0
    for t in range(Trels.shape[0]):
        Trel = Trels[t]
        for k in range(pts.shape[0]):
            if not ook[k]:
                continue
            p0, p1, p2 = pts[k, 0], pts[k, 1], pts[k, 2]
            q0 = Trel[0, 0] * p0 + Trel[0, 1] * p1 + Trel[0, 2] * p2 + Trel[0, 3]
            q1 = Trel[1, 0] * p0 + Trel[1, 1] * p1 + Trel[1, 2] * p2 + Trel[1, 3]
            q2 = Trel[2, 0] * p0 + Trel[2, 1] * p1 + Trel[2, 2] * p2 + Trel[2, 3]
            if q2 <= 1e-6:
                continue
            iz = 1.0 / q2
            u = fx * q0 * iz + cx
            v = fy * q1 * iz + cy
            if not (u >= 0.0 and u <= W - 1 and v >= 0.0 and v <= H - 1):
                continue
            u0 = min(int(math.floor(u)), W - 2)
            v0 = min(int(math.floor(v)), H - 2)
            ui = int(math.floor(u + 0.5))
            vi = int(math.floor(v + 0.5))
            cross = ui >= 1 and ui <= W - 2 and vi >= 1 and vi <= H - 2
            for e in range(9):
                if e < 4:
                    r, c = v0 + e // 2, u0 + e % 2
                elif cross:
                    r = vi + (1 if e == 5 else -1 if e == 6 else 0)
                    c = ui + (1 if e == 7 else -1 if e == 8 else 0)
                else:
                    break
                if done[r, c]:
                    continue
                done[r, c] = True
                todo[count] = r * W + c
                count += 1
    return count


def _render_list(occ, col, dist, dist2, u_c, inv_size, R, rays, step, n, tau,
                 depth32, rgb32, valid8, depth, rgb, valid, todo, count):
    """Render the pixels ``todo[:count]`` (flat indices) with the full renderer's ray
    (:func:`_render_pixel`) into the float32 frame (``depth32``, ``rgb32``, ``valid8``) and
    convert them as :func:`navbench.track.eq7.prepare_reference` converts a frame (float64
    ``depth``, ``rgb``, ``valid``; invalid depth 0). Every pixel is rendered on its own, so
    neither the order nor the thread changes a value."""
    nx, ny, nz = occ.shape
    W = depth.shape[1]
    for i in nb.prange(count):
        f = todo[i]
        r = f // W
        c = f - r * W
        _render_pixel(occ, col, dist, dist2, u_c, inv_size, R, rays, step, n, tau, r, c,
                      nx, ny, nz, depth32, rgb32, valid8)
        d = np.float64(depth32[r, c])
        ok = valid8[r, c] and math.isfinite(d) and d > 0
        valid[r, c] = ok
        depth[r, c] = d if ok else 0.0
        for ch in range(3):
            rgb[r, c, ch] = np.float64(rgb32[r, c, ch])


class LazyFrame:
    """A reference image of one camera pose whose pixels are rendered when first needed.

    ``rgb (H, W, 3)``, ``depth (H, W)`` float64 and ``valid (H, W)`` hold what
    :func:`navbench.track.eq7.prepare_reference` makes of the full rendered frame, at every pixel
    :meth:`fill` has rendered (zeros elsewhere); ``seconds`` sums the time spent rendering.
    """

    def __init__(self, renderer: "FastRenderer", T_wc: np.ndarray):
        H, W = renderer.intrinsics.shape
        T_wc = np.asarray(T_wc, np.float64)
        self.renderer = renderer
        self.T_wc = T_wc
        self._u_c = renderer.centre_index(T_wc[:3, 3])
        self._R = np.ascontiguousarray(T_wc[:3, :3])
        self._depth32 = np.zeros((H, W), np.float32)
        self._rgb32 = np.zeros((H, W, 3), np.float32)
        self._valid8 = np.zeros((H, W), np.bool_)
        self.done = np.zeros((H, W), np.bool_)
        self.rgb = np.zeros((H, W, 3))
        self.depth = np.zeros((H, W))
        self.valid = np.zeros((H, W), np.bool_)
        self.seconds = 0.0
        self.rendered = 0
        self._todo = np.empty(H * W, np.int64)  # pixels to render, flat indices

    def fill(self, points: np.ndarray, ok: np.ndarray, Trels: np.ndarray) -> None:
        """Render the pixels that the eq. 7 kernel reads for ``points (K, 3)`` (where ``ok``)
        under each of ``Trels (N, 4, 4)``."""
        import time

        t0 = time.perf_counter()
        fr, i = self.renderer, self.renderer.intrinsics
        count = collect_projected(self.done, float(i.fx), float(i.fy), float(i.cx), float(i.cy),
                                  points, ok, Trels, self._todo)
        kernel = render_list if fr._kernel is render_kernel else render_list_serial
        kernel(fr.vmap.occ, fr._col, fr.dist, fr.dist2, self._u_c, fr._inv, self._R, fr.rays, fr.step,
               fr.n, fr.vmap.tau, self._depth32, self._rgb32, self._valid8, self.depth, self.rgb,
               self.valid, self._todo, count)
        self.rendered += count
        self.seconds += time.perf_counter() - t0


def _named_copy(fn, name: str):
    """``fn`` under another name: numba names its on-disk cache after the function's qualified
    name, so two dispatchers of one Python function (parallel and serial) would share one cache
    entry, and whichever compiled first would be loaded for both (the parallel kernel then runs
    serial code, at half speed on 2 cores)."""
    import types

    out = types.FunctionType(fn.__code__, fn.__globals__, name, fn.__defaults__, fn.__closure__)
    out.__qualname__ = name
    out.__doc__ = fn.__doc__
    return out


render_kernel = nb.njit(cache=True, parallel=True)(_named_copy(_render_kernel, "_render_kernel_parallel"))
render_kernel_serial = nb.njit(cache=True)(_named_copy(_render_kernel, "_render_kernel_serial"))
render_list = nb.njit(cache=True, parallel=True)(_named_copy(_render_list, "_render_list_parallel"))
render_list_serial = nb.njit(cache=True, nogil=True)(_named_copy(_render_list, "_render_list_serial"))
#: Images with at least this many pixels render on numba's threads by default (measured on 2
#: idle cores: 160 x 120 in 1.9 ms parallel vs 4.1 ms on one thread; 320 x 240 in 7.6 vs 14 ms;
#: 2026-11-23, house-1's 10 000-step map: 80 x 60, the localiser's refinement image, 0.43 vs
#: 0.86 ms, and 40 x 30 still 0.6x, but smaller images stay serial for busy machines).
PARALLEL_MIN_PIXELS = 80 * 60


class FastRenderer:
    """Renders one map for one camera many times (keeps the skip table and ray directions).

    ``step``: ray sample spacing Delta (m), default ``vmap.meta['step']`` or 0.1 m;
    ``max_range`` (m): the last sample is at ``round(max_range / step) * step``.
    ``parallel``: rows on numba's threads; ``None`` = only for images of at least
    :data:`PARALLEL_MIN_PIXELS` pixels (on a busy machine one thread is often faster), and only
    when numba may use more than one thread (pool workers use one).
    ``skip_tables``: ``(dist, dist2)`` to use instead of :func:`skip_distance`'s (lower bounds
    of them render identical images; the online map's cheaper tables,
    :func:`navbench.worldmodel.fusion_render.block_skip_tables`).
    """

    def __init__(self, vmap, intrinsics: Intrinsics, camera_height: float = CAMERA_HEIGHT,
                 max_range: float = MAX_RANGE, step: float | None = None,
                 parallel: bool | None = None, skip_tables: tuple | None = None):
        if parallel is None:  # one numba thread (a pool worker): the serial kernel, same pixels
            parallel = (intrinsics.width * intrinsics.height >= PARALLEL_MIN_PIXELS
                        and nb.get_num_threads() > 1)
        self._kernel = render_kernel if parallel else render_kernel_serial
        self.vmap = vmap
        self.intrinsics = intrinsics
        self.camera_height = float(camera_height)
        self.step = map_step(vmap, step)
        self.n = int(round(max_range / self.step))
        self.rays = _rays(intrinsics)
        if skip_tables is None:
            self.dist, self.dist2 = exact_skip_tables(vmap.occ, vmap.tau)
        else:  # (dist, dist2) given: any lower bounds of skip_distance's tables render the same
            self.dist, self.dist2 = skip_tables
        spec = vmap.spec
        self._lo = np.asarray(spec.lo, np.float64)
        self._inv = 1.0 / spec.size
        self._col = np.ascontiguousarray(vmap.col, np.float32)

    def centre_index(self, centres: np.ndarray) -> np.ndarray:
        """Continuous cell indices of camera centres ``(..., 3)`` (world m), as the kernel reads them."""
        return (centres - self._lo) * self._inv - 0.5

    def render_T(self, T_wc: np.ndarray) -> Frame:
        """Render from an arbitrary camera-to-world transform ``T_wc`` (4x4, OpenCV camera axes)."""
        T_wc = np.asarray(T_wc, np.float64)
        H, W = self.intrinsics.shape
        depth = np.empty((H, W), np.float32)
        rgb = np.empty((H, W, 3), np.float32)
        valid = np.empty((H, W), np.bool_)
        u_c = self.centre_index(T_wc[:3, 3])
        self._kernel(self.vmap.occ, self._col, self.dist, self.dist2, u_c, self._inv,
                      np.ascontiguousarray(T_wc[:3, :3]), self.rays, self.step, self.n,
                      self.vmap.tau, depth, rgb, valid)
        return Frame(rgb, depth, valid)

    def render(self, pose) -> Frame:
        """Render the view of the camera on planar pose ``(x, y, theta)`` (world metres, rad)."""
        return self.render_T(camera_pose(pose, self.camera_height))


_CACHE: dict = {}
_CACHE_SIZE = 8


def _fingerprint(vmap) -> tuple:
    occ = vmap.occ
    return (occ.ctypes.data, vmap.col.ctypes.data, occ.shape, vmap.tau,
            float(occ[::3, ::3, ::2].sum(dtype=np.float64)), float(vmap.col[::5, ::5, ::3].sum(dtype=np.float64)))


def cached_renderer(vmap, intrinsics: Intrinsics, camera_height: float = CAMERA_HEIGHT,
                    max_range: float = MAX_RANGE, step: float | None = None) -> FastRenderer:
    """A :class:`FastRenderer` reused across calls for the same map object and camera.

    Entries are keyed by the map's identity and checked against a fingerprint of its arrays
    (data pointers and strided sums), so a map edited in place gets a fresh renderer; the
    cache holds at most 8 renderers and only weak references to the maps.
    """
    import weakref

    key = (id(vmap), intrinsics, float(camera_height), float(max_range), step)
    hit = _CACHE.get(key)
    fp = _fingerprint(vmap)
    if hit is not None and hit[0]() is vmap and hit[1] == fp:
        return hit[2]
    fr = FastRenderer(vmap, intrinsics, camera_height, max_range, step)
    if len(_CACHE) >= _CACHE_SIZE:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[key] = (weakref.ref(vmap), fp, fr)
    return fr


def render_map(vmap, pose, intrinsics: Intrinsics, camera_height: float = CAMERA_HEIGHT,
               max_range: float = MAX_RANGE, step: float | None = None) -> Frame:
    """Render ``vmap`` from the camera on planar ``pose`` -> :class:`~navbench.geometry.Frame`.

    ``step`` (m): sample spacing Delta, default ``vmap.meta['step']`` or 0.1 m (the paper's
    20 m / 200). The skip table is built once per map object (:func:`cached_renderer`).
    """
    return cached_renderer(vmap, intrinsics, camera_height, max_range, step).render(pose)


def render_map_T(vmap, T_wc, intrinsics: Intrinsics, max_range: float = MAX_RANGE,
                 step: float | None = None) -> Frame:
    """Render ``vmap`` from an arbitrary 6-DoF camera ``T_wc`` (4x4 camera-to-world)."""
    return cached_renderer(vmap, intrinsics, CAMERA_HEIGHT, max_range, step).render_T(T_wc)
