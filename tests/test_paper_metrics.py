"""The paper's measurements (bench/metrics.py) on small fixtures with known answers: the ridge and mean of Fig. 1F's
distribution, U_eq and the steps to 0.8 U_eq of Fig. 4C-D, and the remembered Ubar beside the trial one."""

import math

import numpy as np
import pandas as pd
import pytest

from morphbench.bench import metrics as M


def test_the_ridge_is_the_mode_of_the_density_not_the_mean():
    rng = np.random.default_rng(1)
    assert M.ridge(rng.normal(4.5, 0.3, 4000)) == pytest.approx(4.5, abs=0.05)
    # most trials near the peak, a long tail of bad ones: the ridge stays at the peak, the mean does not
    skewed = np.r_[rng.normal(4.6, 0.2, 600), rng.uniform(-4.0, 4.0, 400)]
    assert M.ridge(skewed) == pytest.approx(4.6, abs=0.1)
    assert skewed.mean() < 3.0
    # two modes: the taller one wins
    assert M.ridge(np.r_[rng.normal(1.0, 0.2, 300), rng.normal(4.5, 0.2, 700)]) == pytest.approx(4.5, abs=0.1)
    assert M.ridge(np.r_[rng.normal(1.0, 0.2, 700), rng.normal(4.5, 0.2, 300)]) == pytest.approx(1.0, abs=0.1)


def test_the_ridge_of_equal_values_is_that_value_and_of_nothing_nan():
    assert M.ridge([2.0, 2.0, 2.0]) == pytest.approx(2.0, abs=M.RIDGE_BANDWIDTH / 20)
    assert M.ridge([1.0, 3.0], bandwidth=0.1) in (pytest.approx(1.0, abs=0.01), pytest.approx(3.0, abs=0.01))
    assert math.isnan(M.ridge([])) and math.isnan(M.ridge([np.nan, np.inf]))
    assert math.isnan(M.ridge([1.0], bandwidth=0.0))


def learning_steps(levels, k0=5.0, steps=60, sd=0.0, seed=0) -> pd.DataFrame:
    """One row per run and step: ubar_true = level (1 - exp(-k / k0)) plus noise, one run per level."""
    rng = np.random.default_rng(seed)
    k = np.arange(steps + 1)
    rows = [pd.DataFrame({"run_id": f"r{i}", "step": k,
                          "ubar_true": level * (1 - np.exp(-k / k0)) + rng.normal(0, sd, len(k))})
            for i, level in enumerate(levels)]
    return pd.concat(rows, ignore_index=True)


def test_the_step_distribution_takes_every_run_and_step_after_step_20():
    steps = learning_steps([4.0, 5.0], k0=2.0)
    found = M.step_distribution(steps)
    late = steps[steps.step > 20].ubar_true
    assert found["values"] == 2 * 40 and found["mean"] == pytest.approx(late.mean())
    assert found["q99"] == pytest.approx(np.quantile(late, 0.99))
    assert found["ridge"] in (pytest.approx(4.0, abs=0.02), pytest.approx(5.0, abs=0.02))
    assert M.step_distribution(steps, after=100)["values"] == 0 and math.isnan(M.step_distribution(steps, 100)["ridge"])


def test_equilibrium_fits_the_average_curve_and_counts_runs_reaching_its_threshold():
    # levels 3 and 5 average to 4 with k_0 = 5: U_eq 4, threshold 3.2, which the run levelling at 3 never reaches
    steps = learning_steps([3.0, 5.0], k0=5.0, steps=100)
    found = M.equilibrium(steps)
    assert found["u_eq"] == pytest.approx(4.0, rel=1e-3) and found["k_0"] == pytest.approx(5.0, rel=1e-3)
    assert found["plateau"] and found["threshold"] == pytest.approx(3.2, rel=1e-3)
    # 5 (1 - exp(-k / 5)) >= 3.2 first at k = ceil(-5 ln(1 - 0.64)) = 6
    assert found["steps_to_threshold"] == 6 and found["reached_fraction"] == 0.5
    assert math.isnan(found["steps_to_threshold_std"])  # one run reached it


def test_without_a_plateau_there_is_no_threshold_to_reach():
    found = M.equilibrium(learning_steps([4.0, 4.0], k0=200.0, steps=60))
    assert not found["plateau"] and math.isnan(found["threshold"])
    assert math.isnan(found["steps_to_threshold"]) and math.isnan(found["reached_fraction"])


def test_the_remembered_ubar_averages_the_living_units_memory_beside_their_trials():
    units = pd.DataFrame({"run_id": "r", "step": [0, 0, 1, 1, 1], "unit": [1, 2, 1, 2, 3],
                          "u_measured": [1.0, 3.0, 2.0, 2.0, np.nan], "u_true": [1.5, 2.5, 2.0, 1.0, 0.0],
                          "u_memory": [1.0, 3.0, 4.0, 2.0, 9.0]})
    table = M.memory_ubar(units)
    assert table.step.tolist() == [0, 1]
    assert table.ubar_memory.tolist() == [2.0, 3.0]  # the dead unit 3 (no measurement) is left out
    assert table.ubar_true.tolist() == [2.0, 1.5] and table.ubar.tolist() == [2.0, 2.0]
    assert M.memory_ubar(units.drop(columns="u_memory")).empty  # units stored before u_memory existed
