"""A physical contact-resistance model: film + clean-metal constriction + macroscopic constriction + series.

The seed paper's eq. 23, ``R = ζh/A``, has no meaning as a constriction resistance (that scales as ρ/Σa, with no
length h). It is the form of a surface-film resistance ``σ_f/A_real`` with ``σ_f = ζh`` [Ω·m²] (a film of
resistivity ρ_f and thickness t has σ_f = ρ_f t; Holm, *Electric Contacts* §14). The model fitted here::

    R(W) = R_s + σ_f / A(W) + R_c(W) + R_macro(W)                                          [Ω]

* ``R_s`` [Ω] series resistance of leads, other contacts and bodies (fitted);
* ``σ_f`` [Ω·m²] film resistance per unit real area (fitted; eq. 23's ζh);
* ``R_c = (ρ1 + ρ2) E* / (2 K)`` clean-metal constriction of all micro-contacts, Barber, Proc. R. Soc. A 459
  (2003) 53 (exact for elastic half-spaces, any spot shapes, small slopes): ``K`` the total normal stiffness of
  the interface [N/m]. In the rig, the spots of each skirt element are in parallel, so ``K = Σ −p′(h_i) ΔA_i``
  over the skirt (the database's slope, local normals), computed, not fitted;
* ``R_macro`` [Ω] constriction of the nominal contact band (the bodies seen from outside the band), Holm's
  elliptic spot of semi-axes ``a ≥ b``: ``(ρ1 + ρ2) K(e) / (2π a)``, ``e² = 1 − b²/a²`` (Holm §4; the circle gives
  ``(ρ1 + ρ2)/(4a)``), with ``a = L/2`` and ``b`` half the nominal band width; computed.

Holm's single spot (all of A in one circle, ``(ρ1+ρ2)/(4√(A/π))``, the ``holm`` conversion of :mod:`analysis.fit`)
is an **upper bound** on the clean-metal constriction of any contact of real area A (Pólya & Szegő 1951: among
plane sets of given area the disc has the least capacity, hence the largest constriction resistance); it is not a
model of the rig, whose measured log slope (−0.92 in Tab. 1) it cannot follow (−0.5 by construction).

The fit of ``R_s`` and ``σ_f`` is linear with the clean-metal terms as a known offset: weighted least squares in
closed form (:func:`fit_film_series`), vectorised over any number of sessions (the design's Monte Carlo uses it).
Weights as :mod:`analysis.fit`'s ``"relative"`` weighting: σ_i = c·R̄_i/√n_i, c the pooled relative SD.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import ellipk

from contactrig.core.validation import SettingError, check_range

__all__ = [
    "FilmFit",
    "PhysicalFit",
    "RigResistanceTerms",
    "SpecimenTerms",
    "barber_resistance_ohm",
    "bench_resistance_ohm",
    "elliptic_spot_resistance_ohm",
    "fit_film_series",
    "fit_measured",
    "holm_upper_bound_ohm",
    "parallel_holm_ohm",
    "physical_sentence",
    "rig_resistance_terms",
    "specimen_resistance_terms",
    "stiffness_weighted_width_m",
    "tab1_statement",
]


def _positive(field_name: str, value: ArrayLike, unit: str) -> np.ndarray:
    x = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(x)) or np.any(x <= 0):
        raise SettingError(field_name, value if x.ndim == 0 else "array", f"expected finite values > 0 {unit}")
    return x


def barber_resistance_ohm(
    stiffness_n_per_m: ArrayLike, resistivity_sum_ohm_m: float, composite_modulus_pa: float
) -> np.ndarray:
    """Barber (2003): clean-metal constriction ``R = (ρ1 + ρ2) E* / (2 dF/dδ)`` [Ω].

    ``stiffness_n_per_m`` incremental normal stiffness dF/dδ [N/m] (> 0); ρ1 + ρ2 [Ω·m]; E* [Pa] (seed eq. 4).
    """
    k = _positive("stiffness_n_per_m", stiffness_n_per_m, "N/m")
    rho = check_range("resistivity_sum_ohm_m", resistivity_sum_ohm_m, 0.0, None, lo_open=True, unit="Ω·m")
    e = check_range("composite_modulus_pa", composite_modulus_pa, 0.0, None, lo_open=True, unit="Pa")
    return rho * e / (2.0 * k)


def elliptic_spot_resistance_ohm(
    semi_axis_a_m: ArrayLike, semi_axis_b_m: ArrayLike, resistivity_sum_ohm_m: float
) -> np.ndarray:
    """Holm: constriction of one elliptic spot between two half-spaces, ``(ρ1+ρ2) K(e)/(2π a)`` [Ω], a ≥ b [m].

    ``K`` the complete elliptic integral of the first kind of modulus ``e = √(1 − b²/a²)``; the circle gives
    ``(ρ1+ρ2)/(4a)``; the axes may be given in either order.
    """
    a1 = _positive("semi_axis_a_m", semi_axis_a_m, "m")
    b1 = _positive("semi_axis_b_m", semi_axis_b_m, "m")
    a, b = np.maximum(a1, b1), np.minimum(a1, b1)
    rho = check_range("resistivity_sum_ohm_m", resistivity_sum_ohm_m, 0.0, None, lo_open=True, unit="Ω·m")
    return np.asarray(rho * ellipk(1.0 - (b / a) ** 2) / (2.0 * math.pi * a))


def parallel_holm_ohm(spot_areas_m2: ArrayLike, resistivity_sum_ohm_m: float) -> float:
    """Holm spots in parallel, each a circle of its area: ``1/R = Σ 4 a_i/(ρ1 + ρ2)``, ``a_i = √(A_i/π)`` [Ω]."""
    areas = _positive("spot_areas_m2", spot_areas_m2, "m²").reshape(-1)
    rho = check_range("resistivity_sum_ohm_m", resistivity_sum_ohm_m, 0.0, None, lo_open=True, unit="Ω·m")
    return float(rho / (4.0 * np.sum(np.sqrt(areas / math.pi))))


def holm_upper_bound_ohm(area_m2: ArrayLike, resistivity_sum_ohm_m: float) -> np.ndarray:
    """Holm's single spot of the whole real area, ``(ρ1+ρ2)/(4√(A/π))`` [Ω]: an upper bound on the clean-metal
    constriction of any contact of real area A (Pólya–Szegő; module docstring)."""
    a = np.sqrt(_positive("area_m2", area_m2, "m²") / math.pi)
    rho = check_range("resistivity_sum_ohm_m", resistivity_sum_ohm_m, 0.0, None, lo_open=True, unit="Ω·m")
    return np.asarray(rho / (4.0 * a))


# ---------------------------------------------------------------------------------------------------------------
# The rig's clean-metal terms from the contact solution.


@dataclass(frozen=True)
class RigResistanceTerms:
    """The computed (not fitted) parts of R(W) for one contact model, per weight.

    ``weight_kg`` [kg]; ``area_m2`` real area A(W) [m²]; ``stiffness_n_per_m`` K(W) = Σ −p′(h) ΔA [N/m];
    ``band_width_m`` the stiffness-weighted band width [m] (:func:`stiffness_weighted_width_m`; R_macro uses it);
    ``pressure_width_m`` the p > 0 band width of the rigid rig [m]; ``barber_ohm`` R_c [Ω]; ``macro_ohm`` R_macro
    [Ω]; ``holm_bound_ohm`` Holm's single-spot upper bound [Ω]; ``resistivity_sum_ohm_m`` ρ1 + ρ2;
    ``composite_modulus_pa`` E*.
    """

    model: str
    weight_kg: np.ndarray
    area_m2: np.ndarray
    stiffness_n_per_m: np.ndarray
    band_width_m: np.ndarray
    barber_ohm: np.ndarray
    macro_ohm: np.ndarray
    holm_bound_ohm: np.ndarray
    resistivity_sum_ohm_m: float
    composite_modulus_pa: float
    pressure_width_m: np.ndarray | None = None

    @property
    def clean_ohm(self) -> np.ndarray:
        """Clean-metal part R_c + R_macro [Ω]."""
        return self.barber_ohm + self.macro_ohm

    def known_terms(self) -> dict[str, np.ndarray]:
        """The computed terms of the physical model by name, per weight [Ω]: "barber" and "macro"."""
        return {"barber": self.barber_ohm, "macro": self.macro_ohm}


def _skirt_stiffness(batch: Any) -> np.ndarray:
    """K = Σ −p′(h_i) ΔA_i [N/m] over the skirt mesh of a batch equilibrium, per weight (local normals)."""
    h = batch.loads.gap(np.asarray(batch.min_separation_m, dtype=float))
    dp = np.asarray(batch.loads.law.dpressure_dh(h.reshape(-1)), dtype=float).reshape(h.shape)
    return np.asarray(np.einsum("...ty,ty->...", -dp, batch.mesh.area_m2))


def stiffness_weighted_width_m(batch: Any) -> np.ndarray:
    """The band width the current sees [m], per weight: 2√3·σ with σ² the stiffness-weighted mean square of the
    arc length R_p·θ over the skirt (weights −p′(h)·ΔA, both mirror halves: mean zero). The current flows where the
    interface is stiff (Barber: conductance ∝ stiffness); the p > 0 edge of the band is the contact law's tail
    (model-dependent, much wider) and made R_macro 30–40 % low (issue 21 §2). A uniform band of width b gives b."""
    h = batch.loads.gap(np.asarray(batch.min_separation_m, dtype=float))
    dp = np.asarray(batch.loads.law.dpressure_dh(h.reshape(-1)), dtype=float).reshape(h.shape)
    k_theta = np.sum(-dp * batch.mesh.area_m2, axis=-1)  # (..., n_theta)
    s = batch.mesh.radius_m * batch.mesh.theta_rad
    total = np.sum(k_theta, axis=-1)
    var = np.sum(k_theta * s**2, axis=-1) / np.where(total > 0, total, 1.0)
    return np.asarray(2.0 * math.sqrt(3.0) * np.sqrt(var))


def rig_resistance_terms(
    config: Any, model: str, weights_kg: Sequence[float] | None = None, *, law: Any = None
) -> RigResistanceTerms:
    """The clean-metal terms of the rig for ``model`` at ``weights_kg`` [kg] (default the scene's).

    ``config`` a :class:`sims.config.SimConfig` whose materials give ``resistivity_ohm_m`` for both bodies;
    ``law`` a prebuilt contact law (else the model's curve is built). Rigid rig, :func:`sims.rig.batch_equilibrium`.
    """
    from sims.rig import batch_equilibrium

    rho = config.materials.resistivity_sum_ohm_m
    if rho is None:
        raise SettingError("materials.liner.resistivity_ohm_m", None, "both bodies' resistivities are needed")
    if law is None:
        from sims.database import build_database

        law = build_database(config, models=[model])[model]
    weights = tuple(config.rig.weights_kg if weights_kg is None else weights_kg)
    batch = batch_equilibrium(law, config.rig, weights, name=model)
    e_star = float(config.materials.E_star)
    stiffness = _skirt_stiffness(batch)
    area = np.asarray(batch.contact_area_m2, dtype=float)
    width = stiffness_weighted_width_m(batch)
    return RigResistanceTerms(
        model=model,
        weight_kg=np.asarray(weights, dtype=float),
        area_m2=area,
        stiffness_n_per_m=stiffness,
        band_width_m=width,
        barber_ohm=barber_resistance_ohm(stiffness, rho, e_star),
        macro_ohm=elliptic_spot_resistance_ohm(0.5 * config.rig.skirt_length_m, 0.5 * width, rho),
        holm_bound_ohm=holm_upper_bound_ohm(area, rho),
        resistivity_sum_ohm_m=rho,
        composite_modulus_pa=e_star,
        pressure_width_m=np.asarray(batch.contact_width_m, dtype=float),
    )


@dataclass(frozen=True)
class SpecimenTerms:
    """A(W) [m²] and the computed terms of R(W) by name [Ω] ("barber", "macro"; empty without resistivities) of one
    contact model at ``weight_kg`` [kg], for the rig or the press."""

    model: str
    weight_kg: np.ndarray
    area_m2: np.ndarray
    terms: dict[str, np.ndarray]

    @property
    def clean_ohm(self) -> np.ndarray:
        """The clean-metal part, the sum of the terms [Ω] (zeros without resistivities)."""
        return np.sum([np.zeros_like(self.area_m2), *self.terms.values()], axis=0)


def specimen_resistance_terms(
    config: Any, models: Sequence[str], weights_kg: Sequence[float], *, laws: Any = None, require: bool = True
) -> dict[str, SpecimenTerms]:
    """The one resistance model of the design, the simulated bench and the physical fit: A(W) and the clean-metal
    terms of each model at ``weights_kg`` [kg]. The rig: :func:`rig_resistance_terms` (the physical conversion's
    function). The press: Barber's term from the press stiffness and Holm's circular spot of the nominal contact
    radius ("macro"). ``laws`` prebuilt contact laws by model (else built); ``require``: a scene without both
    resistivities is a SettingError (else the terms are empty: film and series only)."""
    weights = [float(w) for w in weights_kg]
    rho = config.materials.resistivity_sum_ohm_m
    if rho is None and require:
        raise SettingError(
            "materials.liner.resistivity_ohm_m", None,
            "both bodies' resistivities are needed by the clean-metal terms (materials.*.resistivity_ohm_m)",
        )  # fmt: skip
    if laws is None:
        from sims.database import build_database

        laws = build_database(config, models=list(models))
    w = np.asarray(weights, dtype=float)
    if config.press is not None:
        from sims.press import press_sweep

        res = press_sweep(config, config.press, list(models), weights, laws={n: laws[n] for n in models})
        out = {}
        for n in models:
            area = np.asarray(res.models[n].contact_area_m2, dtype=float)
            terms = {}
            if rho is not None:
                k = np.asarray(res.provenance["press"]["models"][n]["stiffness_n_per_m"], dtype=float)
                radius = 0.5 * np.asarray(res.models[n].contact_width_m, dtype=float)
                terms = {"barber": barber_resistance_ohm(k, rho, float(config.materials.E_star)),
                         "macro": elliptic_spot_resistance_ohm(radius, radius, rho)}  # fmt: skip
            out[n] = SpecimenTerms(n, w, area, terms)
        return out
    if rho is None:
        from sims.rig import batch_equilibrium

        return {
            n: SpecimenTerms(n, w, np.asarray(batch_equilibrium(laws[n], config.rig, weights).contact_area_m2), {})
            for n in models
        }
    out = {}
    for n in models:
        t = rig_resistance_terms(config, n, weights, law=laws[n])
        out[n] = SpecimenTerms(n, w, t.area_m2, t.known_terms())
    return out


def bench_resistance_ohm(
    series_ohm: float, film_ohm_m2: float, area_m2: ArrayLike, clean_ohm: ArrayLike, factors: ArrayLike
) -> np.ndarray:
    """What the bench measures for one block: ``R_s + f·(σ_f/A + R_clean)`` [Ω] (the contact re-made with factor f,
    :mod:`analysis.noise_model`; the series resistance is not). ``area_m2``, ``clean_ohm`` per weight (last axis of
    shape (m,)), ``factors`` shape (..., m, r): the result has the shape of ``factors``. One formula for the design's
    simulated sessions and the simulated bench."""
    contact = film_ohm_m2 / np.asarray(area_m2, dtype=float) + np.asarray(clean_ohm, dtype=float)
    return np.asarray(series_ohm + np.asarray(factors, dtype=float) * contact[:, None])


# ---------------------------------------------------------------------------------------------------------------
# The linear fit of R_s and σ_f, closed form, vectorised over sessions.


@dataclass(frozen=True)
class FilmFit:
    """Weighted least squares of ``R − R_clean = R_s + σ_f/A`` (leading axes: sessions; last axis: weights).

    ``series_ohm`` R_s [Ω], ``film_ohm_m2`` σ_f [Ω·m²], their standard errors ``*_se`` (from the weights:
    ``σ_i`` known up to the pooled relative scatter), ``chi2`` [-], ``dof``, ``aic`` = χ² + 2·2,
    ``predicted_ohm`` the fitted R(W) [Ω], ``shares`` dict of each term's share of the fitted R per weight.
    """

    series_ohm: np.ndarray
    film_ohm_m2: np.ndarray
    series_se: np.ndarray
    film_se: np.ndarray
    chi2: np.ndarray
    dof: int
    aic: np.ndarray
    predicted_ohm: np.ndarray = field(repr=False)
    shares: dict[str, np.ndarray] = field(repr=False, default_factory=dict)


def fit_film_series(
    mean_ohm: ArrayLike,
    sigma_ohm: ArrayLike,
    area_m2: ArrayLike,
    clean_ohm: ArrayLike,
    *,
    barber_ohm: ArrayLike | None = None,
) -> FilmFit:
    """Closed-form WLS of ``R̄_i = R_s + σ_f/A_i + R_clean,i`` with weights ``1/σ_i²``.

    ``mean_ohm``, ``sigma_ohm`` shape (..., m) [Ω] (any leading axes: many sessions at once); ``area_m2`` and
    ``clean_ohm`` shape (m,) or broadcastable [m², Ω]. Normal equations of the two parameters solved directly
    (the determinant is positive for ≥ 2 distinct areas). ``barber_ohm`` splits the clean share in the report.
    """
    y = np.asarray(mean_ohm, dtype=float) - np.asarray(clean_ohm, dtype=float)
    v = 1.0 / np.asarray(sigma_ohm, dtype=float) ** 2
    x = 1.0 / _positive("area_m2", area_m2, "m²")
    x = np.broadcast_to(x, y.shape)
    s, sx, sxx = v.sum(-1), (v * x).sum(-1), (v * x * x).sum(-1)
    sy, sxy = (v * y).sum(-1), (v * x * y).sum(-1)
    det = s * sxx - sx * sx
    film = (s * sxy - sx * sy) / det
    series = (sxx * sy - sx * sxy) / det
    fit_y = series[..., None] + film[..., None] * x
    chi2 = np.sum(v * (y - fit_y) ** 2, axis=-1)
    predicted = fit_y + np.asarray(clean_ohm, dtype=float)
    clean = np.broadcast_to(np.asarray(clean_ohm, dtype=float), predicted.shape)
    shares = {
        "series": np.broadcast_to(series[..., None], predicted.shape) / predicted,
        "film": film[..., None] * x / predicted,
        "clean_metal": clean / predicted,
    }
    if barber_ohm is not None:
        shares["barber"] = np.broadcast_to(np.asarray(barber_ohm, dtype=float), predicted.shape) / predicted
    m = y.shape[-1]
    return FilmFit(
        series_ohm=series,
        film_ohm_m2=film,
        series_se=np.sqrt(sxx / det),
        film_se=np.sqrt(s / det),
        chi2=chi2,
        dof=m - 2,
        aic=chi2 + 4.0,
        predicted_ohm=predicted,
        shares=shares,
    )


def relative_sigma_ohm(values_ohm: ArrayLike) -> np.ndarray:
    """σ_i = c·R̄_i/√n_i with c the pooled relative SD of the repeats (``analysis.fit``'s "relative" weighting).

    ``values_ohm`` shape (..., m, r) [Ω], r ≥ 2 repeats at every weight; returns shape (..., m).
    """
    vals = np.asarray(values_ohm, dtype=float)
    n = vals.shape[-1]
    mean = vals.mean(-1)
    rel2 = vals.var(-1, ddof=1) / mean**2
    c = np.sqrt(rel2.mean(-1))
    return np.asarray(c[..., None] * mean / math.sqrt(n))


@dataclass(frozen=True, eq=False)
class PhysicalFit:
    """The physical model ``R = R_s + σ_f/A + R_Barber + R_macro`` fitted to a measured curve.

    ``fit`` the :class:`analysis.fit.ModelFit` of R − R_clean = R_s + σ_f·(1/A) (``fit.estimate.scale`` is σ_f
    [Ω·m²]; its errors follow :mod:`analysis.fit`'s one rule: repeat covariance, or χ²-scaled when
    over-dispersed, copies of other series counted once); ``terms`` the computed clean-metal terms; ``measured_ohm``
    the measured mean per weight [Ω] (independent series only); ``shares`` each term's share of the **measured**
    mean per weight: "series", "film", "barber", "macro" (they add up to fitted/measured) and "residual"
    (measured − fitted)/measured, so that all five add up to 1.
    """

    fit: Any
    terms: RigResistanceTerms
    measured_ohm: np.ndarray
    shares: dict[str, np.ndarray]
    n_series: int
    series_notes: tuple[str, ...] = ()


def fit_measured(curve: Any, terms: RigResistanceTerms, *, n_boot: int = 0, seed: int | None = 0) -> PhysicalFit:
    """Fit a :class:`analysis.measured.MeasuredCurve` with the clean terms of ``terms`` (:class:`PhysicalFit`),
    through :func:`analysis.fit.compare_models` (same weights, error rule and series handling as every fit)."""
    from analysis.fit import compare_models

    if curve.weight_kg.shape != terms.weight_kg.shape or not np.allclose(curve.weight_kg, terms.weight_kg):
        raise SettingError("weight_kg", curve.weight_kg.tolist(), "expected the weights the terms were computed at")
    cmp = compare_models(
        curve, {terms.model: terms.area_m2}, height_m=1.0, conversion="physical", n_boot=n_boot, seed=seed,
        offset_terms={terms.model: terms.known_terms()},
    )  # fmt: skip
    fit = cmp.fits[terms.model]
    return PhysicalFit(fit, terms, fit.points.measured_ohm, dict(fit.shares), cmp.n_repeats, cmp.series_notes)


def physical_sentence(pf: PhysicalFit, label: str, what: str = "Tab. 1") -> str:
    """The plain sentence: σ_f and R_s with the rule their errors follow, and the clean-metal share of the measured
    mean; ``label`` the contact model's display name, ``what`` the data ("Tab. 1", "this session")."""
    est, terms = pf.fit.estimate, pf.terms
    clean = pf.shares["barber"] + pf.shares["macro"]
    lo, hi = 100 * float(np.min(clean)), 100 * float(np.max(clean))
    verdict = (
        f"so {what} measures a film (or the circuit), not metal-to-metal constriction."
        if hi < 10
        else f"so the clean-metal constriction is a visible part of what {what} measures."
    )
    return (
        f"With the {label} contact area, {what} is R = R_s + σ_f/A + clean metal with σ_f = {est.scale:.2e} ± "
        f"{est.scale_se:.1e} Ω·m² (a surface film; eq. 23's ζh) and R_s = {1e3 * est.R_series_ohm:.2f} ± "
        f"{1e3 * est.R_series_se:.2f} mΩ (± 1 SE; errors: {est.error_rule}"
        + (f"; {'; '.join(pf.series_notes)}" if pf.series_notes else "")
        + f"); the clean-metal constriction (Barber, ρ1+ρ2 = {terms.resistivity_sum_ohm_m:.3g} Ω·m, plus the band's "
        f"macro-constriction {1e3 * float(terms.macro_ohm.mean()):.3f} mΩ) is {lo:.1f}–{hi:.1f} % of the measured "
        f"mean resistance, {verdict}"
    )


def tab1_statement(config: Any = None, model: str = "greenwood_tripp", curve: Any = None) -> str:
    """The plain sentence for the Tab. 1 report: fitted σ_f, R_s and the clean-metal share (default scene).

    ``config`` a :class:`sims.config.SimConfig` (None → the default scene), ``curve`` a measured curve (None →
    seed Tab. 1 via :func:`analysis.measured.load_tab1`).
    """
    if config is None:
        from contactrig.core.scene import load_scene
        from sims.config import SimConfig

        config = SimConfig.from_scene(load_scene(None))
    if curve is None:
        from analysis.measured import load_tab1

        curve = load_tab1()
    terms = rig_resistance_terms(config, model, [float(w) for w in curve.weight_kg])
    return physical_sentence(fit_measured(curve, terms), model, "Tab. 1")
