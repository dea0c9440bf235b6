"""Top views of levels drawn into a matplotlib axis (the report and ``show-level`` reuse it).

:func:`draw_level` never creates a figure or a file: callers own the axis, and planners or
trajectories can be drawn on top in the same world coordinates (x right, y up, metres).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navbench.level import Level, wall_polygon

WALL_COLOUR = "#3a3a3a"
EXTERIOR_COLOUR = "#bdbdbd"
FREE_COLOUR = (0.80, 0.92, 0.80)
DOOR_COLOUR = "#d95f02"


def draw_level(ax, level: Level, *, free_space: bool = True, doors: bool = False,
               colorbar: bool = True, title: bool = True, resolution: float = 0.05,
               clearance: float | None = None, cmap: str = "viridis") -> Any:
    """Draw ``level`` seen from above into the matplotlib axis ``ax``.

    Walls dark grey, the exterior fill (``meta["exterior_obstacles"]``) light grey, obstacles
    coloured by height (colour map ``cmap`` over ``[0, level.height]`` m), and, when
    ``free_space``, the cells farther than ``clearance`` (default 1.2 L) from every solid shaded
    green. ``doors`` marks the door centres from ``meta["doors"]``. Sets equal aspect and the
    level box as limits. Returns the height ``ScalarMappable`` (for a caller's colour bar).
    """
    import matplotlib as mpl
    from matplotlib.patches import Polygon

    from navbench.levelgen import CLEARANCE, clearance_mask

    if free_space:
        free, _, _ = clearance_mask(level, resolution, CLEARANCE if clearance is None else clearance)
        img = np.zeros(free.T.shape + (4,))
        img[free.T] = (*FREE_COLOUR, 1.0)
        ax.imshow(img, origin="lower", extent=(0, free.shape[0] * resolution, 0, free.shape[1] * resolution),
                  interpolation="nearest", zorder=0)
    norm = mpl.colors.Normalize(0.0, level.height)
    cm = mpl.colormaps[cmap]
    exterior = {i for i in level.meta.get("exterior_obstacles", []) if isinstance(i, int)}
    for i, o in enumerate(level.obstacles):
        if i in exterior:
            ax.add_patch(Polygon(np.asarray(o.polygon), closed=True, facecolor=EXTERIOR_COLOUR,
                                 edgecolor="none", zorder=1))
        else:
            ax.add_patch(Polygon(np.asarray(o.polygon), closed=True, facecolor=cm(norm(o.height)),
                                 edgecolor="black", linewidth=0.4, zorder=3))
    for w in level.walls:
        ax.add_patch(Polygon(wall_polygon(w), closed=True, facecolor=WALL_COLOUR,
                             edgecolor=WALL_COLOUR, linewidth=0.3, zorder=2))
    if doors:
        from navbench.levelgen import meta_doors

        for cx, cy, _ in meta_doors(level):
            ax.plot(cx, cy, marker="o", markersize=3, color=DOOR_COLOUR, zorder=4)
    ax.set_xlim(0, level.width)
    ax.set_ylim(0, level.depth)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if title:
        ax.set_title(level.name)
    mappable = mpl.cm.ScalarMappable(norm=norm, cmap=cm)
    if colorbar:
        ax.figure.colorbar(mappable, ax=ax, fraction=0.046, pad=0.04, label="obstacle height (m)")
    return mappable
