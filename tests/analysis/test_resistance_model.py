"""The physical resistance model (analysis.resistance_model) against Holm, Barber, Johnson and quadrature."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from analysis.resistance_model import (
    barber_resistance_ohm,
    elliptic_spot_resistance_ohm,
    fit_film_series,
    holm_upper_bound_ohm,
    parallel_holm_ohm,
    rig_resistance_terms,
    tab1_statement,
)
from contactrig.core.validation import SettingError
from sims.materials import Material

RHO = 8.0e-7 + 4.5e-8  # cast iron + Al-Si [Ω·m]
E_STAR = 49.1e9


def test_flat_punch_barber_equals_holm() -> None:
    """Rigid flat circular punch: dF/dδ = 2aE* (Johnson eq. 3.35), so Barber's R is Holm's (ρ1+ρ2)/(4a)."""
    for a in (1e-6, 3.7e-4, 0.02):
        r_barber = float(barber_resistance_ohm(2 * a * E_STAR, RHO, E_STAR))
        assert r_barber == pytest.approx(RHO / (4 * a), rel=1e-12)
        assert float(elliptic_spot_resistance_ohm(a, a, RHO)) == pytest.approx(RHO / (4 * a), rel=1e-12)


def test_elongated_elliptic_spot_limit() -> None:
    """Holm's ellipse for a ≫ b: (ρ1+ρ2)/(2πa)·ln(4a/b) (K(k) → ln(4/k′))."""
    a, b = 0.02, 2e-6
    assert float(elliptic_spot_resistance_ohm(a, b, RHO)) == pytest.approx(
        RHO * math.log(4 * a / b) / (2 * math.pi * a), rel=1e-7
    )


def test_hertz_sphere_barber_equals_holm_of_the_hertz_radius() -> None:
    """Hertz: F = (4/3)E*√R δ^(3/2); stiffness by central difference; R = (ρ1+ρ2)/(4a), a = (3FR/(4E*))^(1/3)."""
    radius, load = 5e-3, 20.0
    delta = (3 * load / (4 * E_STAR * math.sqrt(radius))) ** (2 / 3)
    step = 1e-6 * delta

    def force(d: float) -> float:
        return 4 / 3 * E_STAR * math.sqrt(radius) * d**1.5

    stiffness = (force(delta + step) - force(delta - step)) / (2 * step)
    a = (3 * load * radius / (4 * E_STAR)) ** (1 / 3)
    assert float(barber_resistance_ohm(stiffness, RHO, E_STAR)) == pytest.approx(RHO / (4 * a), rel=1e-8)
    # the single-spot Holm bound of the Hertz area πa² is the same circle
    assert float(holm_upper_bound_ohm(math.pi * a * a, RHO)) == pytest.approx(RHO / (4 * a), rel=1e-12)


def test_barber_against_parallel_holm_spots_on_a_bem_contact() -> None:
    """BEM (sims.bem, read-only API) at low load: Barber's R from K = −dp̄/dū is the parallel Holm sum within 5 %,
    and below Holm's single-spot upper bound of the same real area."""
    from sims.bem import solve_contact

    n, pixel, e_star = 256, 1e-6, 1e11
    rng = np.random.default_rng(3)
    q = np.fft.fftfreq(n) * 2 * np.pi
    qq = np.hypot(*np.meshgrid(q, q))
    z = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal((n, n))) * np.exp(-((qq * 16) ** 2) / 8)))
    z *= 1e-6 / z.std()
    slope = math.sqrt(float(np.mean(np.gradient(z, pixel)[0] ** 2)))
    p = 1e-3 * e_star * slope
    res = solve_contact(z, pixel, e_star, p, tol=1e-8, workers=1)
    up = solve_contact(z, pixel, e_star, 1.01 * p, tol=1e-8, workers=1)
    down = solve_contact(z, pixel, e_star, 0.99 * p, tol=1e-8, workers=1)
    assert res.success and up.success and down.success and res.n_spots >= 3
    stiffness = -0.02 * p / (up.mean_gap - down.mean_gap) * (n * pixel) ** 2
    r_barber = float(barber_resistance_ohm(stiffness, RHO, e_star))
    assert r_barber == pytest.approx(parallel_holm_ohm(res.spot_areas, RHO), rel=0.05)
    assert r_barber < float(holm_upper_bound_ohm(res.spot_areas.sum(), RHO))


class _ExponentialLaw:
    """p = p_s exp(−h/λ) with a tabulated range, for the rig stiffness against quadrature."""

    h_min, h_max = -1e-6, 6e-6
    p_s, lam = 1e9, 0.1e-6

    def pressure(self, h: np.ndarray) -> np.ndarray:
        return self.p_s * np.exp(-np.asarray(h, dtype=float) / self.lam)

    def dpressure_dh(self, h: np.ndarray) -> np.ndarray:
        return -self.pressure(h) / self.lam

    def area_fraction_at(self, h: np.ndarray) -> np.ndarray:
        return np.minimum(1.0, 1e-3 * np.exp(-np.asarray(h, dtype=float) / self.lam))


