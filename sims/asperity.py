"""Single-asperity contact models (seed eq. 5–21, plus Jackson & Green 2005).

Every model describes one spherical asperity of radius ``R`` (m) pressed by interference ``delta`` (m) against a
flat, with Johnson's composite modulus ``E_star`` (Pa, seed eq. 4), and gives the normal ``force(delta)`` (N) and
the real contact ``area(delta)`` (m²). Vectorised: ``delta`` and ``R`` broadcast. ``delta <= 0`` gives exactly 0.

``"hertz"``              Seed eq. 5–7 as printed (Stachowiak & Batchelor), converted from their E′ = 2E*, R′ = R/2
                         in :func:`_stachowiak_to_johnson` (the only place); equals Johnson's sphere to 0.05 %
                         (their constant 1.0397 stands for (9/8)^(1/3) = 1.04004).
``"lagemann"``           Seed eq. 9–12 corrected: eq. 9 is a cube root, p0 = (6E*²W/R²)^(1/3)/π; eq. 11
                         W = √(16δ³E*²R/9) = (4/3)E*√R δ^(3/2); eq. 10 a = (3WR/(4E*))^(1/3); mean pressure 2/3 p0
                         (eq. 12 is garbled).
``"pasaribu_schipper"``  Seed eq. 13–21 (after Zhao, Maietta & Chang 2000) with ω_c1 = 0.89 R (H/E*)² (the printed
                         eq. 13 lacks the square) and ω_c2 = 54 ω_c1. Area continuous with continuous slope; force
                         continuous to 0.1 % at ω_c1 (it dips by that much: 0.4·π·0.89 = 1.1184 vs
                         (4/3)·0.89^1.5 = 1.1195) and exactly at ω_c2.
``"jackson_green"``      Jackson & Green (2005), elastic–plastic FEM fit: ω_c = (πC S_y/(2E*))² R,
                         C = 1.295 exp(0.736ν); Hertz below 1.9 ω_c; above,
                         P/P_c = e^(−¼(ω/ω_c)^(5/12)) (ω/ω_c)^(3/2) + (4H_G/(C S_y)) [1 − e^(−(ω/ω_c)^(5/9)/25)] ω/ω_c,
                         H_G/S_y = 2.84[1 − e^(−0.82 (a/R)^(−0.7))], a/R = √(ω/R) (ω/(1.9ω_c))^(B/2),
                         A = πRω (ω/(1.9ω_c))^B, B = 0.14 e^(23 S_y/E*). Area exactly continuous at 1.9 ω_c; force
                         rises by 0.5 % there (the published fit). Fitted for ω/ω_c up to ~110; beyond it the mean
                         pressure of the fit falls (extrapolation).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contactrig.core.validation import SettingError, check_choice, check_range
from sims.materials import HARDNESS_TO_YIELD

if TYPE_CHECKING:
    from sims.database import BuildContext, ContactCurve

__all__ = [
    "MODELS",
    "Hertz",
    "JacksonGreen",
    "Lagemann",
    "PasaribuSchipper",
    "model",
]

_STACHOWIAK_CONSTANT = 1.0397  # seed eq. 5, Stachowiak & Batchelor's rounding of (9/8)^(1/3)


def _stachowiak_to_johnson(E_star: float, R: ArrayLike) -> tuple[float, NDArray[np.float64]]:
    """E′ = 2E*, R′ = R/2: the one conversion from Stachowiak & Batchelor's convention (seed eq. 5–7)."""
    return 2.0 * E_star, np.asarray(R, dtype=float) / 2.0


def _check_E(E_star: float) -> float:
    return check_range("E_star", E_star, 1e3, 1e13, unit="Pa")


def _check_R(R: ArrayLike) -> NDArray[np.float64]:
    r = np.asarray(R, dtype=float)
    if r.size and not (np.all(np.isfinite(r)) and r.min() >= 1e-12 and r.max() <= 1e3):
        bad = r[~(np.isfinite(r) & (r >= 1e-12) & (r <= 1e3))]
        raise SettingError("R", float(bad.flat[0]) if bad.size else r, "expected radii in [1e-12, 1e3] m")
    return r


