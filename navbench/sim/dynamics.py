"""The agent's noisy planar dynamics (paper section 5; SPEC "Dynamics").

Controls ``u = (turn, direction, speed)``: the angular velocity ``alpha-dot`` (rad per step,
signed), the absolute world angle ``o`` of the movement (rad) and the speed ``s`` (metres per
step, ``>= 0``). One step of the dynamics::

    alpha' = alpha + sign(turn) * max(0, |turn| + eps_alpha)
    l'     = l + [cos(eps_alpha + o), sin(eps_alpha + o)] * max(0, s + eps_s)

with ``eps_alpha ~ N(0, sigma_alpha)`` and ``eps_s ~ N(0, sigma_s)``. Noise only acts when the
agent tries to move: ``eps_alpha`` enters the rotation only if ``turn != 0`` and the movement
direction only if ``s > 0``; ``eps_s`` only if ``s > 0``. The ``max(0, .)`` clipping means noise
never inverts a turn or a step.

Everything here is pure: poses are ``(3,)`` float64 arrays ``(x, y, theta)`` in world metres and
radians (:mod:`navbench.geometry`), noise comes from a ``numpy.random.Generator`` the caller owns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navbench.errors import ConfigError
from navbench.geometry import AGENT_LENGTH, wrap_angle

#: Largest turn per step (rad), 11.5 degrees.
MAX_TURN = math.radians(11.5)
#: Largest step length per step (m), 0.8 L.
MAX_STEP = 0.8 * AGENT_LENGTH
#: Largest angle between the movement direction and the heading (rad), 5 degrees.
MAX_DIRECTION_OFFSET = math.radians(5.0)

#: Noise levels: name -> ``(sigma_alpha [rad], sigma_s [m])`` (SPEC "Dynamics").
NOISE_LEVELS: dict[str, tuple[float, float]] = {
    "none": (0.0, 0.0),
    "low": (math.radians(3.0), 0.10 * AGENT_LENGTH),
    "mid": (math.radians(6.0), 0.15 * AGENT_LENGTH),
    "high": (math.radians(9.0), 0.30 * AGENT_LENGTH),
    "tracking": (math.radians(3.0), 0.05 * AGENT_LENGTH),
}


@dataclass(frozen=True)
class Control:
    """One control ``u_t``."""

    turn: float  # alpha-dot, rad per step (signed, counter-clockwise positive)
    direction: float  # o, absolute world angle of the movement, rad
    speed: float  # s, metres per step (>= 0)

    def as_array(self) -> np.ndarray:
        """``(3,)`` float64 ``(turn, direction, speed)``."""
        return np.array([self.turn, self.direction, self.speed], dtype=np.float64)


def as_control(u) -> Control:
    """A :class:`Control` from a ``Control`` or any length-3 sequence ``(turn, direction, speed)``."""
    if isinstance(u, Control):
        return u
    a = np.asarray(u, dtype=np.float64).reshape(-1)
    if a.shape != (3,):
        raise ConfigError(f"a control has 3 components (turn, direction, speed), got {a.size}")
    return Control(float(a[0]), float(a[1]), float(a[2]))


def resolve_noise(noise) -> tuple[float, float]:
    """``(sigma_alpha [rad], sigma_s [m])`` from a noise-level name or a ``(sigma_alpha, sigma_s)`` pair."""
    if isinstance(noise, str):
        try:
            return NOISE_LEVELS[noise]
        except KeyError:
            raise ConfigError(f"unknown noise level {noise!r}; choose one of {sorted(NOISE_LEVELS)}") from None
    try:
        sa, ss = (float(v) for v in noise)
    except (TypeError, ValueError):
        raise ConfigError(f"noise must be a level name or a (sigma_alpha, sigma_s) pair, got {noise!r}") from None
    if not (sa >= 0 and ss >= 0 and math.isfinite(sa) and math.isfinite(ss)):
        raise ConfigError(f"noise sigmas must be finite and >= 0, got ({sa}, {ss})")
    return sa, ss


def clip_control(control, heading: float) -> Control:
    """Clip a control to the limits, for an agent with heading ``heading`` (rad).

    ``|turn| <= MAX_TURN``; ``0 <= speed <= MAX_STEP``; the direction is moved to within
    ``MAX_DIRECTION_OFFSET`` of the heading (and wrapped to ``[-pi, pi)``).
    """
    c = as_control(control)
    turn = min(max(c.turn, -MAX_TURN), MAX_TURN)
    speed = min(max(c.speed, 0.0), MAX_STEP)
    off = float(wrap_angle(c.direction - heading))
    off = min(max(off, -MAX_DIRECTION_OFFSET), MAX_DIRECTION_OFFSET)
    return Control(turn, float(wrap_angle(heading + off)), speed)


def draw_noise(rng: np.random.Generator, sigmas: tuple[float, float]) -> tuple[float, float]:
    """One step's noise ``(eps_alpha [rad], eps_s [m])``.

    Always draws exactly two standard normals from ``rng`` (also when a sigma is zero or the
    agent does not move), so a seeded stream stays aligned whatever the controls.
    """
    z = rng.standard_normal(2)
    return float(sigmas[0] * z[0]), float(sigmas[1] * z[1])


def apply_dynamics(pose, control, eps_alpha: float = 0.0, eps_s: float = 0.0) -> np.ndarray:
    """The paper's dynamics: pose ``(3,)`` and control -> next pose ``(3,)`` (heading wrapped).

    The control is used as given (clip it first with :func:`clip_control`); noise is ignored
    where the agent does not try to move (see the module docstring).
    """
    c = as_control(control)
    x, y, a = (float(v) for v in pose)
    if c.turn != 0.0:
        a = a + math.copysign(max(0.0, abs(c.turn) + eps_alpha), c.turn)
    if c.speed > 0.0:
        step = max(0.0, c.speed + eps_s)
        ang = eps_alpha + c.direction
        x = x + math.cos(ang) * step
        y = y + math.sin(ang) * step
    return np.array([x, y, float(wrap_angle(a))], dtype=np.float64)


def predict(pose, control) -> np.ndarray:
    """Noise-free dynamics: ``apply_dynamics(pose, control, 0, 0)``."""
    return apply_dynamics(pose, control, 0.0, 0.0)

