"""Pose-labelled RGB-D views: the data the world model is fitted on (paper appendix A).

:class:`Views` holds ``N`` images from planar poses, :func:`collect_views` samples them uniformly
in a level's free space, :func:`save_views` / :func:`load_views` store them as one artifact,
and :mod:`navbench.worldmodel.tum` reads and writes the TUM RGB-D layout.

Artifact formats (both validated on load, :class:`ArtifactError` naming the problem):

* a directory (any path not ending in ``.npz``): ``views.json`` (intrinsics, camera height,
  level, seed, box, meta, format version) and ``poses.npy``, ``rgb.npy``, ``depth.npy``,
  ``valid.npy``; the image arrays are opened memory-mapped (read-only);
* a single uncompressed ``.npz`` with the same arrays and ``header`` (the JSON), read into memory.

A directory written with ``save_views(..., compress=True)`` (what collect-views writes) holds
``depth`` and ``valid`` losslessly compressed in ``depth_valid.npz`` (zip deflate, level 1)
instead of ``depth.npy`` and ``valid.npy``; they are read into memory, ``rgb`` stays
memory-mapped. The arrays read back are bit-identical (so are fits and content hashes): the
z-depth of walls and floors repeats along image columns and rows, so depth compresses ~37x,
and 2000 ``half`` views take ~119 MB instead of 307 MB (docs/notebook/speed.md).

"""

from __future__ import annotations

import contextlib
import json
import math
import os
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from navbench.errors import ArtifactError, ConfigError
from navbench.geometry import AGENT_RADIUS, CAMERA_HEIGHT, Intrinsics

VIEWS_FORMAT_VERSION = 1
#: TUM depth PNG scale: stored value = metres x 5000.
TUM_DEPTH_SCALE = 5000.0
_ARRAYS = ("poses", "rgb", "depth", "valid")
#: The compressed arrays of a views directory written with ``compress=True``.
COMPRESSED_FILE = "depth_valid.npz"
_COMPRESSED = ("depth", "valid")
#: Largest magnitude (m) of a views box corner, in a views file or an ``intrinsics.json``:
#: navbench's bound on any float setting (``MAX_FLOAT`` of the profile checks, issue 34).
MAX_BOX_M = 1e6


@dataclass
class Views:
    """``N`` pose-labelled RGB-D images.

    ``poses (N, 3)`` float64 planar poses ``(x, y, theta)`` (world metres, rad);
    ``rgb (N, H, W, 3)`` uint8; ``depth (N, H, W)`` float32 (or float16) z-depth in metres
    (``+inf`` or any value where invalid); ``valid (N, H, W)`` bool; ``intrinsics`` of every
    image; ``camera_height`` (m) above the floor; ``level`` name (or a source label); ``seed``
    of the sampling (None for imported data); ``box`` ``((3,), (3,))`` world-metre corners of
    the region the map must cover (the level's box, or the observed points' bounds);
    ``meta`` free JSON-able information.
    """

    poses: np.ndarray
    intrinsics: Intrinsics
    camera_height: float
    rgb: np.ndarray
    depth: np.ndarray
    valid: np.ndarray
    level: str
    seed: int | None
    box: tuple[tuple[float, float, float], tuple[float, float, float]]
    meta: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.poses)

    def __post_init__(self):
        validate_views(self, "views")

    def subset(self, idx) -> "Views":
        """The views at integer indices ``idx`` (arrays copied into memory)."""
        idx = np.asarray(idx)
        return Views(np.asarray(self.poses[idx]), self.intrinsics, self.camera_height,
                     np.asarray(self.rgb[idx]), np.asarray(self.depth[idx]),
                     np.asarray(self.valid[idx]), self.level, self.seed, self.box, dict(self.meta))

    def header(self) -> dict:
        i = self.intrinsics
        return {
            "format_version": VIEWS_FORMAT_VERSION, "count": len(self),
            "intrinsics": {"width": i.width, "height": i.height, "fx": i.fx, "fy": i.fy,
                           "cx": i.cx, "cy": i.cy},
            "camera_height": float(self.camera_height), "level": self.level, "seed": self.seed,
            "box": [list(map(float, self.box[0])), list(map(float, self.box[1]))],
            "meta": self.meta,
        }


