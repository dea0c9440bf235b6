"""The world-model interface: what the planner, the trackers and the stages need of a map.

A world model is whatever the agent knows of the level. The consumers need only this of it:

* the planner: :meth:`WorldModel.occupancy_slice` -> ``(occ2d, xs, ys)``, a boolean ``(nx, ny)``
  raster of the body band (index ``[ix, iy]``) and its cell-centre coordinates (m);
* the map-based trackers (and map evaluation, the benchmark): :meth:`WorldModel.renderer` ->
  a :class:`Renderer` whose ``render(pose)`` is the RGB-D :class:`~navbench.geometry.Frame` the
  model predicts for the camera on planar pose ``(x, y, theta)``;
* the stages: :meth:`WorldModel.save`, :meth:`WorldModel.load` and
  :meth:`WorldModel.content_hash` (sha256 hex of the stored content, stable across save/load);
* ``meta``: free JSON-able information (``step``, ``max_range``, ``sigma2``, ``level`` ...) and
  ``kind``, the name :func:`load_world_model` dispatches on.

The emission tracker also differentiates renders w.r.t. the pose, which needs
:class:`DifferentiableWorldModel` (a ``ray_renderer``); other consumers need only
:class:`WorldModel`. :class:`~navbench.worldmodel.grid.VoxelMap` (kind ``"voxel"``) implements both.

Map files are ``.npz`` files with a JSON ``header`` array. The header's ``kind`` names the world
model (no ``kind``: a voxel map, the format navbench has always written). Other kinds come from
plugins: a distribution declares an entry point in the group ``navbench.world_models`` whose
name is the kind and whose object is the class (with a ``load(path)`` classmethod), e.g.
``[project.entry-points."navbench.world_models"] mymodel = "mypkg.world:MyModel"``.
"""

from __future__ import annotations

import json
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from navbench.errors import ArtifactError
from navbench.geometry import CAMERA_HEIGHT, MAX_RANGE, Frame, Intrinsics

#: The entry-point group plugin world models register under.
ENTRY_POINT_GROUP = "navbench.world_models"
#: The kind of a map file whose header names none (every map navbench writes).
DEFAULT_KIND = "voxel"


@runtime_checkable
class Renderer(Protocol):
    """Renders one world model for one camera, many times."""

    def render(self, pose) -> Frame:
        """The predicted view of the camera on planar pose ``(x, y, theta)`` (m, rad)."""


@runtime_checkable
class WorldModel(Protocol):
    """What every consumer needs of a map (see the module docstring)."""

    kind: str
    meta: dict

    def occupancy_slice(self, mode: str = "band", z_low: float = 0.05, z_high: float = 1.0,
                        height: float = CAMERA_HEIGHT) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(occ2d (nx, ny) bool, xs (nx,), ys (ny,))``: occupied cells of the body band
        ``[z_low, z_high]`` (``mode="band"``) or at ``height`` (``mode="slice"``), metres."""

    def renderer(self, intrinsics: Intrinsics, camera_height: float = CAMERA_HEIGHT,
                 max_range: float = MAX_RANGE, step: float | None = None) -> Renderer:
        """A :class:`Renderer` for a camera with ``intrinsics`` at ``camera_height`` (m);
        ``step`` is a ray-marching hint (m) a model that marches no rays ignores."""

    def save(self, path) -> Path:
        """Write the model to ``path`` (an ``.npz`` map file); returns the path."""

    @classmethod
    def load(cls, path) -> "WorldModel":
        """Read a file :meth:`save` wrote; :class:`~navbench.errors.ArtifactError` names what is wrong."""

    def content_hash(self) -> str:
        """sha256 hex of the stored content: equal after a save/load round trip."""


@runtime_checkable
class DifferentiableWorldModel(WorldModel, Protocol):
    """A world model whose renders can be differentiated w.r.t. the camera (emission tracking)."""

    def ray_renderer(self, step: float | None = None, max_range: float = MAX_RANGE) -> Any:
        """``(origins (R, 3), dirs (R, 3)) -> RayRender`` in torch, differentiable w.r.t. the
        rays (see :class:`navbench.worldmodel.diffrender.GridRayRenderer`)."""


# ------------------------------------------------------------------------------ loading

def plugin_kinds() -> dict[str, Any]:
    """The world-model kinds installed plugins register: ``{kind: entry point}``."""
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def world_model_kinds() -> list[str]:
    """Every loadable kind, sorted: the built-in ``voxel`` and the plugins'."""
    return sorted({DEFAULT_KIND, *plugin_kinds()})


def read_kind(path) -> str:
    """The ``kind`` a map file's header names (``voxel`` when it names none).

    Reads only the header; :class:`ArtifactError` naming ``path`` when the file is missing, not
    an ``.npz``, has no JSON ``header`` or a ``kind`` that is not a string.
    """
    from navbench.safeio import check_regular_file

    path = Path(path)
    check_regular_file(path, ArtifactError, "map file")  # missing, a directory, a FIFO: one line
    try:
        with np.load(path, allow_pickle=False) as z:
            if "header" not in z.files:
                raise ArtifactError(f"{path}: not a navbench map (missing ['header'])")
            header = json.loads(str(z["header"]))
    except ArtifactError:
        raise
    except Exception as e:  # not a zip, truncated, bad JSON, an object array ...
        raise ArtifactError(f"{path}: unreadable map file ({type(e).__name__}: {e})") from None
    if not isinstance(header, dict):
        raise ArtifactError(f"{path}: bad map header (a JSON object expected, got {type(header).__name__})")
    kind = header.get("kind", DEFAULT_KIND)
    if not isinstance(kind, str) or not kind:
        raise ArtifactError(f"{path}: bad map header (kind {kind!r} is not a name)")
    return kind


def world_model_class(kind: str, path=None) -> type:
    """The class of world-model ``kind``: built in, or a plugin's entry point (imported now).

    :class:`ArtifactError` (naming ``path`` when given) for an unknown kind or a plugin entry
    point that does not import.
    """
    where = f"{path}: " if path is not None else ""
    if kind == DEFAULT_KIND:
        from navbench.worldmodel.grid import VoxelMap

        return VoxelMap
    eps = plugin_kinds()
    ep = eps.get(kind)
    if ep is None:
        raise ArtifactError(f"{where}unknown world-model kind {kind!r}; installed: "
                            f"{sorted({DEFAULT_KIND, *eps})} (plugins register under the "
                            f"entry-point group {ENTRY_POINT_GROUP!r})")
    try:
        cls = ep.load()
    except Exception as e:  # a broken plugin install is named, not a traceback here
        raise ArtifactError(f"{where}world-model kind {kind!r}: entry point {ep.value!r} does not "
                            f"load ({type(e).__name__}: {e})") from None
    if not callable(getattr(cls, "load", None)):
        raise ArtifactError(f"{where}world-model kind {kind!r}: entry point {ep.value!r} has no "
                            f"load(path) classmethod")
    return cls


def load_world_model(path) -> WorldModel:
    """Load the map file ``path`` as the world model its header's ``kind`` names.

    Every failure a file can cause (missing, not an ``.npz``, wrong or missing arrays, NaN,
    an absurd size, an unknown kind) is one :class:`ArtifactError` line naming ``path``.
    """
    path = Path(path)
    kind = read_kind(path)
    model = world_model_class(kind, path).load(path)
    if not isinstance(model, WorldModel):
        raise ArtifactError(f"{path}: the {kind!r} loader returned a {type(model).__name__}, "
                            f"which is not a WorldModel")
    return model
