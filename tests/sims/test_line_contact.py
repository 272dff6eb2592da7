"""Elastic line-contact solver against Johnson's closed forms and direct quadrature of the half-plane kernel."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from sims.line_contact import conformal_line_contact, hertz_line_contact, influence_matrix, solve_line_contact

E_STAR, R_EFF, P_LINE = 49.1e9, 44.06, 5658.0


def test_influence_matrix_is_the_integrated_log_kernel():
    # Johnson eq. 2.25b: u(x) = −(2/(πE*)) ∫ ln|x − s| ds over the strip, up to a constant × load. Compare differences
    # between two observation points (the constant cancels) with direct quadrature.
    x = np.linspace(-1e-3, 1e-3, 9)
    dx = x[1] - x[0]
    K = influence_matrix(x, dx, E_STAR)
    j = 3

    def u(xi):
        lo, hi = x[j] - dx / 2, x[j] + dx / 2
        return -(2 / (math.pi * E_STAR)) * quad(lambda s: math.log(abs(xi - s)), lo, hi, points=[xi])[0]

    for i in (0, 3, 4, 8):
        assert K[i, j] - K[5, j] == pytest.approx(u(x[i]) - u(x[5]), rel=1e-9, abs=1e-22)
    assert np.allclose(K, K.T)
    assert np.all(np.linalg.eigvalsh(K) > 0)


@pytest.mark.parametrize("n", [101, 201])
def test_parabolic_gap_reproduces_johnson(n):
    b, p0 = hertz_line_contact(P_LINE, R_EFF, E_STAR)
    x = np.linspace(-1.6 * b, 1.6 * b, n)
    sol = solve_line_contact(x, x**2 / (2 * R_EFF), P_LINE, E_STAR)
    assert sol.converged and sol.status == "converged"
    assert abs(sol.half_width_m - b) <= sol.dx_m
    assert sol.peak_pressure_pa == pytest.approx(p0, rel=2e-4)
    assert np.sum(sol.pressure_pa) * sol.dx_m == pytest.approx(P_LINE, rel=1e-12)
    reference = p0 * np.sqrt(np.clip(1 - x**2 / b**2, 0, None))
    assert np.sqrt(np.mean((sol.pressure_pa - reference) ** 2)) < 5e-3 * p0
    assert np.allclose(sol.pressure_pa, sol.pressure_pa[::-1], rtol=1e-8, atol=1e-8 * p0)
    # Contact conditions: no tension, no interpenetration, zero gap where loaded.
    assert np.all(sol.pressure_pa >= 0)
    assert np.all(sol.gap_m >= -1e-9 * sol.gap_m.max())
    assert np.all(np.abs(sol.gap_m[sol.pressure_pa > 0]) <= 1e-9 * sol.gap_m.max())
    # Johnson's two forms of p0 agree: 2P'/(πb).
    assert p0 == pytest.approx(2 * P_LINE / (math.pi * b), rel=1e-12)


def test_johnson_half_width_is_not_the_wiki_formula():
    b, _ = hertz_line_contact(P_LINE, R_EFF, E_STAR)
    wrong = math.sqrt(2 * P_LINE * R_EFF / (math.pi * E_STAR))
    x = np.linspace(-1.6 * b, 1.6 * b, 161)
    sol = solve_line_contact(x, x**2 / (2 * R_EFF), P_LINE, E_STAR)
    assert abs(sol.half_width_m - b) < abs(sol.half_width_m - wrong)


@settings(max_examples=8, deadline=None)
@given(
    st.floats(10.0, 1e6),  # load per length, N/m
    st.floats(1e-3, 100.0),  # effective radius, m
    st.floats(1e9, 1e12),  # composite modulus, Pa
)
def test_scaling_over_loads_radii_and_moduli(p_line, r_eff, e_star):
    b, p0 = hertz_line_contact(p_line, r_eff, e_star)
    x = np.linspace(-1.5 * b, 1.5 * b, 81)
    sol = solve_line_contact(x, x**2 / (2 * r_eff), p_line, e_star)
    assert sol.converged
    assert abs(sol.half_width_m - b) <= sol.dx_m
    assert sol.peak_pressure_pa == pytest.approx(p0, rel=2e-3)


def test_rig_geometry_is_a_johnson_line_contact():
    # Default rig: R_l = 42 mm, c = 40 µm → R_eff = 44 m, b ≈ 2.5 mm ≪ R: the exact circle-in-circle gap gives Johnson.
    r_l, c = 0.042, 40e-6
    r_eff = (r_l - c) * r_l / c
    sol = conformal_line_contact(r_l, c, P_LINE, E_STAR)
    b, p0 = hertz_line_contact(P_LINE, r_eff, E_STAR)
    assert sol.converged
    assert abs(sol.half_width_m - b) <= sol.dx_m
    assert sol.peak_pressure_pa == pytest.approx(p0, rel=1e-3)


def test_conformal_contact_wider_than_the_domain_is_reported():
    sol = conformal_line_contact(0.042, 4e-6, 50 * P_LINE, E_STAR)
    assert sol.status == "contact reaches the end of the domain" and not sol.converged


def test_bad_input_is_an_error():
    x = np.linspace(-1, 1, 5)
    with pytest.raises(ValueError, match="load_per_length"):
        solve_line_contact(x, x**2, 0.0, E_STAR)
    with pytest.raises(ValueError, match="equally spaced"):
        solve_line_contact(x**3, x**2, 1.0, E_STAR)
    with pytest.raises(ValueError, match="composite_modulus"):
        solve_line_contact(x, x**2, 1.0, math.nan)
