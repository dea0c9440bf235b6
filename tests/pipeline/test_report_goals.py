"""The report's goals section as a reader sees it (issue 15 §5): success rate and SPL by
difficulty in one row per setting, the conditions all rows share said once."""

from __future__ import annotations

import pandas as pd

from navbench.report.goals import difficulty_pivot, split_conditions

BASE = "pose_quantisation=off, direction_limit=believed, collision_check=swept, map=online, mapping=perfect, pose=true"


def _row(level, diff, n, sr, lo, hi, spl, conditions=BASE):
    return {"preset": "nrns", "level": level, "estimator": "gt", "noise": "mid", "goal": "image",
            "difficulty": diff, "episodes": n, "success_rate": sr, "success_rate_ci_low": lo,
            "success_rate_ci_high": hi, "spl": spl, "soft_spl": 0.5, "final_dist_m": 1.0,
            "conditions": conditions}


def test_split_conditions_names_the_shared_part_once():
    shared, settings = split_conditions([BASE, BASE + ", ablation=no-goal", BASE + ", ablation=gt-stopper"])
    # the simulator conditions at their defaults are left out, as in every other table
    assert shared == "map=online, mapping=perfect, pose=true"
    assert settings == ["–", "ablation=no-goal", "ablation=gt-stopper"]
    assert split_conditions(["unrecorded"]) == ("", ["–"])
    assert split_conditions([]) == ("", [])


def test_pivot_cells_are_success_interval_and_spl_per_difficulty():
    abl = BASE + ", ablation=no-goal"
    table = pd.DataFrame([
        _row("house-1", "easy", 2, 1.0, 0.158, 1.0, 0.9), _row("house-1", "hard", 2, 0.5, 0.0126, 0.987, 0.25),
        _row("house-1", "all", 4, 0.75, 0.194, 0.994, 0.575),
        _row("house-1", "easy", 2, 0.5, 0.0126, 0.987, 0.4, abl), _row("house-1", "all", 2, 0.5, 0.0126, 0.987, 0.4, abl),
        _row("all", "easy", 2, 1.0, 0.158, 1.0, 0.9), _row("all", "hard", 2, 0.5, 0.0126, 0.987, 0.25),
        _row("all", "all", 4, 0.75, 0.194, 0.994, 0.575),
        _row("all", "easy", 2, 0.5, 0.0126, 0.987, 0.4, abl), _row("all", "all", 2, 0.5, 0.0126, 0.987, 0.4, abl),
    ])
    pivot, shared = difficulty_pivot(table)
    assert shared == "map=online, mapping=perfect, pose=true"
    assert list(pivot.columns) == ["level", "estimator", "noise", "goal", "setting", "easy", "hard", "all", "episodes"]
    full = pivot[(pivot["level"] == "house-1") & (pivot["setting"] == "–")].iloc[0]
    assert full["easy"] == "1.00 [0.16, 1.00] / 0.90"
    assert full["hard"] == "0.50 [0.01, 0.99] / 0.25"
    assert full["all"] == "0.75 [0.19, 0.99] / 0.57"  # 0.575 is 0.57499... in binary
    assert full["episodes"] == 4
    ablated = pivot[(pivot["level"] == "all") & (pivot["setting"] == "ablation=no-goal")].iloc[0]
    assert ablated["hard"] == "–" and ablated["episodes"] == 2  # no hard task ran under it
    assert len(pivot) == 4


def test_pivot_of_one_setting_has_no_setting_column():
    table = pd.DataFrame([_row("house-1", "easy", 1, 1.0, 0.025, 1.0, 0.8), _row("house-1", "all", 1, 1.0, 0.025, 1.0, 0.8)])
    pivot, shared = difficulty_pivot(table)
    assert "setting" not in pivot.columns and shared == "map=online, mapping=perfect, pose=true"
    assert pivot.iloc[0]["all"] == "1.00 [0.03, 1.00] / 0.80"