def _check_H(H: float | None, E_star: float) -> float:
    if H is None:
        raise SettingError("H", None, "this model needs the hardness of the softer body, Pa")
    H = check_range("H", H, 0.0, 1e12, lo_open=True, unit="Pa")
    if H > E_star:
        raise SettingError("H", H, f"expected H <= E* = {E_star:g} Pa (H/E* is 1e-3..1e-1 for metals)")
    return H


def _delta(delta: ArrayLike) -> NDArray[np.float64]:
    d = np.asarray(delta, dtype=float)
    if d.size and np.isnan(d).any():
        raise SettingError("delta", "nan", "expected interferences in m (got NaN)")
    return d


def _hertz_force(E_star: float, R: NDArray[np.float64], d: NDArray[np.float64]) -> NDArray[np.float64]:
    """Johnson: (4/3) E* √R δ^(3/2), δ >= 0."""
    return (4.0 / 3.0) * E_star * np.sqrt(R) * d * np.sqrt(d)


@dataclass(frozen=True)
class Hertz:
    """Seed eq. 5–7 (Stachowiak & Batchelor's form, converted): one elastic sphere on a flat."""

    E_star: float
    R: NDArray[np.float64] | float
    name: str = "hertz"

    def __post_init__(self) -> None:
        _check_E(self.E_star)
        _check_R(self.R)

    def force(self, delta: ArrayLike) -> NDArray[np.float64]:
        """W = √(δ³ E′² R′ / 1.0397³) (seed eq. 5), N."""
        d = np.maximum(_delta(delta), 0.0)
        E_p, R_p = _stachowiak_to_johnson(self.E_star, self.R)
        return E_p * np.sqrt(R_p) * d * np.sqrt(d) / _STACHOWIAK_CONSTANT**1.5

    def contact_radius(self, delta: ArrayLike) -> NDArray[np.float64]:
        """a = (3 W R′ / E′)^(1/3) (seed eq. 6), m."""
        E_p, R_p = _stachowiak_to_johnson(self.E_star, self.R)
        return np.cbrt(3.0 * self.force(delta) * R_p / E_p)

    def area(self, delta: ArrayLike) -> NDArray[np.float64]:
        """π a², m²."""
        return np.pi * self.contact_radius(delta) ** 2

    def peak_pressure(self, delta: ArrayLike) -> NDArray[np.float64]:
        """P_max = 3W/(2πa²) (seed eq. 7), Pa; 0 out of contact."""
        return 1.5 * self.mean_pressure(delta)

    def mean_pressure(self, delta: ArrayLike) -> NDArray[np.float64]:
        """P_av = W/(πa²) (seed eq. 7), Pa; 0 out of contact."""
        w = self.force(delta)
        a2 = np.pi * self.contact_radius(delta) ** 2
        return np.divide(w, a2, out=np.zeros_like(w), where=a2 > 0)


@dataclass(frozen=True)
class Lagemann:
    """Seed eq. 9–12, corrected to Johnson's Hertz sphere (cube root in eq. 9, mean = 2/3 peak)."""

    E_star: float
    R: NDArray[np.float64] | float
    name: str = "lagemann"

    def __post_init__(self) -> None:
        _check_E(self.E_star)
        _check_R(self.R)

    def force(self, delta: ArrayLike) -> NDArray[np.float64]:
        """W = √(16 δ³ E*² R / 9) (seed eq. 11), N."""
        d = np.maximum(_delta(delta), 0.0)
        return 4.0 / 3.0 * self.E_star * np.sqrt(np.asarray(self.R, dtype=float)) * d * np.sqrt(d)

    def contact_radius(self, delta: ArrayLike) -> NDArray[np.float64]:
        """a = (3WR/(4E*))^(1/3) (seed eq. 10), m."""
        return np.cbrt(3.0 * self.force(delta) * np.asarray(self.R, dtype=float) / (4.0 * self.E_star))

    def area(self, delta: ArrayLike) -> NDArray[np.float64]:
        return np.pi * self.contact_radius(delta) ** 2

    def peak_pressure(self, delta: ArrayLike) -> NDArray[np.float64]:
        """p0 = (1/π)(6 E*² W / R²)^(1/3) (seed eq. 9 with its cube root), Pa."""
        R = np.asarray(self.R, dtype=float)
        return np.cbrt(6.0 * self.E_star**2 * self.force(delta) / R**2) / np.pi

    def mean_pressure(self, delta: ArrayLike) -> NDArray[np.float64]:
        """2/3 p0 (the mean of the Hertz profile p0 √(1 − r²/a²); replaces the garbled eq. 12), Pa."""
        return 2.0 / 3.0 * self.peak_pressure(delta)

    def pressure_profile(self, r: ArrayLike, delta: float) -> NDArray[np.float64]:
        """p(r) = p0 √(1 − r²/a²) for r <= a, else 0, Pa (what eq. 12 should say)."""
        a = float(self.contact_radius(delta))
        p0 = float(self.peak_pressure(delta))
        rr = np.abs(np.asarray(r, dtype=float))
        if a == 0.0:
            return np.zeros_like(rr)
        return np.where(rr < a, p0 * np.sqrt(np.maximum(1.0 - (rr / a) ** 2, 0.0)), 0.0)


