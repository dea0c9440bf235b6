"""The tracking study (paper appendix E, made fair): record trajectories once, replay every estimator.

Recording (:func:`record_trajectories`): the simulator is driven with the tracking-study noise
(``NOISE_LEVELS["tracking"]``: sigma_alpha 3 deg, sigma_s 5 % L) by a random-waypoint controller
that steers with the TRUE pose (so the trajectories do not depend on any estimator): it picks a
free point (clearance ``waypoint_clearance``) that a disc of radius ``waypoint_clearance`` can
reach in a straight line, then applies :func:`navbench.nav.controller.control_towards` (turn in
place while the heading error exceeds 5 deg, else step forward). A trajectory stores the start
pose, the applied (clipped) controls, the noise drawn and the true poses.

Replay (:func:`run_tracking_study`): for every trajectory the observations are rendered once per
step by the exact ray-cast camera at the true pose (a deterministic function of the pose, so
every estimator sees bit-identical inputs) and fed in lock-step to every (estimator, seed)
pair, each starting from the known start pose (an estimator with a ``trajectory_limits`` entry
replays only the first that-many trajectories). Per trajectory and estimator the location RMSE
(m) and orientation RMSE (deg) over the ``T + 1`` poses and the per-step times are kept.

Issue 14 (:mod:`navbench.track.kidnap`): ``kidnap_every`` teleports the true pose every N
steps during the recording; ``odometry="body"`` replays the controls in each estimator's own
frame (:func:`~navbench.track.kidnap.body_control`); the results also hold each trajectory's
raw-odometry ATE and, for estimators with a health test, its per-step alarms, inlier fractions
and relocalisations (:func:`health_summary`). The location RMSE is the ATE.

Pure library: arrays and dicts in and out, no files, printing or database.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from navbench.errors import ConfigError
from navbench.geometry import AGENT_LENGTH, CAMERA_HEIGHT, wrap_angle
from navbench.track.registry import checked_pose

DEFAULT_ESTIMATORS = ("ours", "emission", "no-map", "dynamics", "gt")

#: Emission-tracker options used by default in the study so that the default run fits in a few
#: minutes on a laptop CPU (the paper's budget is ``steps=100, pixels=1000``; pass
#: ``estimator_options={"emission": {}}`` to use it).
STUDY_EMISSION_OPTIONS = {"steps": 20, "pixels": 500}
#: By default the (slow) emission tracker replays only the first 10 trajectories.
STUDY_TRAJECTORY_LIMITS = {"emission": 10}


@dataclass(frozen=True)
class TrackingStudyConfig:
    """Configuration of :func:`run_tracking_study` (lengths in metres)."""

    trajectories: int = 30  # number of recorded trajectories
    seeds: int = 1  # estimator seeds per trajectory (pixel tables); results pooled
    steps: int = 100  # controls per trajectory
    estimators: tuple[str, ...] = DEFAULT_ESTIMATORS
    camera: str = "half"  # navbench.geometry.CAMERAS name
    camera_height: float = CAMERA_HEIGHT
    noise: str = "tracking"  # NOISE_LEVELS name used to record the trajectories
    seed: int = 0  # seed of the trajectory recording (start poses, waypoints, noise)
    waypoint_clearance: float = 1.2 * AGENT_LENGTH  # m, clearance of waypoints and straight moves
    waypoint_range: float = 3.0  # m, largest distance to a new waypoint
    # per-estimator constructor options, e.g. {"ours": {"optimizer": "adam"}}
    estimator_options: dict = field(default_factory=lambda: {"emission": dict(STUDY_EMISSION_OPTIONS)})
    # per-estimator cap on the number of trajectories replayed (the first ones), e.g. {"emission": 10}
    trajectory_limits: dict = field(default_factory=lambda: dict(STUDY_TRAJECTORY_LIMITS))
    # issue 14 (navbench.track.kidnap): teleport the true pose every kidnap_every steps (0: never);
    # odometry "world" replays the recorded controls as they are, "body" in each estimator's own
    # frame (required with kidnapping). Left out of the stage's cache key at these defaults.
    kidnap_every: int = 0
    odometry: str = "world"
    # what the recording does after a collision (COLLISION_MODES): "freeze", appendix D's rule
    # (no further movement: the rest of the trajectory stands still while its controls still
    # command motion), or "stop" (the colliding step does not move the robot and its control
    # records no motion, as a bumper and stalled wheels would; the recording goes on to a new
    # waypoint). Left out of the key at "freeze".
    collisions: str = "freeze"
    # issue 37: the simulator whose frames the estimators replay (navbench.sim.backends): on
    # "vizdoom" the engine renders every recorded pose, and the pose it shows (to the centimetre
    # and 1/65536 turn) is the truth the errors are measured against. Left out of the key at "pymunk".
    sim: str = "pymunk"
    # issue 36: how the frames' textures are evaluated (navbench.sim.texels: "procedural", every
    # navbench-1 frame; "table" under navbench-2; the pymunk camera's, an engine has its own) and
    # the benchmark version the study runs under (navbench.benchmark; the CLI sets the frames'
    # texture and the trackers' options from it, navbench.pipeline.versioning.study_settings).
    # Left out of the key at "procedural" and navbench-1.
    texture: str = "procedural"
    benchmark_version: str = "navbench-1"

    def __post_init__(self):
        if self.trajectories < 1 or self.seeds < 1 or self.steps < 1:
            raise ConfigError("trajectories, seeds and steps must be >= 1")
        if not self.estimators:
            raise ConfigError("no estimator selected")
        if len(set(self.estimators)) != len(self.estimators):
            raise ConfigError(f"estimator listed twice: {list(self.estimators)}")
        if any(int(v) < 1 for v in self.trajectory_limits.values()):
            raise ConfigError("trajectory limits must be >= 1")
        from navbench.track.kidnap import ODOMETRY_MODES

        if int(self.kidnap_every) < 0:
            raise ConfigError(f"kidnap_every: expected a step count >= 1 (or 0 for none), "
                              f"got {self.kidnap_every}")
        if self.odometry not in ODOMETRY_MODES:
            raise ConfigError(f"--odometry: expected one of {', '.join(ODOMETRY_MODES)}, "
                              f"got {self.odometry!r}")
        if self.collisions not in COLLISION_MODES:
            raise ConfigError(f"--collisions: expected one of {', '.join(COLLISION_MODES)}, "
                              f"got {self.collisions!r}")
        from navbench.sim.backends import check_sim

        check_sim(self.sim)
        from navbench.benchmark import UnknownVersion, check_version
        from navbench.sim.texels import check_texture

        check_texture(self.texture, "tracking study texture")
        try:
            check_version(self.benchmark_version, "tracking study benchmark version")
        except UnknownVersion as e:
            raise ConfigError(str(e)) from None
        if self.kidnap_every and self.odometry != "body":
            raise ConfigError("--kidnap-every needs --odometry body (world-frame controls would "
                              "tell the estimators the new true heading)")
        if self.kidnap_every and self.steps < int(self.kidnap_every) + 5:
            raise ConfigError(f"--kidnap-every {self.kidnap_every} with --steps {self.steps}: no "
                              f"kidnap fits (the first is at step {self.kidnap_every} and needs 5 "
                              f"steps after it to recover); give --steps >= "
                              f"{int(self.kidnap_every) + 5} or a smaller --kidnap-every")


#: What a trajectory recording does after a collision (:class:`TrackingStudyConfig.collisions`).
COLLISION_MODES = ("freeze", "stop")


@dataclass
class Trajectory:
    """One recorded trajectory (world metres, radians)."""

    start: np.ndarray  # (3,) known start pose
    true_poses: np.ndarray  # (T + 1, 3) true poses, start first
    controls: np.ndarray  # (T, 3) applied controls (turn, direction, speed), clipped
    noise: np.ndarray  # (T, 2) noise drawn (eps_alpha [rad], eps_s [m])
    collided: bool
    seed: int  # simulator seed
    kidnapped: np.ndarray | None = None  # (T + 1,) bool: teleported to this pose (None: never)


def record_trajectories(level, count: int, steps: int, noise: str = "tracking", seed: int = 0,
                        clearance: float = 1.2 * AGENT_LENGTH,
                        waypoint_range: float = 3.0, kidnap_every: int = 0,
                        collisions: str = "freeze") -> list[Trajectory]:
    """Drive the simulator (no camera) ``count`` times for ``steps`` controls; see the module doc.

    Trajectory ``i`` uses simulator seed ``seed * 100003 + i``; start poses and waypoints come
    from ``np.random.default_rng([seed, i])``. Deterministic for a given ``seed``. With
    ``kidnap_every`` N > 0 the true pose is teleported after every N-th control to a free pose
    (clearance ``clearance``, uniform heading) drawn from its own stream
    ``np.random.default_rng([seed, i, KIDNAP_SALT])`` (:mod:`navbench.track.kidnap`).
    ``collisions="stop"``: a colliding step leaves the robot at its previous pose and records
    no motion for it (a bumper stops the robot, its wheels stall; the collision flag is cleared,
    the noise stream goes on, a new waypoint is drawn) instead of freezing it for the rest of
    the trajectory while its controls still command motion; ``collided`` still reports it.
    """
    from navbench.track.kidnap import KIDNAP_SALT, kidnap_indices

    from navbench.nav.controller import control_towards
    from navbench.sim.world import CollisionWorld, Simulator, sample_free_points

    wide = CollisionWorld(level, radius=clearance)
    out = []
    for i in range(count):
        rng = np.random.default_rng([int(seed), i])
        sim_seed = int(seed) * 100003 + i
        sim = Simulator(level, noise=noise, seed=sim_seed, intrinsics=None)
        xy = sample_free_points(level, rng, 1, clearance)[0]
        start = np.array([xy[0], xy[1], float(wrap_angle(rng.uniform(-math.pi, math.pi)))])
        sim.reset(start)
        poses, controls, eps = [start.copy()], [], []
        target = None
        kidnaps = set(kidnap_indices(steps, kidnap_every).tolist())
        krng = np.random.default_rng([int(seed), i, KIDNAP_SALT])
        collided = False
        for t in range(steps):
            if target is None or np.hypot(*(target - sim.pose[:2])) < 0.5 * AGENT_LENGTH:
                target = _pick_waypoint(level, wide, sim.pose[:2], rng, clearance, waypoint_range)
            res = sim.step(control_towards(sim.pose, target))
            u = sim.last_control
            controls.append((u.turn, u.direction, u.speed))
            eps.append(res.eps)
            poses.append(res.pose.copy())
            if res.collided:  # should not happen with the wide clearance; the record stays valid
                target = None
                if collisions == "stop":  # the bumper stops the robot where it was, its
                    collided = True        # wheels stall: the odometry reads no motion
                    sim.reset(poses[-2])
                    poses[-1] = sim.pose.copy()
                    controls[-1] = (0.0, controls[-1][1], 0.0)
            if t + 1 in kidnaps:
                collided |= bool(sim.collided)
                xy = sample_free_points(level, krng, 1, clearance)[0]
                sim.reset(np.array([xy[0], xy[1], float(wrap_angle(krng.uniform(-math.pi, math.pi)))]))
                poses[-1] = sim.pose.copy()
                target = None
        kidnapped = None
        if kidnaps:
            kidnapped = np.zeros(steps + 1, bool)
            kidnapped[sorted(kidnaps)] = True
        out.append(Trajectory(start, np.array(poses), np.array(controls, dtype=np.float64),
                              np.array(eps, dtype=np.float64), bool(sim.collided) or collided,
                              sim_seed, kidnapped))
    return out


def _pick_waypoint(level, wide, xy, rng, clearance, max_range, tries: int = 200) -> np.ndarray:
    """A free point within ``max_range`` of ``xy`` reachable in a straight line with ``clearance``."""
    from navbench.sim.world import sample_free_points

    cands = sample_free_points(level, rng, tries, clearance)
    for c in cands:
        d = np.hypot(*(c - xy))
        if 0.4 < d <= max_range:
            _, blocked = wide.sweep(xy, c)
            if not blocked:
                return c
    # nothing reachable: turn around in place towards a point behind
    return np.asarray(xy) + rng.normal(size=2) * 0.3


def run_tracking_study(level, vmap, config: TrackingStudyConfig = TrackingStudyConfig(),
                       trajectories: list[Trajectory] | None = None,
                       progress: Callable[[int, int], None] | None = None,
                       health_thresholds: dict[str, float] | None = None) -> dict[str, Any]:
    """Replay recorded trajectories through every estimator; see the module doc.

    ``vmap``: the map the map-based estimators use (``None`` is allowed when none of them is
    selected); an empty :class:`~navbench.worldmodel.fusion.FusedMap` makes them track and map
    together from the start pose (:mod:`navbench.track.slam`, issue 15). ``trajectories``: pre-recorded ones (default: :func:`record_trajectories` with
    the config). ``progress(done, total)`` is called after each trajectory.
    ``health_thresholds``: per estimator name, the map's calibrated alarm threshold for the
    option ``health_min_inliers="auto"`` (constructor argument ``health_threshold``).

    Returns a dict::

        {"config": {...}, "level": name,
         "trajectories": {"start": (N, 3), "true_poses": (N, T+1, 3), "controls": (N, T, 3),
                          "noise": (N, T, 2), "collided": (N,) bool, "seed": (N,) int},
         "estimators": {name: {"seed": (N*S,) int, "trajectory": (N*S,) int,
                               "est_poses": (N*S, T+1, 3), "loc_rmse_m": (N*S,),
                               "rot_rmse_deg": (N*S,), "render_ms": (N*S, T),
                               "estimate_ms": (N*S, T), "step_ms": (N*S, T)}}}
    """
    from navbench.geometry import camera_by_name
    from navbench.sim.backends import PoseRenderer

    camera = PoseRenderer(config.sim, level, camera_by_name(config.camera), config.camera_height,
                          texture=config.texture)
    try:
        return _replay(level, vmap, config, trajectories, progress, health_thresholds, camera)
    finally:
        camera.close()


def _replay(level, vmap, config, trajectories, progress, health_thresholds, camera):
    """:func:`run_tracking_study` with its frames from ``camera`` (a
    :class:`~navbench.sim.backends.PoseRenderer`)."""
    from navbench.sim.dynamics import Control
    from navbench.nav.metrics import location_rmse
    from navbench.track.kidnap import body_control, dead_reckoning
    from navbench.track.registry import make_estimator, uses_map

    intr = camera.intrinsics  # vizdoom: the engine's projection, which the estimators must use
    if trajectories is None:
        trajectories = record_trajectories(level, config.trajectories, config.steps, config.noise,
                                           config.seed, config.waypoint_clearance,
                                           config.waypoint_range, config.kidnap_every,
                                           config.collisions)
    engine = config.sim != "pymunk"
    if engine:  # the engine's pose is the truth: each trajectory's poses are replaced as shown
        import dataclasses

        trajectories = [dataclasses.replace(t, start=t.start.copy(), true_poses=t.true_poses.copy())
                        for t in trajectories]
    opts = config.estimator_options or {}
    online = _is_online(vmap)  # issue 15: each map-based run tracks and maps on its own copy
    runs = []  # (name, seed, estimator)
    for name in config.estimators:
        for s in range(config.seeds):
            extra = {"health_threshold": health_thresholds[name]} \
                if health_thresholds and name in health_thresholds else {}
            if online and uses_map(name):
                from navbench.track.slam import online_estimator

                est = online_estimator(name, vmap, intr, config.camera_height, s,
                                       **extra, **dict(opts.get(name, {})))
            else:
                est = make_estimator(name, vmap=vmap, intrinsics=intr, camera_height=config.camera_height,
                                     renderer=None, seed=s, **extra, **dict(opts.get(name, {})))
            runs.append((name, s, est))
    if not trajectories or len({len(t.controls) for t in trajectories}) != 1:
        raise ConfigError("the trajectories must be non-empty and of equal length")
    T = len(trajectories[0].controls)
    N = len(trajectories)
    per = {(name, s): {"est": np.full((N, T + 1, 3), np.nan), "render": np.full((N, T), np.nan),
                       "estimate": np.full((N, T), np.nan), "alarm": np.zeros((N, T), bool),
                       "inliers": np.full((N, T), np.nan), "relocalized": np.zeros((N, T), bool)}
           for name, s, _ in runs}
    health = {name: False for name in config.estimators}  # reports a health test (last_health)
    body = config.odometry == "body"
    limits = {name: min(N, int(config.trajectory_limits.get(name, N)))
              for name in config.estimators}
    for n, traj in enumerate(trajectories):
        active = [(name, s, est) for name, s, est in runs if n < limits[name]]
        # no camera frame where no active estimator reads one (dynamics, gt; or an estimator's
        # trajectory limit reached): a frame is a function of the pose, skipping it changes nothing.
        # On the engine the frame also gives the pose it shows (the true pose from then on): always.
        see = engine or any(getattr(est, "uses_frames", True) for _, _, est in active)
        frame0 = camera.render(traj.start) if see else None
        if engine:
            traj.start[:] = camera.shown
            traj.true_poses[0] = camera.shown
        for name, s, est in active:
            est.reset(traj.start.copy(), frame0)
            per[(name, s)]["est"][n, 0] = traj.start
        for t in range(len(traj.controls)):
            frame = camera.render(traj.true_poses[t + 1]) if see else None
            if engine:
                traj.true_poses[t + 1] = camera.shown
            u = Control(*(float(v) for v in traj.controls[t]))
            for name, s, est in active:
                rec = per[(name, s)]
                if body:
                    u = body_control(traj.controls[t], traj.true_poses[t, 2], rec["est"][n, t, 2])
                e = checked_pose(est, est.update(u, frame, traj.true_poses[t + 1].copy()), t + 1)
                rec["est"][n, t + 1] = e
                rec["render"][n, t] = est.last_timing.get("render", 0.0)
                rec["estimate"][n, t] = est.last_timing.get("estimate", 0.0)
                h = getattr(est, "last_health", None)
                if h is not None:
                    health[name] = True
                    rec["alarm"][n, t] = bool(h.get("alarm", False))
                    rec["inliers"][n, t] = float(h.get("inliers", np.nan))
                    rec["relocalized"][n, t] = bool(h.get("relocalized", False))
        if progress is not None:
            progress(n + 1, N)

    out_est: dict[str, dict[str, np.ndarray]] = {}
    for name in config.estimators:
        Ne = limits[name]
        rows = [per[(name, s)] for s in range(config.seeds)]
        est_poses = np.concatenate([r["est"][:Ne] for r in rows])
        render = np.concatenate([r["render"][:Ne] for r in rows])
        estimate = np.concatenate([r["estimate"][:Ne] for r in rows])
        traj_idx = np.tile(np.arange(Ne), config.seeds)
        seeds = np.repeat(np.arange(config.seeds), Ne)
        loc, rot = [], []
        for k, i in enumerate(traj_idx):
            tp = trajectories[i].true_poses
            ep = est_poses[k, : len(tp)]
            loc.append(float(np.sqrt(np.mean(np.sum((ep[:, :2] - tp[:, :2]) ** 2, axis=1)))))
            rot.append(float(np.degrees(np.sqrt(np.mean(wrap_angle(ep[:, 2] - tp[:, 2]) ** 2)))))
        out_est[name] = {"seed": seeds, "trajectory": traj_idx, "est_poses": est_poses,
                         "loc_rmse_m": np.array(loc), "rot_rmse_deg": np.array(rot),
                         "render_ms": render, "estimate_ms": estimate, "step_ms": render + estimate}
        if health[name]:  # the health test's record (issue 14): per step, as the poses
            for k in ("alarm", "inliers", "relocalized"):
                out_est[name][k] = np.concatenate([r[k][:Ne] for r in rows])
    extra = {}
    if config.kidnap_every:
        extra["kidnapped"] = np.stack([np.zeros(len(t.true_poses), bool) if t.kidnapped is None
                                       else t.kidnapped for t in trajectories])
    return {
        "config": _config_dict(config),
        "level": level.name,
        "trajectories": {
            "start": np.stack([t.start for t in trajectories]),
            "true_poses": np.stack([t.true_poses for t in trajectories]),
            "controls": np.stack([t.controls for t in trajectories]),
            "noise": np.stack([t.noise for t in trajectories]),
            "collided": np.array([t.collided for t in trajectories]),
            "seed": np.array([t.seed for t in trajectories]),
            "raw_odom_ate_m": np.array([location_rmse(t.true_poses, dead_reckoning(
                t.start, t.controls, t.true_poses)) for t in trajectories]),
            **extra,
        },
        "estimators": out_est,
    }


def _is_online(vmap) -> bool:
    """``vmap`` is an online map (:class:`~navbench.worldmodel.fusion.FusedMap`): the map-based
    estimators track and map together (:mod:`navbench.track.slam`), each from empty."""
    from navbench.worldmodel.fusion import FusedMap

    return isinstance(vmap, FusedMap)


def _config_dict(config: TrackingStudyConfig) -> dict:
    from navbench.config import to_jsonable

    return to_jsonable(config)


def summarise(results: dict[str, Any], threshold_m: float = 0.1) -> dict[str, dict[str, float]]:
    """Per-estimator summary of :func:`run_tracking_study` results (plain floats).

    Keys: ``loc_rmse_m_median``, ``loc_rmse_m_p99``, ``loc_rmse_m_max``, ``rot_rmse_deg_median``,
    ``rot_rmse_deg_p99``, ``frac_loc_rmse_below_0_1m`` (fraction of trajectory runs with location
    RMSE below ``threshold_m``), ``step_ms_median``, ``render_ms_median``, ``estimate_ms_median``,
    ``step_ms_mean``, ``runs`` (trajectories x seeds).
    """
    out = {}
    for name, r in results["estimators"].items():
        loc, rot = r["loc_rmse_m"], r["rot_rmse_deg"]
        out[name] = {
            "loc_rmse_m_median": float(np.median(loc)),
            "loc_rmse_m_p99": float(np.percentile(loc, 99)),
            "loc_rmse_m_max": float(np.max(loc)),
            "rot_rmse_deg_median": float(np.median(rot)),
            "rot_rmse_deg_p99": float(np.percentile(rot, 99)),
            "frac_loc_rmse_below_0_1m": float(np.mean(loc < threshold_m)),
            "step_ms_median": float(np.nanmedian(r["step_ms"])),
            "step_ms_mean": float(np.nanmean(r["step_ms"])),
            "render_ms_median": float(np.nanmedian(r["render_ms"])),
            "estimate_ms_median": float(np.nanmedian(r["estimate_ms"])),
            "runs": int(len(loc)),
        }
        out[name].update(health_summary(results, name))
    return out


def _recoveries(results: dict[str, Any], name: str) -> list[dict[str, np.ndarray]]:
    """:func:`navbench.track.kidnap.recovery` of every run of estimator ``name``."""
    from navbench.track.kidnap import recovery

    r = results["estimators"][name]
    tr = results["trajectories"]
    kid = tr.get("kidnapped")
    out = []
    for k, i in enumerate(r["trajectory"]):
        true = tr["true_poses"][i]
        kidnapped = kid[i] if kid is not None else np.zeros(len(true), bool)
        alarms = r["alarm"][k] if "alarm" in r else None
        out.append(recovery(true, r["est_poses"][k, : len(true)], kidnapped, alarms))
    return out


def health_summary(results: dict[str, Any], name: str, within: int = 5) -> dict[str, float]:
    """Kidnap and health figures of estimator ``name`` (issue 14; :mod:`navbench.track.kidnap`).

    With kidnapping: ``kidnaps``, ``recovered_frac`` (within ``within`` steps, location error
    < 0.25 m and heading error < 10 deg), ``recover_steps_median`` (over recovered kidnaps)
    and, for an estimator with a health test, ``detected_frac``. For an estimator with a health
    test: ``alarms_per_step`` (all alarms / all steps), ``false_alarms_per_step`` (alarms raised
    at a pose within the recovery tolerance / all steps), ``false_alarm_trajectories_frac`` (runs
    with at least one false alarm) and ``relocalizations``. Empty when neither applies.
    """
    from navbench.track.kidnap import median_or_nan, recovered_within

    r = results["estimators"][name]
    out: dict[str, float] = {}
    if results["trajectories"].get("kidnapped") is not None:
        recs = _recoveries(results, name)
        steps = np.concatenate([x["steps"] for x in recs])
        ok = recovered_within(steps, within)
        out.update(kidnaps=int(len(steps)), recovered_frac=float(np.mean(ok)) if len(steps) else math.nan,
                   recover_steps_median=median_or_nan(steps[ok]))
        if "alarm" in r:
            det = np.concatenate([x["detected"] for x in recs])
            out["detected_frac"] = float(np.mean(det)) if len(det) else math.nan
    if "alarm" in r:
        false = r["alarm"] & _on_track(results, name)
        out.update(alarms_per_step=float(np.mean(r["alarm"])),
                   false_alarms_per_step=float(np.mean(false)),
                   false_alarm_trajectories_frac=float(np.mean(np.any(false, axis=1))),
                   relocalizations=int(np.sum(r["relocalized"])))
    return out


def _on_track(results: dict[str, Any], name: str) -> np.ndarray:
    """``(runs, T)`` bool: the pose update ``t`` produced is within the recovery tolerance
    (location < 0.25 m, heading < 10 deg); an alarm there is a false alarm."""
    from navbench.track.kidnap import pose_errors

    r = results["estimators"][name]
    tp = results["trajectories"]["true_poses"]
    out = []
    for k, i in enumerate(r["trajectory"]):
        loc, rot = pose_errors(tp[i][1:], r["est_poses"][k, 1: len(tp[i])])
        out.append((loc < 0.25) & (rot < 10.0))
    return np.array(out)


def tracking_rows(results: dict[str, Any], study_key: str, map_key: str | None = None) -> list[dict]:
    """One row per (estimator, trajectory, seed) of :func:`run_tracking_study` results, in the
    layout of :meth:`navbench.results.db.ResultsDB.add_tracking_rows` (times are per-step
    medians in ms; RMSE in m and deg; ``loc_rmse_m`` is the ATE, :mod:`navbench.track.kidnap`).
    Issue 14's columns where they apply: ``raw_odom_ate_m`` (the trajectory's raw odometry),
    ``kidnaps``, ``kidnaps_recovered`` (within 5 steps), ``kidnaps_detected``, ``alarms``,
    ``false_alarms`` (alarms at a pose within the recovery tolerance)."""
    from navbench.track.kidnap import recovered_within

    cfg = results.get("config", {})
    options = cfg.get("estimator_options", {}) or {}
    noise = cfg.get("noise")
    rows = []
    raw = results["trajectories"].get("raw_odom_ate_m")
    for name, r in results["estimators"].items():
        recs = _recoveries(results, name)
        on_track = _on_track(results, name) if "alarm" in r else None
        kidnapped = results["trajectories"].get("kidnapped") is not None
        for i in range(len(r["loc_rmse_m"])):
            extra = {}
            if raw is not None:
                extra["raw_odom_ate_m"] = float(raw[int(r["trajectory"][i])])
            if kidnapped:
                extra["kidnaps"] = int(len(recs[i]["steps"]))
                extra["kidnaps_recovered"] = int(np.sum(recovered_within(recs[i]["steps"])))
                if "alarm" in r:
                    extra["kidnaps_detected"] = int(np.sum(recs[i]["detected"]))
            if "alarm" in r:
                extra["alarms"] = int(np.sum(r["alarm"][i]))
                extra["false_alarms"] = int(np.sum(r["alarm"][i] & on_track[i]))
            rows.append({
                "study_key": study_key, "level": results["level"], "map_key": map_key,
                "estimator": name, "estimator_options": dict(options.get(name, {})),
                "noise": noise if isinstance(noise, str) else str(noise),
                "trajectory_id": int(r["trajectory"][i]), "seed": int(r["seed"][i]),
                "steps": int(r["step_ms"].shape[1]),
                "loc_rmse_m": float(r["loc_rmse_m"][i]), "rot_rmse_deg": float(r["rot_rmse_deg"][i]),
                "step_ms_median": float(np.nanmedian(r["step_ms"][i])),
                "render_ms": float(np.nanmedian(r["render_ms"][i])),
                "estimate_ms": float(np.nanmedian(r["estimate_ms"][i])),
                **extra,
            })
    return rows
