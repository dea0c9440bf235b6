"""Pose-labelled RGB-D views: the data the world model is fitted on (paper appendix A).

:class:`Views` holds ``N`` images from planar poses, :func:`collect_views` samples them uniformly
in a level's free space, :func:`save_views` / :func:`load_views` store them as one artifact,
and :func:`export_views` / :func:`import_views` read and write the TUM RGB-D layout.

Artifact formats (both validated on load, :class:`ArtifactError` naming the problem):

* a directory (any path not ending in ``.npz``): ``views.json`` (intrinsics, camera height,
  level, seed, box, meta, format version) and ``poses.npy``, ``rgb.npy``, ``depth.npy``,
  ``valid.npy``; the image arrays are opened memory-mapped (read-only);
* a single uncompressed ``.npz`` with the same arrays and ``header`` (the JSON), read into memory.

TUM RGB-D layout (https://cvg.cit.tum.de/data/datasets/rgbd-dataset/file_formats):
``rgb/<t>.png`` (8-bit RGB), ``depth/<t>.png`` (16-bit, metres x 5000, 0 = no reading),
``rgb.txt`` / ``depth.txt`` (``timestamp filename``), ``groundtruth.txt``
(``timestamp tx ty tz qx qy qz qw``: the **camera-to-world** pose ``T_wc`` of the camera in the
navbench world frame, camera axes OpenCV — x right, y down, z forward; quaternion Hamilton,
scalar last) and ``intrinsics.json`` (a navbench convenience: width, height, fx, fy, cx, cy,
camera height, depth scale, level, seed).
"""

from __future__ import annotations

import contextlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from navbench.errors import ArtifactError, ConfigError
from navbench.geometry import AGENT_RADIUS, CAMERA_HEIGHT, Intrinsics, camera_pose, wrap_angle

VIEWS_FORMAT_VERSION = 1
#: TUM depth PNG scale: stored value = metres x 5000.
TUM_DEPTH_SCALE = 5000.0
_ARRAYS = ("poses", "rgb", "depth", "valid")


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


def check_intrinsics(intr: Intrinsics, where: str) -> Intrinsics:
    """Raise :class:`ArtifactError` (naming ``where``) unless ``intr`` is a usable camera.

    Width and height whole numbers >= 1; focal lengths positive and finite; the principal point
    finite and inside the image (``0 <= cx <= width``, ``0 <= cy <= height``).
    """
    if not (intr.width >= 1 and intr.height >= 1):
        raise ArtifactError(f"{where}: width and height must be >= 1, got {intr.width}x{intr.height}")
    for name in ("fx", "fy"):
        v = getattr(intr, name)
        if not (math.isfinite(v) and v > 0):
            raise ArtifactError(f"{where}: {name} must be a positive finite focal length (px), got {v!r}")
    for name, size in (("cx", intr.width), ("cy", intr.height)):
        v = getattr(intr, name)
        if not (math.isfinite(v) and 0 <= v <= size):
            raise ArtifactError(f"{where}: principal point {name} = {v!r} is outside the "
                                f"{intr.width}x{intr.height} image (0 .. {size})")
    return intr


def _intrinsics_from(d, where: str) -> Intrinsics:
    try:
        w, h = float(d["width"]), float(d["height"])
        if not (w.is_integer() and h.is_integer()):
            raise ValueError
        intr = Intrinsics(int(w), int(h), float(d["fx"]), float(d["fy"]),
                          float(d["cx"]), float(d["cy"]))
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
                  renderer: Callable | None = None) -> Views:
    """Sample ``count`` views uniformly in ``level``'s free space and render them exactly.

    Poses: :func:`sample_free_poses` with ``numpy.random.default_rng(seed)`` and ``clearance``
    (m, default agent radius + 5 cm). Images: ``renderer(pose) -> Frame``, by default
    :class:`navbench.sim.camera.RaycastCamera`. ``progress(done, total)`` is called every 50
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

        renderer = RaycastCamera(level, intrinsics, camera_height).render
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

def save_views(views: Views, path) -> Path:
    """Write ``views``: a directory of ``.npy`` files, or one uncompressed ``.npz`` if ``path`` ends so.

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
        tmp = path.with_name(path.name + ".tmp.npz")
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
            np.save(path / f"{name}.npy", np.asarray(arr))
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
        if not hp.is_file():
            raise ArtifactError(f"{path}: not a views artifact (no views.json)")
        try:
            header = json.loads(hp.read_text())
        except json.JSONDecodeError as e:
            raise ArtifactError(f"{hp}: not valid JSON ({e})") from None
        arrays = {}
        for name in _ARRAYS:
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
        raise ArtifactError(f"{path}: no such views artifact")
    return _from_header(header, arrays, str(path))


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
    return v


