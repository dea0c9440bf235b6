"""The TUM RGB-D layout: export :class:`~navbench.worldmodel.views.Views` to it and import any
sequence in it (https://cvg.cit.tum.de/data/datasets/rgbd-dataset/file_formats).

``rgb/<t>.png`` (8-bit RGB), ``depth/<t>.png`` (16-bit, metres x 5000, 0 = no reading),
``rgb.txt`` / ``depth.txt`` (``timestamp filename``), ``groundtruth.txt``
(``timestamp tx ty tz qx qy qz qw``: the **camera-to-world** pose ``T_wc`` of the camera in the
navbench world frame, camera axes OpenCV — x right, y down, z forward; quaternion Hamilton,
scalar last) and ``intrinsics.json`` (a navbench convenience: width, height, fx, fy, cx, cy,
camera height, depth scale, level, seed). Every malformed line, file or image is an
:class:`~navbench.errors.ArtifactError` naming the file (and line).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from navbench.errors import ArtifactError, ConfigError
from navbench.geometry import Intrinsics, camera_pose

from navbench.track.lie import planar_from_camera
from navbench.worldmodel.views import (
    MAX_BOX_M,
    TUM_DEPTH_SCALE,
    Views,
    _intrinsics_from,
    check_intrinsics,
    check_views_memory,
    json_number,
)

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


def planar_height_tilt(T_wc: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Planar pose ``(x, y, theta)`` (:func:`navbench.track.lie.planar_from_camera`), camera height
    and tilt (deg) of a camera-to-world ``T_wc``: the tilt is the angle between the camera's
    ``y`` axis and world down (0 for a planar-mounted camera)."""
    R = T_wc[:3, :3]
    tilt = math.degrees(math.acos(float(np.clip(-R[2, 1], -1.0, 1.0))))
    return planar_from_camera(T_wc), float(T_wc[2, 3]), tilt


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
    if not path.exists():
        raise ArtifactError(f"{path.parent}: missing {path.name} (TUM RGB-D layout: rgb.txt, "
                            f"depth.txt, groundtruth.txt, rgb/, depth/)")
    from navbench.safeio import read_text

    text = read_text(path, ArtifactError, "TUM list file")
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


#: Farthest camera position (m) an imported sequence may have (a building, not a planet).
MAX_POSITION_M = 1e4
#: Largest camera height (m) and depth scale (PNG units per metre) read.
MAX_CAMERA_HEIGHT_M = 100.0
MAX_DEPTH_SCALE = 1e9


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
        if max(abs(v) for v in p[:3]) > MAX_POSITION_M:  # finite but absurd (issue 34)
            raise ArtifactError(f"{path}:{k}: camera position {' '.join(vals[:3])} is more than "
                                f"{MAX_POSITION_M:g} m from the origin")
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
    if not path.exists():
        raise ArtifactError(f"{where}: {name}: no such file")
    from navbench.safeio import check_regular_file

    check_regular_file(path, ArtifactError, "image file")  # a FIFO would block PIL for ever
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


def _positive_number(value, where: str, json_only: bool = False, hi: float = math.inf,
                     lo: float = 1e-3) -> float:
    """``value`` as a positive finite float; ``json_only`` (a value read from a JSON file): a
    number there, not a boolean or a numeric string."""
    if json_only and (isinstance(value, bool) or not isinstance(value, (int, float))):
        raise ArtifactError(f"{where}: {value!r} is not a number")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ArtifactError(f"{where}: {value!r} is not a number") from None
    if isinstance(value, bool) or not (math.isfinite(v) and v > 0):
        raise ArtifactError(f"{where}: must be a positive finite number, got {value!r}")
    if not lo <= v <= hi:  # finite but absurd (issue 34): 1e-320 m, 1e308 units per metre
        raise ArtifactError(f"{where}: must be in [{lo:g}, {hi:g}], got {value!r}")
    return v


#: How far (deg) a ground-truth camera may be tilted from planar before an import refuses it
#: (:func:`planar_height_tilt`): navbench's renderer and fit take planar poses ``(x, y, theta)``
#: at one camera height, and a tilt of 0.5 deg moves a point 5 m away by 4.4 cm, under the
#: paper grid's 5.7 cm cell. A navbench export is planar to ~1e-7 deg.
MAX_TILT_DEG = 0.5
#: How far (m) a ground-truth camera's ``z`` may be from the camera height (the given one, else
#: the median) before an import refuses it: a third of the paper grid's cell.
MAX_HEIGHT_DEV = 0.02


def check_planar(path: Path, rows: list, camera_height: float, max_tilt_deg: float = MAX_TILT_DEG,
                 max_height_dev: float = MAX_HEIGHT_DEV) -> None:
    """Refuse 6-DoF poses: :class:`ArtifactError` naming ``path`` and the first line (of
    ``rows``: ``(timestamp, T_wc, line)``) whose camera is tilted more than ``max_tilt_deg``
    from planar or whose height is more than ``max_height_dev`` m from ``camera_height``.
    navbench never flattens such a pose silently to ``(x, y, theta)``."""
    for _, T, k in sorted(rows, key=lambda r: r[2]):
        _, h, tilt = planar_height_tilt(T)
        if tilt > max_tilt_deg:
            raise ArtifactError(
                f"{path}:{k}: camera tilted {tilt:.3g} deg from planar (tolerance {max_tilt_deg:g} "
                f"deg, --max-tilt): navbench fits and renders planar poses (x, y, theta) at one "
                f"camera height, and does not flatten 6-DoF poses")
        if abs(h - camera_height) > max_height_dev:
            raise ArtifactError(
                f"{path}:{k}: camera z {h:.4g} m is {abs(h - camera_height):.3g} m from the camera "
                f"height {camera_height:.4g} m (tolerance {max_height_dev:g} m, --max-height-dev): "
                f"navbench fits and renders planar poses at one camera height, and does not "
                f"flatten 6-DoF poses")


