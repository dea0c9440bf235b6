"""Intervals of issue 16: exact binomial success intervals, the level-stratified bootstrap, and
the paired differences built on them."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from navbench.nav.metrics import clopper_pearson, stratified_bootstrap_ci, stratified_mean


def test_clopper_pearson_known_and_closed_form_values():
    # textbook value (e.g. Brown, Cai & DasGupta 2001): 3 of 10 -> [0.0667, 0.6525]
    low, high = clopper_pearson(3, 10)
    assert low == pytest.approx(0.06673951, abs=1e-7) and high == pytest.approx(0.65245285, abs=1e-7)
    # the Beta-quantile definition
    assert low == pytest.approx(stats.beta.ppf(0.025, 3, 8), rel=1e-9)
    assert high == pytest.approx(stats.beta.ppf(0.975, 4, 7), rel=1e-9)
    # k = 0 and k = n in closed form: 1 - (alpha/2)^(1/n) and (alpha/2)^(1/n)
    assert clopper_pearson(0, 30) == (0.0, pytest.approx(1 - 0.025 ** (1 / 30), rel=1e-9))
    assert clopper_pearson(30, 30) == (pytest.approx(0.025 ** (1 / 30), rel=1e-9), 1.0)
    assert clopper_pearson(1, 1, level=0.9) == (pytest.approx(0.05), 1.0)
    assert all(np.isnan(clopper_pearson(0, 0)))
    with pytest.raises(ValueError):
        clopper_pearson(5, 4)


def test_stratified_bootstrap_hand_case():
    """Strata {1, 1, 1} and {0, 1}: the first is constant under resampling, so the pooled mean is
    (3 + s) / 5 with s ~ Binomial(2, 1/2): 0.6, 0.8, 1.0 with probabilities 1/4, 1/2, 1/4. Its
    2.5 % and 97.5 % quantiles are 0.6 and 1.0 exactly. An unstratified bootstrap of the five
    values would also draw resamples with fewer than three ones (P = 0.317), so its interval
    reaches below 0.6."""
    strata = [[1.0, 1.0, 1.0], [0.0, 1.0]]
    assert stratified_mean(strata) == pytest.approx(0.8)
    assert stratified_bootstrap_ci(strata, method="percentile") == (pytest.approx(0.6), pytest.approx(1.0))
    assert stratified_bootstrap_ci(strata) == (pytest.approx(0.6), pytest.approx(1.0))  # BCa
    pooled = stats.bootstrap(([1.0, 1.0, 1.0, 0.0, 1.0],), np.mean, method="percentile",
                             n_resamples=2000, rng=np.random.default_rng(0)).confidence_interval
    assert pooled.low < 0.6
    # a one-value stratum is constant too: 1/3 * 1 + 2/3 * mean({0, 1} resampled)
    assert stratified_bootstrap_ci([[1.0], [0.0, 1.0]], method="percentile") == \
        (pytest.approx(1 / 3), pytest.approx(1.0))


@pytest.mark.parametrize("method", ["BCa", "percentile"])
def test_one_stratum_is_scipys_one_sample_bootstrap(method):
    x = np.random.default_rng(3).random(150)
    ref = stats.bootstrap((x,), np.mean, method=method, n_resamples=2000,
                          rng=np.random.default_rng(7)).confidence_interval
    assert stratified_bootstrap_ci([x], method=method, seed=7) == (ref.low, ref.high)


def test_stratified_bootstrap_is_seeded_and_handles_degenerate_input():
    rng = np.random.default_rng(0)
    strata = [rng.random(40), rng.random(25) * 0.5]
    a = stratified_bootstrap_ci(strata, seed=4)
    assert a == stratified_bootstrap_ci(strata, seed=4) and a != stratified_bootstrap_ci(strata, seed=5)
    assert a[0] < stratified_mean(strata) < a[1]
    assert stratified_bootstrap_ci([[0.5, 0.5], [0.5]]) == (0.5, 0.5)
    assert stratified_bootstrap_ci([[np.nan, 0.2, 0.2]]) == (0.2, 0.2)
    assert all(np.isnan(stratified_bootstrap_ci([[], [np.nan]])))


def _claim_frame() -> pd.DataFrame:
    """Two levels x 4 tasks; ours 0.9 everywhere, no-map 0.5 + 0.1 task, dynamics 0.4 but task 3
    missing; plus one ours episode of another condition (another map) that has no partner."""
    rows = []
    for lvl in ("a", "b"):
        for t in range(4):
            for est, spl in (("ours", 0.9), ("no-map", 0.5 + 0.1 * t), ("dynamics", 0.4)):
                if est == "dynamics" and t == 3:
                    continue
                rows.append(dict(cell_key=f"{lvl}-{est}", level=lvl, map_key="m", task_set_key="ts",
                                 task_id=t, estimator=est, estimator_options={}, noise="low", seed=0,
                                 success=spl > 0.55, spl_term=spl, condition_key=f"cond-{lvl}"))
    rows.append(dict(rows[0], cell_key="other-map", map_key="m2", condition_key="cond-a-m2"))
    return pd.DataFrame(rows)


def test_paired_differences_on_a_constructed_table():
    from navbench.results.score import paired_differences, with_identities

    p = paired_differences(with_identities(_claim_frame()), n_boot=500, seed=1)
    assert list(p["comparison"].unique()) == ["ours - no-map", "ours - dynamics"]
    assert list(p["level"]) == ["a", "a", "b", "b", "all", "all"]
    row = p[(p["level"] == "a") & (p["other"] == "no-map")].iloc[0]
    # differences 0.4, 0.3, 0.2, 0.1: mean 0.25; success ours 1, no-map 0,1,1,1 -> 0.25
    assert (row["pairs"], row["unpaired_reference"], row["unpaired_other"]) == (4, 1, 0)
    assert row["spl_diff"] == pytest.approx(0.25) and row["success_diff"] == pytest.approx(0.25)
    assert row["reference_spl"] == pytest.approx(0.9) and row["other_spl"] == pytest.approx(0.65)
    d = 0.9 - np.array([0.5 + 0.1 * t for t in range(4)])  # as stored (BCa counts exact ties)
    assert (row["spl_diff_ci_low"], row["spl_diff_ci_high"]) == \
        pytest.approx(stratified_bootstrap_ci([d], n_resamples=500, seed=1))
    dyn = p[(p["level"] == "all") & (p["other"] == "dynamics")].iloc[0]
    assert (dyn["pairs"], dyn["unpaired_reference"]) == (6, 3)  # task 3 twice + the other map
    assert dyn["spl_diff"] == pytest.approx(0.5) and dyn["spl_diff_ci_low"] == pytest.approx(0.5)
    allnm = p[(p["level"] == "all") & (p["other"] == "no-map")].iloc[0]
    # pooled: pairs resampled within each level (the stratified bootstrap of the two levels)
    assert (allnm["spl_diff_ci_low"], allnm["spl_diff_ci_high"]) == \
        pytest.approx(stratified_bootstrap_ci([d, d], n_resamples=500, seed=1))
    assert allnm["spl_diff_ci_low"] > 0


def test_summarise_uses_the_exact_and_stratified_intervals():
    from navbench.results.score import summarise, with_identities

    f = with_identities(_claim_frame()).assign(loc_rmse_m=0.1, rot_rmse_deg=1.0, step_ms=2.0)
    t = summarise(f, n_boot=300, seed=2)
    nm = t[(t["level"] == "all") & (t["estimator"] == "no-map")].iloc[0]
    assert (nm["success_rate_ci_low"], nm["success_rate_ci_high"]) == pytest.approx(clopper_pearson(6, 8))
    spl = [np.array([0.5, 0.6, 0.7, 0.8])] * 2
    assert (nm["spl_ci_low"], nm["spl_ci_high"]) == pytest.approx(stratified_bootstrap_ci(spl, n_resamples=300, seed=2))
    ours_a = t[(t["level"] == "a") & (t["estimator"] == "ours")].iloc[0]
    assert ours_a["setups"] == 2 and ours_a["episodes"] == 5  # two maps: two setups, warned
