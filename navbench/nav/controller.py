"""The low-level waypoint controller (paper appendix B; SPEC "Planning and control").

Given the ESTIMATED pose and the remaining waypoints (in order), the controller

1. takes the closest remaining waypoint as the local target (waypoints before it count as
   passed and are dropped; the search looks at most ``lookahead`` waypoints ahead, so a later
   part of the path on the far side of a wall cannot capture the agent);
2. drops the local target once the agent is within ``waypoint_tolerance`` of it and takes the
   next one;
3. if the heading error to the local target exceeds ``heading_threshold`` (5 deg), turns in
   place towards it by at most ``MAX_TURN`` without overshooting; otherwise steps forward along
   the heading by ``min(MAX_STEP, distance)`` (never overshooting the local target).

When no waypoint remains the controller returns ``None``: the caller decides whether the agent
reached the target or must replan. Pure functions: poses ``(3,)`` ``(x, y, theta)`` world
metres / radians, waypoints ``(K, 2)`` world metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navbench.geometry import AGENT_LENGTH, wrap_angle
from navbench.sim.dynamics import MAX_STEP, MAX_TURN, Control


@dataclass(frozen=True)
class ControllerConfig:
    """Controller settings; lengths in metres, angles in radians."""

    heading_threshold: float = math.radians(5.0)  # turn in place while |heading error| exceeds this
    # a waypoint this close (m) counts as reached. 0.5 L: with 0.25 L the agent under mid/high
    # noise keeps missing the 0.8 L-spaced lattice waypoints and turning back (step limit);
    # 0.5 L reaches >= 0.95 of house-1's tasks with the true pose at every noise level
    waypoint_tolerance: float = 0.5 * AGENT_LENGTH
    lookahead: int = 8  # the closest waypoint is searched among the next this-many ones
    max_turn: float = MAX_TURN  # rad per step
    max_step: float = MAX_STEP  # m per step


def select_waypoint(xy, waypoints, config: ControllerConfig = ControllerConfig()) -> np.ndarray:
    """Drop passed and reached waypoints; return the remaining ones ``(K', 2)`` (local target first).

    ``xy`` (2,) the estimated position (m).
    """
    wp = np.asarray(waypoints, dtype=np.float64).reshape(-1, 2)
    p = np.asarray(xy, dtype=np.float64)[:2]
    while len(wp):
        window = wp[: max(1, config.lookahead)]
        k = int(np.argmin(np.linalg.norm(window - p, axis=1)))
        wp = wp[k:]
        if np.linalg.norm(wp[0] - p) <= config.waypoint_tolerance:
            wp = wp[1:]
            continue
        break
    return wp


def control_towards(pose, target_xy, config: ControllerConfig = ControllerConfig()) -> Control:
    """The control that turns towards, or steps to, ``target_xy`` from ``pose`` (see module doc)."""
    x, y, theta = (float(v) for v in pose)
    dx, dy = float(target_xy[0]) - x, float(target_xy[1]) - y
    dist = math.hypot(dx, dy)
    err = float(wrap_angle(math.atan2(dy, dx) - theta))
    if abs(err) > config.heading_threshold:
        turn = max(-config.max_turn, min(config.max_turn, err))
        return Control(turn, float(wrap_angle(theta)), 0.0)
    return Control(0.0, float(wrap_angle(theta)), min(config.max_step, dist))


def controller_step(pose, waypoints, config: ControllerConfig = ControllerConfig()) -> tuple[Control | None, np.ndarray]:
    """One controller decision: ``(control or None, remaining waypoints (K', 2))``.

    ``None`` when every waypoint has been reached.
    """
    wp = select_waypoint(np.asarray(pose, dtype=np.float64)[:2], waypoints, config)
    if len(wp) == 0:
        return None, wp
    return control_towards(pose, wp[0], config), wp
