"""A toy world model that is not a voxel grid: a square room with one round pillar, analytic.

It implements :class:`navbench.worldmodel.base.WorldModel` and nothing more, so tests can show
that the consumers need only the interface (and that plugin kinds load through the entry-point
group). Its renderer predicts a flat grey wall at a fixed depth: enough for a tracker to run.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from navbench.errors import ArtifactError
from navbench.geometry import CAMERA_HEIGHT, MAX_RANGE, Frame


class DiscWorld:
    """The room ``[0, width] x [0, depth]`` (walls outside it), a pillar of ``radius`` at ``centre``."""

    kind = "toy-disc"

    def __init__(self, width=4.0, depth=3.0, centre=(2.0, 1.5), radius=0.5, cell=0.1, meta=None):
        self.width, self.depth, self.cell = float(width), float(depth), float(cell)
        self.centre, self.radius = tuple(float(c) for c in centre), float(radius)
        self.meta = dict(meta or {})

    def _params(self) -> dict:
        return {"kind": self.kind, "width": self.width, "depth": self.depth, "cell": self.cell,
                "centre": list(self.centre), "radius": self.radius, "meta": self.meta}

    def occupancy_slice(self, mode="band", z_low=0.05, z_high=1.0, height=CAMERA_HEIGHT):
        xs = (np.arange(round(self.width / self.cell)) + 0.5) * self.cell
        ys = (np.arange(round(self.depth / self.cell)) + 0.5) * self.cell
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        pillar = np.hypot(X - self.centre[0], Y - self.centre[1]) <= self.radius
        border = ((X < self.cell) | (Y < self.cell) | (X > self.width - self.cell)
                  | (Y > self.depth - self.cell))
        return pillar | border, xs, ys

    def renderer(self, intrinsics, camera_height=CAMERA_HEIGHT, max_range=MAX_RANGE, step=None):
        world = self

        class _Flat:
            def render(self, pose):
                H, W = intrinsics.shape
                depth = np.full((H, W), min(world.width, max_range) / 2, np.float32)
                return Frame(np.full((H, W, 3), 0.5, np.float32), depth, np.ones((H, W), bool))

        return _Flat()

    def save(self, path) -> Path:
        path = Path(path)
        np.savez(path, header=np.array(json.dumps(self._params())))
        return path

    @classmethod
    def load(cls, path) -> "DiscWorld":
        with np.load(path, allow_pickle=False) as z:
            p = json.loads(str(z["header"]))
        if p.get("kind") != cls.kind:
            raise ArtifactError(f"{path}: not a {cls.kind} world")
        return cls(p["width"], p["depth"], p["centre"], p["radius"], p["cell"], p["meta"])

    def content_hash(self) -> str:
        return hashlib.sha256(json.dumps(self._params(), sort_keys=True).encode()).hexdigest()


class NotAWorld:
    """An entry point whose ``load`` returns something that is not a world model."""

    @classmethod
    def load(cls, path):
        return object()