@dataclass(frozen=True)
class PasaribuSchipper:
    """Seed eq. 13–21 with ω_c1 = 0.89 R (H/E*)² (eq. 13 corrected) and ω_c2 = 54 ω_c1 (eq. 14)."""

    E_star: float
    R: NDArray[np.float64] | float
    H: float
    name: str = "pasaribu_schipper"

    def __post_init__(self) -> None:
        _check_R(self.R)
        _check_H(self.H, _check_E(self.E_star))

    @property
    def omega_c1(self) -> NDArray[np.float64]:
        """Onset of yield, m: 0.89 R (H/E*)² (yield at a mean pressure of 0.4 H; seed eq. 13 with the square)."""
        return 0.89 * np.asarray(self.R, dtype=float) * (self.H / self.E_star) ** 2

    @property
    def omega_c2(self) -> NDArray[np.float64]:
        """Onset of full plasticity, m: 54 ω_c1 (seed eq. 14)."""
        return 54.0 * self.omega_c1

    def _parts(self, delta: ArrayLike) -> tuple[NDArray[np.float64], ...]:
        d = np.maximum(_delta(delta), 0.0)
        R = np.asarray(self.R, dtype=float)
        w1, w2 = self.omega_c1, self.omega_c2
        d, R, w1, w2 = np.broadcast_arrays(d, R, w1, w2)
        return d, R, w1, w2

    def area(self, delta: ArrayLike) -> NDArray[np.float64]:
        """Seed eq. 15 (elastic), 17 (elastic–plastic), 20 (plastic), m²."""
        d, R, w1, w2 = self._parts(delta)
        x = np.clip((d - w1) / (w2 - w1), 0.0, 1.0)
        smooth = 1.0 - 2.0 * x**3 + 3.0 * x**2  # 1 at ω_c1, 2 at ω_c2
        return np.pi * R * d * smooth

    def force(self, delta: ArrayLike) -> NDArray[np.float64]:
        """Seed eq. 16 (elastic), 18 (elastic–plastic), 21 (plastic), N."""
        d, R, w1, w2 = self._parts(delta)
        a = self.area(delta)
        elastic = _hertz_force(self.E_star, R, d)
        safe_d = np.where(d > 0.0, d, w1)
        ratio = np.log(w2 / np.clip(safe_d, w1, w2)) / math.log(54.0)
        ep = (self.H - 0.6 * self.H * ratio) * a
        return np.where(d < w1, elastic, np.where(d <= w2, ep, self.H * a))


