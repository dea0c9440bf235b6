"""Drawings of a world model into matplotlib axes the caller creates (no files, no figures)."""

from __future__ import annotations

import numpy as np

from navbench.worldmodel.grid import VoxelMap


def draw_slice(ax, vmap, mode: str = "band", z_low: float = 0.05, z_high: float = 1.0,
               true_occ: np.ndarray | None = None, title: str | None = None):
    """Draw the occupancy slice (``vmap.occupancy_slice``) of the world model ``vmap`` into the
    2D axis ``ax``.

    Occupied cells are dark, free cells white; ``x`` and ``y`` in world metres. ``true_occ``
    (optional ``(nx', ny')`` bool on the same cells, cropped like ``level.occupancy_raster``)
    is outlined in red for comparison. Returns the image artist.
    """
    occ2d, xs, ys = vmap.occupancy_slice(mode, z_low, z_high)
    dx, dy = xs[1] - xs[0], ys[1] - ys[0]
    extent = (xs[0] - dx / 2, xs[-1] + dx / 2, ys[0] - dy / 2, ys[-1] + dy / 2)
    im = ax.imshow(occ2d.T, origin="lower", extent=extent, cmap="Greys", vmin=0, vmax=1,
                   interpolation="nearest")
    if true_occ is not None:
        nx, ny = true_occ.shape
        ax.contour(xs[:nx], ys[:ny], true_occ.T.astype(float), levels=[0.5], colors="red",
                   linewidths=0.6)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.set_title(title or f"occupancy {mode} ({z_low:g}-{z_high:g} m)" if mode == "band"
                 else title or "occupancy slice")
    return im


def occupied_voxels(vmap: VoxelMap, max_points: int = 30_000, z_range=(0.02, None),
                    seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Centres ``(P, 3)`` (m) and colours ``(P, 3)`` of occupied cells (``occ > tau``).

    Cells outside ``z_range`` (m; default above 2 cm and below the grid's top margin cell) are
    left out so the floor and the ceiling do not hide the rooms; a seeded random subset of at
    most ``max_points`` cells is kept for drawing speed.
    """
    spec = vmap.spec
    zs = spec.centres(2)
    zhi = z_range[1] if z_range[1] is not None else zs[-1] - 3 * spec.size[2]
    keep_z = (zs >= z_range[0]) & (zs <= zhi)
    mask = (vmap.occ > vmap.tau) & keep_z[None, None, :]
    idx = np.argwhere(mask)
    if len(idx) > max_points:
        idx = idx[np.random.default_rng(seed).choice(len(idx), max_points, replace=False)]
    centres = np.asarray(spec.lo) + (idx + 0.5) * spec.size
    colours = np.clip(vmap.col[idx[:, 0], idx[:, 1], idx[:, 2]], 0, 1)
    return centres, colours


def draw_isometric(ax3d, vmap: VoxelMap, max_points: int = 30_000, marker_size: float = 2.0,
                   seed: int = 0, title: str | None = None):
    """Isometric 3D scatter of occupied voxels coloured by the colour grid (paper Fig. 1 style).

    ``ax3d`` must be a 3D axis (``projection="3d"``). The floor and ceiling layers are left out
    (see :func:`occupied_voxels`); at most ``max_points`` voxels are drawn. Returns the artist.
    """
    pts, cols = occupied_voxels(vmap, max_points, seed=seed)
    sc = ax3d.scatter(pts[:, 0], pts[:, 1], pts[:, 2], c=cols, s=marker_size, marker="s",
                      depthshade=False, linewidths=0)
    lo, hi = np.asarray(vmap.spec.lo), np.asarray(vmap.spec.hi)
    ax3d.set_xlim(lo[0], hi[0])
    ax3d.set_ylim(lo[1], hi[1])
    ax3d.set_zlim(lo[2], hi[2])
    ax3d.set_box_aspect(tuple(hi - lo))
    ax3d.view_init(elev=35.264, azim=-45)  # the isometric direction
    ax3d.set_xlabel("x (m)")
    ax3d.set_ylabel("y (m)")
    ax3d.set_zlabel("z (m)")
    ax3d.locator_params(axis="z", nbins=2)
    if title:
        ax3d.set_title(title)
    return sc
