"""Voxel grids of occupancy and colour (paper section 3.1, appendix A), their files and slices.

Grid convention
    A :class:`GridSpec` covers the world box ``[lo, hi]`` (metres) with ``shape = (nx, ny, nz)``
    cells of size ``size = (hi - lo) / shape``. Cell ``(i, j, k)`` stores the value at its centre
    ``lo + ((i, j, k) + 0.5) * size``. The functions ``f`` (occupancy) and ``g`` (colour) of the
    paper interpolate trilinearly between the 8 surrounding cell centres. Continuous cell index
    of a world point ``p``: ``u = (p - lo) / size - 0.5``.

Outside the cell centres
    ``u`` is clamped to ``[0, n - 1]`` per axis, so a point outside the hull of the cell centres
    (the outer half cell, or outside the box) takes the value of the nearest border cells
    (constant extrapolation). Every renderer in this package uses exactly this rule.

Occupancy is a real number (not a probability): a point is occupied where ``f > tau``
(``tau`` = 0.5 for every map made here; free space is about 0, solids about 1).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np

from navbench.errors import ArtifactError, ConfigError
from navbench.geometry import CAMERA_HEIGHT, MAX_RANGE, MIN_RAY_RANGE, MIN_RAY_STEP
from navbench.worldmodel.gridspec import GridSpec

#: Default occupancy threshold tau of eq. 1.
DEFAULT_TAU = 0.5
#: The paper's grid resolution (appendix A).
PAPER_GRID_SHAPE = (200, 200, 20)
#: Map file format version (bumped when the .npz layout changes).
MAP_FORMAT_VERSION = 1


@dataclass
class VoxelMap:
    """Occupancy and colour grids (the paper's ``M_occ`` and ``M_col``).

    ``occ (nx, ny, nz)`` float32 occupancy; ``col (nx, ny, nz, 3)`` float32 RGB in about
    ``[0, 1]``; ``tau`` the crossing threshold of eq. 1; ``meta`` free JSON-able information
    (for fitted maps: ``step`` the ray sample spacing Delta (m) and ``max_range`` (m) it was
    fitted with, which :func:`navbench.worldmodel.fastrender.render_map` uses by default).
    """

    spec: GridSpec
    occ: np.ndarray
    col: np.ndarray
    tau: float = DEFAULT_TAU
    meta: dict = field(default_factory=dict)

    #: The world-model kind (:mod:`navbench.worldmodel.base`); map files without a ``kind`` in
    #: their header are voxel maps, so this kind is not written (the file format is unchanged).
    kind: ClassVar[str] = "voxel"

    def __post_init__(self):
        self.occ = np.ascontiguousarray(self.occ, dtype=np.float32)
        self.col = np.ascontiguousarray(self.col, dtype=np.float32)
        _check_arrays(self.spec, self.occ, self.col, "voxel map")
        self.tau = float(self.tau)

    # The world-model interface (navbench.worldmodel.base.WorldModel). Each method delegates to
    # the module function of the same job, which stays the arrays-in, arrays-out reference.

    def occupancy_slice(self, mode: str = "band", z_low: float = 0.05, z_high: float = 1.0,
                        height: float = CAMERA_HEIGHT):
        """``(occ2d, xs, ys)`` the planner reads: :func:`occupancy_slice` of this map."""
        return occupancy_slice(self, mode, z_low, z_high, height)  # the module function

    def renderer(self, intrinsics, camera_height: float = CAMERA_HEIGHT,
                 max_range: float = MAX_RANGE, step: float | None = None,
                 parallel: bool | None = None):
        """A fresh :class:`~navbench.worldmodel.fastrender.FastRenderer` of this map (``.render(pose)
        -> Frame``); ``step`` defaults to ``meta['step']``, see there."""
        from navbench.worldmodel.fastrender import FastRenderer

        return FastRenderer(self, intrinsics, camera_height, max_range, step, parallel)

    def ray_renderer(self, step: float | None = None, max_range: float = MAX_RANGE):
        """The differentiable ray renderer of this map (the emission tracker's):
        :class:`~navbench.worldmodel.diffrender.GridRayRenderer`."""
        from navbench.worldmodel.diffrender import GridRayRenderer

        return GridRayRenderer(self.occ, self.col, self.spec, self.tau, self.meta, step, max_range)

    def save(self, path) -> Path:
        """Write this map to ``path`` (:func:`save_map`); returns the path."""
        return save_map(self, path)

    @classmethod
    def load(cls, path) -> "VoxelMap":
        """Read a map file (:func:`load_map`); :class:`ArtifactError` names what is wrong."""
        return load_map(path)

    def content_hash(self) -> str:
        """sha256 hex of what :meth:`save` stores (header, float32 occupancy, float16 colour).

        Stable: equal for a map and the map loaded back from its file, independent of the
        file's zip timestamps, different when any stored voxel, ``tau`` or ``meta`` differs.
        """
        h = hashlib.sha256(b"navbench-world-model\0voxel\0")
        h.update(json.dumps(_header(self), sort_keys=True, default=float).encode())
        for a in (self.occ.astype(np.float32), self.col.astype(np.float16)):
            h.update(f"\0{a.dtype.str}{a.shape}\0".encode())
            h.update(np.ascontiguousarray(a).tobytes())
        return h.hexdigest()


def _check_arrays(spec: GridSpec, occ: np.ndarray, col: np.ndarray, where: str) -> None:
    if occ.shape != spec.shape:
        raise ArtifactError(f"{where}: occ has shape {occ.shape}, the grid spec says {spec.shape}")
    if col.shape != spec.shape + (3,):
        raise ArtifactError(f"{where}: col has shape {col.shape}, expected {spec.shape + (3,)}")
    if not np.all(np.isfinite(occ)):
        raise ArtifactError(f"{where}: occ contains NaN or infinite values")
    if not np.all(np.isfinite(col)):
        raise ArtifactError(f"{where}: col contains NaN or infinite values")


def grid_for_box(lo, hi, shape=PAPER_GRID_SHAPE, margin_z: float = 0.15) -> GridSpec:
    """A grid over the world box ``[lo, hi]`` (metres): square ``xy`` cells, ``z`` with margins.

    ``xy``: cell size ``max((hi - lo)_x / nx, (hi - lo)_y / ny)`` from ``lo``, so the grid covers
    the box (and a little more along the shorter side). ``z``: ``[lo_z - margin_z, hi_z +
    margin_z]``, so surfaces at ``lo_z`` (floor) and ``hi_z`` (ceiling) lie between cell centres.
    """
    nx, ny, nz = (int(v) for v in shape)
    lo = [float(v) for v in lo]
    hi = [float(v) for v in hi]
    cell = max((hi[0] - lo[0]) / nx, (hi[1] - lo[1]) / ny)
    return GridSpec((lo[0], lo[1], lo[2] - margin_z),
                    (lo[0] + nx * cell, lo[1] + ny * cell, hi[2] + margin_z), (nx, ny, nz))


def grid_for_level(level, shape=PAPER_GRID_SHAPE, margin_z: float = 0.15) -> GridSpec:
    """The grid of a level: :func:`grid_for_box` of ``[0, width] x [0, depth] x [0, height]``.

    Its ``xy`` cells are those of ``level.occupancy_raster(level, cell)``. With the default
    shape and margin, 20 ``z`` cells of 7.5 cm put the floor and a 1.2 m ceiling exactly
    half-way between two cell centres.
    """
    return grid_for_box((0.0, 0.0, 0.0), (level.width, level.depth, level.height), shape, margin_z)


# ------------------------------------------------------------------------------ interpolation

def trilinear(values: np.ndarray, spec: GridSpec, points) -> np.ndarray:
    """``f`` or ``g``: trilinear interpolation of ``values (nx, ny, nz[, C])`` at ``points (..., 3)``.

    Reference numpy implementation (float64) of the grid convention in the module docstring.
    Returns ``(...)`` or ``(..., C)``.
    """
    u = spec.to_index(points)
    n = np.asarray(spec.shape)
    u = np.clip(u, 0.0, n - 1)
    i0 = np.minimum(np.floor(u).astype(np.int64), n - 2)
    t = u - i0
    v = np.asarray(values, np.float64)
    out = 0.0
    for dx in (0, 1):
        wx = t[..., 0] if dx else 1 - t[..., 0]
        for dy in (0, 1):
            wy = t[..., 1] if dy else 1 - t[..., 1]
            for dz in (0, 1):
                wz = t[..., 2] if dz else 1 - t[..., 2]
                w = wx * wy * wz
                val = v[i0[..., 0] + dx, i0[..., 1] + dy, i0[..., 2] + dz]
                out = out + (w[..., None] * val if val.ndim > w.ndim else w * val)
    return out


# ------------------------------------------------------------------------------ slices

def band_heights(spec: GridSpec, mode: str, z_low: float, z_high: float,
                 height: float) -> np.ndarray:
    """The heights (m) :func:`occupancy_slice` evaluates: ``[height]`` for ``mode="slice"``;
    for ``mode="band"`` the band ends and every cell centre strictly inside the band."""
    if mode == "slice":
        return np.array([height], float)
    if mode != "band":
        raise ConfigError(f"unknown occupancy slice mode {mode!r}; choose 'band' or 'slice'")
    if z_high < z_low:
        raise ConfigError(f"occupancy band: z_high {z_high} < z_low {z_low}")
    zs = spec.centres(2)
    return np.concatenate([[z_low, z_high], zs[(zs > z_low) & (zs < z_high)]])

def occupancy_slice(vmap: VoxelMap, mode: str = "band", z_low: float = 0.05,
                    z_high: float = 1.0, height: float = CAMERA_HEIGHT):
    """Horizontal occupancy of the map for planning (appendix B), on the grid's ``xy`` cells.

    ``mode="slice"``: ``f`` evaluated at the single height ``height`` (m, default the camera
    height 0.5 m) above each ``xy`` cell centre. ``mode="band"``: the maximum of ``f`` over the
    heights ``[z_low, z_high]`` (m; default 5 cm to 1 m, the agent's body band), so that
    obstacles lower than the camera count too. The maximum is exact for trilinear ``f``: it is
    linear in ``z`` between cell centres, so it is attained at a centre or at a band end.

    Returns ``occ2d (nx, ny) bool`` (``f > tau``, index ``[ix, iy]``) and the cell-centre
    coordinates ``xs (nx,)``, ``ys (ny,)`` in metres.
    """
    spec = vmap.spec
    xs, ys = spec.centres(0), spec.centres(1)
    heights = band_heights(spec, mode, z_low, z_high, height)
    from navbench.worldmodel._slice import _slice_max  # numba: not on the CLI's --help path

    best = _slice_max(np.ascontiguousarray(vmap.occ, np.float32), np.asarray(spec.lo, np.float64),
                      np.asarray(spec.size, np.float64), xs, ys, np.asarray(heights, np.float64))
    return best > vmap.tau, xs, ys


def slice_values_reference(vmap: VoxelMap, heights) -> np.ndarray:
    """``(nx, ny)``: the maximum of :func:`trilinear` ``f`` over ``heights`` at every ``xy`` cell
    centre, in numpy (what :func:`occupancy_slice` thresholds;
    :func:`navbench.worldmodel._slice._slice_max` is its compiled path, tested bit for bit
    against this)."""
    spec = vmap.spec
    xs, ys = spec.centres(0), spec.centres(1)
    best = None
    for z in heights:
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        f = trilinear(vmap.occ, spec, np.stack([X, Y, np.full_like(X, z)], axis=-1))
        best = f if best is None else np.maximum(best, f)
    return best


# ------------------------------------------------------------------------------ files

def _header(vmap: VoxelMap) -> dict:
    """The JSON header of a map file (what :func:`load_map` reads besides the arrays)."""
    return {"format_version": MAP_FORMAT_VERSION, "spec": vmap.spec.to_dict(), "tau": vmap.tau,
            "meta": vmap.meta}


def save_map(vmap: VoxelMap, path) -> Path:
    """Write ``vmap`` as one uncompressed ``.npz`` (occ float32, col float16, spec, tau, meta)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp.npz")
    np.savez(tmp, occ=vmap.occ.astype(np.float32), col=vmap.col.astype(np.float16),
             header=np.array(json.dumps(_header(vmap), default=float)))
    tmp.replace(path)
    return path


def load_map(path) -> VoxelMap:
    """Read and validate a map written by :func:`save_map`; :class:`ArtifactError` names the problem.

    The header and the arrays' declared shapes and dtypes are checked before any array is read,
    so a file declaring an absurd grid (a compressed npz can declare terabytes in a few bytes)
    is refused instead of exhausting the memory.
    """
    from navbench.safeio import check_regular_file

    path = Path(path)
    check_regular_file(path, ArtifactError, "map file")  # missing, a directory, a FIFO: one line
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = {"occ", "col", "header"} - set(z.files)
            if missing:
                raise ArtifactError(f"{path}: not a navbench map (missing {sorted(missing)})")
            header = json.loads(str(z["header"]))
            spec, tau = _parse_header(header, path)
            _check_declared(z, spec, path)
            occ, col = z["occ"], z["col"]
    except ArtifactError:
        raise
    except Exception as e:  # truncated zip, bad JSON, ...
        raise ArtifactError(f"{path}: unreadable map file ({type(e).__name__}: {e})") from None
    _check_arrays(spec, occ, col, str(path))
    for name, a in (("occ", occ), ("col", col)):  # finite but absurd (1e30): renders as solid
        if a.size and float(np.abs(a).max()) > MAX_MAP_VALUE:
            raise ArtifactError(f"{path}: {name} has values beyond {MAX_MAP_VALUE:g} (occupancy is "
                                f"about 0 in free space and 1 in solids, colours in [0, 1])")
    return VoxelMap(spec, occ.astype(np.float32), col.astype(np.float32), tau, header.get("meta", {}))


#: Largest magnitude of a stored occupancy or colour value (a fit keeps them near [0, 1]).
MAX_MAP_VALUE = 1e6
#: The most cells a map file may declare (16 bytes each in memory: float32 occ + RGB col).
MAX_MAP_CELLS = 1 << 30


def _parse_header(header, path: Path) -> tuple[GridSpec, float]:
    """``(spec, tau)`` of a map file's JSON header; :class:`ArtifactError` naming ``path``."""
    if not isinstance(header, dict):
        raise ArtifactError(f"{path}: bad map header (a JSON object expected, got {type(header).__name__})")
    if header.get("format_version") != MAP_FORMAT_VERSION:
        raise ArtifactError(f"{path}: map format version {header.get('format_version')!r}, "
                            f"this navbench reads {MAP_FORMAT_VERSION}")
    if not isinstance(header.get("meta", {}), dict):
        raise ArtifactError(f"{path}: bad map header (meta is not a JSON object)")
    try:
        s = header["spec"]
        spec = GridSpec(tuple(s["lo"]), tuple(s["hi"]), tuple(s["shape"]))
        tau = float(header["tau"])
    except ArtifactError as e:
        raise ArtifactError(f"{path}: {e}") from None
    except (KeyError, TypeError, ValueError) as e:
        raise ArtifactError(f"{path}: bad map header ({e})") from None
    if not np.isfinite(tau) or not np.all(np.isfinite(spec.lo + spec.hi)):
        raise ArtifactError(f"{path}: bad map header (tau {tau}, lo {list(spec.lo)}, hi "
                            f"{list(spec.hi)}: all must be finite)")
    if not 0 < tau < 1:  # occupancy lives in [0, 1]: a tau outside never crosses, renders nothing
        raise ArtifactError(f"{path}: bad map header (tau {tau}: must be in (0, 1))")
    _check_meta(header.get("meta", {}), path)
    cells = int(np.prod(spec.shape, dtype=np.float64))
    if cells > MAX_MAP_CELLS:
        raise ArtifactError(f"{path}: grid {list(spec.shape)} has {cells} cells, more than the "
                            f"{MAX_MAP_CELLS} a map file may have")
    return spec, tau


#: Ranges of the map header's ``meta`` numbers that navbench reads when it renders the map
#: (the ray step, the render range, the emission tracker's depth scale): absent is fine, out of
#: range is refused on load (a step of 1e-9 m hung the renderer; a range of 0 renders nothing).
META_RANGES = {"step": (MIN_RAY_STEP, 1e6), "max_range": (MIN_RAY_RANGE, 1e6), "sigma2": (1e-9, 1e6)}


def _check_meta(meta: dict, path: Path) -> None:
    for k, (lo, hi) in META_RANGES.items():
        if k not in meta:
            continue
        v = meta[k]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not lo <= v <= hi:
            raise ArtifactError(f"{path}: bad map header (meta.{k} = {v!r}: must be a number in "
                                f"[{lo:g}, {hi:g}])")


def _check_declared(z, spec: GridSpec, path: Path) -> None:
    """Shapes and dtypes of ``occ`` and ``col`` from their ``.npy`` headers (nothing read yet)
    match ``spec``, and the arrays fit in the available memory."""
    from numpy.lib import format as npy

    from navbench.worldmodel.memory import check_memory

    for name, want in (("occ", spec.shape), ("col", spec.shape + (3,))):
        with z.zip.open(name + ".npy") as f:
            version = npy.read_magic(f)
            read = npy.read_array_header_1_0 if version == (1, 0) else npy.read_array_header_2_0
            shape, _, dtype = read(f)
        if tuple(shape) != want:
            what = "the grid spec says" if name == "occ" else "expected"
            raise ArtifactError(f"{path}: {name} has shape {tuple(shape)}, {what} {want}")
        if dtype.kind not in "fiu":
            raise ArtifactError(f"{path}: {name} has dtype {dtype}, a real number type expected")
    cells = int(np.prod(spec.shape, dtype=np.int64))
    try:
        check_memory(cells * 32, f"{path}: grid {list(spec.shape)} ({cells} cells)")
    except ConfigError as e:
        raise ArtifactError(str(e)) from None


# ------------------------------------------------------------------------------ ground truth

def voxelize_level(level, spec: GridSpec | None = None, ramp: float | None = None,
                   tau: float = DEFAULT_TAU) -> VoxelMap:
    """The true geometry of ``level`` as a :class:`VoxelMap` (tests, tracker upper bounds).

    Occupancy at a cell centre is ``clip(tau + 0.5 * s / ramp, tau - 0.5, tau + 0.5)``, with ``s`` the signed distance (m,
    positive inside) to the union of the solids: prisms (walls, obstacles), the half spaces
    below the floor and above the ceiling, and everything outside the floor plan. ``ramp``
    (m, default the largest cell size) is the half-width of the linear transition, so ``f``
    crosses ``tau`` on the true surfaces wherever they are flat over the interpolation stencil.
    Colour at a cell centre is the texture colour (:func:`navbench.level.surface_colour`) of the
    nearest surface point (floor, ceiling, prism sides and tops).
    ``meta["step"]`` is set to half the largest cell size, a ray sample spacing that
    renders this map close to the true depth.
    """
    from navbench.level import prisms, texture_table
    from navbench.worldmodel._voxelize import voxelize_kernel

    spec = spec or grid_for_level(level)
    from navbench.worldmodel.memory import check_memory

    # occ + col float32 (16 bytes per cell) before the kernel allocates them
    cells = int(np.prod(spec.shape, dtype=np.float64))
    check_memory(cells * 16 + (16 << 20), f"voxelize {level.name}: grid {list(spec.shape)} ({cells} cells x 16 bytes)")
    size = spec.size
    ramp = float(ramp if ramp is not None else size.max())
    pr = prisms(level)
    kind, base, amp, waves = texture_table(level)
    occ, col = voxelize_kernel(
        spec.centres(0), spec.centres(1), spec.centres(2),
        float(level.width), float(level.depth), float(level.height),
        pr.verts, pr.start, pr.height, pr.texture,
        kind, base, amp, waves, int(level.floor_texture), int(level.ceiling_texture),
        ramp, float(tau),
    )
    meta = {"source": "voxelize_level", "level": level.name, "ramp": ramp,
            "step": float(size.max() / 2), "max_range": 20.0}
    return VoxelMap(spec, occ, col, tau, meta)


def cell_tolerance_scores(pred: np.ndarray, true: np.ndarray, tol_cells: int = 1) -> tuple[float, float]:
    """Precision and recall of occupied cells with a ``tol_cells`` (Chebyshev) tolerance.

    ``pred``, ``true``: ``(nx, ny)`` bool rasters on the same cells. Precision: the fraction of
    predicted-occupied cells within ``tol_cells`` of a truly occupied cell; recall: the fraction
    of truly occupied cells within ``tol_cells`` of a predicted-occupied one. NaN when the
    denominator is empty (a map that predicts nothing has no precision, not a perfect one).
    """
    from scipy.ndimage import binary_dilation

    st = np.ones((2 * tol_cells + 1,) * 2, bool)
    pred = np.asarray(pred, bool)
    true = np.asarray(true, bool)
    prec = float((pred & binary_dilation(true, st)).sum() / pred.sum()) if pred.any() else math.nan
    rec = float((true & binary_dilation(pred, st)).sum() / true.sum()) if true.any() else math.nan
    return prec, rec


def slice_scores(vmap, level, mode: str = "band", z_low: float = 0.05,
                 z_high: float = 1.0, tol_cells: int = 1) -> tuple[float, float]:
    """Precision, recall of a world model's occupancy slice vs ``level.occupancy_raster`` (same cells).

    The true raster uses the slice's ``x`` cell size (a voxel map's exact ``spec.size[0]``; for
    another world model the spacing of its ``xs``) and the band's ``z_low``; both rasters are
    cropped to the floor plan before :func:`cell_tolerance_scores`.
    """
    from navbench.level import occupancy_raster

    occ2d, xs, ys = vmap.occupancy_slice(mode, z_low, z_high)
    spec = getattr(vmap, "spec", None)
    cell = float(spec.size[0]) if isinstance(spec, GridSpec) else float(xs[1] - xs[0])
    true, txs, tys = occupancy_raster(level, cell, z_low=z_low, z_high=z_high)
    nx, ny = min(true.shape[0], occ2d.shape[0]), min(true.shape[1], occ2d.shape[1])
    if not (np.allclose(txs[:nx], xs[:nx], atol=1e-6) and np.allclose(tys[:ny], ys[:ny], atol=1e-6)):
        raise ArtifactError("slice scores: the map's xy cells do not match the level raster "
                            "(build the grid with grid_for_level)")
    return cell_tolerance_scores(occ2d[:nx, :ny], true[:nx, :ny], tol_cells)


def check_fitted_finite(vmap: VoxelMap, metrics: dict, config=None) -> None:
    """Refuse a fit whose parameters are not all finite (a learning rate too large for the data
    makes Adam overflow): :class:`~navbench.errors.ConfigError` in one line, raised before the
    map is saved, so a diverged fit is never cached nor scored (issue 34)."""
    from navbench.errors import ConfigError

    bad = [name for name, a in (("occupancy", vmap.occ), ("colour", vmap.col))
           if not np.isfinite(np.asarray(a)).all()]
    sigma2 = metrics.get("sigma2") if isinstance(metrics, dict) else None
    if isinstance(sigma2, float) and not np.isfinite(sigma2):
        bad.append("sigma2")
    if bad:
        lr = getattr(config, "lr", None)
        raise ConfigError(f"fit-map: the fit diverged: non-finite {', '.join(bad)} parameters"
                          f"{f' with [fit] lr = {lr:g}' if lr is not None else ''}; lower the "
                          "learning rate (nothing was cached)")