def validate_views(v: Views, where: str, check_values: bool = True) -> None:
    """Raise :class:`ArtifactError` unless shapes, dtypes and values of ``v`` are consistent."""
    if not isinstance(v.intrinsics, Intrinsics):
        raise ArtifactError(f"{where}: missing intrinsics")
    H, W = v.intrinsics.shape
    N = len(v.poses) if getattr(v.poses, "ndim", 0) == 2 else -1
    if np.ndim(v.poses) != 2 or np.shape(v.poses)[1] != 3:
        raise ArtifactError(f"{where}: poses has shape {np.shape(v.poses)}, expected (N, 3)")
    expect = {"rgb": (N, H, W, 3), "depth": (N, H, W), "valid": (N, H, W)}
    for name, shape in expect.items():
        arr = getattr(v, name)
        if tuple(arr.shape) != shape:
            raise ArtifactError(f"{where}: {name} has shape {tuple(arr.shape)}, expected {shape} "
                                f"(N = {N} poses, {W}x{H} intrinsics)")
    if v.rgb.dtype != np.uint8:
        raise ArtifactError(f"{where}: rgb must be uint8, got {v.rgb.dtype}")
    if v.depth.dtype not in (np.float32, np.float16):
        raise ArtifactError(f"{where}: depth must be float32 or float16, got {v.depth.dtype}")
    if v.valid.dtype != np.bool_:
        raise ArtifactError(f"{where}: valid must be bool, got {v.valid.dtype}")
    if not (v.camera_height > 0 and math.isfinite(v.camera_height)):
        raise ArtifactError(f"{where}: camera height {v.camera_height!r} is not a positive number")
    lo, hi = np.asarray(v.box[0], float), np.asarray(v.box[1], float)
    if lo.shape != (3,) or hi.shape != (3,) or not np.all(hi > lo):
        raise ArtifactError(f"{where}: box {v.box!r} is not two corners lo < hi")
    if not np.all(np.abs(np.concatenate([lo, hi])) <= MAX_BOX_M):  # NaN too
        raise ArtifactError(f"{where}: box {v.box!r} has a corner beyond {MAX_BOX_M:g} m (the "
                            f"region a map must cover; 1e300 made cells 1e298 m wide)")
    if check_values:
        if not np.all(np.isfinite(v.poses)):
            raise ArtifactError(f"{where}: poses contain NaN or infinite values")
        for n0 in range(0, N, 256):  # chunks: works on memory-mapped arrays
            d = np.asarray(v.depth[n0:n0 + 256], np.float32)
            ok = np.asarray(v.valid[n0:n0 + 256])
            bad = ok & ~(np.isfinite(d) & (d > 0))
            if bad.any():
                k = n0 + int(np.argwhere(bad)[0][0])
                raise ArtifactError(f"{where}: view {k} has NaN, infinite or non-positive depth "
                                    f"where valid")


#: Largest image side (px) and focal length (px) of a camera read from a file or option.
MAX_IMAGE_SIDE = 65_536
MAX_FOCAL_PX = 1e7


def check_intrinsics(intr: Intrinsics, where: str) -> Intrinsics:
    """Raise :class:`ArtifactError` (naming ``where``) unless ``intr`` is a usable camera.

    Width and height whole numbers >= 1; focal lengths positive and finite; the principal point
    finite and inside the image (``0 <= cx <= width``, ``0 <= cy <= height``).
    """
    if not (intr.width >= 1 and intr.height >= 1):
        raise ArtifactError(f"{where}: width and height must be >= 1, got {intr.width}x{intr.height}")
    if intr.width > MAX_IMAGE_SIDE or intr.height > MAX_IMAGE_SIDE:  # finite but absurd (issue 34)
        raise ArtifactError(f"{where}: width and height must be at most {MAX_IMAGE_SIDE} px, got "
                            f"{intr.width}x{intr.height}")
    for name in ("fx", "fy"):
        v = getattr(intr, name)
        if not (math.isfinite(v) and 0 < v <= MAX_FOCAL_PX):
            raise ArtifactError(f"{where}: {name} must be a positive finite focal length (px) of at "
                                f"most {MAX_FOCAL_PX:g}, got {v!r}")
    for name, size in (("cx", intr.width), ("cy", intr.height)):
        v = getattr(intr, name)
        if not (math.isfinite(v) and 0 <= v <= size):
            raise ArtifactError(f"{where}: principal point {name} = {v!r} is outside the "
                                f"{intr.width}x{intr.height} image (0 .. {size})")
    return intr


