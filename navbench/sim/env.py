"""A gymnasium point-goal navigation environment around the :class:`~navbench.sim.world.Simulator`.

Build ``PointNavEnv(level, ...)`` directly, or through gymnasium after ``import navbench.envs``
(which registers ``navbench/PointNav-v0``): ``gymnasium.make("navbench/PointNav-v0", level="house-1")``.

Observation (``Dict``):

* ``rgb``: ``(H, W, 3)`` uint8, the camera image (``round(255 * rgb)``);
* ``depth``: ``(H, W, 1)`` float32 z-depth in metres (one channel, as RL libraries expect of an image); pixels that see nothing within ``max_range``
  (``valid = False`` in the simulator's frame) read ``max_range``;
* ``goal``: ``(2,)`` float32 ``(distance [m], bearing [rad])`` of the goal in the agent frame,
  the bearing counter-clockwise from the heading, in ``[-pi, pi)``.

With ``intrinsics=None`` the observation holds only ``goal``.

Action: ``(3,)`` float32 ``(turn [rad], direction offset from the heading [rad], speed [m])``,
within the paper's limits (values outside are clipped; the direction offset is taken from the
true heading, so the environment moves the agent along ``heading + offset``).

Reward: the decrease of the Euclidean distance to the goal during the step (m). An episode
terminates on success (true position within ``2 L`` of the goal) or on a collision (movement
is then prohibited), and is truncated after ``max_steps`` steps. ``info`` holds ``success``,
``collided``, ``pose`` (true ``(3,)``), ``distance`` and ``task_index``.

Tasks: without ``tasks``, ``reset`` samples start and goal uniformly in the level box with at
least ``1.2 L`` clearance to every solid and more than ``3 L`` apart (connectivity is not
checked: pass ``tasks`` from :mod:`navbench.plan` for feasible ones). ``tasks`` is a sequence of
objects with ``start (x, y, theta)`` and ``target (x, y)`` attributes, or ``(start, target)``
pairs; they are used in order, or ``reset(options={"task_index": i})`` picks one.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from navbench.errors import TaskError
from navbench.geometry import AGENT_LENGTH, CAMERA_HEIGHT, HALF_CAMERA, MAX_RANGE, Intrinsics, wrap_angle
from navbench.level import Level
from navbench.sim.dynamics import MAX_DIRECTION_OFFSET, MAX_STEP, MAX_TURN, Control
from navbench.sim.world import Simulator, sample_free_points

#: Success radius (m): the goal is reached within 2 L (SPEC "Tasks and scoring").
SUCCESS_RADIUS = 2 * AGENT_LENGTH
#: Clearance (m) of sampled start and goal points to every solid.
TASK_CLEARANCE = 1.2 * AGENT_LENGTH
#: Minimum start-goal distance (m) of sampled tasks.
MIN_TASK_DISTANCE = 3 * AGENT_LENGTH


def _task_parts(task) -> tuple[np.ndarray, np.ndarray]:
    if hasattr(task, "start") and hasattr(task, "target"):
        start, target = task.start, task.target
    else:
        try:
            start, target = task
        except (TypeError, ValueError):
            raise TaskError(f"a task is (start, target) or has .start/.target, got {task!r}") from None
    s = np.asarray(start, dtype=np.float64).reshape(-1)
    t = np.asarray(target, dtype=np.float64).reshape(-1)
    if s.shape not in ((2,), (3,)) or t.shape[0] < 2:
        raise TaskError(f"a task start is (x, y[, theta]) and a target (x, y), got {start!r}, {target!r}")
    return s, t[:2]


class PointNavEnv(gym.Env):
    """Point-goal navigation in a level with the paper's noisy dynamics (see the module docstring)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, level: Level, noise="low", intrinsics: Intrinsics | None = HALF_CAMERA,
                 max_steps: int = 500, seed: int | None = None, tasks=None,
                 camera_height: float = CAMERA_HEIGHT, max_range: float = MAX_RANGE,
                 render_mode: str | None = None, texture: str = "procedural"):
        if max_steps < 1:
            raise TaskError(f"max_steps must be >= 1, got {max_steps}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise TaskError(f"unknown render mode {render_mode!r}")
        self.level = level
        self.max_steps = int(max_steps)
        self.max_range = float(max_range)
        self.render_mode = render_mode
        self.tasks = [_task_parts(t) for t in tasks] if tasks is not None else None
        if self.tasks is not None and not self.tasks:
            raise TaskError("tasks is empty")
        self.sim = Simulator(level, noise=noise, seed=0, intrinsics=intrinsics, camera_height=camera_height,
                             texture=texture)  # the camera's texture mode (navbench.sim.texels)
        if self.sim.camera is not None:
            self.sim.camera.max_range = self.max_range
        self._init_seed = seed
        self._seeded = False
        self._next_task = 0

        obs = {}
        if intrinsics is not None:
            H, W = intrinsics.height, intrinsics.width
            obs["rgb"] = spaces.Box(0, 255, (H, W, 3), np.uint8)
            obs["depth"] = spaces.Box(0.0, self.max_range, (H, W, 1), np.float32)
        diag = math.hypot(level.width, level.depth)
        obs["goal"] = spaces.Box(np.array([0.0, -math.pi], np.float32), np.array([diag, math.pi], np.float32),
                                 dtype=np.float32)
        self.observation_space = spaces.Dict(obs)
        self.action_space = spaces.Box(
            np.array([-MAX_TURN, -MAX_DIRECTION_OFFSET, 0.0], np.float32),
            np.array([MAX_TURN, MAX_DIRECTION_OFFSET, MAX_STEP], np.float32), dtype=np.float32)

        self.goal = np.zeros(2)
        self.task_index = -1
        self._steps = 0
        self._distance = 0.0
        self._frame = None

    # -------------------------------------------------------------------------- helpers
    def _sample_task(self) -> tuple[np.ndarray, np.ndarray]:
        rng = self.np_random
        for _ in range(1000):
            pts = sample_free_points(self.level, rng, 2, TASK_CLEARANCE)
            if np.hypot(*(pts[1] - pts[0])) > MIN_TASK_DISTANCE:
                start = np.array([pts[0, 0], pts[0, 1], rng.uniform(-math.pi, math.pi)])
                return start, pts[1]
        raise TaskError(f"could not sample a task in level {self.level.name!r}")

    def _goal_obs(self) -> np.ndarray:
        x, y, th = self.sim.pose
        dx, dy = self.goal[0] - x, self.goal[1] - y
        bearing = float(wrap_angle(math.atan2(dy, dx) - th))
        hi = self.observation_space["goal"].high[0]
        return np.array([min(math.hypot(dx, dy), hi), bearing], np.float32)

    def _obs(self) -> dict:
        out = {}
        f = self._frame
        if f is not None:
            out["rgb"] = np.round(np.clip(f.rgb, 0.0, 1.0) * 255).astype(np.uint8)
            depth = np.where(f.valid, np.minimum(f.depth, self.max_range), self.max_range)
            out["depth"] = depth.astype(np.float32)[..., None]
        out["goal"] = self._goal_obs()
        return out

    def _info(self) -> dict:
        return {"success": self._distance < SUCCESS_RADIUS, "collided": self.sim.collided,
                "pose": self.sim.pose.copy(), "distance": self._distance, "task_index": self.task_index}

    # -------------------------------------------------------------------------- gymnasium API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if seed is None and not self._seeded:
            seed = self._init_seed
        super().reset(seed=seed)
        self._seeded = True
        options = options or {}
        if self.tasks is not None:
            i = int(options.get("task_index", self._next_task)) % len(self.tasks)
            self._next_task = i + 1
            start, self.goal = self.tasks[i]
            if start.shape == (2,):
                start = np.array([start[0], start[1], self.np_random.uniform(-math.pi, math.pi)])
            self.task_index = i
        else:
            start, self.goal = self._sample_task()
            self.task_index = -1
        noise_seed = int(self.np_random.integers(0, 2**63 - 1))
        self._frame = self.sim.reset(start, seed=noise_seed)
        self._steps = 0
        self._distance = float(np.hypot(*(self.goal - self.sim.pose[:2])))
        return self._obs(), self._info()

    def step(self, action):
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape != (3,):
            raise TaskError(f"an action is (turn, direction offset, speed), got shape {a.shape}")
        heading = float(self.sim.pose[2])
        off = min(max(float(a[1]), -MAX_DIRECTION_OFFSET), MAX_DIRECTION_OFFSET)
        res = self.sim.step(Control(float(a[0]), heading + off, float(a[2])))
        self._frame = res.frame
        self._steps += 1
        before = self._distance
        self._distance = float(np.hypot(*(self.goal - res.pose[:2])))
        reward = before - self._distance
        success = self._distance < SUCCESS_RADIUS
        terminated = bool(success or res.collided)
        truncated = bool(not terminated and self._steps >= self.max_steps)
        return self._obs(), float(reward), terminated, truncated, self._info()

    def render(self):
        if self.render_mode == "rgb_array" and self._frame is not None:
            return np.round(np.clip(self._frame.rgb, 0.0, 1.0) * 255).astype(np.uint8)
        return None
