"""Online mapping: fuse tracked RGB-D frames into a voxel world model (issue 15 section 3).

The fused map is a truncated signed distance field (TSDF, Curless and Levoy 1996; KinectFusion,
Newcombe et al. 2011) kept on a :class:`~navbench.worldmodel.gridspec.GridSpec`, and exposed as a
:class:`~navbench.worldmodel.grid.VoxelMap` (``FusedMap.vmap``) of the same kind as a fitted map,
so :func:`~navbench.worldmodel.fastrender.render_map`, the planner's
:func:`~navbench.worldmodel.grid.occupancy_slice` and the ``ours`` tracker use it unchanged.

Fusing one frame (:func:`fuse_frame`, projective, voxel by voxel)
    Every cell centre ``p`` is moved into the camera frame of the tracked pose, ``(x_c, y_c,
    z_c)``, and projected to its nearest pixel ``(round(u), round(v))`` (the pixel convention of
    :mod:`navbench.geometry`). A cell in front of the camera (``0 < z_c <= max_depth + trunc``)
    whose pixel is inside the image and valid gets the projective signed distance
    ``s = g[v, u] (depth[v, u] - z_c)`` (m; positive in front of the observed surface, the free
    space the pixel's ray crossed; negative behind it). ``g`` (:func:`distance_scale`) turns the
    z-depth difference into the distance to the surface's tangent plane: ``g = |ray| cos(angle
    between the ray and the surface normal)``, the normal from one-sided differences of the
    back-projected depth (on each image axis the neighbour whose depth is closer, so occluding
    edges take the normal of their own side), clamped to ``[min_scale, |ray|]``. Without it a
    surface seen at a grazing angle (the floor a few metres ahead) leaves no cell centre within
    ``trunc`` behind it and vanishes from the map; with it a plane's distances are exact.

    * ``s < -trunc``: occluded by the surface, its occupancy is not updated (stays as it was,
      possibly unseen);
    * otherwise ``t = min(s, trunc) / trunc`` in ``[-1, 1]`` enters the running weighted mean
      ``D <- (W D + t) / (W + 1)``, ``W <- min(W + 1, max_weight)`` (one count per frame, so free
      space along each ray and the occupied shell at each hit are both counted);
    * ``|s| <= colour_band``: the colour of the surface point nearest to the cell (the cell
      centre moved by ``-s`` along the pixel's normal, projected to its nearest pixel; the
      pixel itself where that leaves the image or has no normal) enters the running mean of the
      cell's colour (weight ``min(W_col + 1, max_weight)``): colour at the hit, on both sides
      of the surface (also behind ``-trunc``) so that the renderer's trilinear colour at a
      crossing reads coloured cells only. Cells just outside the image (within ``colour_band``
      of its border) that have no colour yet take the border pixel's as a provisional colour
      (weight 0: the first real observation replaces it), so a crossing near the border of
      the map's seen part does not mix in black. (Taking the colour of the pixel the cell
      projects to instead shifts it by ``~ s tan(angle off the axis)``, 4 cm at the image
      border 5 cm before a wall. Colour L1 of the map rendered at the next pose along a 30-step
      house-2 walk: 0.040 so, 0.026 from the nearest surface point, 0.018 with the provisional
      border colours too.)

Occupancy (the ``occ`` the renderer and the planner read) is ``clip(tau - D / 2, tau - 1/2,
tau + 1/2)``: the same ramp as :func:`~navbench.worldmodel.grid.voxelize_level` with ``ramp =
trunc`` (``D = -s / ramp`` there), so ``f`` crosses ``tau`` on the observed surface (sub-cell
accurate where the surface is flat over the interpolation stencil) and the fusion of exact
frames approaches the voxelised true geometry.

**Unseen cells** (``W = 0``) hold ``tau - UNSEEN_MARGIN`` (``2^-20``): *neutral*. Occupied
means ``f > tau``, so the unknown is never occupied: the renderer never invents a surface in
unseen space and :func:`~navbench.worldmodel.grid.occupancy_slice` reads it as free (optimistic
planning through the unknown, as frontier exploration does). And an unseen corner (almost) does
not move a crossing: ``f - tau`` is the seen corners' ``occ - tau`` weighted, minus at most
``2^-20``, so the thin shell of occupied cells a single view leaves behind a surface renders
without holes (with unseen = 0, a ray could slip between a shell cell and the unseen cells
behind it). The margin, rather than exactly ``tau``, keeps interpolation rounding from making
an unseen cell occupied: ``occupancy_slice`` computes a cell centre's index in floating point
and mixes in the neighbour column with a weight of ~1e-14, which turned unseen cells beside a
wall into obstacles at exactly ``tau``. :func:`seen_slice` says which planning cells are known,
for a planner that must treat the unknown otherwise.

Determinism: the kernel visits cells in a fixed order and each cell reads one pixel, so the same
frames and poses give bit-identical grids. :func:`fuse_frame_reference` is the pure-numpy
reference the kernel is tested against.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba as nb
import numpy as np

from navbench.errors import ConfigError
from navbench.geometry import AGENT_RADIUS, CAMERA_HEIGHT, MAX_RANGE, Frame, Intrinsics
from navbench.worldmodel.grid import DEFAULT_TAU, VoxelMap, band_heights
from navbench.worldmodel.gridspec import GridSpec


#: Bumped when fusing the same frames gives other grids (part of the online study's map key).
FUSION_VERSION = 1
#: Unseen cells hold ``tau - UNSEEN_MARGIN`` (exact in float32 for ``tau = 0.5``).
UNSEEN_MARGIN = 2.0 ** -20


@dataclass(frozen=True)
class FusionConfig:
    """How frames are fused (lengths in metres; ``None``: derived from the grid).

    ``trunc``: truncation distance of the signed distance, default the grid's largest cell size
    (the ramp of :func:`~navbench.worldmodel.grid.voxelize_level`). ``colour_band``: cells this
    close to the observed surface take its colour, default ``2 * trunc``. ``max_weight``: the
    running means' weight cap (frames). ``max_depth``: cells farther (z-depth) than this plus
    ``trunc`` are not updated. ``body_radius``: the cells under the agent's body at each fused
    pose are marked visited (free by construction) in :func:`seen_slice`; 0 disables.
    ``min_scale``: the smallest distance scale ``g`` (:func:`distance_scale`). A small scale lets
    grazing surfaces (the far floor) into the map but also extrapolates a horizontal face past
    its edge into the occluded space behind it (phantom cells behind a low box's top); 0.3 keeps
    the floor to ~3.6 m and was chosen on house-2 (a 200-step walk, seed 0: planning-slice
    precision / recall on the seen part 0.986 / 1.0 at 0.2, 0.987 / 1.0 at 0.3, 1.0 / 1.0 at 0.5;
    rendered depth at the next pose 0.8, 0.9, 1.5 mm median error), not on house-1.
    """

    trunc: float | None = None
    colour_band: float | None = None
    max_weight: float = 100.0
    max_depth: float = MAX_RANGE
    body_radius: float = AGENT_RADIUS
    min_scale: float = 0.3

    def __post_init__(self):
        for name in ("trunc", "colour_band"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise ConfigError(f"fusion {name}: expected a length > 0 m, got {v}")
        if not (math.isfinite(self.max_weight) and self.max_weight >= 1):
            raise ConfigError(f"fusion max_weight: expected >= 1, got {self.max_weight}")
        if not (math.isfinite(self.max_depth) and self.max_depth > 0):
            raise ConfigError(f"fusion max_depth: expected a length > 0 m, got {self.max_depth}")
        if not (math.isfinite(self.min_scale) and 0 < self.min_scale <= 1):
            raise ConfigError(f"fusion min_scale: expected a factor in (0, 1], got {self.min_scale}")
        if not (math.isfinite(self.body_radius) and self.body_radius >= 0):
            raise ConfigError(f"fusion body_radius: expected a length >= 0 m, got {self.body_radius}")

    def resolved(self, spec: GridSpec) -> tuple[float, float]:
        """``(trunc, colour_band)`` in metres for grid ``spec``."""
        trunc = float(self.trunc) if self.trunc is not None else float(spec.size.max())
        band = float(self.colour_band) if self.colour_band is not None else 2.0 * trunc
        return trunc, band


@dataclass
class FusedMap:
    """A TSDF being fused and the :class:`VoxelMap` it defines (see the module docstring).

    ``sdf (nx, ny, nz)`` float32: the running mean ``D`` of ``s / trunc`` in ``[-1, 1]``
    (positive: free side); ``weight`` float32 its frame count (0: unseen); ``col_weight``
    float32 the colour's; ``visited (nx, ny)`` bool: cells under the agent's body at a fused pose;
    ``vmap``: the world model, whose ``occ`` and ``col`` are updated in place by every
    :meth:`fuse`; ``frames``: how many frames were fused.
    """

    spec: GridSpec
    config: FusionConfig
    sdf: np.ndarray
    weight: np.ndarray
    col_weight: np.ndarray
    visited: np.ndarray
    vmap: VoxelMap
    frames: int = 0
    meta: dict = field(default_factory=dict)
    #: Bumped by every change (fuse, clear): what renderers of the map check for staleness.
    version: int = 0
    #: The cells whose occupancy the change to ``version`` may have written, ``(i0, i1, j0, j1,
    #: k0, k1)`` inclusive (``i1 < i0``: none), or None: anything (a renderer rebuilds whole).
    dirty: tuple | None = None

    @classmethod
    def empty(cls, spec: GridSpec, config: FusionConfig = FusionConfig(),
              tau: float = DEFAULT_TAU) -> "FusedMap":
        """An empty (all unseen) map on ``spec``."""
        from navbench.worldmodel.memory import check_memory

        cells = int(np.prod(spec.shape, dtype=np.int64))
        check_memory(cells * 40, f"fused map: grid {list(spec.shape)} ({cells} cells)")
        trunc, band = config.resolved(spec)
        occ = np.full(spec.shape, tau - UNSEEN_MARGIN, np.float32)
        col = np.zeros(spec.shape + (3,), np.float32)
        meta = {"source": "fusion", "trunc": trunc, "colour_band": band,
                "step": float(spec.size.max() / 2), "max_range": float(MAX_RANGE)}
        vmap = VoxelMap(spec, occ, col, tau, meta)
        return cls(spec, config, np.zeros(spec.shape, np.float32), np.zeros(spec.shape, np.float32),
                   np.zeros(spec.shape, np.float32), np.zeros(spec.shape[:2], bool), vmap)

    def fresh(self) -> "FusedMap":
        """An empty map with this one's grid, config and ``tau``."""
        return FusedMap.empty(self.spec, self.config, self.vmap.tau)

    def clear(self) -> None:
        """Back to empty (all unseen), in place: the arrays (and the ``vmap`` object) are kept."""
        for a in (self.sdf, self.weight, self.col_weight, self.vmap.col):
            a[...] = 0
        self.vmap.occ[...] = self.vmap.tau - UNSEEN_MARGIN
        self.visited[...] = False
        self.frames = 0
        self.version += 1
        self.dirty = None

    @property
    def seen(self) -> np.ndarray:
        """``(nx, ny, nz)`` bool: cells updated by at least one frame (the known cells)."""
        return self.weight > 0

    def fuse(self, frame: Frame, pose, intrinsics: Intrinsics,
             camera_height: float = CAMERA_HEIGHT) -> int:
        """Fuse ``frame`` seen from planar ``pose`` (:func:`fuse_frame`); returns cells updated."""
        return fuse_frame(self, frame, pose, intrinsics, camera_height)


def _camera(pose, camera_height: float):
    x, y, theta = (float(v) for v in np.asarray(pose, np.float64).reshape(3))
    return x, y, float(camera_height), math.cos(theta), math.sin(theta)


@nb.njit(cache=True)
def fuse_kernel(sdf, weight, col_weight, occ, col, lo, size, cam, depth, valid, rgb, scale, normals,
                fx, fy, cx, cy, trunc, band, max_weight, max_depth, tau):
    """Fuse one frame into the grids in place (the module docstring's rule); returns the number
    of cells updated and the bounding box ``(i0, i1, j0, j1, k0, k1)`` of their occupancy writes.

    ``lo, size (3,)`` the grid's corner and cell size (m); ``cam = (x, y, z, cos t, sin t)`` the
    camera centre (m) and heading; ``depth (H, W)`` z-depth (m), ``valid (H, W)``, ``rgb (H, W,
    3)`` float32; ``scale (H, W)`` the distance scale ``g`` (:func:`distance_scale`); ``trunc``,
    ``band``, ``max_depth`` (m). Camera frame (OpenCV, planar mount):
    ``x_c = sin t dx - cos t dy``, ``y_c = -(z - cam_z)``, ``z_c = cos t dx + sin t dy``.
    """
    nx, ny, nz = sdf.shape
    H, W = depth.shape
    ox, oy, oz, c, s = cam[0], cam[1], cam[2], cam[3], cam[4]
    zmax = max_depth + trunc
    count = 0
    box = np.array([nx, -1, ny, -1, nz, -1], np.int64)  # the occupancy writes' bounding box
    for i in range(nx):
        dx = lo[0] + (i + 0.5) * size[0] - ox
        for j in range(ny):
            dy = lo[1] + (j + 0.5) * size[1] - oy
            zc = c * dx + s * dy
            if zc <= 1e-9 or zc > zmax:
                continue
            xc = s * dx - c * dy
            ur = int(math.floor(fx * xc / zc + cx + 0.5))
            if ur < -fx * band / zc or ur > W - 1 + fx * band / zc:
                continue
            ui = min(max(ur, 0), W - 1)
            for k in range(nz):
                yc = oz - (lo[2] + (k + 0.5) * size[2])
                vr = int(math.floor(fy * yc / zc + cy + 0.5))
                if vr < -fy * band / zc or vr > H - 1 + fy * band / zc:
                    continue
                vi = min(max(vr, 0), H - 1)
                if not valid[vi, ui]:
                    continue
                sd = (np.float64(depth[vi, ui]) - zc) * scale[vi, ui]
                if ur != ui or vr != vi:  # just outside the image: a provisional colour only
                    if col_weight[i, j, k] == 0 and abs(sd) <= band:
                        for ch in range(3):
                            col[i, j, k, ch] = rgb[vi, ui, ch]
                    continue
                if sd < -trunc and sd < -band:
                    continue
                if sd >= -trunc:
                    t = min(sd, trunc) / trunc
                    w = np.float64(weight[i, j, k])
                    d = (w * sdf[i, j, k] + t) / (w + 1.0)
                    sdf[i, j, k] = d
                    weight[i, j, k] = min(w + 1.0, max_weight)
                    o = tau - 0.5 * np.float64(sdf[i, j, k])
                    occ[i, j, k] = min(max(o, tau - 0.5), tau + 0.5)
                    count += 1
                    box[0], box[1] = min(box[0], i), max(box[1], i)
                    box[2], box[3] = min(box[2], j), max(box[3], j)
                    box[4], box[5] = min(box[4], k), max(box[5], k)
                if abs(sd) <= band:
                    # the colour of the surface point nearest to the cell: along the normal
                    qx = xc - sd * normals[vi, ui, 0]
                    qy = yc - sd * normals[vi, ui, 1]
                    qz = zc - sd * normals[vi, ui, 2]
                    cu, cv = ui, vi
                    if qz > 1e-9:
                        pu = int(math.floor(fx * qx / qz + cx + 0.5))
                        pv = int(math.floor(fy * qy / qz + cy + 0.5))
                        if 0 <= pu < W and 0 <= pv < H and valid[pv, pu]:
                            cu, cv = pu, pv
                    wc = np.float64(col_weight[i, j, k])
                    for ch in range(3):
                        col[i, j, k, ch] = (wc * col[i, j, k, ch] + rgb[cv, cu, ch]) / (wc + 1.0)
                    col_weight[i, j, k] = min(wc + 1.0, max_weight)
    return count, box


def fuse_frame(fused: FusedMap, frame: Frame, pose, intrinsics: Intrinsics,
               camera_height: float = CAMERA_HEIGHT) -> int:
    """Fuse one RGB-D ``frame`` (:class:`~navbench.geometry.Frame`, z-depth) seen by the camera
    ``intrinsics`` on planar ``pose (x, y, theta)`` (world m, rad) into ``fused`` in place, by
    :func:`fuse_kernel`; marks the body's cells visited. Returns the number of cells updated."""
    if frame.depth.shape != intrinsics.shape:
        raise ConfigError(f"fusion: frame is {frame.depth.shape}, intrinsics say {intrinsics.shape}")
    spec = fused.spec
    trunc, band = fused.config.resolved(spec)
    vm = fused.vmap
    depth = np.ascontiguousarray(frame.depth, np.float32)
    valid = np.ascontiguousarray(frame.valid, np.bool_)
    scale, normals = scale_and_normals(depth, valid, intrinsics, fused.config.min_scale)
    n, box = fuse_kernel(fused.sdf, fused.weight, fused.col_weight, vm.occ, vm.col,
                    np.asarray(spec.lo, np.float64), spec.size, np.array(_camera(pose, camera_height)),
                    depth, valid, np.ascontiguousarray(frame.rgb, np.float32), scale, normals,
                    float(intrinsics.fx), float(intrinsics.fy),
                    float(intrinsics.cx), float(intrinsics.cy), trunc, band,
                    float(fused.config.max_weight), float(fused.config.max_depth), float(vm.tau))
    if fused.config.body_radius > 0:
        fused.visited |= body_cells(spec, pose, fused.config.body_radius)
    fused.frames += 1
    fused.version += 1
    fused.dirty = tuple(int(v) for v in box)
    return int(n)


@nb.njit(cache=True)
def _distance_scale_kernel(depth, valid, fx, fy, cx, cy, min_scale, out, normals):
    H, W = depth.shape
    for v in range(H):
        for u in range(W):
            out[v, u] = 1.0
            normals[v, u, 0] = normals[v, u, 1] = normals[v, u, 2] = 0.0
            if not valid[v, u]:
                continue
            d = np.float64(depth[v, u])
            px, py = (u - cx) / fx * d, (v - cy) / fy * d
            # one-sided tangents: towards the neighbour of closer depth, on each axis
            best = np.inf
            ax = ay = az = 0.0
            for uu in (u - 1, u + 1):
                if 0 <= uu < W and valid[v, uu] and abs(np.float64(depth[v, uu]) - d) < best:
                    e = np.float64(depth[v, uu])
                    best = abs(e - d)
                    ax, ay, az = (uu - cx) / fx * e - px, (v - cy) / fy * e - py, e - d
            if best == np.inf:
                continue
            best = np.inf
            bx = by = bz = 0.0
            for vv in (v - 1, v + 1):
                if 0 <= vv < H and valid[vv, u] and abs(np.float64(depth[vv, u]) - d) < best:
                    e = np.float64(depth[vv, u])
                    best = abs(e - d)
                    bx, by, bz = (u - cx) / fx * e - px, (vv - cy) / fy * e - py, e - d
            if best == np.inf:
                continue
            nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
            nn = math.sqrt(nx * nx + ny * ny + nz * nz)
            if nn == 0.0:
                continue
            rx, ry = (u - cx) / fx, (v - cy) / fy
            ray = math.sqrt(rx * rx + ry * ry + 1.0)
            dot = (nx * rx + ny * ry + nz) / nn
            g = abs(dot)  # = |ray| cos(angle(ray, normal))
            out[v, u] = min(max(g, min_scale), ray)
            sign = -1.0 if dot > 0 else 1.0  # towards the camera
            normals[v, u, 0] = sign * nx / nn
            normals[v, u, 1] = sign * ny / nn
            normals[v, u, 2] = sign * nz / nn


def distance_scale(depth: np.ndarray, valid: np.ndarray, intrinsics: Intrinsics,
                   min_scale: float = 0.3) -> np.ndarray:
    """``g (H, W)`` float64: z-depth differences along each pixel's ray times ``g`` are distances
    to the surface's tangent plane there (see the module docstring); 1 where the pixel or both
    neighbours on an image axis are invalid (no normal: the z-depth difference is used)."""
    return scale_and_normals(depth, valid, intrinsics, min_scale)[0]


def scale_and_normals(depth: np.ndarray, valid: np.ndarray, intrinsics: Intrinsics,
                      min_scale: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    """:func:`distance_scale` and the unit surface normals ``(H, W, 3)`` (camera frame, towards
    the camera; 0 where there is none) it is computed from."""
    out = np.empty(depth.shape, np.float64)
    normals = np.empty(depth.shape + (3,), np.float64)
    _distance_scale_kernel(np.ascontiguousarray(depth, np.float32), np.ascontiguousarray(valid, np.bool_),
                           float(intrinsics.fx), float(intrinsics.fy), float(intrinsics.cx),
                           float(intrinsics.cy), float(min_scale), out, normals)
    return out, normals


def distance_scale_reference(depth: np.ndarray, valid: np.ndarray, intrinsics: Intrinsics,
                             min_scale: float = 0.3) -> np.ndarray:
    """Pure-numpy :func:`distance_scale` (the tests' reference; equal to rounding)."""
    from navbench.geometry import pixel_rays

    H, W = depth.shape
    d = np.where(valid, depth, np.nan).astype(np.float64)
    P = pixel_rays(intrinsics) * d[..., None]

    def tangent(axis):
        pad = [(0, 0), (0, 0), (0, 0)]
        pad[axis] = (1, 1)
        Pp = np.pad(P, pad, constant_values=np.nan)
        dp = np.pad(d, pad[:2], constant_values=np.nan)
        sl = [slice(None), slice(None)]
        prev, nxt = list(sl), list(sl)
        prev[axis], nxt[axis] = slice(0, -2), slice(2, None)
        e_prev, e_next = np.abs(dp[tuple(prev)] - d), np.abs(dp[tuple(nxt)] - d)
        e_prev, e_next = np.where(np.isnan(e_prev), np.inf, e_prev), np.where(np.isnan(e_next), np.inf, e_next)
        use_prev = e_prev <= e_next
        t = np.where(use_prev[..., None], Pp[tuple(prev)], Pp[tuple(nxt)]) - P
        return t, np.minimum(e_prev, e_next) < np.inf

    a, oka = tangent(1)
    b, okb = tangent(0)
    n = np.cross(a, b)
    nn = np.linalg.norm(n, axis=-1)
    rays = pixel_rays(intrinsics)
    ok = valid & oka & okb & (nn > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        g = np.abs(np.sum(n * rays, axis=-1)) / nn
    g = np.minimum(np.maximum(g, min_scale), np.linalg.norm(rays, axis=-1))
    return np.where(ok, g, 1.0)


def body_cells(spec: GridSpec, pose, radius: float) -> np.ndarray:
    """``(nx, ny)`` bool: the ``xy`` cells whose centre is within ``radius`` (m) of the pose."""
    xs, ys = spec.centres(0), spec.centres(1)
    x, y = float(pose[0]), float(pose[1])
    return ((xs[:, None] - x) ** 2 + (ys[None, :] - y) ** 2) <= radius * radius


def fuse_frame_reference(fused: FusedMap, frame: Frame, pose, intrinsics: Intrinsics,
                         camera_height: float = CAMERA_HEIGHT) -> int:
    """Pure-numpy :func:`fuse_frame` (vectorised over cells; the tests' reference)."""
    spec = fused.spec
    trunc, band = fused.config.resolved(spec)
    tau = fused.vmap.tau
    ox, oy, oz, c, s = _camera(pose, camera_height)
    X, Y, Z = np.meshgrid(spec.centres(0), spec.centres(1), spec.centres(2), indexing="ij")
    dx, dy = X - ox, Y - oy
    zc = c * dx + s * dy
    xc = s * dx - c * dy
    yc = oz - Z
    H, W = intrinsics.shape
    ok = (zc > 1e-9) & (zc <= fused.config.max_depth + trunc)
    with np.errstate(divide="ignore", invalid="ignore"):
        ur = np.floor(intrinsics.fx * xc / zc + intrinsics.cx + 0.5)
        vr = np.floor(intrinsics.fy * yc / zc + intrinsics.cy + 0.5)
        mu, mv = intrinsics.fx * band / zc, intrinsics.fy * band / zc
    near = ok & (ur >= -mu) & (ur <= W - 1 + mu) & (vr >= -mv) & (vr <= H - 1 + mv)
    ui = np.clip(np.where(near, ur, 0), 0, W - 1).astype(np.int64)
    vi = np.clip(np.where(near, vr, 0), 0, H - 1).astype(np.int64)
    near &= frame.valid[vi, ui]
    ok = near & (ur == ui) & (vr == vi)
    margin = near & ~ok
    g, nrm = scale_and_normals(frame.depth, frame.valid, intrinsics, fused.config.min_scale)  # tested apart
    sd = np.where(near, (frame.depth[vi, ui].astype(np.float64) - zc) * g[vi, ui], 0.0)
    provisional = margin & (fused.col_weight == 0) & (np.abs(sd) <= band)
    cb = ok & (np.abs(sd) <= band)
    n = nrm[vi, ui]
    q = np.stack([xc, yc, zc], -1) - sd[..., None] * n
    with np.errstate(divide="ignore", invalid="ignore"):
        pu = np.floor(intrinsics.fx * q[..., 0] / q[..., 2] + intrinsics.cx + 0.5)
        pv = np.floor(intrinsics.fy * q[..., 1] / q[..., 2] + intrinsics.cy + 0.5)
    inside = (q[..., 2] > 1e-9) & (pu >= 0) & (pu < W) & (pv >= 0) & (pv < H)
    pu = np.where(inside, pu, 0).astype(np.int64)
    pv = np.where(inside, pv, 0).astype(np.int64)
    inside &= frame.valid[pv, pu]
    cu, cv = np.where(inside, pu, ui), np.where(inside, pv, vi)
    ok &= sd >= -trunc
    t = np.minimum(sd, trunc) / trunc
    w = fused.weight.astype(np.float64)
    d = ((w * fused.sdf + t) / (w + 1.0)).astype(np.float32)
    fused.sdf[ok] = d[ok]
    fused.weight[ok] = np.minimum(w + 1.0, fused.config.max_weight)[ok]
    occ = np.clip(tau - 0.5 * fused.sdf.astype(np.float64), tau - 0.5, tau + 0.5)
    fused.vmap.occ[ok] = occ[ok]
    wc = fused.col_weight.astype(np.float64)[..., None]
    newc = ((wc * fused.vmap.col + frame.rgb[cv, cu].astype(np.float64)) / (wc + 1.0)).astype(np.float32)
    fused.vmap.col[cb] = newc[cb]
    fused.col_weight[cb] = np.minimum(wc[..., 0] + 1.0, fused.config.max_weight)[cb]
    fused.vmap.col[provisional] = frame.rgb[vi, ui][provisional]
    if fused.config.body_radius > 0:
        fused.visited |= body_cells(spec, pose, fused.config.body_radius)
    fused.frames += 1
    fused.version += 1
    fused.dirty = None  # the reference does not track what it wrote
    return int(ok.sum())


# ------------------------------------------------------------------------------ planning view

def _z_stencil(spec: GridSpec, heights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(k0, t)``: the lower cell index and weight of each height (the grid's clamped rule)."""
    nz = spec.shape[2]
    u = np.clip((heights - spec.lo[2]) / spec.size[2] - 0.5, 0.0, nz - 1)
    k0 = np.minimum(np.floor(u).astype(np.int64), nz - 2)
    return k0, u - k0


def slice_heights(spec: GridSpec, mode: str = "band", z_low: float = 0.05, z_high: float = 1.0,
                  height: float = CAMERA_HEIGHT) -> np.ndarray:
    """The ``z`` cell indices :func:`~navbench.worldmodel.grid.occupancy_slice` reads (the two
    cell centres around every height it evaluates), sorted, unique."""
    k0, t = _z_stencil(spec, band_heights(spec, mode, z_low, z_high, height))
    return np.unique(np.concatenate([k0[t < 1], (k0 + 1)[t > 0]]))


def column_slice(vmap: VoxelMap, mode: str = "band", z_low: float = 0.05, z_high: float = 1.0,
                 height: float = CAMERA_HEIGHT) -> np.ndarray:
    """:func:`~navbench.worldmodel.grid.occupancy_slice`'s ``occ2d`` evaluated on each cell's own
    column: ``f`` at an ``xy`` cell centre is the ``z`` interpolation of that column (the
    ``xy`` weights are exactly 1 and 0 there), which this computes directly, ~20x faster.
    ``occupancy_slice`` computes the ``xy`` index of a centre in floating point, so at a few
    cells it mixes in a neighbour column with a weight of ~1e-14; the results are equal except
    where ``f`` is within that of ``tau`` (never on a fused map: unseen cells keep
    :data:`UNSEEN_MARGIN` from it; tested)."""
    k0, t = _z_stencil(vmap.spec, band_heights(vmap.spec, mode, z_low, z_high, height))
    best = None
    for k, w in zip(k0.tolist(), t.tolist()):
        f = vmap.occ[:, :, k].astype(np.float64) * (1 - w) + vmap.occ[:, :, k + 1].astype(np.float64) * w
        best = f if best is None else np.maximum(best, f)
    return best > vmap.tau


def seen_slice(fused: FusedMap, mode: str = "band", z_low: float = 0.05, z_high: float = 1.0,
               height: float = CAMERA_HEIGHT, min_seen: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """``(known, occupied)``: ``(nx, ny)`` bool rasters on the planning grid (the cells of
    :func:`~navbench.worldmodel.grid.occupancy_slice`, index ``[ix, iy]``).

    ``occupied``: ``f > tau`` in the body band (``mode="band"``, ``z_low`` to ``z_high``, m) or
    at ``height`` (``mode="slice"``), as ``occupancy_slice(fused.vmap, ...)`` gives it, computed
    column by column (:func:`column_slice`: fast enough to call every step). ``known``: occupied, or visited (under the agent's body at a fused pose), or
    at least the fraction ``min_seen`` (default all) of the column's cells that the slice reads
    (:func:`slice_heights`) have been seen. Free known space is ``known & ~occupied``; the
    unknown is ``~known`` (the planner decides how to treat it; ``occupied`` alone treats it as
    free).
    """
    if not (0.0 < min_seen <= 1.0):
        raise ConfigError(f"seen_slice min_seen: expected a fraction in (0, 1], got {min_seen}")
    occupied = column_slice(fused.vmap, mode, z_low, z_high, height)
    ks = slice_heights(fused.spec, mode, z_low, z_high, height)
    frac = (fused.weight[:, :, ks] > 0).mean(axis=2)
    known = (frac >= min_seen - 1e-9) | occupied | fused.visited
    return known, occupied
