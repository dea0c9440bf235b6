"""Scoring presets: the success rules of three navigation benchmarks over stored episodes.

navbench's agent decides by itself when it has arrived: an episode ends ``"reached"`` when the
agent believes it is at the goal (:mod:`navbench.nav.episode`), which is a STOP action; every
other end (``"stuck"``, ``"step-limit"``, ``"no-plan"``) is an episode without a stop. Episodes
run at most ``EpisodeConfig.max_steps`` controls (500 by default, the limit of both NRNS and
habitat-lab PointNav). A preset is therefore a *scoring rule* over stored episodes, never an
episode setting: it changes no episode and no key, and one stored grid is scored under every
preset.

========  =================================================  ======================  ==========
preset    success                                            distance ``d_T``        step limit
========  =================================================  ======================  ==========
paper     final true position closer than ``2 L`` (0.4 m)    Euclidean               --
          to the target; no stop needed (SPEC "Tasks and
          scoring", the paper's appendix D)
nrns      stopped (``end_reason == "reached"``) within       Euclidean               500
          ``1.0 m`` (``d_T <= 1``) of the goal (NRNS, Hahn
          et al. 2021; RNR-Map's benchmark)
habitat   stopped within ``0.2 m`` geodesic                  geodesic                500
          (``d_T < 0.2``; habitat-lab ``Success``:
          ``is_stop_called and distance_to_target <
          success_distance``)
========  =================================================  ======================  ==========

Steps are executed controls; the stop itself is not counted (habitat counts its STOP action, so
an episode stopping after exactly 500 moves is one action over habitat's limit there and within
it here). An episode that ran more controls than a preset's step limit did not stop within it: not a
success under that preset (its ``d_T`` is still the distance where it ended). Profiles refuse a
preset with a step limit below ``max_steps`` (:func:`check_preset_steps`), so a run's own
episodes never exceed it.

For every preset, per episode (``l`` = the task's exact shortest feasible path length, the SPL
``l_i`` / habitat's geodesic start-goal distance ``d_0``; ``p`` = the path the agent took):

* ``spl_term = s * l / max(p, l)`` (Anderson et al. 2018, eq. 1; paper eq. 8);
* ``soft_spl_term = max(0, 1 - d_geo / l) * l / max(p, l)`` with ``d_geo`` the final geodesic
  distance to the goal: habitat-lab's ``SoftSPL`` (``habitat/tasks/nav/nav.py``:
  ``ep_soft_success = max(0, 1 - distance_to_target / start_end_episode_distance)`` times
  ``start_end_episode_distance / max(start_end_episode_distance, agent_episode_distance)``,
  ``distance_to_target`` the geodesic ``DistanceToGoal``). It needs no stop, so it is the same
  under every preset;
* ``dist_to_goal_m = d_T``, the preset's final distance.

The ``paper`` preset keeps the stored ``success`` and ``spl_term`` (computed by
:func:`navbench.nav.metrics.score_episode` from the same numbers, so equal bit for bit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from navbench.errors import ConfigError
from navbench.geometry import AGENT_LENGTH

#: NRNS difficulty bands by exact geodesic start-goal distance (m): [lo, hi), hard's hi closed.
DIFFICULTY_BANDS: dict[str, tuple[float, float]] = {"easy": (1.5, 3.0), "medium": (3.0, 5.0),
                                                    "hard": (5.0, 10.0)}
#: Tasks outside every band (shorter than 1.5 m or longer than 10 m).
OTHER_DIFFICULTY = "other"


@dataclass(frozen=True)
class ScoringPreset:
    """One benchmark's success rule. ``radius`` in metres; ``distance``: ``"euclidean"`` or
    ``"geodesic"`` (of the final true position to the goal); ``inclusive``: success at
    ``d_T <= radius`` (else ``d_T < radius``); ``needs_stop``: only an episode the agent ended
    itself (``"reached"``) can succeed; ``step_limit``: controls allowed (``None``: any)."""

    name: str
    radius: float
    distance: str
    inclusive: bool
    needs_stop: bool
    step_limit: int | None
    description: str


PRESETS: dict[str, ScoringPreset] = {
    "paper": ScoringPreset("paper", 2 * AGENT_LENGTH, "euclidean", False, False, None,
                           "final position within 2 L of the target, no stop needed"),
    "nrns": ScoringPreset("nrns", 1.0, "euclidean", True, True, 500,
                          "stopped within 1 m (Euclidean) of the goal, 500 steps"),
    "habitat": ScoringPreset("habitat", 0.2, "geodesic", False, True, 500,
                             "stopped within 0.2 m (geodesic) of the goal, 500 steps"),
}
DEFAULT_PRESET = "paper"


def get_preset(name: str, where: str = "[scoring] preset") -> ScoringPreset:
    """The preset called ``name``; :class:`ConfigError` naming ``where`` and the choices."""
    if not isinstance(name, str) or name not in PRESETS:
        from navbench.names import did_you_mean

        raise ConfigError(f"{where}: unknown scoring preset {name!r}{did_you_mean(name, PRESETS)}; "
                          f"choose one of {', '.join(PRESETS)}")
    return PRESETS[name]


def check_preset_steps(name: str, max_steps: int, where: str) -> None:
    """Refuse episodes that could run past the preset's step limit (:class:`ConfigError`)."""
    p = get_preset(name, where)
    if p.step_limit is not None and int(max_steps) > p.step_limit:
        raise ConfigError(f"{where}: scoring preset {name!r} allows {p.step_limit} steps, but "
                          f"[navigation.episode] max_steps is {max_steps}")


