"""track-sequence: track a TUM RGB-D sequence against a map with odometry (issue 13).

The Python front door is :func:`navbench.pipeline.tracking.track_sequence` (``navbench
track-sequence`` adapts it):
read the sequence (:func:`navbench.worldmodel.tumtraj.read_sequence`), take the odometry
(:func:`sequence_odometry`), build the estimator on the map (:func:`resolve_map`), run it from
the known first pose (:func:`navbench.track.sequence.track_frames`) and score it: ATE RMSE
(translation, no alignment: :func:`navbench.nav.metrics.location_rmse`), RPE per frame
(:func:`navbench.nav.metrics.relative_pose_error`) and the median ms per frame.

Odometry (``TrackSequenceConfig.odometry``):

* ``gt+NOISE``: the ground truth's relative pose increments with the noise of level ``NOISE``
  of :data:`navbench.sim.dynamics.NOISE_LEVELS` per frame (``none``, ``low``, ``mid``,
  ``high``, ``tracking``; see :func:`navbench.track.odometry.noisy_increments`), drawn from
  ``numpy.random.default_rng([seed, ODOMETRY_STREAM])``: as RNR-Map's camera tracking (seed
  003, C.1) gives its trackers noisy odometry readings;
* a path: a TUM pose file of odometry poses (the groundtruth convention), one pose per frame
  matched by timestamp; only consecutive differences are used.

Not a cached stage: the timing is the point of a run, and the tracking is cheap next to its
inputs. Its database row is keyed by :func:`sequence_key`, so repeating a tracking stores
nothing new.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navbench.errors import ConfigError
from navbench.worldmodel.tum import MAX_TILT_DEG

#: Estimators ``track-sequence`` accepts (``gt`` needs the truth at run time: nothing to test).
SEQUENCE_ESTIMATORS = ("ours", "no-map", "dynamics", "emission")
#: Second entry of the odometry noise generator's seed (the first is the config's seed).
ODOMETRY_STREAM = 0x0D0


@dataclass(frozen=True)
class TrackSequenceConfig:
    """How a sequence is tracked (angles in degrees, times in seconds)."""

    estimator: str = "ours"  # one of SEQUENCE_ESTIMATORS, or a plugin's name
    odometry: str = "gt+mid"  # gt+NOISE (simulated from the ground truth) or a TUM odometry file
    seed: int = 0  # odometry noise and the estimator's pixel sampling
    options: dict = field(default_factory=dict)  # the estimator's keyword options
    max_tilt_deg: float = MAX_TILT_DEG  # largest camera tilt from planar accepted (ground truth, odometry)
    max_dt: float = 0.02  # association of rgb, depth, ground truth and odometry timestamps

    def __post_init__(self):
        if not (self.max_tilt_deg >= 0 and self.max_dt >= 0):
            raise ConfigError("max_tilt_deg and max_dt must be >= 0")
        parse_odometry(self.odometry)


def parse_odometry(spec: str) -> tuple[str, str]:
    """``("gt", NOISE)`` for ``gt+NOISE``, else ``("file", spec)``; an unknown noise is one
    :class:`ConfigError` listing the levels."""
    from navbench.sim.dynamics import NOISE_LEVELS

    if not isinstance(spec, str) or not spec:
        raise ConfigError("--odometry: expected gt+NOISE or a TUM odometry file")
    if spec.startswith("gt+"):
        noise = spec[3:]
        if noise not in NOISE_LEVELS:
            raise ConfigError(f"--odometry {spec}: unknown noise level {noise!r}; choose one of "
                              f"{', '.join('gt+' + n for n in NOISE_LEVELS)} or a TUM odometry file")
        return "gt", noise
    return "file", spec


def sequence_odometry(seq, cfg: TrackSequenceConfig) -> tuple[np.ndarray, str]:
    """The odometry increments ``(N-1, 3)`` between the frames of ``seq`` and a hash of their
    source (the noise spec and seed, or the file's bytes)."""
    from navbench.sim.dynamics import NOISE_LEVELS
    from navbench.track.odometry import noisy_increments, relative_increments
    from navbench.worldmodel.tumtraj import read_odometry

    kind, value = parse_odometry(cfg.odometry)
    if kind == "gt":
        rng = np.random.default_rng([int(cfg.seed), ODOMETRY_STREAM])
        inc = noisy_increments(relative_increments(seq.views.poses), NOISE_LEVELS[value], rng)
        return inc, hashlib.sha256(f"{cfg.odometry}:{int(cfg.seed)}".encode()).hexdigest()
    path = Path(value)
    poses = read_odometry(path, seq.times, cfg.max_dt, cfg.max_tilt_deg)
    return relative_increments(poses), hashlib.sha256(path.read_bytes()).hexdigest()


#: How far beyond one step of the simulator's dynamics (MAX_STEP, MAX_TURN) the median motion
#: between frames may go before track-sequence warns that the frames are not a sequence.
MOTION_WARN_FACTOR = 4.0


def motion_warning(poses) -> str | None:
    """One line when the median frame-to-frame motion of the planar ``poses (N, 3)`` is far
    beyond what the odometry model expects (one step of :mod:`navbench.sim.dynamics` per frame:
    ``MAX_STEP`` m, ``MAX_TURN`` rad; :data:`MOTION_WARN_FACTOR` times either), else ``None``:
    views sampled independently (collect-views) are no sequence, and tracking them is meaningless."""
    import math

    from navbench.geometry import wrap_angle
    from navbench.sim.dynamics import MAX_STEP, MAX_TURN

    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    if len(p) < 2:
        return None
    d = np.diff(p, axis=0)
    move = float(np.median(np.hypot(d[:, 0], d[:, 1])))
    turn = float(np.median(np.abs(wrap_angle(d[:, 2]))))
    if move <= MOTION_WARN_FACTOR * MAX_STEP and turn <= MOTION_WARN_FACTOR * MAX_TURN:
        return None
    return (f"warning: the median motion between frames is {move:.2f} m and {math.degrees(turn):.1f} deg, "
            f"far beyond one step of the odometry model (<= {MAX_STEP:.2f} m, {math.degrees(MAX_TURN):.1f} "
            "deg): the frames are not a continuous sequence (collect-views samples poses independently; "
            "navbench render-sequence renders a walk), so the ATE says little")


def check_map_covers(model, poses, what: str) -> None:
    """Every camera position of ``poses (N, 3)`` lies on the map's grid (else the map is of
    another place, or the sequence in another frame): one error naming ``what``."""
    _, xs, ys = model.occupancy_slice("band")
    hx = (float(xs[1]) - float(xs[0])) / 2 if len(xs) > 1 else 0.0
    hy = (float(ys[1]) - float(ys[0])) / 2 if len(ys) > 1 else 0.0
    lo = np.array([float(xs[0]) - hx, float(ys[0]) - hy])
    hi = np.array([float(xs[-1]) + hx, float(ys[-1]) + hy])
    out = np.flatnonzero(np.any((poses[:, :2] < lo) | (poses[:, :2] > hi), axis=1))
    if len(out):
        i = int(out[0])
        raise ConfigError(f"{what}: the map's grid [{lo[0]:g}, {hi[0]:g}] x [{lo[1]:g}, {hi[1]:g}] m "
                          f"does not hold frame {i}'s camera at ({poses[i, 0]:.3f}, {poses[i, 1]:.3f}) "
                          f"m ({len(out)} of {len(poses)} frames outside): a map of another place?")


def sequence_hash(seq) -> str:
    """sha256 of the frames, poses, intrinsics and timestamps the tracking reads."""
    h = hashlib.sha256()
    v = seq.views
    for a in (v.poses, v.rgb, v.depth, v.valid, seq.times):
        h.update(np.ascontiguousarray(a).tobytes())
    i = v.intrinsics
    h.update(repr((i.width, i.height, i.fx, i.fy, i.cx, i.cy, float(v.camera_height))).encode())
    return h.hexdigest()


def sequence_key(seq_hash: str, map_key: str | None, odometry_hash: str, cfg: TrackSequenceConfig) -> str:
    """The database key of one tracking: the sequence, map, odometry, estimator, options, seed."""
    from navbench.config import config_hash
    from navbench.track.relocalize import relocalizer_settings
    from navbench.track.trackconfig import keyed_options

    d = {"sequence": seq_hash, "map": map_key, "odometry": odometry_hash, "estimator": cfg.estimator,
         "options": keyed_options(cfg.options), "seed": int(cfg.seed), "max_dt": cfg.max_dt}
    reloc = relocalizer_settings(dict(cfg.options))
    if reloc:  # recovery: the relocaliser's settings (since 2026-11-26)
        d["relocalizer"] = reloc
    return config_hash(d)


@dataclass
class SequenceResult:
    """What :func:`track_sequence` returns: the estimate (``est_poses (N, 3)``), the truth
    (``true_poses``), the odometry's dead reckoning (``odometry_poses``), scores and the row."""

    sequence: Any  # navbench.worldmodel.tumtraj.Sequence
    est_poses: np.ndarray
    true_poses: np.ndarray
    odometry_poses: np.ndarray
    ate_m: float
    rot_rmse_deg: float
    rpe_m: float
    rpe_deg: float
    odometry_ate_m: float
    ms_per_frame: float
    row: dict
    out: Path | None = None
    stored: int | None = None

    def summary(self) -> dict:
        """The scores as plain values (the command's ``--json``)."""
        keys = ("sequence", "sequence_key", "map_key", "estimator", "odometry", "seed", "frames",
                "ate_m", "rot_rmse_deg", "rpe_m", "rpe_deg", "odometry_ate_m", "ms_per_frame",
                "render_ms", "estimate_ms")
        return {k: self.row.get(k) for k in keys}


def run_tracking(seq, model, map_key: str | None, cfg: TrackSequenceConfig,
                 sequence_label: str | None = None, health_threshold: float | None = None) -> SequenceResult:
    """Track the read sequence ``seq`` on ``model`` (``None`` for estimators without a map);
    ``health_threshold``: the map's calibrated one for ``health_min_inliers="auto"``."""
    from navbench.nav.metrics import location_rmse, orientation_rmse, relative_pose_error
    from navbench.track.odometry import integrate
    from navbench.track.registry import make_estimator, uses_map
    from navbench.track.sequence import track_frames

    if uses_map(cfg.estimator) and model is None:
        raise ConfigError(f"--map: the estimator {cfg.estimator!r} tracks against a map; give "
                          f"--map PATH|KEY (a map.npz or a fit-map cache key)")
    v = seq.views
    if model is not None and uses_map(cfg.estimator):
        check_map_covers(model, v.poses, f"--map ({map_key[:12] if map_key else 'map'})")
    increments, odo_hash = sequence_odometry(seq, cfg)
    extra = {} if health_threshold is None else {"health_threshold": health_threshold}
    est = make_estimator(cfg.estimator, vmap=model, intrinsics=v.intrinsics,
                         camera_height=v.camera_height, seed=int(cfg.seed), **extra, **dict(cfg.options))
    track = track_frames(est, v, v.poses[0], increments)
    truth = np.asarray(v.poses, dtype=np.float64)
    odo = integrate(truth[0], increments)
    rpe_m, rpe_deg = relative_pose_error(truth, track.est_poses)
    seq_hash = sequence_hash(seq)
    use_map = map_key if uses_map(cfg.estimator) else None
    row = {
        "sequence_key": sequence_key(seq_hash, use_map, odo_hash, cfg),
        "sequence": sequence_label or str(seq.directory), "sequence_hash": seq_hash,
        "map_key": use_map, "estimator": cfg.estimator, "estimator_options": dict(cfg.options),
        "odometry": cfg.odometry, "odometry_hash": odo_hash, "seed": int(cfg.seed),
        "frames": len(v), "ate_m": location_rmse(truth, track.est_poses),
        "rot_rmse_deg": orientation_rmse(truth, track.est_poses), "rpe_m": rpe_m, "rpe_deg": rpe_deg,
        "odometry_ate_m": location_rmse(truth, odo),
        "ms_per_frame": float(np.median(track.step_ms)),
        "render_ms": float(np.median(track.render_ms)),
        "estimate_ms": float(np.median(track.estimate_ms)),
    }
    return SequenceResult(seq, track.est_poses, truth, odo, row["ate_m"], row["rot_rmse_deg"],
                          rpe_m, rpe_deg, row["odometry_ate_m"], row["ms_per_frame"], row)


def default_output(seq, cfg: TrackSequenceConfig, results_dir: str | Path = "results") -> Path:
    """``results/sequences/<sequence dir name>/<estimator>_<odometry>_seed<S>.txt`` (a file
    odometry is named by its stem)."""
    kind, value = parse_odometry(cfg.odometry)
    odo = f"gt-{value}" if kind == "gt" else f"odom-{Path(value).stem}"
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", f"{cfg.estimator}_{odo}_seed{int(cfg.seed)}")
    return Path(results_dir) / "sequences" / re.sub(r"[^A-Za-z0-9_.-]", "_", seq.directory.name) / f"{name}.txt"
