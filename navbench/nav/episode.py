"""One navigation episode: plan on the world model, follow the plan on the estimated pose.

Loop (paper fig. 2, appendix B): reset the simulator at the task's start and the estimator at
the known start pose; plan once from the start with A* on the occupancy slice; then per step

1. the controller picks a control from the ESTIMATED pose and the remaining waypoints;
2. the simulator executes it (noisy dynamics, collision check);
3. the estimator updates the pose estimate from the control and the new observation.

End reasons (``EpisodeRecord.end_reason``):

* ``"reached"``: the controller has reached every waypoint (the last one is the target, or the
  A* lattice point within the SPEC's goal test) and the estimate is within
  ``goal_tolerance`` (1.3 L: the SPEC's A* goal test 0.8 L plus the controller's waypoint
  tolerance 0.5 L) of the target. Usually the last waypoint is the target itself, so the agent
  believes it is within 0.5 L of it: the agent *believes* it
  arrived. Success is scored later from the true pose (:mod:`navbench.nav.metrics`);
* ``"stuck"``: the simulator reported a collision; movement is prohibited for the rest of the
  episode (appendix D), so the episode ends at once;
* ``"step-limit"``: ``max_steps`` controls were executed;
* ``"no-plan"``: the planner found no path from the start (or from a replanning point).

When the controller runs out of waypoints without the estimate being within the goal
tolerance, the agent replans from its estimated position (counted in ``replans``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from navbench.errors import ConfigError
from navbench.geometry import AGENT_LENGTH
from navbench.nav.controller import ControllerConfig, controller_step
from navbench.nav.timing import TIMING_KEYS
from navbench.plan.astar import PlannerConfig, PlannerMap, cached_planner_map, plan_on_map
from navbench.track.registry import checked_pose

END_REASONS = ("reached", "step-limit", "stuck", "no-plan")


@dataclass(frozen=True)
class EpisodeConfig:
    """Episode settings; lengths in metres."""

    max_steps: int = 500  # controls per episode
    # believed arrival: the estimate within this distance (m) of the target once every waypoint
    # is reached; the SPEC's A* goal test (0.8 L) plus the controller's waypoint tolerance
    # (0.5 L), since the last waypoint may be the A* lattice point within 0.8 L of the target
    goal_tolerance: float = 1.3 * AGENT_LENGTH
    max_replans: int = 10  # replans allowed before the episode ends as "no-plan"
    # the simulator also clips the movement direction to within 5 deg of the TRUE heading (a
    # body-fixed drive, navbench's behaviour before 2026-11-22); False: the paper's equation, the
    # agent moves along the direction it commands, which it keeps within 5 deg of its ESTIMATED
    # heading (see navbench.sim.world.Simulator)
    body_fixed_drive: bool = False
    # ViZDoom's pose quantisation ("off" | "round" | "truncate") and appendix D's collision check
    # ("swept" | "endpoint"): the simulator conditions of navbench.sim.conditions (the condition
    # direction_limit is body_fixed_drive). At "off" / "swept" they are left out of the episode
    # key (navbench.sim.conditions.KEY_NEUTRAL_FIELDS), so earlier keys stay valid
    pose_quantisation: str = "off"
    collision_check: str = "swept"
    # how the simulator's camera evaluates textures (navbench.sim.texels.TEXTURE_MODES):
    # "procedural" (libm sines per pixel, navbench-1's images) | "table" (texel tables, bilinear)
    # | "polynomial"; left out of the episode key at "procedural" (KEY_NEUTRAL_FIELDS)
    texture: str = "procedural"
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    controller: ControllerConfig = field(default_factory=ControllerConfig)


@dataclass
class EpisodeRecord:
    """Everything needed to score an episode offline (shapes: ``T`` executed controls)."""

    level: str
    task_id: int
    estimator: str
    noise: str
    seed: int
    start: np.ndarray  # (3,) start pose
    target: np.ndarray  # (2,) target position (m)
    optimal_length: float  # shortest feasible path (m)
    true_poses: np.ndarray  # (T + 1, 3) true poses, start first
    est_poses: np.ndarray  # (T + 1, 3) estimated poses, start first
    controls: np.ndarray  # (T, 3) executed (clipped) controls (turn rad, direction rad, speed m)
    collided: bool
    collision_step: int  # index t of the control whose move collided (-1 if none)
    plan: np.ndarray  # (K, 2) initial waypoints (m); (0, 2) without a plan
    replans: int
    end_reason: str  # one of END_REASONS
    # key -> (T,) float64 milliseconds per step, keys TIMING_KEYS: "sim" the simulator step
    # (dynamics, collision and its camera), "render" and "estimate" the estimator's map render
    # and the rest of its update (from estimator.last_timing; "estimate" falls back to the
    # measured update time), "plan" planning done before that step's control (the initial plan
    # at step 0, replans where they happen, else 0), "control" the controller decision
    timings_ms: dict
    plan_status: str = ""  # status of the initial plan: shortcut | astar | no-plan
    plan_ms: float = 0.0  # time of the initial plan (ms; also added to timings_ms["plan"][0])

    @property
    def steps(self) -> int:
        return len(self.controls)


def run_episode(level, occ2d, xs, ys, task, estimator, simulator, config: EpisodeConfig = EpisodeConfig(),
                planner_map: PlannerMap | None = None) -> EpisodeRecord:
    """Run one episode of ``task`` in ``simulator`` (already constructed for ``level``).

    ``occ2d (nx, ny)`` bool / ``xs``, ``ys`` the world model's occupancy slice the agent plans
    on (see :mod:`navbench.plan.astar`); ``estimator`` implements
    :class:`navbench.track.base.Estimator`. ``planner_map`` (optional, from
    :func:`navbench.plan.astar.make_planner_map`) skips the per-map cache; its own config is used.
    """
    from navbench.sim.conditions import KEY_NEUTRAL_FIELDS
    from navbench.sim.dynamics import clip_control
    from navbench.track.base import observed_pixels

    drive = simulator.enforce_direction_limit
    if bool(drive) != config.body_fixed_drive:
        raise ConfigError(f"the simulator's enforce_direction_limit={bool(drive)} disagrees with "
                          f"EpisodeConfig.body_fixed_drive={config.body_fixed_drive}")
    for name, neutral in KEY_NEUTRAL_FIELDS.items():
        if getattr(simulator, name, neutral) != getattr(config, name):
            raise ConfigError(f"the simulator's {name}={getattr(simulator, name, None)!r} disagrees with "
                              f"EpisodeConfig.{name}={getattr(config, name)!r}")
    pm = planner_map if planner_map is not None else cached_planner_map(occ2d, xs, ys, config.planner)
    start = np.asarray(task.start, dtype=np.float64).reshape(3)
    target = np.asarray(task.target, dtype=np.float64).reshape(2)

    frame0 = simulator.reset(start)
    start = np.asarray(simulator.pose, dtype=np.float64).copy()  # heading wrapped by the simulator
    estimator.reset(start.copy(), frame0)
    # the camera casts only the pixels the estimator reads (the same estimates, less work)
    pixels = observed_pixels(estimator)
    est = start.copy()
    true_poses = [start.copy()]
    est_poses = [est.copy()]
    controls: list[np.ndarray] = []
    timings = {k: [] for k in TIMING_KEYS}

    t0 = time.perf_counter()
    plan = plan_on_map(pm, start[:2], target)
    plan_ms = (time.perf_counter() - t0) * 1e3
    pending_plan_ms = plan_ms
    waypoints = plan.waypoints if plan.ok else None
    replans = 0
    collided, collision_step = False, -1
    end_reason = "no-plan" if waypoints is None else "step-limit"

    while waypoints is not None and len(controls) < config.max_steps:
        t0 = time.perf_counter()
        control, waypoints = controller_step(est, waypoints, config.controller)
        control_ms = (time.perf_counter() - t0) * 1e3
        if control is None:
            if math.dist(est[:2], target) <= config.goal_tolerance:
                end_reason = "reached"
                break
            if replans >= config.max_replans:
                end_reason = "no-plan"
                break
            replans += 1
            t0 = time.perf_counter()
            again = plan_on_map(pm, est[:2], target)
            pending_plan_ms += (time.perf_counter() - t0) * 1e3
            if not again.ok:
                end_reason = "no-plan"
                break
            waypoints = again.waypoints
            continue
        control = clip_control(control, est[2])

        t0 = time.perf_counter()
        res = simulator.step(control, pixels) if pixels is not None else simulator.step(control)
        sim_ms = (time.perf_counter() - t0) * 1e3
        true_pose = np.asarray(res.pose, dtype=np.float64).copy()

        t0 = time.perf_counter()
        est = checked_pose(estimator, estimator.update(control, res.frame, true_pose=true_pose),
                           len(controls) + 1)
        est_ms = (time.perf_counter() - t0) * 1e3
        lt = estimator.last_timing
        render_ms = float(lt.get("render", 0.0))

        controls.append(control.as_array())
        true_poses.append(true_pose)
        est_poses.append(est.copy())
        timings["sim"].append(sim_ms)
        timings["render"].append(render_ms)
        timings["estimate"].append(float(lt.get("estimate", max(0.0, est_ms - render_ms))))
        timings["plan"].append(pending_plan_ms)
        timings["control"].append(control_ms)
        pending_plan_ms = 0.0

        if res.collided:
            collided, collision_step = True, len(controls) - 1
            end_reason = "stuck"
            break
    else:
        if waypoints is not None and len(controls) >= config.max_steps:
            end_reason = "step-limit"

    return EpisodeRecord(
        level=level.name,
        task_id=int(task.id),
        estimator=str(estimator.name),
        noise=str(simulator.noise),
        seed=int(simulator.seed),
        start=start,
        target=target,
        optimal_length=float(task.optimal_length),
        true_poses=np.asarray(true_poses, dtype=np.float64).reshape(-1, 3),
        est_poses=np.asarray(est_poses, dtype=np.float64).reshape(-1, 3),
        controls=np.asarray(controls, dtype=np.float64).reshape(-1, 3),
        collided=collided,
        collision_step=collision_step,
        plan=(plan.waypoints.copy() if plan.ok else np.zeros((0, 2))),
        replans=replans,
        end_reason=end_reason,
        timings_ms={k: np.asarray(v, dtype=np.float64) for k, v in timings.items()},
        plan_status=plan.status,
        plan_ms=plan_ms,
    )
