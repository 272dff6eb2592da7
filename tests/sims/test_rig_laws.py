"""Analytic contact laws for the rig tests (independent of ``sims.database``), and checks of the laws themselves.

- :class:`ExponentialLaw`: p = p0 e^(−h/λ), A/A0 = a0 e^(−h/λa). With the small-clearance gap its force and area
  on a straight skirt have closed forms in modified Bessel functions (:func:`exponential_force_n`).
- :class:`WinklerLaw`: p = k max(0, h_c − h) (a linear "mattress"), A/A0 = min(1, max(0, (h_c − h)/h_a)).
- :class:`GreenwoodTrippLaw`: Greenwood–Tripp with F_n from the parabolic-cylinder closed form (scipy.special.pbdv),
  written here independently of ``sims.greenwood_tripp``; its tail extends beyond ``h_max``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import gamma, ive, pbdv

from sims.rig.law import ContactLaw, check_law


@dataclass(frozen=True)
class ExponentialLaw:
    p0: float = 2e6
    lam: float = 0.3e-6
    a0: float = 0.05
    lam_a: float = 0.4e-6
    h_min: float = 0.0
    h_max: float = 3.6e-6

    def pressure(self, h):
        return self.p0 * np.exp(-np.asarray(h, dtype=float) / self.lam)

    def dpressure_dh(self, h):
        return -self.pressure(h) / self.lam

    def area_fraction_at(self, h):
        return np.minimum(1.0, self.a0 * np.exp(-np.asarray(h, dtype=float) / self.lam_a))


def exponential_force_n(law: ExponentialLaw, h0: float, radius_m: float, length_m: float, clearance_m: float) -> float:
    """∫ p(h0 + e(1 − cos θ)) cos θ R L dθ over the full circle = 2π p0 R L e^(−h0/λ) I1~(e/λ) (I~ scaled Bessel)."""
    e = clearance_m - h0
    return 2 * math.pi * law.p0 * radius_m * length_m * ive(1, e / law.lam) * math.exp(-h0 / law.lam)


def exponential_area_m2(law: ExponentialLaw, h0: float, radius_m: float, length_m: float, clearance_m: float) -> float:
    """∫ a(h0 + e(1 − cos θ)) R L dθ over the full circle = 2π a0 R L e^(−h0/λa) I0~(e/λa) (needs a < 1)."""
    e = clearance_m - h0
    return 2 * math.pi * law.a0 * radius_m * length_m * ive(0, e / law.lam_a) * math.exp(-h0 / law.lam_a)


@dataclass(frozen=True)
class WinklerLaw:
    k: float = 1e13  # Pa/m
    h_c: float = 0.0
    h_a: float = 1e-6
    h_min: float = -2e-6
    h_max: float = 0.0
    p_cap: float = math.inf

    def pressure(self, h):
        return np.minimum(self.p_cap, self.k * np.maximum(0.0, self.h_c - np.asarray(h, dtype=float)))

    def dpressure_dh(self, h):
        h = np.asarray(h, dtype=float)
        p = self.k * (self.h_c - h)
        return np.where((h < self.h_c) & (p < self.p_cap), -self.k, 0.0)

    def area_fraction_at(self, h):
        return np.clip((self.h_c - np.asarray(h, dtype=float)) / self.h_a, 0.0, 1.0)


def gt_F(n: float, t):
    """F_n(t) = Γ(n+1)/√(2π) e^(−t²/4) D_−(n+1)(t); 0 beyond t = 37 (underflow), |t|^n below t = −30."""
    t = np.asarray(t, dtype=float)
    tc = np.clip(t, -30.0, 37.0)
    f = gamma(n + 1) / math.sqrt(2 * math.pi) * np.exp(-tc * tc / 4) * pbdv(-(n + 1), tc)[0]
    return np.where(t > 37.0, 0.0, np.where(t < -30.0, np.abs(t) ** n, f))


@dataclass(frozen=True)
class GreenwoodTrippLaw:
    sigma: float = 0.72e-6
    eta: float = 5e9  # summits per m²
    beta: float = 20e-6  # summit radius, m
    e_star: float = 49e9
    h_min: float = 0.0
    h_max_sigmas: float = 4.0

    @property
    def h_max(self) -> float:
        return self.h_max_sigmas * self.sigma

    @property
    def _k(self) -> float:
        ebs = self.eta * self.beta * self.sigma
        return 16 * math.sqrt(2) * math.pi / 15 * ebs**2 * math.sqrt(self.sigma / self.beta) * self.e_star

    def pressure(self, h):
        return self._k * gt_F(2.5, np.asarray(h, dtype=float) / self.sigma)

    def dpressure_dh(self, h):
        return -self._k * 2.5 * gt_F(1.5, np.asarray(h, dtype=float) / self.sigma) / self.sigma

    def area_fraction_at(self, h):
        ebs = self.eta * self.beta * self.sigma
        return np.minimum(1.0, math.pi**2 * ebs**2 * gt_F(2.0, np.asarray(h, dtype=float) / self.sigma))


LAWS: dict[str, ContactLaw] = {"exponential": ExponentialLaw(), "winkler": WinklerLaw(), "gt": GreenwoodTrippLaw()}


def test_laws_have_the_interface_and_their_slopes_are_right():
    for name, law in LAWS.items():
        check_law(law, name)
        h = np.linspace(law.h_min, law.h_max, 7)[1:-1] + 1e-9 * (law.h_max - law.h_min) / 3
        step = 1e-6 * (law.h_max - law.h_min)
        fd = (law.pressure(h + step) - law.pressure(h - step)) / (2 * step)
        assert np.allclose(law.dpressure_dh(h), fd, rtol=1e-5, atol=0), name


def test_gt_F_matches_its_elementary_case():
    # F_1 = φ(t) − t F_0 with F_0 = erfc(t/√2)/2: an independent check of the pbdv form used by GreenwoodTrippLaw.
    t = np.array([-1.0, 0.0, 1.5, 3.0])
    phi = np.exp(-t * t / 2) / math.sqrt(2 * math.pi)
    f0 = 0.5 * np.array([math.erfc(x / math.sqrt(2)) for x in t])
    assert np.allclose(gt_F(1.0, t), phi - t * f0, rtol=1e-10)


def test_check_law_rejects_a_broken_law():
    import pytest

    @dataclass(frozen=True)
    class Rising(ExponentialLaw):
        def pressure(self, h):
            return -super().pressure(h)

    with pytest.raises(ValueError, match="non-increasing"):
        check_law(Rising(), "rising")
    with pytest.raises(TypeError):
        check_law(object(), "nothing")
