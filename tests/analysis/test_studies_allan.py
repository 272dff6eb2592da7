"""Allan deviation against its closed forms: white noise σ/√m, a linear drift rate·τ/√2."""

import numpy as np
import pytest

from analysis.studies.allan import allan_deviation
from contactrig.core.validation import SettingError


def test_white_noise_falls_as_one_over_sqrt_m():
    rng = np.random.default_rng(7)
    sigma = 2.5e-9
    y = rng.normal(0.0, sigma, 200_000)
    res = allan_deviation(y, 0.1, m=np.array([1, 4, 16, 64]))
    expected = sigma / np.sqrt(res.m)
    # relative SD of an Allan estimate with ~N/m independent pairs is about 1/sqrt(N/m)
    tol = 4.0 / np.sqrt(y.size / res.m)
    assert np.all(np.abs(res.adev / expected - 1) < tol)
    np.testing.assert_allclose(res.tau_s, 0.1 * res.m)


def test_linear_drift_gives_rate_tau_over_sqrt2():
    rate = 3.0  # units per second
    dt = 0.5
    y = rate * dt * np.arange(1000)
    res = allan_deviation(y, dt, m=np.array([1, 2, 8]))
    np.testing.assert_allclose(res.adev, rate * res.tau_s / np.sqrt(2), rtol=1e-9)


def test_bad_input_is_named():
    with pytest.raises(SettingError, match="interval_s"):
        allan_deviation(np.ones(10), 0.0)
    with pytest.raises(SettingError, match="y"):
        allan_deviation(np.array([1.0, np.nan, 2.0, 3.0]), 1.0)
    with pytest.raises(SettingError, match="m ="):
        allan_deviation(np.ones(10), 1.0, m=np.array([6]))
