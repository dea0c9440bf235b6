"""Scoring presets (issue 15 §4) against hand-computed episodes, and the final distances."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from navbench.errors import ConfigError
from navbench.nav.metrics import FinalGeodesic, score_episode
from navbench.nav.presets import check_preset_steps, difficulty, get_preset, preset_terms, soft_spl_terms

# Every episode: optimal (geodesic start-goal) length l = 4 m. Columns: end_reason, steps, path
# taken p (m), final Euclidean distance, final geodesic distance (m).
EPISODES = [
    ("reached", 100, 5.0, 0.3, 0.3),     # 0: stopped 0.3 m away
    ("stuck", 80, 3.5, 0.35, 0.35),      # 1: collided 0.35 m away: no stop
    ("reached", 501, 6.0, 0.1, 0.1),     # 2: stopped, but after 501 steps
    ("reached", 500, 4.0, 1.0, 1.5),     # 3: stopped exactly 1 m away (Euclidean), 500 steps
    ("reached", 50, 4.4, 0.15, 0.19),    # 4: stopped 0.19 m away (geodesic)
    ("reached", 50, 4.0, 0.2, 0.2),      # 5: stopped exactly 0.2 m away (geodesic)
    ("step-limit", 500, 8.0, 5.0, 5.0),  # 6: lost, farther than the start
    ("reached", 60, 4.0, float("nan"), float("nan")),  # 7: stored before final distances
]
L0 = 4.0

# hand-computed (success, SPL term) per preset
WANT = {
    "paper": [(True, 4 / 5), (True, 1.0), (True, 4 / 6), (False, 0.0), (True, 4 / 4.4), (True, 1.0),
              (False, 0.0), (False, 0.0)],
    "nrns": [(True, 4 / 5), (False, 0.0), (False, 0.0), (True, 1.0), (True, 4 / 4.4), (True, 1.0),
             (False, 0.0), (False, 0.0)],
    "habitat": [(False, 0.0), (False, 0.0), (False, 0.0), (False, 0.0), (True, 4 / 4.4), (False, 0.0),
                (False, 0.0), (False, 0.0)],
}
# habitat SoftSPL: max(0, 1 - d_geo / l) * l / max(p, l)
SOFT = [(1 - 0.3 / 4) * 4 / 5, (1 - 0.35 / 4) * 1.0, (1 - 0.1 / 4) * 4 / 6, (1 - 1.5 / 4) * 1.0,
        (1 - 0.19 / 4) * 4 / 4.4, (1 - 0.2 / 4) * 1.0, 0.0, float("nan")]


def _terms(preset):
    cols = list(zip(*EPISODES))
    return preset_terms(preset, end_reason=np.array(cols[0], dtype=object), steps=np.array(cols[1]),
                        path_length=np.array(cols[2]), optimal_length=np.full(len(EPISODES), L0),
                        final_dist_m=np.array(cols[3]), final_geo_m=np.array(cols[4]))


@pytest.mark.parametrize("preset", ["paper", "nrns", "habitat"])
def test_success_and_spl_of_hand_computed_episodes(preset):
    t = _terms(preset)
    assert t["success"].tolist() == [s for s, _ in WANT[preset]]
    np.testing.assert_allclose(t["spl_term"], [v for _, v in WANT[preset]], rtol=0, atol=1e-15)
    np.testing.assert_allclose(t["soft_spl_term"], SOFT, rtol=0, atol=1e-15)  # same under every preset
    d = [e[4] if preset == "habitat" else e[3] for e in EPISODES]
    np.testing.assert_array_equal(t["dist_to_goal_m"], d)


def test_paper_preset_is_the_stored_score_rule():
    """The paper's rule is score_episode's: closer than 2 L, no stop, the exact l_i."""
    rec = SimpleNamespace(true_poses=np.array([[0, 0, 0.0], [3, 0, 0.0], [3, 3.7, 0.0]]),
                          est_poses=np.zeros((3, 3)), target=np.array([3.0, 4.0]), optimal_length=5.0,
                          end_reason="stuck", collided=True)
    s = score_episode(rec)
    assert s.final_dist_m == pytest.approx(0.3) and math.isnan(s.final_geo_m)
    t = preset_terms("paper", end_reason=np.array(["stuck"], dtype=object), steps=np.array([2]),
                     path_length=np.array([s.path_length]), optimal_length=np.array([5.0]),
                     final_dist_m=np.array([s.final_dist_m]), final_geo_m=np.array([np.nan]))
    assert bool(t["success"][0]) == s.success is True
    assert t["spl_term"][0] == s.spl_term  # bit for bit


def test_soft_spl_is_zero_beyond_the_start_distance_and_needs_no_stop():
    assert soft_spl_terms([8.0], [4.0], [2.0])[0] == 0.0
    assert soft_spl_terms([0.0], [4.0], [2.0])[0] == 1.0  # arrived by a path shorter than l: capped
    assert soft_spl_terms([1.0], [4.0], [8.0])[0] == pytest.approx(0.75 * 0.5)


def test_difficulty_bands_nrns():
    got = difficulty([1.49, 1.5, 2.99, 3.0, 4.99, 5.0, 10.0, 10.01])
    assert got.tolist() == ["other", "easy", "easy", "medium", "medium", "hard", "hard", "other"]


def test_unknown_preset_and_step_limit_are_one_line_errors():
    with pytest.raises(ConfigError, match="unknown scoring preset 'nrn'.*paper, nrns, habitat"):
        get_preset("nrn")
    check_preset_steps("nrns", 500, "x.toml")
    check_preset_steps("paper", 5000, "x.toml")
    with pytest.raises(ConfigError, match="x.toml: scoring preset 'habitat' allows 500 steps.*max_steps is 501"):
        check_preset_steps("habitat", 501, "x.toml")


def test_final_geodesic_around_a_box_exact():
    """tiny level: a 0.4 m box at x 1.3-1.7, y 1.0-1.4; the agent's disc (r = 0.1) goes around it."""
    from tests.pipeline.test_stages import tiny_level

    geo = FinalGeodesic(tiny_level())
    # tangent to the rounded corner, arc, 0.4 m along the top, arc, tangent (symmetric)
    d = math.sqrt(0.3 ** 2 + 0.2 ** 2)
    tangent = math.sqrt(d * d - 0.01)
    ang_ca = math.atan2(-0.2, -0.3) % (2 * math.pi)
    arc = 0.1 * (ang_ca - math.acos(0.1 / d) - math.pi / 2)
    exact = 2 * (tangent + arc) + 0.4
    got = geo((1.0, 1.2), (2.0, 1.2))
    # the circumscribed corner polygons (11.25 deg) lengthen the arcs by at most 0.32 %
    assert exact <= got <= exact + 0.0033 * 2 * arc + 1e-9
    # a final position the disc does not fit at (0.05 m from the box): the distance of a point
    point = math.hypot(0.05, 0.2) + 0.4 + math.hypot(0.3, 0.2)
    assert geo((1.25, 1.2), (2.0, 1.2)) == pytest.approx(point, abs=1e-12)
    assert geo((2.0, 1.2), (2.0, 1.2)) == 0.0
