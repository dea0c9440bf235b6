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


def _intrinsics_from(d, where: str) -> Intrinsics:
    try:
        intr = Intrinsics(int(d["width"]), int(d["height"]), float(d["fx"]), float(d["fy"]),
                          float(d["cx"]), float(d["cy"]))
    except (KeyError, TypeError, ValueError):
        raise ArtifactError(f"{where}: missing or malformed intrinsics") from None
    if min(intr.width, intr.height) <= 0 or min(intr.fx, intr.fy) <= 0:
        raise ArtifactError(f"{where}: intrinsics must have positive size and focal lengths")
    return intr


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
    views. RGB is stored as uint8 (``round(255 rgb)``), depth float32.
    """
    if count <= 0:
        raise ConfigError(f"view count must be positive, got {count}")
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
    """Write ``views``: a directory of ``.npy`` files, or one uncompressed ``.npz`` if ``path`` ends so."""
    path = Path(path)
    header = json.dumps(views.header(), default=float)
    arrays = {"poses": np.asarray(views.poses, np.float64), "rgb": views.rgb,
              "depth": views.depth, "valid": views.valid}
    if path.suffix == ".npz":
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp.npz")
        np.savez(tmp, header=np.array(header), **arrays)
        tmp.replace(path)
        return path
    path.mkdir(parents=True, exist_ok=True)
    for name, arr in arrays.items():
        np.save(path / f"{name}.npy", np.asarray(arr))
    (path / "views.json").write_text(header + "\n")  # written last: marks a complete artifact
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
    13.1 m and invalid pixels are written as 0 = no reading).
    """
    from PIL import Image

    d = Path(directory)
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
    for name, lines in (("rgb.txt", rgb_lines), ("depth.txt", depth_lines), ("groundtruth.txt", gt_lines)):
        (d / name).write_text("\n".join(lines) + "\n")
    i = views.intrinsics
    (d / "intrinsics.json").write_text(json.dumps({
        "width": i.width, "height": i.height, "fx": i.fx, "fy": i.fy, "cx": i.cx, "cy": i.cy,
        "camera_height": views.camera_height, "depth_scale": TUM_DEPTH_SCALE,
        "level": views.level, "seed": views.seed,
        "box": [list(views.box[0]), list(views.box[1])]}, indent=1) + "\n")
    return d


def _read_list(path: Path) -> list[tuple[float, list[str]]]:
    if not path.is_file():
        raise ArtifactError(f"{path.parent}: missing {path.name}")
    out = []
    for k, line in enumerate(path.read_text().splitlines()):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = line.split()
        try:
            out.append((float(parts[0]), parts[1:]))
        except (ValueError, IndexError):
            raise ArtifactError(f"{path}:{k + 1}: malformed line {line!r}") from None
    return out


def _associate(a: list, b: list, max_dt: float) -> dict[int, int]:
    """Greedy nearest-timestamp association ``index in a -> index in b`` within ``max_dt`` s."""
    tb = np.array([t for t, _ in b])
    out, used = {}, set()
    if len(tb) == 0:
        return out
    order = np.argsort(tb)
    tbs = tb[order]
    for i, (t, _) in enumerate(a):
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


def import_views(directory, intrinsics: Intrinsics | None = None, camera_height: float | None = None,
                 depth_scale: float | None = None, max_dt: float = 0.02, level: str | None = None,
                 box_margin: float = 0.1) -> Views:
    """Read a TUM RGB-D directory into :class:`Views`.

    ``rgb.txt``, ``depth.txt`` and ``groundtruth.txt`` are associated by nearest timestamp
    (within ``max_dt`` s). Intrinsics: the argument, else ``intrinsics.json``; camera height:
    the argument, else ``intrinsics.json``, else the median camera ``z``. The planar pose is
    :func:`planar_from_camera` of each ground-truth pose; ``meta['max_tilt_deg']`` reports how
    far the cameras are from planar. ``box``: ``intrinsics.json``'s, else the bounds of the
    camera centres and the back-projected depth points (every 8th pixel) plus ``box_margin``.
    """
    from PIL import Image

    d = Path(directory)
    if not d.is_dir():
        raise ArtifactError(f"{d}: no such directory")
    info = {}
    if (d / "intrinsics.json").is_file():
        try:
            info = json.loads((d / "intrinsics.json").read_text())
        except json.JSONDecodeError as e:
            raise ArtifactError(f"{d / 'intrinsics.json'}: not valid JSON ({e})") from None
    if intrinsics is None:
        if not info:
            raise ArtifactError(f"{d}: no intrinsics given and no intrinsics.json")
        intrinsics = _intrinsics_from(info, str(d / "intrinsics.json"))
    scale = float(depth_scale or info.get("depth_scale", TUM_DEPTH_SCALE))
    rgbs, depths, gts = (_read_list(d / n) for n in ("rgb.txt", "depth.txt", "groundtruth.txt"))
    a_d, a_g = _associate(rgbs, depths, max_dt), _associate(rgbs, gts, max_dt)
    keep = [i for i in range(len(rgbs)) if i in a_d and i in a_g]
    if not keep:
        raise ArtifactError(f"{d}: no rgb image has a depth map and a pose within {max_dt} s")
    H, W = intrinsics.shape
    N = len(keep)
    rgb = np.empty((N, H, W, 3), np.uint8)
    depth = np.empty((N, H, W), np.float32)
    valid = np.empty((N, H, W), bool)
    Ts = np.empty((N, 4, 4))
    for n, i in enumerate(keep):
        try:
            im = np.asarray(Image.open(d / rgbs[i][1][0]).convert("RGB"))
            dep = np.asarray(Image.open(d / depths[a_d[i]][1][0]))
        except (OSError, IndexError) as e:
            raise ArtifactError(f"{d}: unreadable image for timestamp {rgbs[i][0]} ({e})") from None
        if im.shape[:2] != (H, W) or dep.shape != (H, W):
            raise ArtifactError(f"{d}: image at timestamp {rgbs[i][0]} is {im.shape[1]}x{im.shape[0]}, "
                                f"the intrinsics say {W}x{H}")
        rgb[n] = im
        valid[n] = dep > 0
        depth[n] = np.where(valid[n], dep.astype(np.float64) / scale, np.inf)
        vals = gts[a_g[i]][1]
        if len(vals) != 7:
            raise ArtifactError(f"{d}/groundtruth.txt: expected 7 numbers at {gts[a_g[i]][0]}")
        p = [float(v) for v in vals]
        Ts[n] = np.eye(4)
        Ts[n, :3, :3] = _quat_to_rot(p[3:])
        Ts[n, :3, 3] = p[:3]
    planar = [planar_from_camera(T) for T in Ts]
    poses = np.array([p for p, _, _ in planar])
    cam_h = float(camera_height if camera_height is not None
                  else info.get("camera_height", np.median([h for _, h, _ in planar])))
    if "box" in info and info["box"]:
        box = tuple(tuple(float(c) for c in corner) for corner in info["box"])
    else:
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
    return Views(poses, intrinsics, cam_h, rgb, depth, valid,
                 level or info.get("level") or d.name, info.get("seed"), box, meta)
