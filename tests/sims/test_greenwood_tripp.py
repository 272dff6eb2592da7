"""Greenwood–Tripp F_n, pressure and area against independent references (mpmath quadrature, scipy quadrature of
the asperity-pair integral, elementary closed forms)."""

from __future__ import annotations

import math
import sys
import warnings

import mpmath as mp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate
from scipy.special import erfc

from contactrig.core.validation import SettingError
from sims import greenwood_tripp as gt

ORDERS = (0.0, 1.0, 1.5, 2.0, 2.5)


def f_ref(n: float, t: float) -> float:
    """F_n(t) by mpmath quadrature of the defining integral (not the closed form), written with u = s − t as
    φ(t) ∫_0^∞ u^n exp(−t u − u²/2) du and split around the integrand's peak so that tails are resolved."""
    with mp.workdps(20):
        n_, t_ = mp.mpf(n), mp.mpf(t)
        u_peak = (-t_ + mp.sqrt(t_ * t_ + 4 * n_)) / 2
        width = 1 / mp.sqrt(1 + (n_ / u_peak**2 if u_peak > 0 else 0))
        points = sorted({mp.mpf(0)} | {u_peak + k * width for k in range(-10, 11) if u_peak + k * width > 0})
        val = mp.quad(lambda u: u**n_ * mp.exp(-t_ * u - u * u / 2), [*points, mp.inf])
        return float(val * mp.exp(-t_ * t_ / 2) / mp.sqrt(2 * mp.pi))


@pytest.mark.parametrize("n", ORDERS)
def test_F_matches_mpmath_quadrature_to_1e9(n: float) -> None:
    ts = np.array([-8.0, -5.3, -2.1, -0.7, 0.0, 0.33, 1.9, 3.0, 3.7, 4.6, 5.9, 7.2, 8.8, 10.0])
    ref = np.array([f_ref(n, t) for t in ts])
    assert np.max(np.abs(gt.F(n, ts) / ref - 1)) <= 1e-9


@pytest.mark.parametrize("n", (2.5,))
def test_F_tails_match_mpmath(n: float) -> None:
    ts = np.array([-40.0, -12.0001, -11.999, 13.999, 14.0001, 30.0])
    ref = np.array([f_ref(n, t) for t in ts])
    assert np.max(np.abs(gt.F(n, ts) / ref - 1)) <= 1e-9


def test_F_elementary_cases() -> None:
    t = np.linspace(-8, 4, 1201)
    phi = np.exp(-t * t / 2) / math.sqrt(2 * math.pi)
    f0 = 0.5 * erfc(t / math.sqrt(2))
    np.testing.assert_allclose(gt.F(0, t), f0, rtol=1e-9)
    np.testing.assert_allclose(gt.F(1, t), phi - t * f0, rtol=1e-9)
    np.testing.assert_allclose(gt.F(2, t), (1 + t * t) * f0 - t * phi, rtol=1e-9)


def test_recurrence_and_derivative_identities() -> None:
    t = np.linspace(-6, 3, 301)
    # F_n = (n − 1) F_(n−2) − t F_(n−1)
    np.testing.assert_allclose(gt.F(2.5, t), 1.5 * gt.F(0.5, t) - t * gt.F(1.5, t), rtol=1e-9)
    # dF_n/dt against a central difference
    eps = 1e-5
    num = (gt.F(2.5, t + eps) - gt.F(2.5, t - eps)) / (2 * eps)
    np.testing.assert_allclose(gt.dF_dt(2.5, t), num, rtol=1e-6)
    np.testing.assert_allclose(gt.dF_dt(0, t), -np.exp(-t * t / 2) / math.sqrt(2 * math.pi), rtol=1e-12)


