"""The grid convention of the world model: :class:`GridSpec` (a box of cells).

Split from :mod:`navbench.worldmodel.grid` so the renderers (:mod:`.fastrender`,
:mod:`.diffrender`), which need only the grid convention, do not import the map class, and the
map class can delegate its rendering methods to them without an import cycle. The convention
itself is documented in :mod:`navbench.worldmodel.grid`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from navbench.errors import ArtifactError


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