# ------------------------------------------------------------------------------ TUM RGB-D

def _rot_to_quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternion ``(qx, qy, qz, qw)`` of a rotation matrix (Shepperd's method), qw >= 0."""
    m = R
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = [0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = [(m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s]
    q = np.asarray(q)
    q /= np.linalg.norm(q)
    return -q if q[3] < 0 else q


def _quat_to_rot(q) -> np.ndarray:
    x, y, z, w = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def planar_from_camera(T_wc: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Planar pose ``(x, y, theta)``, camera height and tilt (deg) of a camera-to-world ``T_wc``.

    ``theta`` is the heading of the optical axis projected on the floor; the tilt is the angle
    between the camera's ``y`` axis and world down (0 for a planar-mounted camera).
    """
    R = T_wc[:3, :3]
    fwd = R[:, 2]
    theta = math.atan2(fwd[1], fwd[0])
    tilt = math.degrees(math.acos(float(np.clip(-R[2, 1], -1.0, 1.0))))
    return np.array([T_wc[0, 3], T_wc[1, 3], float(wrap_angle(theta))]), float(T_wc[2, 3]), tilt


def export_views(views: Views, directory, dt: float = 0.05) -> Path:
    """Write ``views`` in the TUM RGB-D layout under ``directory`` (see the module docstring).

    View ``n`` gets timestamp ``n * dt`` seconds. Depth is quantised to 1/5000 m (values above
    13.1 m and invalid pixels are written as 0 = no reading). ``directory`` must be new or an
    empty directory: an export never overwrites another sequence's files or mixes with them.
    A failed write raises :class:`ArtifactError` and removes the directory if this call made it.
    """
    import shutil

    from PIL import Image

    d = Path(directory)
    if d.exists() and not d.is_dir():
        raise ArtifactError(f"{d}: exists and is not a directory")
    if d.is_dir() and any(d.iterdir()):
        raise ArtifactError(f"{d}: directory is not empty; export into a new or empty directory")
    if not (math.isfinite(dt) and dt > 0):
        raise ConfigError(f"export: dt must be a positive number of seconds, got {dt!r}")
    if len(views) == 0:
        raise ArtifactError(f"views of {views.level!r}: no views to export")
    created = not d.exists()
    try:
        (d / "rgb").mkdir(parents=True, exist_ok=True)
        (d / "depth").mkdir(parents=True, exist_ok=True)
        rgb_lines = ["# color images", "# timestamp filename"]
        depth_lines = ["# depth maps (16-bit PNG, metres x 5000, 0 = no reading)", "# timestamp filename"]
        gt_lines = ["# camera-to-world pose of the camera (OpenCV axes) in the navbench world frame",
                    "# timestamp tx ty tz qx qy qz qw"]
        for n in range(len(views)):
            ts = f"{n * dt:.6f}"
            Image.fromarray(np.asarray(views.rgb[n])).save(d / "rgb" / f"{ts}.png")
            dep = np.asarray(views.depth[n], np.float64)
            ok = np.asarray(views.valid[n]) & np.isfinite(dep)
            q16 = np.where(ok, np.rint(np.where(ok, dep, 0) * TUM_DEPTH_SCALE), 0)
            q16 = np.where(q16 > 65535, 0, q16).astype(np.uint16)
            Image.fromarray(q16).save(d / "depth" / f"{ts}.png")
            T = camera_pose(views.poses[n], views.camera_height)
            q = _rot_to_quat(T[:3, :3])
            rgb_lines.append(f"{ts} rgb/{ts}.png")
            depth_lines.append(f"{ts} depth/{ts}.png")
            gt_lines.append(f"{ts} " + " ".join(f"{v:.9f}" for v in (*T[:3, 3], *q)))
        for name, lines in (("rgb.txt", rgb_lines), ("depth.txt", depth_lines),
                            ("groundtruth.txt", gt_lines)):
            (d / name).write_text("\n".join(lines) + "\n")
        i = views.intrinsics
        (d / "intrinsics.json").write_text(json.dumps({
            "width": i.width, "height": i.height, "fx": i.fx, "fy": i.fy, "cx": i.cx, "cy": i.cy,
            "camera_height": views.camera_height, "depth_scale": TUM_DEPTH_SCALE,
            "level": views.level, "seed": views.seed,
            "box": [list(views.box[0]), list(views.box[1])]}, indent=1) + "\n")
    except OSError as e:
        if created:
            shutil.rmtree(d, ignore_errors=True)
        raise ArtifactError(f"{d}: cannot write the TUM export ({e.strerror or e})") from None
    return d


#: How far a ground-truth quaternion's norm may be from 1 (the TUM files print 4 decimals, and
#: rounding every component by up to 5e-5 moves the norm by about 1e-4; 1e-2 still allows 2
#: decimals). A larger error is not rounding but a wrong column, a typo or a zero quaternion.
QUAT_NORM_TOL = 1e-2
#: PIL modes of 16-bit single-channel images (TUM depth); Pillow opens 16-bit PNGs as I;16,
#: older versions as I (int32 holding the 16-bit values).
_DEPTH_MODES = ("I;16", "I;16B", "I;16L", "I;16N", "I")


def _short(line: str, n: int = 60) -> str:
    return repr(line if len(line) <= n else line[:n] + "...")


def _read_list(path: Path, n_fields: int, layout: str) -> list[tuple[float, list[str], int]]:
    """The data lines of a TUM list file as ``(timestamp, fields, line number)``.

    Blank lines and ``#`` comments are skipped; every other line must have the timestamp and
    exactly ``n_fields`` more whitespace-separated fields (``layout`` names them in the error),
    and a finite timestamp. Errors name ``path:line``.
    """
    if not path.is_file():
        raise ArtifactError(f"{path.parent}: missing {path.name} (TUM RGB-D layout: rgb.txt, "
                            f"depth.txt, groundtruth.txt, rgb/, depth/)")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise ArtifactError(f"{path}: unreadable ({type(e).__name__}: {e})") from None
    out = []
    for k, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = line.split()
        if len(parts) != 1 + n_fields:
            raise ArtifactError(f"{path}:{k}: expected {1 + n_fields} fields ({layout}), got "
                                f"{len(parts)}: {_short(line)}")
        try:
            t = float(parts[0])
        except ValueError:
            raise ArtifactError(f"{path}:{k}: timestamp {_short(parts[0])} is not a number") from None
        if not math.isfinite(t):
            raise ArtifactError(f"{path}:{k}: timestamp {parts[0]} is not finite")
        out.append((t, parts[1:], k))
    return out


def _read_groundtruth(path: Path) -> list[tuple[float, np.ndarray, int]]:
    """``groundtruth.txt`` as ``(timestamp, T_wc 4x4, line number)``; every pose must be seven
    finite numbers with a unit quaternion (within :data:`QUAT_NORM_TOL`, then normalised)."""
    out = []
    for t, vals, k in _read_list(path, 7, "timestamp tx ty tz qx qy qz qw"):
        p = []
        for v in vals:
            try:
                p.append(float(v))
            except ValueError:
                raise ArtifactError(f"{path}:{k}: pose value {_short(v)} is not a number") from None
        if not all(math.isfinite(v) for v in p):
            raise ArtifactError(f"{path}:{k}: pose has NaN or infinite values")
        qn = math.sqrt(sum(v * v for v in p[3:]))
        if not abs(qn - 1.0) <= QUAT_NORM_TOL:
            raise ArtifactError(f"{path}:{k}: quaternion qx qy qz qw = {' '.join(vals[3:])} has "
                                f"norm {qn:.6g}, not a unit quaternion (rotation)")
        T = np.eye(4)
        T[:3, :3] = _quat_to_rot(p[3:])
        T[:3, 3] = p[:3]
        out.append((t, T, k))
    return out


def _associate(a: list, b: list, max_dt: float) -> dict[int, int]:
    """Greedy nearest-timestamp association ``index in a -> index in b`` within ``max_dt`` s
    (rows are tuples whose first entry is the timestamp)."""
    tb = np.array([r[0] for r in b], float)
    out, used = {}, set()
    if len(tb) == 0:
        return out
    order = np.argsort(tb)
    tbs = tb[order]
    for i, r in enumerate(a):
        t = r[0]
        k = int(np.searchsorted(tbs, t))
        best = None
        for c in (k - 1, k):
            if 0 <= c < len(tbs) and abs(tbs[c] - t) <= max_dt and int(order[c]) not in used:
                if best is None or abs(tbs[c] - t) < abs(tbs[best] - t):
                    best = c
        if best is not None:
            out[i] = int(order[best])
            used.add(int(order[best]))
    return out


def _open_listed(d: Path, row: tuple, list_path: Path):
    """Open (header only) the image a list line names; errors name the image and ``list:line``."""
    from PIL import Image

    name, k = row[1][0], row[2]
    path = d / name
    where = f"{list_path}:{k}"
    if not path.is_file():
        raise ArtifactError(f"{where}: {name}: no such file")
    try:
        return Image.open(path), path, where
    except Exception as e:  # PIL raises OSError, SyntaxError, ValueError, DecompressionBombError
        raise ArtifactError(f"{path}: not a readable image ({_why(e, path)}) "
                            f"(listed at {where})") from None


def _why(e: Exception, path: Path) -> str:
    """``Type: message`` of a decoder error, without the path PIL repeats in it."""
    msg = str(e).replace(f"'{path}'", "").replace(str(path), "").strip(" :")
    return f"{type(e).__name__}: {msg}" if msg else type(e).__name__


def _pixels(im, path: Path, where: str, mode: str | None = None) -> np.ndarray:
    """Decode ``im`` (converted to ``mode`` if given) into an array; a corrupt or truncated file
    is an :class:`ArtifactError` naming it."""
    try:
        with im:
            return np.asarray(im.convert(mode) if mode else im)
    except Exception as e:  # the decoder's errors: OSError, SyntaxError, ValueError, ...
        raise ArtifactError(f"{path}: corrupt or truncated image ({_why(e, path)}) "
                            f"(listed at {where})") from None


def _mode_desc(im) -> str:
    from PIL import ImageMode

    try:
        dtype = np.dtype(ImageMode.getmode(im.mode).typestr).name
    except Exception:  # an exotic mode: the name alone
        dtype = "unknown dtype"
    return f"PIL mode {im.mode}, {len(im.getbands())} channel(s) of {dtype}"


def first_rgb_size(directory) -> tuple[int, int]:
    """``(width, height)`` of the first image listed in ``directory/rgb.txt`` (read from its
    header), the image size of intrinsics given as focal lengths only."""
    d = Path(directory)
    if not d.is_dir():
        raise ArtifactError(f"{d}: no such directory" if not d.exists() else f"{d}: not a directory")
    rows = _read_list(d / "rgb.txt", 1, "timestamp filename")
    if not rows:
        raise ArtifactError(f"{d / 'rgb.txt'}: lists no images")
    im, _, _ = _open_listed(d, rows[0], d / "rgb.txt")
    with im:
        return im.size


def _positive_number(value, where: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ArtifactError(f"{where}: {value!r} is not a number") from None
    if isinstance(value, bool) or not (math.isfinite(v) and v > 0):
        raise ArtifactError(f"{where}: must be a positive finite number, got {value!r}")
    return v


def import_views(directory, intrinsics: Intrinsics | None = None, camera_height: float | None = None,
                 depth_scale: float | None = None, max_dt: float = 0.02, level: str | None = None,
                 box_margin: float = 0.1, intrinsics_source: str = "given") -> Views:
    """Read a TUM RGB-D directory into :class:`Views`.

    ``rgb.txt``, ``depth.txt`` and ``groundtruth.txt`` are associated by nearest timestamp
    (within ``max_dt`` s). Intrinsics: the argument (``intrinsics_source`` names where it came
    from in errors), else ``intrinsics.json``; camera height: the argument, else
    ``intrinsics.json``, else the median camera ``z``. The planar pose is
    :func:`planar_from_camera` of each ground-truth pose; ``meta['max_tilt_deg']`` reports how
    far the cameras are from planar. ``box``: ``intrinsics.json``'s, else the bounds of the
    camera centres and the back-projected depth points (every 8th pixel) plus ``box_margin``.

    Everything is checked before it is used, each error one :class:`ArtifactError` naming the
    file (and line of the lists): list lines (field counts, numbers, finite values, unit
    quaternions), listed files that are missing, unreadable or corrupt, rgb images that are not
    8-bit, depth images that are not 16-bit single-channel (an 8-bit depth PNG would silently
    become depths of at most 51 mm), image sizes against the intrinsics, and the memory the
    views need (:func:`check_views_memory`, before the arrays are allocated).
    """
    d = Path(directory)
    if not d.is_dir():
        raise ArtifactError(f"{d}: no such directory" if not d.exists() else f"{d}: not a directory")
    if not (isinstance(max_dt, (int, float)) and math.isfinite(max_dt) and max_dt >= 0):
        raise ConfigError(f"max_dt must be a finite number of seconds >= 0, got {max_dt!r}")
    info_path = d / "intrinsics.json"
    info = {}
    if info_path.is_file():
        try:
            info = json.loads(info_path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as e:
            raise ArtifactError(f"{info_path}: not valid JSON ({e})") from None
        except OSError as e:
            raise ArtifactError(f"{info_path}: unreadable ({e.strerror or e})") from None
        if not isinstance(info, dict):
            raise ArtifactError(f"{info_path}: expected a JSON object, got {type(info).__name__}")
    if intrinsics is None:
        if not info:
            raise ArtifactError(f"{d}: no intrinsics given and no intrinsics.json")
        intrinsics = _intrinsics_from(info, str(info_path))
        intrinsics_source = str(info_path)
    else:
        check_intrinsics(intrinsics, f"intrinsics ({intrinsics_source})")
    if depth_scale is not None:
        scale = _positive_number(depth_scale, "depth_scale")
    else:
        scale = _positive_number(info.get("depth_scale", TUM_DEPTH_SCALE), f"{info_path}: depth_scale")
    if camera_height is not None:
        camera_height = _positive_number(camera_height, "camera_height")
    elif info.get("camera_height") is not None:
        camera_height = _positive_number(info["camera_height"], f"{info_path}: camera_height")
    box = None
    if info.get("box"):
        try:
            box = tuple(tuple(float(c) for c in corner) for corner in info["box"])
            lo, hi = np.asarray(box[0]), np.asarray(box[1])
            ok = len(box) == 2 and lo.shape == hi.shape == (3,) and np.all(np.isfinite(lo + hi))
        except (TypeError, ValueError, IndexError):
            ok = False
        if not (ok and np.all(hi > lo)):
            raise ArtifactError(f"{info_path}: box must be two corners [[x, y, z], [x, y, z]] "
                                f"with lo < hi, got {info['box']!r}")
    if info.get("level") is not None and not isinstance(info["level"], str):
        raise ArtifactError(f"{info_path}: level must be a string, got {info['level']!r}")
    seed = info.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
        raise ArtifactError(f"{info_path}: seed must be a whole number or null, got {seed!r}")

    rgb_txt, depth_txt, gt_txt = d / "rgb.txt", d / "depth.txt", d / "groundtruth.txt"
    rgbs = _read_list(rgb_txt, 1, "timestamp filename")
    depths = _read_list(depth_txt, 1, "timestamp filename")
    gts = _read_groundtruth(gt_txt)
    for path, rows in ((rgb_txt, rgbs), (depth_txt, depths), (gt_txt, gts)):
        if not rows:
            raise ArtifactError(f"{path}: empty sequence (no data lines)")
    a_d, a_g = _associate(rgbs, depths, max_dt), _associate(rgbs, gts, max_dt)
    keep = [i for i in range(len(rgbs)) if i in a_d and i in a_g]
    if not keep:
        raise ArtifactError(f"{d}: no rgb image has a depth map and a pose within {max_dt} s")
    H, W = intrinsics.shape
    N = len(keep)
    check_views_memory(N, intrinsics, f"import-views {d}")
    rgb = np.empty((N, H, W, 3), np.uint8)
    depth = np.empty((N, H, W), np.float32)
    valid = np.empty((N, H, W), bool)
    Ts = np.empty((N, 4, 4))
    for n, i in enumerate(keep):
        im, rpath, rwhere = _open_listed(d, rgbs[i], rgb_txt)
        if im.size != (W, H):
            im.close()
            raise ArtifactError(f"{rpath}: rgb image is {im.size[0]}x{im.size[1]}, the intrinsics "
                                f"({intrinsics_source}) say {W}x{H} (listed at {rwhere})")
        if np.dtype(_typestr(im)).itemsize != 1:
            desc = _mode_desc(im)
            im.close()
            raise ArtifactError(f"{rpath}: rgb image is {desc}; TUM colour images are 8-bit "
                                f"(listed at {rwhere})")
        rgb[n] = _pixels(im, rpath, rwhere, "RGB")
        dm, dpath, dwhere = _open_listed(d, depths[a_d[i]], depth_txt)
        if dm.size != (W, H):
            dm.close()
            raise ArtifactError(f"{dpath}: depth image is {dm.size[0]}x{dm.size[1]}, its rgb image "
                                f"{rgbs[i][1][0]} and the intrinsics ({intrinsics_source}) are "
                                f"{W}x{H} (listed at {dwhere})")
        if dm.mode not in _DEPTH_MODES:
            desc = _mode_desc(dm)
            dm.close()
            raise ArtifactError(f"{dpath}: depth image is {desc}; TUM depth must be a 16-bit "
                                f"single-channel PNG (metres x {TUM_DEPTH_SCALE:g}) "
                                f"(listed at {dwhere})")
        dep = _pixels(dm, dpath, dwhere)
        valid[n] = dep > 0
        depth[n] = np.where(valid[n], dep.astype(np.float64) / scale, np.inf)
        Ts[n] = gts[a_g[i]][1]
    planar = [planar_from_camera(T) for T in Ts]
    poses = np.array([p for p, _, _ in planar])
    if camera_height is None:
        camera_height = float(np.median([h for _, h, _ in planar]))
        if not camera_height > 0:
            raise ArtifactError(f"{gt_txt}: the median camera z is {camera_height:g} m, not above "
                                f"the floor; give the camera height (intrinsics.json "
                                f"camera_height or --camera-height)")
    if box is None:
        from navbench.geometry import pixel_rays, transform_points

        rays = pixel_rays(intrinsics)[::8, ::8]
        pts = [Ts[:, :3, 3]]
        for n in range(N):
            dd = depth[n, ::8, ::8]
            ok = valid[n, ::8, ::8]
            pts.append(transform_points(Ts[n], rays[ok] * dd[ok][:, None]))
        allp = np.concatenate(pts)
        box = (tuple(allp.min(0) - box_margin), tuple(allp.max(0) + box_margin))
    meta = {"source": str(d), "max_tilt_deg": max(t for _, _, t in planar),
            "timestamps": [rgbs[i][0] for i in keep]}
    return Views(poses, intrinsics, float(camera_height), rgb, depth, valid,
                 level or info.get("level") or d.name, seed, box, meta)


def _typestr(im) -> str:
    """numpy typestr of a PIL image's pixels (``|u1`` for 8-bit modes)."""
    from PIL import ImageMode

    try:
        return ImageMode.getmode(im.mode).typestr
    except Exception:
        return "|V0"
