"""Static equilibrium of the piston in its liner, against closed forms and independent quadrature."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad
from scipy.optimize import brentq

from sims.rig.equilibrium import RigLoadError, equilibrium, roughness_parameter
from sims.rig.settings import STANDARD_GRAVITY, RigSettings
from tests.sims.test_rig_laws import (
    ExponentialLaw,
    GreenwoodTrippLaw,
    WinklerLaw,
    exponential_area_m2,
    exponential_force_n,
)

EXP = ExponentialLaw()


def _bessel_reference(law, s: RigSettings, weight_kg: float) -> tuple[float, float]:
    R, L, c = s.piston_radius_m, s.skirt_length_m, s.clearance_m
    W = s.load_n(weight_kg)
    h0 = brentq(lambda h: exponential_force_n(law, h, R, L, c) - W, -5e-6, 30e-6, xtol=1e-22, rtol=1e-15)
    return h0, exponential_area_m2(law, h0, R, L, c)


@pytest.mark.parametrize("weight_kg", [5.44, 25.966, 400.0])
def test_variable_mesh_matches_bessel_closed_form(weight_kg):
    s = RigSettings(gap="small_clearance", mesh="variable", n_theta=16, mesh_tol=1e-4)
    eq = equilibrium(EXP, s, weight_kg)
    h_ref, a_ref = _bessel_reference(EXP, s, weight_kg)
    assert eq.status == "converged" and eq.converged
    assert eq.min_separation_m == pytest.approx(h_ref, rel=1e-5, abs=1e-12)
    assert eq.contact_area_m2 == pytest.approx(a_ref, rel=1e-4)
    # Force balance: the contact force carries the weight.
    assert abs(eq.residual_n) <= 1e-9 * eq.load_n
    assert eq.contact_force_n == pytest.approx((weight_kg) * STANDARD_GRAVITY, rel=1e-9)
    assert eq.evaluations > 0 and eq.iterations > 0 and eq.mesh_levels >= 2
    assert eq.peak_pressure_pa == pytest.approx(EXP.p0 * math.exp(-h_ref / EXP.lam), rel=1e-4)


def test_uniform_mesh_matches_bessel_closed_form():
    s = RigSettings(gap="small_clearance", mesh="uniform", n_theta=512, n_axial=1)
    eq = equilibrium(EXP, s, 10.0)
    h_ref, a_ref = _bessel_reference(EXP, s, 10.0)
    assert eq.n_nodes == 512
    assert eq.contact_area_m2 == pytest.approx(a_ref, rel=1e-6)
    assert eq.min_separation_m == pytest.approx(h_ref, rel=1e-6)


def _exact_gap(theta, h0, R_l, c):
    # Offset circle in a circle, written directly: distance along the liner's ray from the piston surface to the liner.
    e = c - h0
    R_p = R_l - c
    return R_l - (e * math.cos(theta) + math.sqrt(R_p**2 - (e * math.sin(theta)) ** 2))


def test_exact_gap_equilibrium_matches_quadrature():
    s = RigSettings(gap="exact", mesh="variable", n_theta=16, mesh_tol=1e-5)
    R_l, c, L, R_p = s.liner_radius_m, s.clearance_m, s.skirt_length_m, s.piston_radius_m
    W = s.load_n(20.0)

    def force(h0):
        f = quad(lambda t: EXP.pressure(_exact_gap(t, h0, R_l, c)) * math.cos(t), 0, math.pi, limit=200, points=[0.3])
        return 2 * R_p * L * f[0]

    h_ref = brentq(lambda h: force(h) - W, -2e-6, 3e-6, xtol=1e-20)
    a_ref = 2 * R_p * L * quad(lambda t: EXP.area_fraction_at(_exact_gap(t, h_ref, R_l, c)), 0, math.pi, limit=200)[0]
    eq = equilibrium(EXP, s, 20.0)
    assert eq.min_separation_m == pytest.approx(h_ref, rel=1e-6)
    assert eq.contact_area_m2 == pytest.approx(a_ref, rel=3e-5)


def test_exact_and_small_clearance_gaps_differ_by_order_h0_over_c():
    exact = equilibrium(EXP, RigSettings(gap="exact", mesh_tol=1e-5), 20.0)
    small = equilibrium(EXP, RigSettings(gap="small_clearance", mesh_tol=1e-5), 20.0)
    rel = abs(exact.contact_area_m2 - small.contact_area_m2) / small.contact_area_m2
    assert 1e-6 < rel < 1e-2


def test_zero_clearance_linear_law_gives_the_cosine_distribution():
    # Winkler p = k·max(0, −h), exact fit (c = 0): p(θ) = (2W/(π R_p L)) cos θ on the lower half, 0 above.
    law = WinklerLaw(k=1e13, h_c=0.0, h_min=-2e-6, h_max=0.0)
    s = RigSettings(clearance_m=0.0, gap="small_clearance", mesh="uniform", n_theta=64, n_axial=2)
    eq = equilibrium(law, s, 20.0)
    theta = eq.mesh.theta_rad
    expected = 2 * eq.load_n / (math.pi * s.piston_radius_m * s.skirt_length_m) * np.maximum(np.cos(theta), 0.0)
    assert np.allclose(eq.pressure_pa, expected[:, None], rtol=1e-9, atol=1e-9 * expected.max())
    # The exact gap differs by O(e/R): the same distribution to that order.
    eq_exact = equilibrium(law, RigSettings(clearance_m=0.0, gap="exact", mesh="uniform", n_theta=64, n_axial=1), 20.0)
    assert np.allclose(eq_exact.pressure_pa[:, 0], expected, rtol=0, atol=1e-4 * expected.max())


def test_zero_clearance_with_the_variable_mesh():
    law = WinklerLaw(k=1e13, h_c=0.0, h_min=-2e-6, h_max=0.0)
    s = RigSettings(clearance_m=0.0, gap="small_clearance", n_theta=8, mesh_tol=1e-6)
    eq = equilibrium(law, s, 20.0)
    R, L = s.piston_radius_m, s.skirt_length_m
    e = eq.load_n / (law.k * math.pi * R * L / 2)  # W = k e ∫cos² = k e π R L / 2
    assert eq.min_separation_m == pytest.approx(-e, rel=1e-6)
    # Real area: ∫ clip(e cos θ / h_a) R L dθ over |θ| < π/2 = 2 e R L / h_a (e < h_a here).
    assert e < law.h_a
    assert eq.contact_area_m2 == pytest.approx(2 * e * R * L / law.h_a, rel=1e-5)


def test_crowned_skirt_against_two_dimensional_quadrature():
    from scipy.integrate import dblquad

    crown = 2e-6
    s = RigSettings(gap="small_clearance", crown_m=crown, n_theta=8, n_axial=4, mesh_tol=1e-5)
    eq = equilibrium(EXP, s, 15.0)
    R, L, c, h0 = s.piston_radius_m, s.skirt_length_m, s.clearance_m, eq.min_separation_m

    def gap(t, y):
        return h0 + (c - h0) * (1 - math.cos(t)) + crown * (2 * y / L) ** 2

    force = 4 * R * dblquad(lambda y, t: EXP.pressure(gap(t, y)) * math.cos(t), 0, math.pi, 0, L / 2)[0]
    area = 4 * R * dblquad(lambda y, t: EXP.area_fraction_at(gap(t, y)), 0, math.pi, 0, L / 2)[0]
    assert force == pytest.approx(eq.load_n, rel=1e-4)
    assert eq.contact_area_m2 == pytest.approx(area, rel=1e-4)
    assert eq.mesh.shape[1] > 1


def test_zero_weight_gives_zero_area_and_no_nan():
    for law in (EXP, GreenwoodTrippLaw(), WinklerLaw(h_c=1e-6, h_max=1e-6)):
        eq = equilibrium(law, RigSettings(), 0.0)
        assert eq.status == "no load"
        assert eq.contact_area_m2 == 0.0 and eq.contact_force_n == 0.0 and eq.contact_width_m == 0.0
        assert np.all(np.isfinite(eq.pressure_pa)) and math.isfinite(eq.min_separation_m)


def test_piston_mass_is_added_to_the_weight():
    eq = equilibrium(EXP, RigSettings(piston_mass_kg=1.5), 0.0)
    assert eq.load_n == pytest.approx(1.5 * STANDARD_GRAVITY)
    assert eq.contact_force_n == pytest.approx(1.5 * STANDARD_GRAVITY, rel=1e-9)
    assert eq.contact_area_m2 > 0


def test_load_beyond_the_law_is_an_error_naming_the_remedy():
    capped = WinklerLaw(k=1e13, h_c=1e-6, h_max=1e-6, h_min=-1e-6, p_cap=1e5)
    # The most a capped law can carry is p_cap × projected area 2 R_p L ≈ 378 N.
    with pytest.raises(RigLoadError, match="extend the database"):
        equilibrium(capped, RigSettings(), 100.0, name="capped")


def test_extrapolated_law_warns():
    eq = equilibrium(EXP, RigSettings(), 2000.0, name="exp")
    assert not eq.in_range and eq.min_separation_m < EXP.h_min
    assert any("below the contact law's range" in w and w.startswith("exp:") for w in eq.warnings)


def test_mesh_budget_is_reported_not_hidden():
    eq = equilibrium(GreenwoodTrippLaw(), RigSettings(n_theta=4, mesh_tol=1e-9, max_nodes=60), 10.0)
    assert not eq.converged and eq.status == "mesh budget reached"
    assert any("max_nodes" in w for w in eq.warnings)
    assert eq.n_nodes <= 60


def test_roughness_parameter_is_johnsons_alpha():
    s = RigSettings()
    W, sigma, e_star = 250.0, 0.7e-6, 49e9
    r_eff = s.piston_radius_m * s.liner_radius_m / s.clearance_m
    b2 = 4 * (W / s.skirt_length_m) * r_eff / (math.pi * e_star)
    assert roughness_parameter(W, s.skirt_length_m, sigma, e_star) == pytest.approx(sigma * r_eff / b2, rel=1e-12)
    eq = equilibrium(EXP, s, 1000.0, roughness_m=sigma, composite_modulus_pa=e_star)
    assert any("roughness parameter" in w for w in eq.warnings)
    assert not any(
        "roughness" in w for w in equilibrium(EXP, s, 1.0, roughness_m=sigma, composite_modulus_pa=e_star).warnings
    )


@settings(max_examples=15, deadline=None)
@given(st.lists(st.floats(0.0, 300.0), min_size=2, max_size=4, unique=True))
def test_area_grows_and_gap_shrinks_with_weight(weights):
    law = GreenwoodTrippLaw()
    s = RigSettings(n_theta=8, mesh_tol=1e-4)
    weights = sorted(weights)
    eqs = [equilibrium(law, s, w) for w in weights]
    areas = [e.contact_area_m2 for e in eqs]
    gaps = [e.min_separation_m for e in eqs]
    assert all(np.isfinite(areas)) and all(a >= 0 for a in areas)
    for i in range(len(weights) - 1):
        assert areas[i + 1] >= areas[i] and gaps[i + 1] <= gaps[i]
        if weights[i + 1] - weights[i] > 1e-3:  # distinguishable loads: strictly
            assert areas[i + 1] > areas[i] and gaps[i + 1] < gaps[i]


@pytest.mark.parametrize(
    "law",
    [
        GreenwoodTrippLaw(sigma=0.02e-6, eta=5e11, beta=2e-6),  # very smooth
        GreenwoodTrippLaw(sigma=5e-6, eta=1e9, beta=50e-6),  # very rough
        GreenwoodTrippLaw(e_star=1e12),  # very stiff materials
    ],
    ids=["smooth", "rough", "stiff"],
)
def test_extreme_surfaces_stay_finite_and_balanced(law):
    for w in (0.5, 25.966, 5000.0):
        eq = equilibrium(law, RigSettings(n_theta=8), w)
        assert math.isfinite(eq.contact_area_m2) and eq.contact_area_m2 > 0
        assert abs(eq.residual_n) <= 1e-8 * eq.load_n
        assert np.all(eq.pressure_pa >= 0) and np.all(np.isfinite(eq.pressure_pa))
        assert eq.contact_area_m2 <= 2 * math.pi * RigSettings().piston_radius_m * RigSettings().skirt_length_m


def test_tail_bound_bounds_the_integral_beyond_the_zone():
    # Independent: quad of the force and area integrands beyond θ_z on the exact gap, against the bound.
    from sims.rig.loads import tail_bound

    s = RigSettings()
    R_l, c, L, R_p = s.liner_radius_m, s.clearance_m, s.skirt_length_m, s.piston_radius_m
    h0 = 0.5e-6
    for law in (EXP, GreenwoodTrippLaw()):
        for zone in (0.2, 0.3, 0.5):
            f_bound, a_bound = tail_bound(law, s, zone, h0)
            f_tail = 2 * R_p * L * quad(lambda t, w=law: _p_at(w, t, h0, R_l, c) * math.cos(t), zone, math.pi)[0]
            a_tail = 2 * R_p * L * quad(lambda t, w=law: _a_at(w, t, h0, R_l, c), zone, math.pi)[0]
            assert abs(f_tail) <= f_bound[0] and a_tail <= a_bound[0]
    # A law that is exactly zero above h_max (contact onset, like an asperity curve): nothing beyond its edge.
    onset = WinklerLaw(k=1e13, h_c=1e-6, h_max=1e-6, h_min=-1e-6)
    from sims.rig.geometry import contact_edge_angle_rad

    edge = contact_edge_angle_rad(onset.h_max, h0, R_l, c)
    assert tail_bound(onset, s, edge, h0)[0][0] == 0.0 and tail_bound(onset, s, edge + 0.1, h0)[1][0] == 0.0
    assert tail_bound(onset, s, 0.5 * edge, h0)[1][0] > 0


def _p_at(law, t, h0, R_l, c):
    return float(law.pressure(_exact_gap(t, h0, R_l, c)))


def _a_at(law, t, h0, R_l, c):
    return float(law.area_fraction_at(_exact_gap(t, h0, R_l, c)))


def test_variable_mesh_leaves_out_the_tail_only_where_it_carries_nothing():
    # Onset law (zero above h_max, like an asperity curve): the mesh ends at the contact edge. Reference: the
    # equilibrium of quad integrals over the whole half circumference on the small-clearance gap.
    onset = WinklerLaw(k=1e13, h_c=1e-6, h_max=1e-6, h_min=-1e-6)
    s = RigSettings(gap="small_clearance", n_theta=8, mesh_tol=1e-6)
    eq = equilibrium(onset, s, 25.966)
    assert eq.mesh.theta_edges_rad[-1] < 0.5 and eq.converged
    R, L, c = s.piston_radius_m, s.skirt_length_m, s.clearance_m

    def gap(t, h0):
        return h0 + (c - h0) * (1 - math.cos(t))

    def edge(h0):
        return [math.acos(1 - (onset.h_c - h0) / (c - h0))]

    def force(h0):
        integrand = lambda t: float(onset.pressure(gap(t, h0))) * math.cos(t)  # noqa: E731
        return 2 * R * L * quad(integrand, 0, math.pi, points=edge(h0), limit=200)[0]

    h_ref = brentq(lambda h: force(h) - eq.load_n, -2e-6, 0.99e-6, xtol=1e-20)
    area = quad(lambda t: float(onset.area_fraction_at(gap(t, h_ref))), 0, math.pi, points=edge(h_ref), limit=200)[0]
    assert eq.contact_area_m2 == pytest.approx(2 * R * L * area, rel=1e-5)
    # Midpoint cells are second order on this integrand (it vanishes linearly at the edge): h0 to ~(Δθ/θe)²/8.
    assert eq.min_separation_m == pytest.approx(h_ref, abs=1e-3 * (onset.h_c - h_ref))
    # The exponential law's tail beyond h_max still carries load: the mesh keeps its tail cells to θ = π.
    assert equilibrium(EXP, RigSettings(), 25.966).mesh.theta_edges_rad[-1] == pytest.approx(math.pi)
