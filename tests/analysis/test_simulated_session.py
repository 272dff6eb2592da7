"""The simulated session (``--sim``): re-seating factors mean-one log-normal, seeded, indexed by block number;
the bench's speed setting. The whole simulated session (R = R_s + f·ζh/A from the rig) is checked end to end
through the CLI in tests/daq/test_commands.py."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from analysis.simulated_session import SimulatedRigBench, repeat_factors
from contactrig.core.validation import SettingError
from daq.plan import DEFAULT_SIM_REPEAT_SD
from daq.table_import import tab1_path


@pytest.mark.parametrize("sd", [0.05, 0.15, 0.5])
def test_factors_are_mean_one_lognormal_with_the_given_log_sd(sd):
    n = 40_000
    f = repeat_factors(n, sd, seed=3)
    assert np.all(f > 0)
    log = np.log(f)
    # sampling errors of a normal sample's mean and SD: σ/√n and σ/√(2n); 5 of them is a generous bound
    assert abs(log.mean() + sd**2 / 2) < 5 * sd / math.sqrt(n)
    assert abs(log.std(ddof=1) - sd) < 5 * sd / math.sqrt(2 * n)
    # E[f] = 1 exactly for the log-normal with μ = −σ²/2; SD of f is sqrt(exp(σ²) − 1)
    assert abs(f.mean() - 1) < 5 * math.sqrt(math.expm1(sd**2) / n)


def test_factors_are_seeded_and_depend_only_on_the_block_number():
    a = repeat_factors(48, 0.15, seed=1)
    np.testing.assert_array_equal(a, repeat_factors(48, 0.15, seed=1))
    np.testing.assert_array_equal(a[:10], repeat_factors(10, 0.15, seed=1))  # a resumed plan gets the same f_b
    assert not np.array_equal(a, repeat_factors(48, 0.15, seed=2))
    np.testing.assert_array_equal(repeat_factors(5, 0.0, seed=1), np.ones(5))


def test_default_scatter_is_that_of_tab1_independent_repeats():
    """Tab. 1: M4 is the mean of M1–M3 and M5, M6 are offset copies, so M1–M3 are the independent repeats; their
    relative SD per weight (pooled over the weights) is the default ``sim_repeat_sd`` to within 0.02."""
    t = pd.read_csv(tab1_path())
    v = t[["M1", "M2", "M3"]].to_numpy()
    assert np.sum(np.abs(t["M4"] - v.mean(axis=1)) < 1e-4) >= 7  # M4 = mean(M1–M3) at 7 of 8 weights
    rel = v.std(axis=1, ddof=1) / v.mean(axis=1)
    log_sd = math.sqrt(np.mean(np.log(v).var(axis=1, ddof=1)))
    assert abs(np.median(rel) - DEFAULT_SIM_REPEAT_SD) < 0.02 and abs(log_sd - DEFAULT_SIM_REPEAT_SD) < 0.02


@pytest.mark.parametrize("speed", [0.0, -1.0, float("nan")])
def test_sim_speed_must_be_positive(speed):
    with pytest.raises(SettingError, match="--sim-speed"):
        SimulatedRigBench(speed)


def test_sim_speed_sets_the_time_scale():
    assert SimulatedRigBench(4.0).time_scale == 0.25
    assert SimulatedRigBench(math.inf).time_scale == 0.0
    assert SimulatedRigBench().simulated
