"""The stop decision (issue 15 section 7): an agent at the goal stops; an agent in a look-alike
room elsewhere does not stop there on first sight, whether the map holds the goal room too or
has not seen it yet; identical views are reported ambiguous. Exact renders (the level itself is
the world model), the stopper's thresholds at their defaults."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.errors import ConfigError
from navbench.geometry import CAMERA_HEIGHT, HALF_CAMERA
from navbench.localize import Localizer, LocalizerConfig
from navbench.nav.stop import GoalMatch, GoalStopper, StopConfig, match_goal
from navbench.sim.camera import RaycastCamera
from tests.localize.worlds import ExactWorld
from tests.nav.twin import SHIFT, twin_rooms

LOC = LocalizerConfig(lattice_step=0.25)
#: The goal: in room A, 0.7 m from its door, looking out through it (the view shows the corridor
#: wall and box opposite A's door, which B's door does not show).
GOAL = np.array([1.6, 1.9, -math.pi / 2 + math.radians(25)])
#: The same pose in the look-alike room B.
MIRROR = GOAL + np.array([SHIFT, 0.0, 0.0])
#: A view of A's back wall and boxes only: B shows exactly the same.
INSIDE = np.array([1.6, 2.5, math.pi / 2])


@pytest.fixture(scope="module")
def full():
    return Localizer.build(ExactWorld(twin_rooms()), HALF_CAMERA, CAMERA_HEIGHT, LOC)


@pytest.fixture(scope="module")
def without_a():
    """A map that has seen the corridor and room B but not room A (its place renders nothing)."""
    return Localizer.build(ExactWorld(twin_rooms(with_a=False)), HALF_CAMERA, CAMERA_HEIGHT, LOC)


def _view(pose):
    return RaycastCamera(twin_rooms(), HALF_CAMERA).render(pose)


def test_the_rooms_look_alike():
    cam = RaycastCamera(twin_rooms(), HALF_CAMERA)
    a, b = cam.render(INSIDE), cam.render(INSIDE + [SHIFT, 0, 0])
    np.testing.assert_allclose(a.depth, b.depth, atol=1e-4)
    np.testing.assert_allclose(a.rgb, b.rgb, atol=1e-4)
    # the goal view differs from the look-alike's only through the door (a minority of pixels)
    g, m = cam.render(GOAL), cam.render(MIRROR)
    same = np.isclose(g.depth, m.depth, atol=1e-4) & np.all(np.isclose(g.rgb, m.rgb, atol=1e-3), axis=-1)
    assert 0.6 < same.mean() < 0.95


def test_agent_at_the_goal_stops(full):
    stopper = GoalStopper(_view(GOAL))
    here = GOAL + np.array([0.05, -0.05, 0.1])
    first = stopper.update(full, here)
    assert not first.stop and first.reason == "confirming" and first.match.status == "matched"
    assert first.match.confidence >= 0.9 and first.distance < 0.1
    second = stopper.update(full, here)
    assert second.stop and second.reason == "at-goal"


def test_lookalike_room_with_goal_room_mapped_does_not_stop(full):
    stopper = GoalStopper(_view(GOAL))
    for _ in range(3):
        d = stopper.update(full, MIRROR)
        assert not d.stop and d.reason == "far"
        assert np.hypot(*(d.match.pose[:2] - GOAL[:2])) < 0.05  # the map puts the goal in A
        assert d.match.rival < d.match.confidence - 0.1  # B explains the goal view less well


def test_lookalike_room_before_the_goal_room_is_seen_does_not_stop(without_a):
    goal = _view(GOAL)
    # the agent's own pose in B is one of the map's best places for the goal image (a stopper
    # that trusts the best match could stop here); the robust search also finds the goal's own
    # place, which this map sees only through A's door, scoring the same within 0.01
    hyps = without_a.localize(goal, k=2)
    assert any(np.hypot(*(h.pose[:2] - MIRROR[:2])) < 0.05 and h.score >= hyps[0].score - 0.01
               for h in hyps)
    stopper = GoalStopper(goal)
    for _ in range(3):
        d = stopper.update(without_a, MIRROR)
        assert not d.stop and d.reason == "weak" and d.match.confidence < 0.9


def test_identical_views_are_ambiguous_and_never_stop(full):
    stopper = GoalStopper(_view(INSIDE))
    for pose in (INSIDE, INSIDE + [SHIFT, 0, 0]):
        for _ in range(2):
            d = stopper.update(full, pose)
            assert not d.stop and d.reason == "ambiguous"
            assert d.match.rival >= d.match.confidence - 0.05


def test_match_goal_statuses(full):
    m = match_goal(full, _view(GOAL))
    assert m.status == "matched" and np.hypot(*(m.pose[:2] - GOAL[:2])) < 0.05
    strict = match_goal(full, _view(GOAL), StopConfig(ambiguity_margin=0.5))
    assert strict.status == "ambiguous"  # B's 0.7-0.8 is within 0.5 of A's 1.0


def _m(status, x):
    return GoalMatch(status, np.array([x, 0.0, 0.0]), 1.0 if status == "matched" else 0.5, 0.0)


def test_consistency_rule_by_hand():
    s = GoalStopper(None, StopConfig(consistent=3))
    at = np.zeros(3)
    assert [s.decide(_m("matched", 0.0), at).reason for _ in range(2)] == ["confirming"] * 2
    assert s.decide(_m("weak", 0.0), at).reason == "weak"  # resets the count
    assert [s.decide(_m("matched", 0.0), at).stop for _ in range(3)] == [False, False, True]
    s.reset()
    s.decide(_m("matched", 0.0), at)
    s.decide(_m("matched", 0.0), at)
    d = s.decide(_m("matched", 0.2), np.array([0.2, 0, 0]))  # the place moved 0.2 m (<= 0.25): same
    assert d.stop
    s.reset()
    s.decide(_m("matched", 0.0), at)
    s.decide(_m("matched", 0.0), at)
    assert s.decide(_m("matched", 0.3), np.array([0.3, 0, 0])).reason == "confirming"  # a new place
    assert s.decide(_m("matched", 1.0), at).reason == "far"
    assert s.decide(GoalMatch("none", None, 0.0, 0.0), at).distance == math.inf


@pytest.mark.parametrize("kw", [dict(match_confidence=0.0), dict(hypotheses=1), dict(consistent=0),
                                dict(stop_radius=-1.0)])
def test_bad_config_is_a_config_error(kw):
    with pytest.raises(ConfigError, match="stop:"):
        StopConfig(**kw)