@dataclass(frozen=True)
class JacksonGreen:
    """Jackson & Green (2005): FEM-fitted elastic–plastic sphere on a rigid flat, with S_y and ν of the softer body."""

    E_star: float
    R: NDArray[np.float64] | float
    yield_strength: float
    nu: float = 0.3
    name: str = "jackson_green"

    def __post_init__(self) -> None:
        _check_E(self.E_star)
        _check_R(self.R)
        check_range("yield_strength", self.yield_strength, 0.0, 1e12, lo_open=True, unit="Pa")
        check_range("nu", self.nu, 0.0, 0.5, hi_open=True)
        e_y = self.yield_strength / self.E_star
        if not 1e-7 <= e_y <= 0.1:
            raise SettingError("yield_strength", self.yield_strength, "expected S_y/E* in [1e-7, 0.1] (J&G's range)")

    @property
    def C(self) -> float:
        return 1.295 * math.exp(0.736 * self.nu)

    @property
    def omega_c(self) -> NDArray[np.float64]:
        """Critical interference, m: (π C S_y / (2E*))² R."""
        return (math.pi * self.C * self.yield_strength / (2.0 * self.E_star)) ** 2 * np.asarray(self.R, dtype=float)

    @property
    def critical_force(self) -> NDArray[np.float64]:
        """P_c = (4/3)(R/E*)² (C π S_y / 2)³, N."""
        R = np.asarray(self.R, dtype=float)
        return 4.0 / 3.0 * (R / self.E_star) ** 2 * (self.C * math.pi * self.yield_strength / 2.0) ** 3

    @property
    def B(self) -> float:
        return 0.14 * math.exp(23.0 * self.yield_strength / self.E_star)

    def _parts(self, delta: ArrayLike) -> tuple[NDArray[np.float64], ...]:
        d = np.maximum(_delta(delta), 0.0)
        R = np.asarray(self.R, dtype=float)
        wc = self.omega_c
        d, R, wc = np.broadcast_arrays(d, R, wc)
        x = d / wc
        return d, R, wc, x

    def area(self, delta: ArrayLike) -> NDArray[np.float64]:
        """πRω below 1.9 ω_c, πRω (ω/(1.9ω_c))^B above, m²."""
        d, R, _, x = self._parts(delta)
        ln_x19 = np.log(np.maximum(x, 1.9) / 1.9)
        return np.pi * R * d * np.exp(self.B * ln_x19)

    def force(self, delta: ArrayLike) -> NDArray[np.float64]:
        """Hertz below 1.9 ω_c, the J&G fit above, N."""
        d, R, wc, x = self._parts(delta)
        elastic = _hertz_force(self.E_star, R, d)
        xp = np.maximum(x, 1.9)
        ln_a_over_r = 0.5 * np.log(xp * wc / R) + 0.5 * self.B * np.log(xp / 1.9)
        hg_sy = HARDNESS_TO_YIELD * (1.0 - np.exp(-0.82 * np.exp(-0.7 * ln_a_over_r)))
        pc = self.critical_force
        plastic = pc * (
            np.exp(-0.25 * xp ** (5.0 / 12.0)) * xp**1.5
            + 4.0 * hg_sy / self.C * (1.0 - np.exp(-(xp ** (5.0 / 9.0)) / 25.0)) * xp
        )
        return np.where(x < 1.9, elastic, plastic)


def _make_hertz(E_star: float, R: NDArray[np.float64] | float, H: float | None, sy: float | None, nu: float) -> Any:
    return Hertz(E_star, R)


def _make_lagemann(E_star: float, R: NDArray[np.float64] | float, H: float | None, sy: float | None, nu: float) -> Any:
    return Lagemann(E_star, R)


def _make_ps(E_star: float, R: NDArray[np.float64] | float, H: float | None, sy: float | None, nu: float) -> Any:
    return PasaribuSchipper(E_star, R, _check_H(H, E_star))


def _make_jg(E_star: float, R: NDArray[np.float64] | float, H: float | None, sy: float | None, nu: float) -> Any:
    H = _check_H(H, E_star)
    sy = H / HARDNESS_TO_YIELD if sy is None else check_range("yield_strength", sy, 0.0, 1e12, lo_open=True, unit="Pa")
    return JacksonGreen(E_star, R, sy, check_range("nu", nu, 0.0, 0.5, hi_open=True))


# The one table of single-asperity models: key → factory(E*, R, H, S_y, ν).
_FACTORIES: dict[str, Callable[..., Any]] = {
    "hertz": _make_hertz,
    "lagemann": _make_lagemann,
    "pasaribu_schipper": _make_ps,
    "jackson_green": _make_jg,
}
MODELS = tuple(_FACTORIES)


