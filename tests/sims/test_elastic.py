"""Bulk elasticity under an asperity layer (sims.rig.elastic) against Johnson's closed forms and limits."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from scipy.integrate import quad

from sims.line_contact import influence_matrix
from sims.rig.elastic import LayerSolution, axisymmetric_influence, rig_elastic_comparison, solve_layer
from sims.rig.settings import RigSettings

E_STAR = 1e11
R = 0.01


class PowerLayer:
    """A stiff asperity layer with an onset at h = 0: p = k (−h)^1.5 (σ → 0 when k → ∞)."""

    h_min, h_max = -1e-6, 0.0  # tabulated range [m], as a ContactLaw gives it

    def __init__(self, k: float) -> None:
        self.k = k

    def pressure(self, h: np.ndarray) -> np.ndarray:
        return self.k * np.maximum(-np.asarray(h, dtype=float), 0.0) ** 1.5

    def dpressure_dh(self, h: np.ndarray) -> np.ndarray:
        return -1.5 * self.k * np.maximum(-np.asarray(h, dtype=float), 0.0) ** 0.5

    def area_fraction_at(self, h: np.ndarray) -> np.ndarray:
        return np.minimum(1.0, np.maximum(-np.asarray(h, dtype=float), 0.0) / 1e-9)


class ExponentialLayer:
    """p = p_s exp(−h/λ): positive everywhere; a very compliant layer when λ is large (rough limit)."""

    def __init__(self, p_s: float, lam: float) -> None:
        self.p_s, self.lam = p_s, lam

    def pressure(self, h: np.ndarray) -> np.ndarray:
        return self.p_s * np.exp(-np.asarray(h, dtype=float) / self.lam)

    def dpressure_dh(self, h: np.ndarray) -> np.ndarray:
        return -self.pressure(h) / self.lam

    def area_fraction_at(self, h: np.ndarray) -> np.ndarray:
        return np.minimum(1.0, 1e-3 * self.pressure(h) / self.p_s)


def test_axisymmetric_kernel_reproduces_hertz_displacement() -> None:
    """Hertz pressure p0√(1 − r²/a²) displaces the surface by π p0 (2a² − r²)/(4 a E*) inside (Johnson eq. 3.41)."""
    a, p0 = 1e-3, 1e9
    edges = np.linspace(0.0, a, 2001)
    r = 0.5 * (edges[1:] + edges[:-1])
    u = axisymmetric_influence(edges, E_STAR) @ (p0 * np.sqrt(1.0 - (r / a) ** 2))
    exact = math.pi * p0 * (2 * a * a - r * r) / (4 * a * E_STAR)
    inner = r < 0.9 * a
    assert np.max(np.abs(u[inner] / exact[inner] - 1)) < 2e-3
    # uniform pressure on a disc: centre displacement 2 p a / E* (Johnson eq. 3.38)
    c = axisymmetric_influence(np.array([0.0, a]), E_STAR)
    assert c[0, 0] == pytest.approx(2 * a / E_STAR, rel=1e-12)


def _sphere(law: Any, load: float, extent: float, n: int = 150) -> tuple[np.ndarray, LayerSolution]:
    edges = np.linspace(0.0, extent, n + 1)
    r = 0.5 * (edges[1:] + edges[:-1])
    sol = solve_layer(law, r * r / (2 * R), axisymmetric_influence(edges, E_STAR), np.pi * np.diff(edges**2), load)
    return edges, sol


def test_rough_sphere_smooth_limit_is_hertz() -> None:
    """σ → 0 (layer compliance 1e-3 of the Hertz approach): p(0) → p0 = 3W/(2πa²), contact radius → a."""
    load = 100.0
    a = (3 * load * R / (4 * E_STAR)) ** (1 / 3)
    p0 = 3 * load / (2 * math.pi * a * a)
    k = p0 / (1e-3 * a * a / R) ** 1.5
    edges, sol = _sphere(PowerLayer(k), load, 1.5 * a)
    assert sol.success and sol.status == 0 and sol.nit > 0 and sol.nfev > 0 and "converged" in sol.message
    assert sol.pressure_pa[0] == pytest.approx(p0, rel=5e-3)
    assert edges[1:][sol.pressure_pa > 0].max() == pytest.approx(a, rel=0.02)
    assert sol.load_n == pytest.approx(load, rel=1e-9)
    assert np.all(sol.pressure_pa >= 0) and np.all(np.isfinite(sol.gap_m))


def test_rough_sphere_rough_limit_is_rigid() -> None:
    """α = σR/a² ≫ 1: bulk deformation negligible; exponential layer on a paraboloid: p(0) = W/(2πRλ) exactly."""
    load, lam = 100.0, 1e-3
    _, sol = _sphere(ExponentialLayer(1e9, lam), load, 8 * math.sqrt(2 * R * lam), n=300)
    assert sol.success
    assert sol.pressure_pa[0] == pytest.approx(load / (2 * math.pi * R * lam), rel=5e-3)


def test_rough_cylinder_limits() -> None:
    """Line contact: σ → 0 gives Johnson's b = √(4P′R/(πE*)), p0 = √(P′E*/(πR)); σ ≫ b²/R gives the rigid
    exponential-layer peak P′/√(2πRλ)."""
    load = 5000.0  # N per metre
    b = math.sqrt(4 * load * R / (math.pi * E_STAR))
    p0 = math.sqrt(load * E_STAR / (math.pi * R))
    x = np.linspace(-1.5 * b, 1.5 * b, 301)
    dx = float(x[1] - x[0])
    k = p0 / (1e-3 * b * b / (2 * R)) ** 1.5
    sol = solve_layer(PowerLayer(k), x * x / (2 * R), influence_matrix(x, dx, E_STAR), np.full(x.size, dx), load)
    assert sol.success
    assert sol.pressure_pa.max() == pytest.approx(p0, rel=5e-3)
    assert 0.5 * dx * np.count_nonzero(sol.pressure_pa > 0) == pytest.approx(b, rel=0.03)
    lam = 1e-4
    x = np.linspace(-8, 8, 301) * math.sqrt(2 * R * lam)
    dx = float(x[1] - x[0])
    sol = solve_layer(
        ExponentialLayer(1e9, lam), x * x / (2 * R), influence_matrix(x, dx, E_STAR), np.full(x.size, dx), load
    )
    assert sol.pressure_pa.max() == pytest.approx(load / math.sqrt(2 * math.pi * R * lam), rel=2e-3)


def test_rig_bulk_elasticity_effect_at_the_heaviest_weight() -> None:
    """The default-scene-like rig with an exponential layer: rigid strips reproduce the rigid rig's closed form
    (force ∫ p ΔA cos θ by quadrature), and bulk elasticity lowers the peak and raises the area at 25.966 kg."""
    s = RigSettings()
    lam = 0.1e-6
    law = ExponentialLayer(1e9, lam)
    law.h_max = 6e-6  # type: ignore[attr-defined]
    law.h_min = -1e-6  # type: ignore[attr-defined]
    comp = rig_elastic_comparison(law, s, [25.966], 49.1e9)
    assert comp.success.all()
    assert comp.peak_change[0] < -0.01 and comp.area_change[0] > 0.0
    # rigid strips against quadrature near the bottom: W = p(0)·L·R_l·∫exp(−e(1−cos θ)/λ)cos θ dθ
    e = s.clearance_m

    def integrand(t: float) -> float:
        return math.exp(-e * (1 - math.cos(t)) / lam) * math.cos(t)

    integral = quad(integrand, -0.5, 0.5, epsabs=0, epsrel=1e-12)[0]
    peak = s.load_n(25.966) / (s.skirt_length_m * s.liner_radius_m * integral)
    assert comp.peak_rigid_pa[0] == pytest.approx(peak, rel=2e-3)


def test_weighted_width_of_known_distributions() -> None:
    from sims.rig.elastic import weighted_width_m

    x = np.linspace(-1.0, 1.0, 200_001)
    assert weighted_width_m(x, np.ones_like(x)) == pytest.approx(2.0, rel=1e-4)  # uniform band: its width
    a = 0.7  # Hertz line contact: p ∝ √(1 − x²/a²), σ² = a²/4, so 2√3·σ = √3·a
    assert weighted_width_m(x, np.sqrt(np.clip(1 - (x / a) ** 2, 0, None))) == pytest.approx(math.sqrt(3) * a, rel=1e-4)


def test_band_width_is_not_a_strip_count() -> None:
    """Edges interpolated between strips: a Hertz band's width within 1 % of a strip on any grid, and the elastic
    rig's width change does not jump with the strip count (it did by several % with a strip count)."""
    from sims.rig.elastic import _band_width_m

    a = 0.37
    for n in (41, 101, 257):
        x = np.linspace(-1.0, 1.0, n)
        p = np.sqrt(np.clip(1 - (x / a) ** 2, 0, None))
        dx = x[1] - x[0]
        assert abs(_band_width_m(x, p, 0.0) - 2 * a) < 0.3 * dx  # linear interpolation of a √ edge
    s = RigSettings()
    law = ExponentialLayer(1e9, 0.1e-6)
    law.h_max = 6e-6  # type: ignore[attr-defined]
    law.h_min = -1e-6  # type: ignore[attr-defined]
    changes = [rig_elastic_comparison(law, s, [25.966], 49.1e9, n_strips=n) for n in (151, 201, 301)]
    widths = [c.width_change[0] for c in changes]
    lw = [c.lw_width_change[0] for c in changes]
    assert max(widths) - min(widths) < 0.005, widths
    assert max(lw) - min(lw) < 0.002 and all(v > 0 for v in lw), lw
    assert "load-weighted width" in changes[0].sentences()[0]
