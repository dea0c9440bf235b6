"""The options of a map fit (:class:`FitConfig`), the memory they need, and the check that the
views leave the fit something to see within its ``max_range`` (:func:`require_depth_within`).

Kept apart from :mod:`navbench.worldmodel.fit` (which re-exports them) so that the checks of a
profile read the options without the fitting code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navbench.errors import ConfigError
from navbench.geometry import MIN_RAY_RANGE, MIN_RAY_STEP
from navbench.worldmodel.grid import PAPER_GRID_SHAPE


@dataclass(frozen=True)
class FitConfig:
    """Fitting options; defaults are the paper's (appendix A) plus the documented additions."""

    steps: int = 10_000  # Adam steps
    lr: float = 0.05  # Adam learning rate of M_occ and M_col
    images_per_batch: int = 25  # images drawn per step (with replacement)
    pixels_per_image: int = 200  # pixels drawn uniformly per batch image
    sigma2_init: float = 2.4  # initial depth scale sigma2 (m); sigma1 = sigma2 / 5
    sigma2_lr: float = 0.01  # Adam learning rate of sigma2
    grid_shape: tuple[int, int, int] = PAPER_GRID_SHAPE  # (nx, ny, nz) cells
    margin_z: float = 0.15  # m of grid below the box floor and above its ceiling
    max_range: float = 20.0  # n * Delta (m): the last ray sample
    n_samples: int = 200  # n: samples per ray, Delta = max_range / n_samples (m)
    tau: float = 0.5  # crossing threshold of eq. 1
    init: str = "box"  # "box" (cells outside the views' box start solid) or "empty"
    init_free: float = 0.0  # initial occupancy inside the box
    init_solid: float = 1.0  # initial occupancy outside the box (init="box")
    init_colour: float = 0.5  # initial colour (all channels)
    free_space_weight: float = 1.0  # weight of the auxiliary free-space term; 0 = pure eq. 3
    free_space_samples: int = 1  # free (and as many behind-surface) points per ray
    free_space_margin: float = 0.05  # m of depth kept clear of the observed surface
    free_space_delta: float = 0.25  # hinge margin around tau
    min_sigma2: float = 1e-3  # lower clamp of sigma2 (m)
    optimizer: str = "lazy-adam"  # "adam": dense torch Adam (fused); "lazy-adam": touched cells only
    seed: int = 0  # seed of the batch sampling
    threads: int = 1  # torch threads during the fit (the torch graph is tiny; 1 avoids spin contention)
    # where the fit runs: "auto" = "cpu" (navbench.worldmodel.fit's docstring); "cpu" = the
    # sparse numba path; "cuda" / "cuda:N" = the device path on that GPU
    # (navbench.worldmodel.fit_device); "torch-cpu" = the device path on the CPU (slow; it exists
    # so the GPU path's code is tested on machines without a GPU). The map's metrics record the
    # device that ran.
    device: str = "auto"

    def __post_init__(self):
        if self.steps < 0 or self.images_per_batch < 1 or self.pixels_per_image < 1:
            raise ConfigError("fit: steps >= 0, images_per_batch >= 1, pixels_per_image >= 1")
        if self.n_samples < 1:
            raise ConfigError("fit: n_samples >= 1 required")
        if not self.max_range >= MIN_RAY_RANGE:  # NaN too
            raise ConfigError(f"fit: max_range must be >= {MIN_RAY_RANGE:g} m (the nearest a depth "
                              f"camera reads), got {self.max_range!r}")
        if not self.max_range / self.n_samples >= MIN_RAY_STEP:  # the map's meta['step'] (load_map)
            raise ConfigError(f"fit: max_range / n_samples (the ray step) must be >= {MIN_RAY_STEP:g} m, "
                              f"got {self.max_range:g} / {self.n_samples} m")
        if self.init not in ("box", "empty"):
            raise ConfigError(f"fit: unknown init {self.init!r}; choose 'box' or 'empty'")
        if not (self.device in ("cpu", "auto", "torch-cpu") or self.device.startswith("cuda")):
            raise ConfigError(f"fit: unknown device {self.device!r}; choose cpu, auto, cuda[:N] or torch-cpu")
        if self.optimizer not in ("adam", "lazy-adam"):
            raise ConfigError(f"fit: unknown optimizer {self.optimizer!r}; choose 'adam' or 'lazy-adam'")
        if self.sigma2_init <= 0 or self.free_space_weight < 0:
            raise ConfigError("fit: sigma2_init > 0 and free_space_weight >= 0 required")
        gs = self.grid_shape
        try:
            ok = (not isinstance(gs, (str, bytes)) and len(gs) == 3
                  and all(not isinstance(v, bool) and int(v) == v and v >= 2 for v in gs))
        except (TypeError, ValueError, OverflowError):
            ok = False
        if not ok:
            raise ConfigError(f"fit: grid_shape must be three whole numbers >= 2 (nx, ny, nz), got {gs!r}")

    @property
    def step(self) -> float:
        """Delta, the ray sample spacing (m)."""
        return self.max_range / self.n_samples


