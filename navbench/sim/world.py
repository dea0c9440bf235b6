"""The collision world and the :class:`Simulator` (true pose, noisy dynamics, camera).

Collision geometry: every solid of the level (walls and obstacles of any height, even boxes
lower than the camera) is a static convex ``pymunk.Poly`` built from
:func:`navbench.level.prisms`, so what blocks the agent is exactly what the camera sees. The
level's bounding box ``[0, width] x [0, depth]`` is closed by four static segments as well, so
the agent can never leave the level. The agent is a disc of diameter ``L``
(:data:`navbench.geometry.AGENT_LENGTH`).

A move is a swept disc (``Shape.segment_query`` with radius ``L / 2``, exact in Chipmunk, on
every shape whose bounding box, grown by the radius, meets the move's; ``Space.segment_query_first``
is not used because Chipmunk's broad phase ignores the radius and misses near contacts): it stops
at the first contact, backed off by :data:`CONTACT_EPS` so that the disc never overlaps
a solid. Appendix D: once the agent has collided, further movement is prohibited for the rest of
the episode. We read "movement" as the whole pose: after a collision neither translation nor
rotation happens (the rotation of the colliding step itself is kept). Noise is still drawn on
every step so the seeded stream stays aligned.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from navbench.errors import TaskError
from navbench.geometry import AGENT_RADIUS, CAMERA_HEIGHT, HALF_CAMERA, Frame, Intrinsics, wrap_angle
from navbench.level import Level, distance_to_solids, prisms
from navbench.sim.conditions import check_condition, quantise_pose
from navbench.sim.dynamics import Control, apply_dynamics, as_control, clip_control, draw_noise, resolve_noise
from navbench.sim.texels import check_texture

#: Distance (m) a blocked move is backed off from the exact contact point.
CONTACT_EPS = 1e-6


class CollisionWorld:
    """Static solids of a level in a pymunk space; sweeps the agent's disc through it."""

    def __init__(self, level: Level, radius: float = AGENT_RADIUS):
        import pymunk

        self.level = level
        self.radius = float(radius)
        self._pymunk = pymunk
        self.space = pymunk.Space()
        body = self.space.static_body
        pr = prisms(level)
        shapes = [pymunk.Poly(body, [tuple(v) for v in pr.polygon(p)]) for p in range(len(pr))]
        w, d = float(level.width), float(level.depth)
        box = [(0.0, 0.0), (w, 0.0), (w, d), (0.0, d)]
        shapes += [pymunk.Segment(body, box[k], box[(k + 1) % 4], 0.0) for k in range(4)]
        self.space.add(*shapes)
        self._shapes = shapes
        # bounding boxes (S, 4): left, bottom, right, top
        self._bb = np.array([[s.bb.left, s.bb.bottom, s.bb.right, s.bb.top] for s in shapes])

    def _candidates(self, lo, hi, margin: float) -> np.ndarray:
        bb = self._bb
        return np.flatnonzero((bb[:, 0] <= hi[0] + margin) & (bb[:, 2] >= lo[0] - margin)
                              & (bb[:, 1] <= hi[1] + margin) & (bb[:, 3] >= lo[1] - margin))

    def clearance(self, xy) -> float:
        """Distance (m) from the point ``xy (2,)`` to the nearest solid or boundary (0 inside one)."""
        p = (float(xy[0]), float(xy[1]))
        return max(0.0, min(s.point_query(p).distance for s in self._shapes))

    def sweep(self, xy_from, xy_to) -> tuple[np.ndarray, bool]:
        """Move the disc from ``xy_from`` towards ``xy_to`` (world metres) until it touches a solid.

        Returns the end point ``(2,)`` and whether the move was blocked. A blocked move ends
        :data:`CONTACT_EPS` before the exact contact along the path, never overlapping a solid.
        """
        a = np.asarray(xy_from, dtype=np.float64)[:2]
        b = np.asarray(xy_to, dtype=np.float64)[:2]
        length = float(np.hypot(*(b - a)))
        if length == 0.0:
            return a.copy(), False
        pa, pb = (float(a[0]), float(a[1])), (float(b[0]), float(b[1]))
        alpha = math.inf
        for k in self._candidates(np.minimum(a, b), np.maximum(a, b), self.radius + 1e-9):
            q = self._shapes[k].segment_query(pa, pb, self.radius)
            if q is not None and q.alpha < alpha:
                alpha = q.alpha
        if alpha == math.inf:
            return b.copy(), False
        travel = max(0.0, alpha * length - CONTACT_EPS)
        direction = (b - a) / length
        end = a + direction * travel
        # guard against round-off: never end closer than the radius (unless we started there)
        while travel > 0.0 and self._near_clearance(end) < self.radius:
            travel = max(0.0, travel - 10 * CONTACT_EPS)
            end = a + direction * travel
        return end, True

    def _near_clearance(self, xy) -> float:
        """:meth:`clearance`, looking only at shapes within about one radius of ``xy``."""
        p = (float(xy[0]), float(xy[1]))
        ks = self._candidates(xy, xy, 2 * self.radius)
        return min((self._shapes[k].point_query(p).distance for k in ks), default=math.inf)