def json_number(v) -> float:
    """``float(v)`` for a JSON number; ``TypeError`` for anything else, booleans and numeric
    strings included (``float(True)`` is 1.0 and ``float("640")`` 640.0: neither is a number
    the file wrote, issue 34)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise TypeError(f"{v!r} is not a number")
    return float(v)


def _intrinsics_from(d, where: str) -> Intrinsics:
    try:
        w, h = json_number(d["width"]), json_number(d["height"])
        if not (w.is_integer() and h.is_integer()):
            raise ValueError
        intr = Intrinsics(int(w), int(h), json_number(d["fx"]), json_number(d["fy"]),
                          json_number(d["cx"]), json_number(d["cy"]))
    except (KeyError, TypeError, ValueError, OverflowError):
        raise ArtifactError(f"{where}: missing or malformed intrinsics (width, height: whole "
                            f"numbers; fx, fy, cx, cy: numbers)") from None
    return check_intrinsics(intr, where)


#: Bytes per pixel of a view held in memory: RGB uint8 (3) + depth float32 (4) + valid bool (1).
VIEW_BYTES_PER_PIXEL = 8
#: Bytes per view beyond its pixels: the pose, and the free-space pose sampler's candidates and
#: their distance computation (two float64 candidates per view, a few hundred bytes each).
VIEW_OVERHEAD_BYTES = 1024
#: Fixed slack for everything else a collection or import holds (renderer, level, buffers).
VIEWS_BASE_BYTES = 16 << 20


def views_memory_bytes(count: int, intrinsics: Intrinsics) -> int:
    """Bytes of memory ``count`` views of ``intrinsics`` need while they are collected or
    imported: ``count x H x W x 8`` (RGB + depth + valid) plus per-view and fixed overhead."""
    H, W = intrinsics.shape
    return int(count) * (H * W * VIEW_BYTES_PER_PIXEL + VIEW_OVERHEAD_BYTES) + VIEWS_BASE_BYTES


def check_views_memory(count: int, intrinsics: Intrinsics, what: str) -> None:
    """Refuse (:class:`ConfigError`, naming ``what``) ``count`` views that do not fit in memory,
    before anything is allocated (see :func:`navbench.worldmodel.memory.check_memory`)."""
    from navbench.worldmodel.memory import check_memory

    H, W = intrinsics.shape
    check_memory(views_memory_bytes(count, intrinsics),
                 f"{what}: {count} views of {W}x{H} (count x H x W x {VIEW_BYTES_PER_PIXEL} bytes + overhead)")


def check_views_disk(count: int, intrinsics: Intrinsics, directory, what: str) -> None:
    """Refuse (:class:`ArtifactError`) saving ``count`` views into ``directory`` when its file
    system has less free space than their ``count x H x W x 8`` bytes: a collection that can
    only fail at the end should fail before it starts."""
    import shutil

    from navbench.worldmodel.memory import format_bytes

    H, W = intrinsics.shape
    need = int(count) * (H * W * VIEW_BYTES_PER_PIXEL + 24)
    try:
        free = shutil.disk_usage(directory).free
    except OSError:
        return
    if need > free:
        raise ArtifactError(f"{what}: {count} views of {W}x{H} need {format_bytes(need)} on disk, "
                            f"only {format_bytes(free)} is free under {directory}")


# ------------------------------------------------------------------------------ collection

def sample_free_poses(level, count: int, rng: np.random.Generator, clearance: float) -> np.ndarray:
    """``count`` planar poses uniform in the free space at least ``clearance`` (m) from solids.

    Rejection sampling of ``(x, y)`` uniform in the floor plan, heading uniform in ``[-pi, pi)``.
    """
    from navbench.level import distance_to_solids, prisms

    pr = prisms(level)
    out = np.zeros((0, 2))
    tries = 0
    while len(out) < count:
        cand = rng.uniform((0.0, 0.0), (level.width, level.depth), size=(max(256, 2 * count), 2))
        ok = distance_to_solids(pr, cand) >= clearance
        ok &= (cand[:, 0] > clearance) & (cand[:, 0] < level.width - clearance)
        ok &= (cand[:, 1] > clearance) & (cand[:, 1] < level.depth - clearance)
        out = np.concatenate([out, cand[ok]])
        tries += 1
        if tries > 200 and len(out) == 0:
            raise ConfigError(f"level {level.name}: no free space with clearance {clearance} m")
    theta = rng.uniform(-np.pi, np.pi, size=count)
    return np.column_stack([out[:count], theta])


def collect_views(level, count: int, intrinsics: Intrinsics, seed: int,
                  progress: Callable[[int, int], None] | None = None,
                  camera_height: float = CAMERA_HEIGHT, clearance: float = AGENT_RADIUS + 0.05,
                  renderer: Callable | None = None, texture: str = "procedural") -> Views:
    """Sample ``count`` views uniformly in ``level``'s free space and render them exactly.

    Poses: :func:`sample_free_poses` with ``numpy.random.default_rng(seed)`` and ``clearance``
    (m, default agent radius + 5 cm). Images: ``renderer(pose) -> Frame``, by default
    :class:`navbench.sim.camera.RaycastCamera` with texture mode ``texture``
    (:mod:`navbench.sim.texels`). ``progress(done, total)`` is called every 50
    views. RGB is stored as uint8 (``round(255 rgb)``), depth float32. ``count`` views that do
    not fit in the available memory are refused (:func:`check_views_memory`) before anything
    is sampled or allocated.
    """
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count <= 0:
        raise ConfigError(f"view count must be a positive whole number, got {count!r}")
    check_intrinsics(intrinsics, "collect-views: camera")
    check_views_memory(count, intrinsics, "collect-views")
    rng = np.random.default_rng(seed)
    poses = sample_free_poses(level, count, rng, clearance)
    if renderer is None:
        from navbench.sim.camera import RaycastCamera

        renderer = RaycastCamera(level, intrinsics, camera_height, texture=texture).render
    H, W = intrinsics.shape
    rgb = np.empty((count, H, W, 3), np.uint8)
    depth = np.empty((count, H, W), np.float32)
    valid = np.empty((count, H, W), bool)
    for n, pose in enumerate(poses):
        fr = renderer(pose)
        rgb[n] = np.clip(np.rint(fr.rgb * 255.0), 0, 255).astype(np.uint8)
        depth[n] = fr.depth
        valid[n] = fr.valid
        if progress is not None and ((n + 1) % 50 == 0 or n + 1 == count):
            progress(n + 1, count)
    box = ((0.0, 0.0, 0.0), (float(level.width), float(level.depth), float(level.height)))
    return Views(poses, intrinsics, float(camera_height), rgb, depth, valid, level.name, int(seed),
                 box, {"clearance": float(clearance)})


# ------------------------------------------------------------------------------ files

def _write_compressed(path: Path, arrays: dict) -> None:
    """An ``.npz`` (what ``np.load`` reads) of ``arrays``, zip deflate level 1 (``np.savez_compressed``
    uses level 6: 2.6x slower to write here for a 25 % smaller file)."""
    import zipfile

    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
        for name, arr in arrays.items():
            with zf.open(f"{name}.npy", "w", force_zip64=True) as f:
                np.lib.format.write_array(f, np.ascontiguousarray(arr), allow_pickle=False)


def save_views(views: Views, path, compress: bool = False) -> Path:
    """Write ``views``: a directory of ``.npy`` files, or one uncompressed ``.npz`` if ``path`` ends so.

    ``compress`` (directories only): ``depth`` and ``valid`` go losslessly compressed into
    ``depth_valid.npz`` (module docstring).

    A write that fails (no space, no permission, ``path`` is a file) raises
    :class:`ArtifactError` naming ``path`` and removes what it had written (the ``.npz``'s temp
    file; the directory when this call created it).
    """
    import shutil

    path = Path(path)
    header = json.dumps(views.header(), default=float)
    arrays = {"poses": np.asarray(views.poses, np.float64), "rgb": views.rgb,
              "depth": views.depth, "valid": views.valid}
    if path.suffix == ".npz":
        tmp = path.with_name(f".{path.name}.{os.getpid()}-{uuid.uuid4().hex[:8]}.tmp.npz")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            np.savez(tmp, header=np.array(header), **arrays)
            tmp.replace(path)
        except OSError as e:
            with contextlib.suppress(OSError):
                tmp.unlink(missing_ok=True)
            raise ArtifactError(f"{path}: cannot write views ({e.strerror or e})") from None
        return path
    created = not path.exists()
    try:
        path.mkdir(parents=True, exist_ok=True)
        for name, arr in arrays.items():
            if not (compress and name in _COMPRESSED):
                np.save(path / f"{name}.npy", np.asarray(arr))
        if compress:
            _write_compressed(path / COMPRESSED_FILE, {k: arrays[k] for k in _COMPRESSED})
        (path / "views.json").write_text(header + "\n")  # written last: marks a complete artifact
    except OSError as e:
        if created and path.is_dir():
            shutil.rmtree(path, ignore_errors=True)
        raise ArtifactError(f"{path}: cannot write views ({e.strerror or e})") from None
    return path


def load_views(path, mmap: bool = True) -> Views:
    """Read and validate views written by :func:`save_views` (memory-mapped for directories)."""
    path = Path(path)
    if path.is_dir():
        hp = path / "views.json"
        if not hp.exists():
            raise ArtifactError(f"{path}: not a views artifact (no views.json)")
        from navbench.safeio import load_json

        header = load_json(hp, ArtifactError, "views header", finite=False)
        arrays = _read_compressed(path) if (path / COMPRESSED_FILE).is_file() else {}
        for name in _ARRAYS:
            if name in arrays:
                continue
            f = path / f"{name}.npy"
            if not f.is_file():
                raise ArtifactError(f"{path}: missing {name}.npy")
            try:
                arrays[name] = np.load(f, mmap_mode="r" if mmap else None, allow_pickle=False)
            except Exception as e:
                raise ArtifactError(f"{f}: unreadable ({type(e).__name__}: {e})") from None
    elif path.is_file():
        from navbench.worldmodel.memory import check_memory

        # an .npz is read into memory whole (uncompressed: its size is the arrays' size)
        check_memory(path.stat().st_size, f"{path}: reading this .npz views file (use a views "
                     f"directory, which is memory-mapped, for large collections) would")
        try:
            with np.load(path, allow_pickle=False) as z:
                missing = ({"header"} | set(_ARRAYS)) - set(z.files)
                if missing:
                    raise ArtifactError(f"{path}: not a views artifact (missing {sorted(missing)})")
                header = json.loads(str(z["header"]))
                arrays = {name: z[name] for name in _ARRAYS}
        except ArtifactError:
            raise
        except Exception as e:
            raise ArtifactError(f"{path}: unreadable views file ({type(e).__name__}: {e})") from None
    else:
        from navbench.safeio import check_regular_file

        if path.exists():  # a FIFO or device: refused by stat, never opened
            check_regular_file(path, ArtifactError, "views file")
        raise ArtifactError(f"{path}: no such views artifact")
    return _from_header(header, arrays, str(path))


def _read_compressed(path: Path) -> dict:
    """``depth`` and ``valid`` of a views directory written with ``compress=True``, in memory."""
    f = path / COMPRESSED_FILE
    try:
        with np.load(f, allow_pickle=False) as z:
            missing = set(_COMPRESSED) - set(z.files)
            if missing:
                raise ArtifactError(f"{f}: missing {sorted(missing)}")
            return {name: z[name] for name in _COMPRESSED}
    except ArtifactError:
        raise
    except Exception as e:
        raise ArtifactError(f"{f}: unreadable ({type(e).__name__}: {e})") from None


def _from_header(header: dict, arrays: dict, where: str) -> Views:
    if not isinstance(header, dict) or header.get("format_version") != VIEWS_FORMAT_VERSION:
        raise ArtifactError(f"{where}: views format version "
                            f"{header.get('format_version') if isinstance(header, dict) else None!r}, "
                            f"this navbench reads {VIEWS_FORMAT_VERSION}")
    intr = _intrinsics_from(header.get("intrinsics"), where)
    count = header.get("count")
    if count != len(arrays["poses"]):
        raise ArtifactError(f"{where}: header says {count} views, poses has {len(arrays['poses'])}")
    try:
        box = tuple(tuple(float(c) for c in corner) for corner in header["box"])
        cam_h = float(header["camera_height"])
    except (KeyError, TypeError, ValueError):
        raise ArtifactError(f"{where}: missing or malformed box / camera_height") from None
    return _make(arrays, intr, cam_h, header.get("level", ""), header.get("seed"), box,
                 header.get("meta", {}), where)


def _make(arrays, intr, cam_h, level, seed, box, meta, where) -> Views:
    v = Views.__new__(Views)  # validate with the artifact's name in the message
    v.poses, v.rgb, v.depth, v.valid = (arrays[k] for k in _ARRAYS)
    v.intrinsics, v.camera_height, v.level, v.seed, v.box, v.meta = intr, cam_h, level, seed, box, meta
    validate_views(v, where)
    if len(v) == 0:  # every command needs a view; the message names the file (P-019)
        raise ArtifactError(f"{where}: holds no views")
    return v


# ------------------------------------------------------------------------------ identity and split

def views_content_hash(views: Views) -> str:
    """sha256 (hex) of what a fit sees: the intrinsics, camera height and box (as sorted JSON),
    then each array's dtype, shape and bytes (poses as float64, rgb, depth, valid). The level
    label, seed and ``meta`` (source path, timestamps) are left out, so the same images and
    poses read from an ``.npz``, a views directory or a TUM import of them hash alike."""
    import hashlib

    i = views.intrinsics
    head = {"intrinsics": [i.width, i.height, i.fx, i.fy, i.cx, i.cy],
            "camera_height": float(views.camera_height),
            "box": [[float(c) for c in views.box[0]], [float(c) for c in views.box[1]]]}
    h = hashlib.sha256(json.dumps(head, sort_keys=True).encode())
    arrays = (("poses", np.asarray(views.poses, np.float64)), ("rgb", views.rgb),
              ("depth", views.depth), ("valid", views.valid))
    for name, arr in arrays:
        h.update(f"{name} {np.dtype(arr.dtype).str} {tuple(arr.shape)}".encode())
        for n0 in range(0, len(arr), 64):  # chunks: memory-mapped arrays stay on disk
            h.update(np.ascontiguousarray(arr[n0:n0 + 64]).tobytes())
    return h.hexdigest()


def heldout_split(count: int, every: int) -> tuple[np.ndarray, np.ndarray]:
    """The deterministic train / held-out split of ``count`` views: every ``every``-th view
    (indices ``every - 1, 2 every - 1, ...``) is held out, the rest train. Returns
    ``(train indices, held-out indices)``; :class:`ConfigError` unless both are non-empty."""
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 2:
        raise ConfigError(f"held-out split: every must be a whole number >= 2, got {every!r}")
    idx = np.arange(count)
    held = (idx % every) == every - 1
    if not held.any() or held.all():
        raise ConfigError(f"held-out split: {count} views hold out none with every {every} "
                          f"(give at least {every} views, a smaller --heldout-every or --heldout)")
    return idx[~held], idx[held]
