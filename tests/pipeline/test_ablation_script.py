"""docs/data/ablation/ablation.py's intervals and settings (the grid itself runs through run_profile,
tested elsewhere)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest

from tests.scripts import load_script

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def ablation():
    return load_script("docs/data/ablation/ablation.py")


def test_clopper_pearson_edges(ablation):
    # 0 of n: [0, 1 - (alpha/2)^(1/n)]; n of n: [(alpha/2)^(1/n), 1]
    lo, hi = ablation.success_ci(0, 10)
    assert lo == 0.0 and hi == pytest.approx(1 - 0.025 ** (1 / 10), abs=1e-9)
    lo, hi = ablation.success_ci(20, 20)
    assert lo == pytest.approx(0.025 ** (1 / 20), abs=1e-9) and hi == 1.0


def test_bootstrap_is_stratified_by_level(ablation):
    """Each level constant: a stratified resample keeps every level's count, so the mean never
    moves (an unstratified bootstrap would spread)."""
    values = np.array([1.0] * 3 + [0.0] * 7)
    strata = np.array(["a"] * 3 + ["b"] * 7)
    assert ablation.mean_ci(values, strata) == (pytest.approx(0.3), pytest.approx(0.3))
    lo, hi = ablation.mean_ci(values, np.zeros(10))
    assert lo < 0.3 < hi
    d, lo, hi = ablation.paired_ci([1.0, 0.5, 0.8], [0.5, 0.5, 0.3], ["a", "a", "b"])
    assert d == pytest.approx(1.0 / 3) and lo <= d <= hi


def test_settings_one_per_condition_value_then_all(ablation):
    args = argparse.Namespace(base=[], all_on=True, condition=[
        "pose_quantisation=truncate", "pose_quantisation=round", "direction_limit=true"])
    labels = [label for label, _ in ablation.settings_of(args)]
    assert labels == ["baseline", "pose_quantisation=truncate", "pose_quantisation=round",
                      "direction_limit=true", "all"]
    assert ablation.settings_of(args)[-1][1] == {"pose_quantisation": "round", "direction_limit": "true"}
    base = argparse.Namespace(base=["collision_check=endpoint"], all_on=False, condition=[])
    assert ablation.settings_of(base) == [("base:collision_check=endpoint", {"collision_check": "endpoint"})]
    assert ablation.main(["--condition", "nosuch=1", "--levels", "house-1"]) == 2


def test_only_all_runs_the_baseline_and_all_together(ablation):
    args = argparse.Namespace(base=[], all_on=False, only_all=True, condition=[
        "pose_quantisation=round", "direction_limit=true", "collision_check=endpoint"])
    assert ablation.settings_of(args) == [
        ("baseline", {}),
        ("all", {"pose_quantisation": "round", "direction_limit": "true", "collision_check": "endpoint"})]