class StepResult(NamedTuple):
    """What :meth:`Simulator.step` returns."""

    pose: np.ndarray  # (3,) true pose after the step, world frame
    collided: bool  # the agent has collided (this step or before)
    frame: Frame | None  # observation at the new pose (None without a camera)
    eps: tuple[float, float]  # this step's noise draw (eps_alpha [rad], eps_s [m])


class Simulator:
    """Ground-truth simulator: true pose, noisy dynamics, collisions and the RGB-D camera.

    ``noise`` is a level name (:data:`navbench.sim.dynamics.NOISE_LEVELS`) or a
    ``(sigma_alpha [rad], sigma_s [m])`` pair; ``seed`` fully determines the noise draws (two
    normals per step, whatever the controls). ``intrinsics=None`` skips rendering: ``step``
    then returns ``frame=None`` (fast stepping). Controls are clipped to the turn and speed
    limits before they are applied; the applied control is kept in ``last_control``.

    The movement direction ``o`` is an absolute world angle and, as in the paper's equations
    (section 5), the location update depends on ``o`` alone, never on the true heading: the
    agent keeps ``|o - alpha| <= 5 deg`` against the heading it BELIEVES it has
    (:func:`navbench.nav.episode.run_episode` clips against the estimate), so a heading error
    turns into a position error only through what the estimator feeds back to the controller.
    ``enforce_direction_limit=True`` also clips ``o`` to within 5 deg of the TRUE heading
    (a body-fixed drive: a heading error of ``d`` then bends every step by ``|d| - 5 deg``);
    this was the default before and halves the ``dynamics`` baseline's SPL.

    The paper's other simulator conditions (:mod:`navbench.sim.conditions`):
    ``pose_quantisation`` (``"off"``, ``"round"``, ``"truncate"``) quantises the pose after every
    step and at reset as ViZDoom does (whole degrees, 0.01 m); the quantised pose is the truth
    from then on, and a quantised position whose disc overlaps a solid counts as a collision.
    ``collision_check="endpoint"`` replaces the swept disc by appendix D's check at the end of
    the move: the agent is teleported there and has collided when its disc overlaps a solid.

    ``texture``: how the camera evaluates colours (:mod:`navbench.sim.texels`; ``procedural``,
    the default, is every ``navbench-1`` image).
    """

    def __init__(self, level: Level, noise="none", seed: int = 0,
                 intrinsics: Intrinsics | None = HALF_CAMERA, camera_height: float = CAMERA_HEIGHT,
                 enforce_direction_limit: bool = False, pose_quantisation: str = "off",
                 collision_check: str = "swept", texture: str = "procedural"):
        self.level = level
        self.enforce_direction_limit = bool(enforce_direction_limit)
        self.pose_quantisation = check_condition("pose_quantisation", pose_quantisation, "Simulator")
        self.collision_check = check_condition("collision_check", collision_check, "Simulator")
        self.noise = noise if isinstance(noise, str) else tuple(float(v) for v in noise)
        self.sigmas = resolve_noise(noise)
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self.world = CollisionWorld(level)
        self.intrinsics = intrinsics
        self.camera_height = float(camera_height)
        self.camera = None
        self.texture = check_texture(texture, "Simulator texture")
        if intrinsics is not None:
            from navbench.sim.camera import RaycastCamera

            self.camera = RaycastCamera(level, intrinsics, camera_height, texture=texture)
        self.pose = np.zeros(3)
        self.collided = False
        self.collision_step = -1
        self.steps = 0
        self.last_control: Control | None = None

    def reset(self, pose, seed: int | None = None) -> Frame | None:
        """Place the agent at ``pose (3,)`` and clear the collision flag; return the observation.

        ``seed`` (optional) restarts the noise stream; otherwise it continues. Raises
        :class:`~navbench.errors.TaskError` when the agent's disc would overlap a solid.
        """
        p = np.asarray(pose, dtype=np.float64).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise TaskError(f"a pose is (x, y, theta), got {pose!r}")
        if self.world.clearance(p[:2]) < self.world.radius - 1e-9:
            raise TaskError(f"start pose ({p[0]:.3f}, {p[1]:.3f}) overlaps a solid of level {self.level.name!r}")
        if seed is not None:
            self.seed = seed
            self.rng = np.random.default_rng(seed)
        self.pose = self._realise(np.array([p[0], p[1], float(wrap_angle(p[2]))]))
        self.collided = False
        self.collision_step = -1
        self.steps = 0
        self.last_control = None
        return self.observe()

    def step(self, control, pixels=None) -> StepResult:
        """Apply one control ``(turn, direction, speed)`` (clipped) with noise and collisions.

        ``pixels``: the flat pixel indices the camera casts for the new frame
        (:meth:`RaycastCamera.render <navbench.sim.camera.RaycastCamera.render>`); None: all."""
        u = clip_control(control, float(self.pose[2]))
        if not self.enforce_direction_limit:  # o as commanded (paper eq. for l_{t+1}); see the class doc
            u = Control(u.turn, float(wrap_angle(as_control(control).direction)), u.speed)
        eps = draw_noise(self.rng, self.sigmas)
        self.last_control = u
        if not self.collided:
            nxt = apply_dynamics(self.pose, u, eps[0], eps[1])
            if self.collision_check == "endpoint":  # teleport, then a distance check (appendix D)
                xy, hit = nxt[:2], self._overlaps(nxt[:2])
            else:
                xy, hit = self.world.sweep(self.pose[:2], nxt[:2])
            self.pose = np.array([xy[0], xy[1], nxt[2]])
            realised = self._realise(self.pose)
            if realised is not self.pose:  # quantised: a disc overlapping a solid there collides
                self.pose = realised
                hit = hit or self._overlaps(self.pose[:2])
            if hit:
                self.collided = True
                self.collision_step = self.steps
        self.steps += 1
        return StepResult(self.pose.copy(), self.collided, self.observe(pixels), eps)

    def _realise(self, pose: np.ndarray) -> np.ndarray:
        """The pose the world takes when the agent is put at ``pose (3,)``: ``pose`` itself (the
        same object) or, under ``pose_quantisation``, a new quantised array. A backend whose
        engine places the agent its own way (:class:`navbench.sim.doom.simulator.DoomSimulator`)
        overrides this and returns the pose its engine shows."""
        if self.pose_quantisation != "off":
            return quantise_pose(pose, self.pose_quantisation)
        return pose

    def _overlaps(self, xy) -> bool:
        """Whether the agent's disc at ``xy`` overlaps a solid or the level's boundary (or lies
        outside the level: a teleport may jump past a wall, never out of the level)."""
        x, y = float(xy[0]), float(xy[1])
        if not (0.0 < x < self.level.width and 0.0 < y < self.level.depth):
            return True
        return self.world._near_clearance(xy) < self.world.radius

    def observe(self, pixels=None) -> Frame | None:
        """The camera's view from the current true pose (None without a camera); ``pixels``:
        only those (flat indices), the others unseen (``RaycastCamera.render``)."""
        return self.camera.render(self.pose, pixels) if self.camera is not None else None


def sample_free_points(level: Level, rng: np.random.Generator, count: int, clearance: float,
                       max_tries: int = 100_000) -> np.ndarray:
    """``count`` points ``(count, 2)`` uniform in the level box with ``>= clearance`` (m) to every solid.

    Rejection sampling with ``rng``; connectivity is not checked. Raises
    :class:`~navbench.errors.TaskError` when too few free points are found.
    """
    pr = prisms(level)
    out = np.zeros((0, 2))
    tries = 0
    lo = np.array([clearance, clearance])
    hi = np.array([level.width - clearance, level.depth - clearance])
    if np.any(hi <= lo):
        raise TaskError(f"level {level.name!r} is too small for clearance {clearance} m")
    while len(out) < count:
        if tries >= max_tries:
            raise TaskError(f"found only {len(out)} of {count} free points with clearance {clearance} m "
                            f"in level {level.name!r}")
        n = max(64, 4 * (count - len(out)))
        pts = rng.uniform(lo, hi, size=(n, 2))
        tries += n
        ok = distance_to_solids(pr, pts) >= clearance
        out = np.concatenate([out, pts[ok]])
    return out[:count]