def test_rig_stiffness_and_terms_against_quadrature() -> None:
    """K(W) = L R_p ∫ −p′(h(θ)) dθ on the exact gap, by adaptive quadrature at the solver's h0."""
    from contactrig.core.scene import load_scene
    from sims.config import SimConfig
    from sims.rig.geometry import gap_m

    config = SimConfig.from_scene(load_scene(None))
    s = config.rig
    law = _ExponentialLaw()
    terms = rig_resistance_terms(config, "exp", [10.0], law=law)
    from sims.rig import equilibrium

    h0 = equilibrium(law, s, 10.0).min_separation_m  # type: ignore[arg-type]

    def integrand(t: float) -> float:
        return float(-law.dpressure_dh(gap_m(t, h0, s.liner_radius_m, s.clearance_m))) * s.piston_radius_m

    k = 2 * s.skirt_length_m * quad(integrand, 0, math.pi, epsabs=0, epsrel=1e-10, limit=200)[0]
    assert terms.stiffness_n_per_m[0] == pytest.approx(k, rel=2e-3)
    assert terms.barber_ohm[0] == pytest.approx(RHO * config.materials.E_star / (2 * k), rel=2e-3)
    assert np.all(terms.macro_ohm > 0) and np.all(terms.holm_bound_ohm > terms.barber_ohm)


def test_fit_film_series_closed_form_against_lstsq() -> None:
    """Many sessions at once; each equals numpy's weighted lstsq; exact data give the parameters back."""
    rng = np.random.default_rng(0)
    area = np.linspace(2e-7, 1e-6, 8)
    clean = 1e-5 * np.ones(8)
    truth = 1e-4 + 2e-9 / area + clean
    data = truth * (1 + 0.05 * rng.standard_normal((50, 8)))
    sigma = 0.05 * truth * np.ones((50, 8))
    fit = fit_film_series(data, sigma, area, clean)
    for i in (0, 17, 49):
        design = np.stack([np.ones(8), 1 / area], axis=1) / sigma[i][:, None]
        sol, *_ = np.linalg.lstsq(design, (data[i] - clean) / sigma[i], rcond=None)
        assert fit.series_ohm[i] == pytest.approx(sol[0], rel=1e-9, abs=1e-15)
        assert fit.film_ohm_m2[i] == pytest.approx(sol[1], rel=1e-9)
    exact = fit_film_series(truth, sigma[0], area, clean)
    assert float(exact.film_ohm_m2) == pytest.approx(2e-9, rel=1e-10)
    assert float(exact.series_ohm) == pytest.approx(1e-4, rel=1e-8)
    total = sum(exact.shares[k] for k in ("series", "film", "clean_metal"))
    assert np.allclose(total, 1.0)


def test_material_resistivity_is_validated() -> None:
    steel = {"E_pa": 210e9, "nu": 0.3, "H_pa": 2e9}
    assert Material.from_table("materials.liner", {**steel, "resistivity_ohm_m": 1.5e-7}).resistivity_ohm_m == 1.5e-7
    with pytest.raises(SettingError, match=r"resistivity_ohm_m"):
        Material.from_table("materials.liner", {**steel, "resistivity_ohm_m": -1.0})


def test_tab1_statement_states_the_film_and_honest_errors() -> None:
    """Tab. 1 with M1–M3 (M4–M6 are copies of them), checked by an independent WLS (numpy lstsq on the printed
    table), per-series estimates for the paired-series SE and scipy's curve_fit(absolute_sigma=False), which scales
    the curvature covariance by χ²/ν; the sentence states the larger for each parameter; clean metal ≈ 1 % of the
    measured mean."""
    from scipy.optimize import curve_fit

    from analysis.measured import load_tab1
    from contactrig.core.scene import load_scene
    from sims.config import SimConfig

    config = SimConfig.from_scene(load_scene(None))
    curve = load_tab1()
    text = tab1_statement(config, curve=curve)
    terms = rig_resistance_terms(config, "greenwood_tripp", list(curve.weight_kg))
    v = curve.values_ohm[:, :3]  # M1, M2, M3: the independent series
    mean = v.mean(axis=1)
    c = math.sqrt(float(np.mean(v.var(axis=1, ddof=1) / mean**2)))
    sigma = c * mean / math.sqrt(3)
    x = 1 / terms.area_m2
    y = mean - terms.clean_ohm
    design = np.stack([np.ones(x.size), x], axis=1) / sigma[:, None]
    sol, *_ = np.linalg.lstsq(design, y / sigma, rcond=None)
    per_series = [np.linalg.lstsq(design, (v[:, k] - terms.clean_ohm) / sigma, rcond=None)[0] for k in range(3)]
    se_series = np.std(per_series, axis=0, ddof=1) / math.sqrt(3)
    popt, pcov = curve_fit(lambda xx, a, b: a + b * xx, x, y, p0=sol, sigma=sigma, absolute_sigma=False)
    se_scaled = np.sqrt(np.diag(pcov))
    assert popt == pytest.approx(sol, rel=1e-6)
    se = np.maximum(se_series, se_scaled)  # the larger, per parameter (issue 26 item 12)
    assert f"σ_f = {sol[1]:.2e} ± {se[1]:.1e}" in text
    assert f"R_s = {1e3 * sol[0]:.2f} ± {1e3 * se[0]:.2f} mΩ" in text
    assert "3 independent series" in text and "M4, M5, M6 counted once" in text
    assert 1e-9 < sol[1] < 4e-9
    share = terms.clean_ohm / mean
    assert f"{100 * share.min():.1f}–{100 * share.max():.1f} % of the measured mean" in text
    assert 0.003 < share.min() and share.max() < 0.03
