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

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from navbench.errors import ArtifactError
from navbench.geometry import CAMERA_HEIGHT

#: Default occupancy threshold tau of eq. 1.
DEFAULT_TAU = 0.5
#: The paper's grid resolution (appendix A).
PAPER_GRID_SHAPE = (200, 200, 20)
#: Map file format version (bumped when the .npz layout changes).
MAP_FORMAT_VERSION = 1


@dataclass(frozen=True)
class GridSpec:
    """An axis-aligned grid of cells.

    ``lo``, ``hi``: world-frame corners of the box (metres); ``shape``: ``(nx, ny, nz)`` cells;
    cell centres at ``lo + (i + 0.5) * (hi - lo) / shape``.
    """

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    shape: tuple[int, int, int]

    def __post_init__(self):
        lo = tuple(float(v) for v in self.lo)
        hi = tuple(float(v) for v in self.hi)
        shape = tuple(int(v) for v in self.shape)
        if len(lo) != 3 or len(hi) != 3 or len(shape) != 3:
            raise ArtifactError("grid spec: lo, hi and shape need 3 entries each")
        if any(h <= l for l, h in zip(lo, hi)) or any(n < 2 for n in shape):
            raise ArtifactError(f"grid spec: need hi > lo and at least 2 cells per axis, got "
                                f"lo={lo} hi={hi} shape={shape}")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)
        object.__setattr__(self, "shape", shape)

    @property
    def size(self) -> np.ndarray:
        """Cell size per axis ``(3,)`` float64, metres."""
        return (np.asarray(self.hi) - np.asarray(self.lo)) / np.asarray(self.shape)

    def centres(self, axis: int) -> np.ndarray:
        """Cell-centre coordinates along ``axis`` (0, 1, 2), shape ``(shape[axis],)`` metres."""
        return self.lo[axis] + (np.arange(self.shape[axis]) + 0.5) * self.size[axis]

    def to_index(self, points) -> np.ndarray:
        """Continuous cell indices ``u = (p - lo) / size - 0.5`` of world points ``(..., 3)``."""
        return (np.asarray(points, np.float64) - np.asarray(self.lo)) / self.size - 0.5

    def to_dict(self) -> dict:
        return {"lo": list(self.lo), "hi": list(self.hi), "shape": list(self.shape)}


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

    def __post_init__(self):
        self.occ = np.ascontiguousarray(self.occ, dtype=np.float32)
        self.col = np.ascontiguousarray(self.col, dtype=np.float32)
        _check_arrays(self.spec, self.occ, self.col, "voxel map")
        self.tau = float(self.tau)


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
    xs, ys, zs = spec.centres(0), spec.centres(1), spec.centres(2)
    if mode == "slice":
        heights = np.array([height], float)
    elif mode == "band":
        if z_high < z_low:
            from navbench.errors import ConfigError

            raise ConfigError(f"occupancy band: z_high {z_high} < z_low {z_low}")
        heights = np.concatenate([[z_low, z_high], zs[(zs > z_low) & (zs < z_high)]])
    else:
        from navbench.errors import ConfigError

        raise ConfigError(f"unknown occupancy slice mode {mode!r}; choose 'band' or 'slice'")
    best = None
    for z in heights:
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        f = trilinear(vmap.occ, spec, np.stack([X, Y, np.full_like(X, z)], axis=-1))
        best = f if best is None else np.maximum(best, f)
    return best > vmap.tau, xs, ys


# ------------------------------------------------------------------------------ files

def save_map(vmap: VoxelMap, path) -> Path:
    """Write ``vmap`` as one uncompressed ``.npz`` (occ float32, col float16, spec, tau, meta)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp.npz")
    header = {"format_version": MAP_FORMAT_VERSION, "spec": vmap.spec.to_dict(), "tau": vmap.tau,
              "meta": vmap.meta}
    np.savez(tmp, occ=vmap.occ.astype(np.float32), col=vmap.col.astype(np.float16),
             header=np.array(json.dumps(header, default=float)))
    tmp.replace(path)
    return path


def load_map(path) -> VoxelMap:
    """Read and validate a map written by :func:`save_map`; :class:`ArtifactError` names the problem."""
    path = Path(path)
    if not path.is_file():
        raise ArtifactError(f"{path}: no such map file")
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = {"occ", "col", "header"} - set(z.files)
            if missing:
                raise ArtifactError(f"{path}: not a navbench map (missing {sorted(missing)})")
            header = json.loads(str(z["header"]))
            occ, col = z["occ"], z["col"]
    except ArtifactError:
        raise
    except Exception as e:  # truncated zip, bad JSON, ...
        raise ArtifactError(f"{path}: unreadable map file ({type(e).__name__}: {e})") from None
    if header.get("format_version") != MAP_FORMAT_VERSION:
        raise ArtifactError(f"{path}: map format version {header.get('format_version')!r}, "
                            f"this navbench reads {MAP_FORMAT_VERSION}")
    try:
        s = header["spec"]
        spec = GridSpec(tuple(s["lo"]), tuple(s["hi"]), tuple(s["shape"]))
        tau = float(header["tau"])
    except (KeyError, TypeError, ValueError) as e:
        raise ArtifactError(f"{path}: bad map header ({e})") from None
    _check_arrays(spec, occ, col, str(path))
    return VoxelMap(spec, occ.astype(np.float32), col.astype(np.float32), tau, header.get("meta", {}))


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
    of truly occupied cells within ``tol_cells`` of a predicted-occupied one. 1.0 when the
    denominator is empty.
    """
    from scipy.ndimage import binary_dilation

    st = np.ones((2 * tol_cells + 1,) * 2, bool)
    pred = np.asarray(pred, bool)
    true = np.asarray(true, bool)
    prec = float((pred & binary_dilation(true, st)).sum() / pred.sum()) if pred.any() else 1.0
    rec = float((true & binary_dilation(pred, st)).sum() / true.sum()) if true.any() else 1.0
    return prec, rec


def slice_scores(vmap: VoxelMap, level, mode: str = "band", z_low: float = 0.05,
                 z_high: float = 1.0, tol_cells: int = 1) -> tuple[float, float]:
    """Precision, recall of the map's occupancy slice vs ``level.occupancy_raster`` (same cells).

    The true raster uses the grid's ``x`` cell size and the band's ``z_low``; both rasters are
    cropped to the floor plan before :func:`cell_tolerance_scores`.
    """
    from navbench.level import occupancy_raster

    occ2d, xs, ys = occupancy_slice(vmap, mode, z_low, z_high)
    true, txs, tys = occupancy_raster(level, float(vmap.spec.size[0]), z_low=z_low, z_high=z_high)
    nx, ny = min(true.shape[0], occ2d.shape[0]), min(true.shape[1], occ2d.shape[1])
    if not (np.allclose(txs[:nx], xs[:nx], atol=1e-6) and np.allclose(tys[:ny], ys[:ny], atol=1e-6)):
        raise ArtifactError("slice scores: the map's xy cells do not match the level raster "
                            "(build the grid with grid_for_level)")
    return cell_tolerance_scores(occ2d[:nx, :ny], true[:nx, :ny], tol_cells)