def test_limits() -> None:
    assert gt.F(2.5, [1e6])[0] == 0.0
    assert gt.F(2.5, [np.inf])[0] == 0.0
    big = np.array([-1e3, -1e6, -1e50])
    # E[(|t| + X)^n] = |t|^n (1 + n(n − 1)/(2t²) + …), X ~ N(0, 1)
    np.testing.assert_allclose(gt.F(2.5, big) / np.abs(big) ** 2.5, 1 + 1.875 / big**2, rtol=1e-12)
    # the far left: finite up to the float range, an explicit error beyond it (never inf or an overflow warning)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for n in (0.0, 1.0, 2.5, 10.0):
            t = max(gt.t_min(n), -sys.float_info.max)
            f = gt.F(n, [t, 0.5 * t])
            assert np.all(np.isfinite(f)) and f[0] >= f[1] > 0
            assert gt.log_F(n, [-sys.float_info.max])[0] == pytest.approx(n * math.log(sys.float_info.max), rel=1e-12)
    assert gt.F(0, [-sys.float_info.max])[0] == pytest.approx(1.0, rel=1e-12)
    with pytest.raises(SettingError, match="float range"):
        gt.F(2.5, [-1e122])
    with pytest.raises(SettingError):
        gt.F(10, [-1e31])
    with pytest.raises(SettingError):
        gt.F(2.5, [-np.inf])
    with pytest.raises(SettingError):
        gt.F(2.5, [0.0, np.nan])
    with pytest.raises(SettingError):
        gt.F(-0.5, [0.0])


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(min_value=-50, max_value=1e6, allow_nan=False), min_size=2, max_size=40),
    st.sampled_from(ORDERS),
)
def test_F_finite_nonnegative_monotone_no_warning(ts: list[float], n: float) -> None:
    t = np.sort(np.asarray(ts))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f = gt.F(n, t)
    assert np.all(np.isfinite(f)) and np.all(f >= 0)
    assert np.all(np.diff(f) <= 1e-14 * f[:-1])  # non-increasing to rounding (a few ulp)


def test_F_monotone_across_table_ends_and_nodes() -> None:
    for t0 in (-12.0, 14.0, 0.0):
        t = t0 + np.linspace(-1e-6, 1e-6, 2001)
        f = gt.F(2.5, t)
        assert np.all(np.diff(f) <= 1e-14 * f[:-1])


def test_methods_agree_where_they_should() -> None:
    t = np.linspace(-5, 4.5, 50)
    np.testing.assert_allclose(gt.F(2.5, t, method="exact"), gt.F(2.5, t), rtol=1e-9)
    np.testing.assert_allclose(gt.F(2.5, t, method="closed_form"), gt.F(2.5, t), rtol=1e-9)


def test_paper_polynomial_nodes_and_where_it_is_wrong() -> None:
    x, y = gt.paper_table()
    ref = np.array([f_ref(2.5, t) for t in x])
    np.testing.assert_allclose(y, ref, rtol=1e-9)
    np.testing.assert_allclose(gt.paper_polynomial(x), ref, rtol=1e-9)
    # Between 3 and 4 the interpolant is off by tens of per cent to several-fold.
    t = np.linspace(3.0, 4.0, 101)
    ratio = gt.paper_polynomial(t) / gt.F(2.5, t)
    assert ratio.max() > 3.0 and ratio.min() < 0.95
    # Beyond 4 the polynomial itself is negative (adhesive pressure): the option refuses to go there.
    assert np.polyval(gt.paper_coefficients(), 5.0) < 0 and np.polyval(gt.paper_coefficients(), 6.0) < -0.5
    with pytest.raises(SettingError):
        gt.paper_polynomial([4.5])
    with pytest.raises(SettingError):
        gt.F(2.5, [-0.1], method="paper_polynomial")


def test_paper_polynomial_rounded_table_goes_negative_with_warning() -> None:
    t = np.linspace(3.0, 4.0, 201)
    raw = np.polyval(gt.paper_coefficients(4), t)
    assert raw.min() < 0  # a 4-decimal table makes the interpolant negative near t ≈ 3.4
    with pytest.warns(gt.PaperPolynomialWarning):
        guarded = gt.paper_polynomial(t, decimals=4)
    assert guarded.min() >= 0.0


def test_power_fit_errors_as_documented() -> None:
    r = gt.power_fit([0.0, 3.0]) / gt.F(2.5, [0.0, 3.0])
    assert r[0] == pytest.approx(0.893, abs=0.005)  # 10 % low
    assert r[1] == pytest.approx(0.258, abs=0.005)  # 74 % low
    assert gt.power_fit([4.0, 10.0]).tolist() == [0.0, 0.0]


