"""The spatial world model of paper section 3.1: occupancy and colour voxel grids.

* :mod:`.base` — the :class:`WorldModel` interface every consumer uses (occupancy slice,
  renderer, save/load, content hash) and :func:`load_world_model` (built-in and plugin kinds);
* :mod:`.gridspec` — :class:`GridSpec`, the grid convention the renderers share;
* :mod:`.grid` — :class:`VoxelMap` (the built-in world model), trilinear lookup, map files, horizontal
  occupancy slices, and :func:`voxelize_level` (the true geometry as a grid);
* :mod:`.diffrender` — the differentiable renderer of eq. 1-2 in torch and ``laplace_nll``;
* :mod:`.fastrender` — ``render_map``, the numba inference renderer (same images, no gradients);
* :mod:`.views` — the pose-labelled RGB-D ``Views`` artifact, ``collect_views``, save and load;
* :mod:`.fit` — ``fit_map`` (eq. 3 by Adam; its CPU kernels in :mod:`.sparse_adam`);
* :mod:`.evaluate` — ``evaluate_map`` (map quality on held-out views);
* :mod:`.tum` — the TUM RGB-D layout (``export_views``, ``import_views``);
* :mod:`.plots` — slice and isometric drawings into a given matplotlib axis.

Only :mod:`.base` and :mod:`.grid` are imported here; torch and numba load with the submodules
that need them.
"""

from navbench.worldmodel.base import WorldModel, load_world_model  # noqa: F401
from navbench.worldmodel.grid import (  # noqa: F401
    GridSpec,
    VoxelMap,
    grid_for_level,
    load_map,
    occupancy_slice,
    save_map,
)