#: Bytes per grid cell a fit holds: occupancy (4) and colour (12) float32, their gradients
#: (16) and two Adam moments (32), the per-cell stamps of the lazy optimiser (8), and the
#: float64 cell centres the box init compares (24, freed before the optimiser state exists):
#: 72 at the peak, rounded up for the evaluation's voxelized true map.
FIT_BYTES_PER_CELL = 80
#: Bytes per batch ray a step holds (its samples are searched in slices of at most 256, each
#: sample a trilinear stencil), and a fixed slack for torch, numba and the views' index arrays.
FIT_BYTES_PER_RAY_SAMPLE = 64
FIT_BASE_BYTES = 64 << 20


def fit_memory_bytes(config: FitConfig) -> int:
    """An upper estimate of the memory :func:`fit_map` needs for ``config``: the grids and their
    optimiser state (:data:`FIT_BYTES_PER_CELL` per cell) plus one step's batch."""
    cells = math.prod(int(v) for v in config.grid_shape)
    rays = config.images_per_batch * config.pixels_per_image
    return (cells * FIT_BYTES_PER_CELL
            + rays * (FIT_BYTES_PER_RAY_SAMPLE * min(config.n_samples + 1, 256) + 1024)
            + FIT_BASE_BYTES)


def check_fit_memory(config: FitConfig, what: str = "fit") -> None:
    """Refuse (:class:`ConfigError`) a fit whose grids or batches do not fit in the available
    memory, before anything is allocated (a ``grid_shape`` of ``[5000, 5000, 5000]`` is 1.25e11
    cells: a ``MemoryError`` or the kernel's OOM killer otherwise)."""
    from navbench.worldmodel.memory import check_memory

    shape = tuple(int(v) for v in config.grid_shape)
    check_memory(fit_memory_bytes(config),
                 f"{what}: grid_shape {list(shape)} ({math.prod(shape)} cells x "
                 f"{FIT_BYTES_PER_CELL} bytes) and batches of "
                 f"{config.images_per_batch} x {config.pixels_per_image} rays")


def require_depth_within(views, max_range: float, what: str, idx=None) -> None:
    """One :class:`ConfigError` naming ``what`` when ``views`` (those at ``idx``, default all)
    have no valid depth pixel at most ``max_range`` (m) away (the fit's rays end at
    ``max_range``, in z-depth like the views' depth): a map fitted to them learns nothing, and a
    quality measured on them is a score of nothing. Stops at the first view with such a pixel."""
    idx = range(len(views)) if idx is None else [int(i) for i in idx]
    nearest = math.inf
    for i in idx:
        d = np.asarray(views.depth[i])[np.asarray(views.valid[i])]
        if d.size:
            near = float(d.min())
            if near <= max_range:
                return
            nearest = min(nearest, near)
    if not math.isfinite(nearest):
        raise ConfigError(f"{what}: none of its {len(idx)} views has a valid depth pixel; a map "
                          f"cannot be fitted to or scored on views without depth")
    raise ConfigError(f"{what}: none of its {len(idx)} views has a valid depth pixel within "
                      f"max_range = {max_range:g} m (the nearest is {nearest:.3g} m away); a map "
                      f"cannot be fitted to or scored on pixels its rays never reach: raise [fit] "
                      f"max_range")

