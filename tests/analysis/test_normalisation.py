"""R/R₀ and its uncertainty: exact first point, hand formula, Monte Carlo with correlated series."""

import numpy as np
import pytest

from analysis.measured import MeasuredCurve
from analysis.normalisation import normalise_measured, normalise_simulated
from contactrig.core.validation import SettingError


def test_first_point_is_exactly_one_with_zero_uncertainty():
    rng = np.random.default_rng(0)
    v = 5e-3 * (1 + 0.05 * rng.normal(size=(4, 6)))
    for paired in (True, False):
        nc = normalise_measured(MeasuredCurve([1.0, 2.0, 3.0, 4.0], v, paired=True), paired=paired)
        assert nc.ratio[0] == 1.0
        assert nc.se[0] == 0.0
        assert np.all(nc.cov[0] == 0.0) and np.all(nc.cov[:, 0] == 0.0)
        assert np.all(nc.se[1:] > 0)


def test_independent_repeats_hand_formula():
    v = np.array([[10.0, 12.0, 11.0], [5.0, 6.0, 4.0]])
    nc = normalise_measured(MeasuredCurve([1.0, 2.0], v), paired=False)
    y0, y1 = 11.0, 5.0
    var0, var1 = 1.0 / 3, 1.0 / 3  # sample variance 1 over 3 repeats, each
    expected = (y1 / y0) * np.sqrt(var1 / y1**2 + var0 / y0**2)
    assert nc.ratio[1] == pytest.approx(y1 / y0)
    assert nc.se[1] == pytest.approx(expected, rel=1e-12)


def _monte_carlo(paired: bool, n_sets: int = 3000, r: int = 20):
    rng = np.random.default_rng(42)
    mu = np.array([8e-3, 6e-3, 4e-3, 2e-3])
    sd = 0.02 * mu
    rho = 0.7 if paired else 0.0
    corr = np.full((4, 4), rho) + (1 - rho) * np.eye(4)
    chol = np.linalg.cholesky(corr * np.outer(sd, sd))
    ratios, ses = [], []
    for _ in range(n_sets):
        v = mu[:, None] + chol @ rng.normal(size=(4, r))
        nc = normalise_measured(MeasuredCurve([1.0, 2.0, 3.0, 4.0], v, paired=paired))
        ratios.append(nc.ratio)
        ses.append(nc.se)
    return np.array(ratios), np.array(ses), mu, sd, corr


@pytest.mark.parametrize("paired", [True, False])
def test_uncertainty_matches_monte_carlo(paired):
    ratios, ses, mu, sd, corr = _monte_carlo(paired)
    empirical = ratios.std(axis=0, ddof=1)
    assert empirical[0] == 0.0
    # the reported SE (averaged over the data sets) matches the spread of the ratios across data sets
    n = ratios.shape[0]
    tol = 4 * empirical[1:] / np.sqrt(2 * (n - 1)) + 0.02 * empirical[1:]
    assert np.all(np.abs(ses[:, 1:].mean(axis=0) - empirical[1:]) < tol)
    # and the closed-form delta method with the true covariance (independent of the code) agrees too
    r = 20
    c = corr * np.outer(sd, sd) / r
    true_ratio = mu / mu[0]
    var = true_ratio**2 * (np.diag(c) / mu**2 + c[0, 0] / mu[0] ** 2 - 2 * c[:, 0] / (mu * mu[0]))
    assert np.allclose(np.sqrt(var[1:]), empirical[1:], rtol=0.06)


def test_ignoring_the_correlation_would_be_wrong():
    # strongly correlated series: the paired SE is much smaller than one that treats repeats as independent
    rng = np.random.default_rng(5)
    offset = rng.normal(size=8)
    v = 5e-3 * (1 + 0.1 * offset[None, :] + 0.005 * rng.normal(size=(3, 8)))
    curve = MeasuredCurve([1.0, 2.0, 3.0], v, paired=True)
    assert normalise_measured(curve).se[1] < 0.3 * normalise_measured(curve, paired=False).se[1]


def test_simulated_curve_is_exact():
    nc = normalise_simulated(np.array([1.0, 2.0, 3.0]), np.array([3.0, 1.5, 1.0]))
    assert nc.ratio.tolist() == [1.0, 0.5, 1.0 / 3.0]
    assert np.all(nc.se == 0)
    with pytest.raises(SettingError, match="resistance_ohm"):
        normalise_simulated(np.array([1.0, 2.0]), np.array([1.0, 0.0]))


def test_single_repeat_has_no_uncertainty_to_give():
    with pytest.raises(SettingError, match="repeats"):
        normalise_measured(MeasuredCurve([1.0, 2.0], [[1.0], [2.0]]), paired=False)


@pytest.mark.parametrize("paired", [True, False])
def test_standard_errors_without_the_dense_covariance_match_it(paired, monkeypatch):
    """Beyond DENSE_COV_MAX weights no (m, m) matrix is formed; the standard errors are the dense J C Jᵀ's."""
    from analysis import normalisation

    rng = np.random.default_rng(3)
    v = 5e-3 * (1 + 0.05 * rng.normal(size=(50, 6)))
    curve = MeasuredCurve(np.linspace(1.0, 5.0, 50), v, paired=True)
    dense = normalise_measured(curve, paired=paired)
    monkeypatch.setattr(normalisation, "DENSE_COV_MAX", 10)
    sparse = normalise_measured(curve, paired=paired)
    assert sparse.cov is None and dense.cov is not None
    np.testing.assert_allclose(sparse.se, np.sqrt(np.clip(np.diag(dense.cov), 0, None)), rtol=1e-10, atol=0)
    np.testing.assert_array_equal(sparse.ratio, dense.ratio)
