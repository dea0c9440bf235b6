"""Image goals (issue 15 §1-2): the picture taken at a task's target, and finding it in a map.

A task's image goal is the RGB-D view of the TRUE level from the target position, at the
camera height, with a heading drawn uniformly in ``[-pi, pi)`` from a seeded stream of its own
(:func:`goal_heading`: a :class:`numpy.random.SeedSequence` over a tag, the goal seed and the
task id). Nothing is stored with the task: the heading, and with it the view rendered by
:class:`navbench.sim.camera.RaycastCamera`, is derived byte-identically from (level, task,
seed, camera), so task files keep their format and keys.

Known map (the paper's pipeline with a picture instead of coordinates): the agent localises
the goal image in its world model with :class:`navbench.localize.Localizer` (two hypotheses)
and plans to the best one exactly as to a point goal. :func:`classify` says how sure it is:

* ``failed`` -- no hypothesis, or the best one's confidence is below ``min_confidence``;
* ``ambiguous`` -- a second hypothesis farther than ``ambiguity_radius`` from the best is
  verified too (confidence >= ``min_confidence``) and scores within ``ambiguity_margin`` of it
  (a lookalike place);
* ``ok`` -- otherwise.

The agent navigates to the best hypothesis whatever the status (an agent has nothing better to
do); only without any hypothesis it has no goal and the episode ends ``"no-plan"`` at once.
Success is always scored against the TRUE target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Tag of the goal-heading stream ("goal" in ASCII): no other stream of navbench draws from it.
GOAL_STREAM = 0x676F616C
GOAL_STATUSES = ("ok", "ambiguous", "failed")


def goal_heading(seed: int, task_id: int) -> float:
    """The image goal's heading (rad, uniform in ``[-pi, pi)``) of task ``task_id`` under goal
    seed ``seed``: deterministic, independent of every other random stream."""
    rng = np.random.default_rng(np.random.SeedSequence([GOAL_STREAM, int(seed), int(task_id)]))
    return float(rng.uniform(-math.pi, math.pi))


def goal_pose(task, seed: int) -> np.ndarray:
    """``(x, y, theta)`` of the goal view of ``task`` (a :class:`navbench.plan.tasks.Task`)."""
    return np.array([float(task.target[0]), float(task.target[1]), goal_heading(seed, task.id)])


def render_goal(level, task, intrinsics, seed: int, camera_height: float | None = None):
    """The goal image of ``task``: the TRUE level's RGB-D :class:`~navbench.geometry.Frame` from
    :func:`goal_pose` (the simulator's camera, noise free)."""
    from navbench.geometry import CAMERA_HEIGHT
    from navbench.sim.camera import RaycastCamera

    cam = RaycastCamera(level, intrinsics, CAMERA_HEIGHT if camera_height is None else camera_height)
    return cam.render(goal_pose(task, seed))


@dataclass(frozen=True)
class GoalRules:
    """When a localised goal counts as found: confidences in [0, 1], distances in metres,
    ``ambiguity_margin`` in the localiser's score units."""

    min_confidence: float = 0.8      # the localiser's own acceptance level (LocalizerConfig.accept)
    ambiguity_radius: float = 1.0    # m: a second verified place at least this far away ...
    ambiguity_margin: float = 0.02   # ... scoring within this of the best is a lookalike


@dataclass(frozen=True)
class GoalLocalization:
    """The outcome of localising one goal image: ``status`` (:data:`GOAL_STATUSES`), ``pose``
    ``(x, y, theta)`` of the best hypothesis (``None`` without any), its ``confidence`` and
    ``error_m`` (distance of the found position to the true target, for the record only)."""

    status: str
    pose: tuple[float, float, float] | None
    confidence: float
    error_m: float


def classify(hypotheses, target_xy, rules: GoalRules = GoalRules()) -> GoalLocalization:
    """The :class:`GoalLocalization` of ``hypotheses`` (the localiser's, best first: objects
    with ``pose``, ``score``, ``confidence``) for a goal at ``target_xy`` (m)."""
    if not hypotheses:
        return GoalLocalization("failed", None, float("nan"), float("nan"))
    best = hypotheses[0]
    pose = tuple(float(v) for v in np.asarray(best.pose, dtype=float)[:3])
    err = math.dist(pose[:2], (float(target_xy[0]), float(target_xy[1])))
    conf = float(best.confidence)
    if conf < rules.min_confidence:
        return GoalLocalization("failed", pose, conf, err)
    for h in hypotheses[1:]:
        far = math.dist(np.asarray(h.pose, float)[:2], pose[:2]) >= rules.ambiguity_radius
        if far and h.confidence >= rules.min_confidence and h.score >= best.score - rules.ambiguity_margin:
            return GoalLocalization("ambiguous", pose, conf, err)
    return GoalLocalization("ok", pose, conf, err)


def run_image_goal_episode(level, occ2d, xs, ys, task, found_pose, estimator, simulator, config):
    """One known-map image-goal episode: :func:`navbench.nav.episode.run_episode` to the
    position the localiser found (``found_pose`` ``(x, y, theta)``, or ``None`` when it found
    nothing: the episode ends ``"no-plan"`` before any step), with the record's ``target`` set
    back to the task's TRUE target, so that it is scored like a point-goal episode."""
    import dataclasses

    from navbench.nav.episode import EpisodeRecord, run_episode
    from navbench.nav.timing import TIMING_KEYS

    true_target = np.asarray(task.target, dtype=np.float64).reshape(2)
    if found_pose is None:  # no goal to plan to: the episode ends before its first step
        simulator.reset(np.asarray(task.start, dtype=np.float64))
        start = np.asarray(simulator.pose, dtype=np.float64).copy()
        return EpisodeRecord(
            level=level.name, task_id=int(task.id), estimator=str(estimator.name),
            noise=str(simulator.noise), seed=int(simulator.seed), start=start, target=true_target,
            optimal_length=float(task.optimal_length), true_poses=start[None].copy(),
            est_poses=start[None].copy(), controls=np.zeros((0, 3)), collided=False, collision_step=-1,
            plan=np.zeros((0, 2)), replans=0, end_reason="no-plan",
            timings_ms={k: np.zeros(0) for k in TIMING_KEYS}, plan_status="no-plan")
    found = dataclasses.replace(task, target=(float(found_pose[0]), float(found_pose[1])))
    record = run_episode(level, occ2d, xs, ys, found, estimator, simulator, config=config)
    record.target = true_target
    return record