def import_views(directory, intrinsics: Intrinsics | None = None, camera_height: float | None = None,
                 depth_scale: float | None = None, max_dt: float = 0.02, level: str | None = None,
                 box_margin: float = 0.1, intrinsics_source: str = "given",
                 max_tilt_deg: float = MAX_TILT_DEG, max_height_dev: float = MAX_HEIGHT_DEV) -> Views:
    """Read a TUM RGB-D directory into :class:`Views`.

    ``rgb.txt``, ``depth.txt`` and ``groundtruth.txt`` are associated by nearest timestamp
    (within ``max_dt`` s). Intrinsics: the argument (``intrinsics_source`` names where it came
    from in errors), else ``intrinsics.json``; camera height: the argument, else
    ``intrinsics.json``, else the median camera ``z``. The planar pose is
    :func:`planar_height_tilt` of each ground-truth pose; a pose tilted more than
    ``max_tilt_deg`` or off the camera height by more than ``max_height_dev`` m is refused
    (:func:`check_planar`: never flattened), ``meta['max_tilt_deg']`` reports how far the
    accepted cameras are from planar. ``box``: ``intrinsics.json``'s, else the bounds of the
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
    if info_path.exists():  # a directory or FIFO of that name is refused by load_json
        from navbench.safeio import load_json

        info = load_json(info_path, ArtifactError, "intrinsics file")
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
        scale = _positive_number(depth_scale, "depth_scale", hi=MAX_DEPTH_SCALE)
    else:
        scale = _positive_number(info.get("depth_scale", TUM_DEPTH_SCALE), f"{info_path}: depth_scale",
                                 json_only=True, hi=MAX_DEPTH_SCALE)
    if camera_height is not None:
        camera_height = _positive_number(camera_height, "camera_height", hi=MAX_CAMERA_HEIGHT_M)
    elif info.get("camera_height") is not None:
        camera_height = _positive_number(info["camera_height"], f"{info_path}: camera_height",
                                         json_only=True, hi=MAX_CAMERA_HEIGHT_M)
    box = None
    if info.get("box"):
        try:
            box = tuple(tuple(json_number(c) for c in corner) for corner in info["box"])
            lo, hi = np.asarray(box[0]), np.asarray(box[1])
            ok = (len(box) == 2 and lo.shape == hi.shape == (3,)
                  and np.all(np.abs(np.concatenate([lo, hi])) <= MAX_BOX_M))  # finite, not absurd
        except (TypeError, ValueError, IndexError):
            ok = False
        if not (ok and np.all(hi > lo)):
            raise ArtifactError(f"{info_path}: box must be two corners [[x, y, z], [x, y, z]] "
                                f"with lo < hi, each coordinate within {MAX_BOX_M:g} m, got {info['box']!r}")
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
        _no_association(rgbs, depths, gts, a_d, rgb_txt, depth_txt, gt_txt, max_dt)
    # the poses first: a 6-DoF sequence is refused before any image is read
    Ts = np.array([gts[a_g[i]][1] for i in keep])
    planar = [planar_height_tilt(T) for T in Ts]
    poses = np.array([p for p, _, _ in planar])
    if camera_height is None:
        camera_height = float(np.median([h for _, h, _ in planar]))
        if not camera_height > 0:
            raise ArtifactError(f"{gt_txt}: the median camera z is {camera_height:g} m, not above "
                                f"the floor; give the camera height (intrinsics.json "
                                f"camera_height or --camera-height)")
    check_planar(gt_txt, [gts[a_g[i]] for i in keep], camera_height, max_tilt_deg, max_height_dev)
    H, W = intrinsics.shape
    N = len(keep)
    check_views_memory(N, intrinsics, f"import-views {d}")
    rgb = np.empty((N, H, W, 3), np.uint8)
    depth = np.empty((N, H, W), np.float32)
    valid = np.empty((N, H, W), bool)
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
    if not valid.any():  # nothing to fit a map to or to score one on (a depth MAE of nothing)
        raise ArtifactError(f"{d / 'depth.txt'}: no depth pixel of the {N} associated depth "
                            f"images is valid (all 0 = no reading); a sequence without depth "
                            f"cannot be fitted or scored")
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


def _no_association(rgbs, depths, gts, a_d, rgb_txt, depth_txt, gt_txt, max_dt) -> None:
    """Raise the error of a sequence where no rgb image has both a depth map and a pose within
    ``max_dt``: it names the first rgb line, the list that has nothing near it and the nearest
    timestamp there."""
    t, _, k = rgbs[0]
    other, rows = (depth_txt, depths) if 0 not in a_d else (gt_txt, gts)
    near = min(rows, key=lambda r: abs(r[0] - t))
    raise ArtifactError(f"{rgb_txt}:{k}: no rgb image has a depth map and a pose within --max-dt "
                        f"{max_dt:g} s; the first, at {t:.6f} s, has none in {other.name} (nearest "
                        f"{near[0]:.6f} s at {other.name}:{near[2]})")


def _typestr(im) -> str:
    """numpy typestr of a PIL image's pixels (``|u1`` for 8-bit modes)."""
    from PIL import ImageMode

    try:
        return ImageMode.getmode(im.mode).typestr
    except Exception:
        return "|V0"