SIGMA, ETA, BETA, E_STAR = 0.5e-6, 2.0e7, 2.0e-3, 50e9


def _pair_integral(h: float, power: float, weight: float) -> float:
    """η² ∫ dZ N(0,σ²)(Z) ∫_0^r_max 2πr · weight · (Z − h − r²/(4β))^power dr — two spherical asperities of radius β
    with summed heights Z at lateral offset r (Greenwood & Tripp's picture), done by scipy quadrature."""

    def inner(z: float) -> float:
        d0 = z - h
        if d0 <= 0:
            return 0.0
        # ∫ 2πr (d0 − r²/(4β))^power dr = π·4β·d0^(power+1)/(power+1); integrate numerically anyway
        r_max = math.sqrt(4 * BETA * d0)
        val, _ = integrate.quad(lambda r: 2 * math.pi * r * max(d0 - r * r / (4 * BETA), 0.0) ** power, 0, r_max)
        return val * math.exp(-z * z / (2 * SIGMA**2)) / (math.sqrt(2 * math.pi) * SIGMA)

    val, _ = integrate.quad(inner, h, h + 12 * SIGMA, limit=200, epsabs=0, epsrel=1e-10)
    return ETA**2 * weight * val


@pytest.mark.parametrize("h", [-0.5e-6, 0.0, 0.6e-6, 1.5e-6])
def test_pressure_prefactor_against_asperity_pair_integral(h: float) -> None:
    # Hertz pair of radius β/2: F = (4/3) E* √(β/2) δ^(3/2). With E′ = 2E* the printed 8√2π/15 would give the
    # same number; the trap is using 8√2π/15 with E*: off by exactly 2.
    ref = _pair_integral(h, 1.5, 4.0 / 3.0 * E_STAR * math.sqrt(BETA / 2))
    p = float(gt.pressure([h], sigma=SIGMA, eta=ETA, beta=BETA, E_star=E_STAR)[0])
    assert p == pytest.approx(ref, rel=1e-6)
    trap = 8 * math.sqrt(2) * math.pi / 15 * (ETA * BETA * SIGMA) ** 2 * math.sqrt(SIGMA / BETA) * E_STAR
    assert trap * float(gt.F(2.5, [h / SIGMA])[0]) == pytest.approx(ref / 2, rel=1e-6)


@pytest.mark.parametrize("h", [-0.5e-6, 0.6e-6])
def test_area_fraction_against_asperity_pair_integral(h: float) -> None:
    ref = _pair_integral(h, 1.0, math.pi * BETA / 2)
    a = float(gt.area_fraction([h], sigma=SIGMA, eta=ETA, beta=BETA)[0])
    assert a == pytest.approx(ref, rel=1e-6)


@settings(max_examples=40, deadline=None)
@given(
    st.floats(min_value=1e-15, max_value=1e-4),
    st.floats(min_value=-1e-3, max_value=1.0),
    st.floats(min_value=1e3, max_value=1e13),
)
def test_pressure_finite_nonnegative_for_extreme_inputs(sigma: float, h: float, e_star: float) -> None:
    # σ → 0 (1e-15 m), separations from −1 mm to 1 m, E* from kPa to 10 TPa
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        p = gt.pressure([h, h + sigma], sigma=sigma, eta=1e9, beta=1e-5, E_star=e_star)
        a = gt.area_fraction([h + sigma, h + 2 * sigma], sigma=sigma, eta=1e7, beta=1e-5)
    assert np.all(np.isfinite(p)) and np.all(p >= 0) and p[0] >= p[1]
    assert np.all(np.isfinite(a)) and np.all(a >= 0) and a[0] >= a[1]


def test_bad_statistics_are_errors_naming_the_field() -> None:
    with pytest.raises(SettingError, match="sigma"):
        gt.pressure([0.0], sigma=0.0, eta=1e7, beta=1e-3, E_star=1e9)
    with pytest.raises(SettingError, match="method"):
        gt.F(2.5, [0.0], method="polynomial")
    with pytest.raises(SettingError, match="area fraction"):
        gt.area_fraction([-1.0], sigma=1e-6, eta=1e9, beta=1e-3)
