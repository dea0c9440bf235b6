"""The stop decision of image-goal navigation (issue 15 section 3): no oracle, the map decides.

Math layer. The agent holds a world model (any :class:`~navbench.worldmodel.base.WorldModel`:
the online map, a fitted or the true map) wrapped in a :class:`~navbench.localize.Localizer`,
its estimated pose and the goal image (an RGB-D :class:`~navbench.geometry.Frame` taken at the
goal). It decides "I am at the goal" in three tests, each against a way a look-alike place
fools a stopper that trusts the first match:

1. **The goal view must be explained by the map** (:func:`match_goal`): the localiser's best
   pose for the goal image must have ``confidence >= match_confidence`` (0.9): at least 90 %
   of the goal image's sampled pixels agree in depth and colour with the map's render there.
   A room that looks like the goal room explains its inside but not what the goal image shows
   beyond it (through the door, the next room's wall); in a map that has not seen the goal's
   surroundings, those pixels render nothing and are not inliers either. The best pose alone
   (RNR-Map's heat-map maximum) would have stopped there.
2. **The match must be unique** (the localiser's ambiguity report): no other place farther than
   ``distinct_radius`` (0.5 m) from it may reach ``confidence >= best - ambiguity_margin``
   (0.05). Two rooms that show the goal image equally well (identical rooms, a view of their
   inside only) are ambiguous: the stopper refuses to stop in either, rather than flip a coin;
   exploring on (the map grows until one of them explains the view better) is the caller's
   move. This loses the episodes whose goal view cannot tell two places apart.
3. **The decision must hold** (:class:`GoalStopper`): a stop needs ``consistent`` (2)
   consecutive updates that each match the goal (tests 1 and 2) at the same place (within
   ``consistent_radius``, 0.25 m), the last with the estimated pose within ``stop_radius``
   (0.25 m) of it. Updates far from the goal count (a match seen from afar, confirmed on
   arrival from another pose and a grown map); a failed match resets the count, so a match
   that new observations contradict (the look-alike room seen from its doorway) never stops.

Thresholds were set a priori (90 % of the goal view explained, the localiser's own 5 cm / 3 %
depth and 0.1 colour inlier tests), not tuned on any level reported. ``docs/data/image-goals/stop_calibrate.py``
checks them on ``tune-house`` (seed 1234): on its voxelised true map, 39 of 40 random views were
matched to the right place with confidence 0.945-0.999, and the one wrong best place reached
0.909. So a wrong place can pass test 1 alone; tests 2 and 3 are there for that.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navbench.errors import ConfigError
from navbench.geometry import Frame


@dataclass(frozen=True)
class StopConfig:
    """Stop-decision settings (module docstring); lengths in metres."""

    match_confidence: float = 0.9   # share of the goal view the map must explain at the goal pose
    ambiguity_margin: float = 0.05  # a rival place within this confidence of the best: ambiguous
    distinct_radius: float = 0.5    # hypotheses farther apart than this are different places
    hypotheses: int = 4             # hypotheses asked of the localiser (the best and its rivals)
    stop_radius: float = 0.25       # the estimated pose must be this close to the matched goal
    consistent: int = 2             # consecutive matching updates needed to stop
    consistent_radius: float = 0.25  # successive matches this close are the same place

    def __post_init__(self):
        if not 0.0 < self.match_confidence <= 1.0:
            raise ConfigError(f"stop: match_confidence must be in (0, 1], got {self.match_confidence}")
        if self.hypotheses < 2 or self.consistent < 1:
            raise ConfigError("stop: hypotheses must be >= 2 and consistent >= 1")
        if min(self.ambiguity_margin, self.distinct_radius, self.stop_radius, self.consistent_radius) < 0:
            raise ConfigError("stop: margins and radii must be >= 0")


@dataclass(frozen=True)
class GoalMatch:
    """Where the map puts the goal image. ``status``: ``"matched"`` (tests 1 and 2 pass),
    ``"weak"`` (best confidence below ``match_confidence``), ``"ambiguous"`` (a rival place),
    ``"none"`` (no hypothesis). ``pose (3,)`` the best hypothesis (``None`` for ``"none"``),
    ``confidence`` its confidence, ``rival`` the best distinct rival's confidence (0 if none)."""

    status: str
    pose: np.ndarray | None
    confidence: float
    rival: float


@dataclass(frozen=True)
class StopDecision:
    """``stop``: stop now. ``reason``: ``"at-goal"``, ``"confirming"`` (matched and close, fewer
    than ``consistent`` updates so far), ``"far"`` (matched, the agent is farther than
    ``stop_radius``), or the match status (``"weak"``, ``"ambiguous"``, ``"none"``).
    ``match``: this update's :class:`GoalMatch`; ``distance``: agent to matched goal (m, ``inf``
    without a pose)."""

    stop: bool
    reason: str
    match: GoalMatch
    distance: float


def match_goal(localizer, goal: Frame, config: StopConfig = StopConfig()) -> GoalMatch:
    """Tests 1 and 2 of the module docstring on ``localizer`` (a
    :class:`~navbench.localize.Localizer` of the current world model)."""
    hyps = localizer.localize(goal, k=config.hypotheses)
    if not hyps:
        return GoalMatch("none", None, 0.0, 0.0)
    best = max(hyps, key=lambda h: (h.confidence, h.score))
    rivals = [h.confidence for h in hyps
              if math.hypot(*(h.pose[:2] - best.pose[:2])) > config.distinct_radius]
    rival = max(rivals, default=0.0)
    pose = np.asarray(best.pose, np.float64).copy()
    if best.confidence < config.match_confidence:
        return GoalMatch("weak", pose, float(best.confidence), float(rival))
    if rival >= best.confidence - config.ambiguity_margin:
        return GoalMatch("ambiguous", pose, float(best.confidence), float(rival))
    return GoalMatch("matched", pose, float(best.confidence), float(rival))


class GoalStopper:
    """Test 3 of the module docstring: call :meth:`update` once per decision step."""

    def __init__(self, goal: Frame, config: StopConfig = StopConfig()):
        self.goal = goal
        self.config = config
        self._streak = 0
        self._last: np.ndarray | None = None

    def reset(self) -> None:
        self._streak = 0
        self._last = None

    def update(self, localizer, pose) -> StopDecision:
        """Match the goal in ``localizer``'s map and decide for the estimated ``pose (3,)``."""
        return self.decide(match_goal(localizer, self.goal, self.config), pose)

    def decide(self, match: GoalMatch, pose) -> StopDecision:
        """The decision for a precomputed ``match`` (what :meth:`update` does after matching)."""
        cfg = self.config
        xy = np.asarray(pose, np.float64)[:2]
        dist = math.inf if match.pose is None else float(np.hypot(*(match.pose[:2] - xy)))
        if match.status != "matched":
            self.reset()
            return StopDecision(False, match.status, match, dist)
        same = self._last is not None and float(np.hypot(*(match.pose[:2] - self._last))) <= cfg.consistent_radius
        self._streak = self._streak + 1 if same else 1
        self._last = match.pose[:2].copy()
        if dist > cfg.stop_radius:
            return StopDecision(False, "far", match, dist)
        if self._streak >= cfg.consistent:
            return StopDecision(True, "at-goal", match, dist)
        return StopDecision(False, "confirming", match, dist)
