"""The paper's documented simulation conditions, each a named option (issue 16, section 1).

A *condition* is something the paper (seed 000) states about how its experiments ran that a
reimplementation may or may not do. Each has a name, a small set of values, a default that
keeps navbench's earlier behaviour (and so its cache keys and stored numbers), the
:class:`navbench.nav.episode.EpisodeConfig` field it sets, and the paper's own words:

``pose_quantisation`` (``off`` | ``round`` | ``truncate``)
    Section 5: "Vizdoom only allows for setting an integer angle in [0, 360] degrees and the
    2D location can only be specified up to two decimal points of precision." With ``round``
    or ``truncate`` the simulator quantises the executed pose after every step (and at reset):
    the heading to whole degrees in ``[0, 360)``, the location to 0.01 m, to the nearest value
    (``round``) or towards minus infinity (``truncate``; levels lie in the positive quadrant,
    so this is also truncation towards zero). The quantised pose is the truth from then on:
    the next step starts from it, the camera renders it, it is recorded and scored. The paper
    does not say which of the two roundings ViZDoom applies; both are offered.
``direction_limit`` (``believed`` | ``true``)
    Section 5: "The movement angle is distinct from the current heading angle alpha but must
    align with it up to a threshold of 5 deg." ``believed``: the agent keeps ``|o - alpha|
    <= 5 deg`` against its ESTIMATED heading and moves along ``o`` (the equation for
    ``l_{t+1}`` uses ``o`` alone); ``true``: the simulator also clips ``o`` to within 5 deg of
    the TRUE heading (a body-fixed drive). Sets ``EpisodeConfig.body_fixed_drive``.
``collision_check`` (``swept`` | ``endpoint``)
    Appendix D: "we implement continuous control via the teleportation and rotation commands.
    These do not check for collisions, so we check these manually by calculating distances to
    the obstacles ... As soon as a collision occurs, we prohibit further movement."
    ``swept``: the agent's disc is swept along the move and stops at the first contact;
    ``endpoint``: the agent is teleported to the end of the move, and it has collided when its
    disc there overlaps a solid (a distance check at the teleported pose, as the appendix
    describes; the move itself is not checked along the way).

Pure functions only (no I/O); :func:`quantise_pose` is the math of ``pose_quantisation``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from decimal import ROUND_FLOOR, ROUND_HALF_EVEN, Decimal
from typing import Any

import numpy as np

from navbench.errors import ConfigError


@dataclass(frozen=True)
class Condition:
    """One documented condition: its values, default, the EpisodeConfig field it sets."""

    name: str
    values: tuple[str, ...]
    default: str
    field: str                      # EpisodeConfig field
    field_values: tuple[Any, ...]   # the field's value for each of ``values``
    source: str                     # where the paper states it
    quote: str                      # the paper's words


CONDITIONS: dict[str, Condition] = {c.name: c for c in (
    Condition("pose_quantisation", ("off", "round", "truncate"), "off", "pose_quantisation",
              ("off", "round", "truncate"), "seed 000, section 5",
              "Vizdoom only allows for setting an integer angle in [0, 360] degrees and the 2D location "
              "can only be specified up to two decimal points of precision. Together, these factors make "
              "for enough perturbation to pose a non-trivial challenge against navigation."),
    Condition("direction_limit", ("believed", "true"), "believed", "body_fixed_drive", (False, True),
              "seed 000, section 5",
              "The movement angle is distinct from the current heading angle alpha but must align with "
              "it up to a threshold of 5 deg"),
    Condition("collision_check", ("swept", "endpoint"), "swept", "collision_check", ("swept", "endpoint"),
              "seed 000, appendix D",
              "In Vizdoom, we implement continuous control via the teleportation and rotation commands. "
              "These do not check for collisions, so we check these manually by calculating distances to "
              "the obstacles, which we extract from the simulator in the form of a set of line segments. "
              "As soon as a collision occurs, we prohibit further movement."),
)}

#: Values of the new EpisodeConfig fields that leave the episode key as it was before they existed.
KEY_NEUTRAL_FIELDS: dict[str, Any] = {"pose_quantisation": "off", "collision_check": "swept",
                                      "texture": "procedural"}


def check_condition(name: Any, value: Any, where: str) -> str:
    """The checked value of condition ``name``; :class:`ConfigError` ``"<where>: ..."`` otherwise."""
    if name not in CONDITIONS:
        raise ConfigError(f"{where}: unknown condition {name!r}; known: {sorted(CONDITIONS)}")
    c = CONDITIONS[name]
    if value not in c.values:
        raise ConfigError(f"{where}: condition {name} must be one of {list(c.values)}, got {value!r}")
    return value


def parse_condition_args(items, where: str = "--condition") -> dict[str, str]:
    """``{"NAME": "VALUE"}`` from ``["NAME=VALUE", ...]`` (a later item overrides an earlier one)."""
    out: dict[str, str] = {}
    for item in items or ():
        name, sep, value = str(item).partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name:
            raise ConfigError(f"{where}: expected NAME=VALUE, got {item!r}; names: {sorted(CONDITIONS)}")
        out[name] = check_condition(name, value, where)
    return out


def conditions_to_episode(conditions: dict[str, str], where: str = "conditions") -> dict[str, Any]:
    """The EpisodeConfig field overrides that select ``conditions`` (checked)."""
    out = {}
    for name, value in dict(conditions).items():
        check_condition(name, value, where)
        c = CONDITIONS[name]
        out[c.field] = c.field_values[c.values.index(value)]
    return out


def merge_conditions(episode: dict, conditions: dict[str, str], where: str) -> dict:
    """``episode`` overrides with ``conditions`` applied; a field set in both to different values
    is a :class:`ConfigError` naming ``where``."""
    merged = dict(episode)
    for k, v in conditions_to_episode(conditions, where).items():
        if k in merged and merged[k] != v:
            name = next(c.name for c in CONDITIONS.values() if c.field == k)
            raise ConfigError(f"{where}: condition {name} sets {k}={v!r} but the episode config has "
                              f"{k}={merged[k]!r}; set it in one place")
        merged[k] = v
    return merged


def episode_conditions(episode_config) -> dict[str, str]:
    """``{name: value}`` of every condition for an EpisodeConfig (or a dict of its fields)."""
    get = (episode_config.get if isinstance(episode_config, dict)
           else lambda k, d=None: getattr(episode_config, k, d))
    out = {}
    for c in CONDITIONS.values():
        fv = get(c.field, c.field_values[c.values.index(c.default)])
        out[c.name] = c.values[c.field_values.index(fv)] if fv in c.field_values else str(fv)
    return out


#: Truncation takes a heading within this many degrees below a whole degree as that degree: the
#: radians of a whole degree, converted back, may come out an ulp below it.
_DEG_SNAP = 1e-9
_CENTI = Decimal("0.01")


def _centi(v: float, mode: str) -> float:
    """``v`` (m) to 0.01 m, exactly on the double's binary value: nearest (halves to even) or
    truncated to the largest grid value ``k / 100`` whose double is ``<= v`` (so the double
    that stores 0.29, an ulp below 0.29, stays 0.29)."""
    if mode == "round":
        return float(Decimal(v).quantize(_CENTI, ROUND_HALF_EVEN))
    k = int((Decimal(v) * 100).to_integral_value(ROUND_FLOOR))
    return (k + 1) / 100 if (k + 1) / 100 <= v else k / 100


def quantise_pose(pose, mode: str) -> np.ndarray:
    """ViZDoom's pose quantisation: heading to whole degrees in ``[0, 360)``, location to 0.01 m.

    ``mode``: ``"off"`` (a copy), ``"round"`` (nearest; halves to even, as Python's ``round``)
    or ``"truncate"`` (towards minus infinity, a stored grid value staying where it is).
    Returns ``(3,)`` float64 ``(x, y, theta)`` with ``theta = math.radians(k)`` for the whole
    degree ``k`` in ``[-180, 180)`` (so in ``[-pi, pi)``).
    """
    x, y, a = (float(v) for v in np.asarray(pose, dtype=np.float64).reshape(3))
    if mode == "off":
        return np.array([x, y, a], dtype=np.float64)
    if mode not in ("round", "truncate"):
        raise ConfigError(f"pose_quantisation must be one of ['off', 'round', 'truncate'], got {mode!r}")
    deg = math.degrees(a) % 360.0
    if mode == "round":
        deg_q = round(deg) % 360
    else:  # radians(k) -> degrees may come back a hair below k
        deg_q = math.floor(deg + _DEG_SNAP) % 360
    xq, yq = (_centi(v, mode) for v in (x, y))
    signed = deg_q - 360 if deg_q >= 180 else deg_q  # whole degrees in [-180, 180)
    return np.array([xq, yq, math.radians(signed)], dtype=np.float64)