def difficulty(optimal_length) -> np.ndarray:
    """NRNS difficulty names (``easy`` / ``medium`` / ``hard`` / ``other``) of geodesic
    start-goal lengths (m), any shape."""
    length = np.asarray(optimal_length, dtype=float)
    out = np.full(length.shape, OTHER_DIFFICULTY, dtype=object)
    for name, (lo, hi) in DIFFICULTY_BANDS.items():
        upper = length <= hi if name == "hard" else length < hi
        out[(length >= lo) & upper] = name
    return out


def soft_spl_terms(final_geo_m, optimal_length, path_length) -> np.ndarray:
    """Habitat's SoftSPL per episode: ``max(0, 1 - d_T / d_0) * d_0 / max(p, d_0)`` with ``d_T``
    the final geodesic distance, ``d_0`` the geodesic start-goal length and ``p`` the path taken
    (m; arrays of one shape; NaN where ``d_T`` is unknown)."""
    d = np.asarray(final_geo_m, dtype=float)
    l0 = np.asarray(optimal_length, dtype=float)
    p = np.asarray(path_length, dtype=float)
    return np.maximum(0.0, 1.0 - d / l0) * (l0 / np.maximum(p, l0))


def preset_terms(preset: ScoringPreset | str, *, end_reason, steps, path_length, optimal_length,
                 final_dist_m, final_geo_m) -> dict[str, np.ndarray]:
    """Per-episode ``success`` (bool), ``spl_term``, ``soft_spl_term`` and ``dist_to_goal_m``
    under ``preset`` (see the module docstring), from arrays of one length: ``end_reason``
    (str), ``steps`` (controls executed), ``path_length`` / ``optimal_length`` (m),
    ``final_dist_m`` / ``final_geo_m`` (the final true position's Euclidean / geodesic distance
    to the goal, m; NaN where unknown: such an episode is no success under a rule that needs it).
    """
    p = get_preset(preset) if isinstance(preset, str) else preset
    d = np.asarray(final_geo_m if p.distance == "geodesic" else final_dist_m, dtype=float)
    with np.errstate(invalid="ignore"):
        near = d <= p.radius if p.inclusive else d < p.radius
    ok = near & np.isfinite(d)
    if p.needs_stop:
        ok &= np.asarray(end_reason, dtype=object) == "reached"
    if p.step_limit is not None:
        ok &= np.asarray(steps, dtype=float) <= p.step_limit
    l0 = np.asarray(optimal_length, dtype=float)
    path = np.asarray(path_length, dtype=float)
    spl = np.where(ok, l0 / np.maximum(path, l0), 0.0)
    return {"success": ok, "spl_term": spl,
            "soft_spl_term": soft_spl_terms(final_geo_m, l0, path), "dist_to_goal_m": d}