def model(
    name: str,
    *,
    E_star: float,
    R: ArrayLike,
    H: float | None = None,
    yield_strength: float | None = None,
    nu: float = 0.3,
) -> Hertz | Lagemann | PasaribuSchipper | JacksonGreen:
    """The asperity model ``name`` (one of :data:`MODELS`) for composite modulus ``E_star`` (Pa) and radius ``R``
    (m, scalar or array). ``H`` (Pa, softer body) is needed by the plastic models; Jackson–Green uses
    ``yield_strength`` (Pa, default H/2.84) and the softer body's Poisson ratio ``nu``."""
    check_choice("model", name, MODELS)
    E_star = _check_E(E_star)
    Rc = _check_R(R)
    R_val: NDArray[np.float64] | float = float(Rc) if Rc.ndim == 0 else Rc
    made: Hertz | Lagemann | PasaribuSchipper | JacksonGreen = _FACTORIES[name](E_star, R_val, H, yield_strength, nu)
    return made


# ---------------------------------------------------------------------------------------------------------------
# Registration: each model summed over the composite surface's summits (sims.database.BuildContext.summed_curve).

_JG_FIT_LIMIT = 110.0  # Jackson & Green (2005) fitted ω/ω_c up to about this


def _summed(key: str, ctx: BuildContext) -> tuple[Any, ContactCurve]:
    soft = ctx.materials.softer
    assert ctx.summits is not None  # needs_surface=True guarantees it
    m = model(key, E_star=ctx.E_star, R=ctx.summits.radius_m, H=ctx.materials.H,
              yield_strength=soft.yield_strength_pa, nu=soft.nu)
    extra = {"yield_pa": soft.yield_strength_pa, "nu": soft.nu} if key == "jackson_green" else {}
    return m, ctx.summed_curve(key, m, extra)


def _summed_curve(key: str, ctx: BuildContext) -> ContactCurve:
    return _summed(key, ctx)[1]


def _build_jackson_green(ctx: BuildContext) -> ContactCurve:
    m, curve = _summed("jackson_green", ctx)
    assert ctx.summits is not None
    # J&G fitted their FEM results up to ω/ω_c ≈ 110; deeper, the fit is an extrapolation
    reach = float(np.max((ctx.summits.height_m - ctx.summits.separation_m[0]) / m.omega_c))
    curve.parameters["max_interference_over_omega_c"] = reach
    if reach > _JG_FIT_LIMIT:
        ctx.warn(
            f"jackson_green: summits reach ω/ω_c = {reach:.3g} at the deepest separation, beyond the "
            f"range of Jackson & Green's fit (≤ {_JG_FIT_LIMIT:g}): extrapolated there"
        )
    return curve


def _register() -> None:
    from sims.models import ContactModel, register

    # key, label, source, elastic only, figure style (the same in every figure; coinciding models stay visible)
    specs: tuple[tuple[str, str, str, bool, dict[str, Any]], ...] = (
        ("hertz", "Hertz", "seed eq. 5–7", True, {"color": "#d62728", "linestyle": "--", "marker": "s"}),
        ("lagemann", "Lagemann", "seed eq. 9–12", True, {"color": "#2ca02c", "linestyle": "-.", "marker": "^"}),
        (
            "pasaribu_schipper",
            "Pasaribu–Schipper",
            "seed eq. 13–21",
            False,
            {"color": "#9467bd", "linestyle": ":", "marker": "v"},
        ),
    )
    for key, label, eqs, elastic, style in specs:
        register(
            ContactModel(
                key,
                label,
                build=partial(_summed_curve, key),
                equations=eqs,
                elastic_only=elastic,
                style=style,
            ),
            replace=True,
        )
    jg_style = {"color": "#ff7f0e", "linestyle": (0, (6, 2, 1, 2, 1, 2)), "marker": "D"}
    register(
        ContactModel(
            "jackson_green",
            "Jackson–Green",
            build=_build_jackson_green,
            equations="Jackson & Green (2005)",
            style=jg_style,
        ),
        replace=True,
    )


_register()
