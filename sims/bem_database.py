"""The boundary-element reference as a contact model: the ``bem`` entry of the contact database.

The asperity models (:mod:`sims.asperity`) sum single-summit laws over the summits of the composite surface
z = z_liner + z_piston and ignore the elastic interaction between summits and the merging of contact spots. The
reference is the periodic FFT boundary-element solution (:mod:`sims.bem`, Polonsky & Keer, Wear 231 (1999) 206) of
the full composite topography on an elastic half-space of modulus E* (seed eq. 4), elastic–perfectly-plastic with
the softer body's hardness H as the local pressure cap (Almqvist et al. 2007) unless ``plastic=False``.

Separation. The database's coordinate h is the separation of the mean planes of the undeformed surfaces (m), the
same origin as the asperity models (the gap at a point is h − z before deformation). In the BEM solution that is the
rigid-body separation h₀ − mean z; for an elastic half-space (periodic, zero-mean displacement) it equals the mean
gap ū, so p(h) here is p(ū) and −dp/dh is the interfacial stiffness K = −dp̄/dū. An elastic solid can never reach
h ≤ 0 (ū ≥ 0), so the BEM curve ends at its deepest solved point, ``max_area_fraction`` of real contact, and below
it the database's tangent extrapolation applies (``in_range`` False) like any model's.

The curve: ``n_points`` load-controlled solves at mean pressures spaced logarithmically from
``p_hi·min_pressure_ratio`` to p_hi, with p_hi = A_max·E*·h′rms/κ (Persson's small-load law A/A₀ = κ p̄/(E* h′rms),
κ = 2 as a first guess; h′rms the RMS slope of z), capped below H. Each solve's separation is
h = max z − mean z − δ (δ the rigid-body approach), and the onset point h = max z − mean z carries p = A = 0. The
area is the perimeter-corrected count (Yastrebov, Anciaux & Molinari, Tribol. Int. 114 (2017) 161; ``area =
"counted"`` for the plain count); a running maximum keeps it monotone against one-pixel flicker (the number of
points so changed is in ``parameters["area_monotone_fixes"]``).

Physics only: no files. The composite surface comes from the database's build context (:func:`composite_surface`)
or from a :class:`~sims.config.SimConfig` (:func:`composite_from_config`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from contactrig.core.validation import SettingError, check_choice, check_int, check_range

if TYPE_CHECKING:
    from sims import bem
    from sims.config import SimConfig
    from sims.database import BuildContext, ContactCurve

__all__ = [
    "BEM_KEY",
    "BemCurveSettings",
    "bem_curve",
    "composite_from_config",
    "composite_surface",
    "rms_slope_spectral",
]

BEM_KEY = "bem"
_KAPPA_GUESS = 2.0  # Persson's κ in A/A₀ = κ p̄/(E* h′rms); BEM gives 2.2–2.6 on the default surface


@dataclass(frozen=True)
class BemCurveSettings:
    """How the ``bem`` curve is solved.

    ``n_points``: load-controlled solves per curve (4…200). ``max_area_fraction``: real-area fraction aimed at by
    the deepest solve (0.01…0.9). ``min_pressure_ratio``: lowest / highest solved mean pressure (1e-8…0.5).
    ``plastic``: cap the local pressure at the hardness H (else elastic). ``area``: ``"corrected"`` (perimeter
    correction) or ``"counted"``. ``refine``: Fourier refinement factor of the composite surface before solving
    (1 = the grid as generated; exact for a band-limited surface, :func:`sims.bem.refine`). ``tol``, ``max_iter``,
    ``workers``: as for :func:`sims.bem.solve_contact`.
    """

    n_points: int = 20
    max_area_fraction: float = 0.3
    min_pressure_ratio: float = 1e-4
    plastic: bool = True
    area: str = "corrected"
    refine: int = 1
    tol: float = 1e-6
    max_iter: int = 5000
    workers: int | None = None

    def __post_init__(self) -> None:
        check_int("bem.n_points", self.n_points, 4, 200)
        check_range("bem.max_area_fraction", self.max_area_fraction, 0.01, 0.9)
        check_range("bem.min_pressure_ratio", self.min_pressure_ratio, 1e-8, 0.5)
        check_choice("bem.area", self.area, ("corrected", "counted"))
        check_int("bem.refine", self.refine, 1, 8)


# ---------------------------------------------------------------------------------------------------------------
# The composite surface.


def composite_surface(ctx: BuildContext) -> tuple[NDArray[np.float64], float]:
    """(composite heights z_liner + z_piston in m, pixel in m) of the surface pair the database built its summits
    from. Needs the build context to carry them (``ctx.summits.composite_m`` and ``ctx.summits.pixel_m``, or the same
    names on the context itself); a RuntimeError says so otherwise."""
    for holder in (ctx.summits, ctx):
        z = getattr(holder, "composite_m", None)
        pixel = getattr(holder, "pixel_m", None)
        if z is not None and pixel is not None and math.isfinite(float(pixel)):
            return np.asarray(z, dtype=np.float64), float(pixel)
    raise RuntimeError(
        "model 'bem' needs the composite height map in the database build context (Summits.composite_m and "
        "Summits.pixel_m, set by sims.database._composite_summits); this contactrig's database does not pass it yet"
    )


def composite_from_config(config: SimConfig) -> tuple[NDArray[np.float64], float]:
    """(z_liner + z_piston in m, pixel in m) of a configuration's surface pair, as :func:`sims.database.build_database`
    generates them (same seeds, same grid). Both surfaces must share one grid (ny×nx, square pixels), with even ny and
    nx (a measured map's mirrored edges always give that; a windowed map of an odd size is refused naming ``edges``)."""
    liner, piston = config.liner, config.piston
    z1, z2 = liner.heights(), piston.heights()
    if z1.shape != z2.shape or not math.isclose(liner.pixel_m, piston.pixel_m, rel_tol=1e-9):
        raise SettingError(
            "surfaces.piston",
            f"{z2.shape} at {piston.pixel_m:g} m",
            f"the BEM reference needs both surfaces on one grid: liner is {z1.shape} at {liner.pixel_m:g} m",
        )
    if any(k % 2 for k in z1.shape):
        edges = (liner.conditioning or {}).get("edges")
        raise SettingError(
            f"{liner.section}.edges" if edges is not None else f"{liner.section}.n",
            edges if edges is not None else z1.shape[0],
            f"the periodic BEM needs even numbers of rows and columns, this map has {z1.shape[0]} × {z1.shape[1]}: "
            "edges = 'mirror' doubles each side (every height kept)",
        )
    return z1 + z2, float(liner.pixel_m)


def rms_slope_spectral(z: NDArray[np.float64], pixel_m: float) -> float:
    """RMS slope h′rms = √⟨|∇z|²⟩ of a periodic map by spectral differentiation (exact for a band-limited map), −."""
    n0, n1 = z.shape
    qx = 2.0 * np.pi * np.fft.fftfreq(n0, d=pixel_m)
    qy = 2.0 * np.pi * np.fft.rfftfreq(n1, d=pixel_m)
    spec = np.abs(np.fft.rfft2(z)) ** 2
    weight = np.full(qy.size, 2.0)
    weight[0] = 1.0
    if n1 % 2 == 0:
        weight[-1] = 1.0
    q2 = qx[:, None] ** 2 + qy[None, :] ** 2
    return math.sqrt(float((spec * q2 * weight[None, :]).sum()) / (n0 * n1) ** 2)


# ---------------------------------------------------------------------------------------------------------------
# The curve.


def _pressure_ramp(
    z: NDArray[np.float64], pixel_m: float, E_star: float, hardness: float | None, st: BemCurveSettings
) -> NDArray[np.float64]:
    """Mean pressures to solve at, Pa, increasing (see the module doc)."""
    from sims import bem  # the solver is imported when a curve is built, not when the registry lists the models

    slope = rms_slope_spectral(z, pixel_m)
    p_hi = st.max_area_fraction * E_star * slope / _KAPPA_GUESS
    p_hi = min(p_hi, 0.95 * bem.full_contact_pressure(z, pixel_m, E_star))
    if hardness is not None:
        p_hi = min(p_hi, 0.5 * hardness)
    if not p_hi > 0.0:
        raise SettingError("surfaces", "flat composite surface", "expected a rough composite surface for BEM")
    return np.geomspace(p_hi * st.min_pressure_ratio, p_hi, st.n_points)


def _solve_points(
    z: NDArray[np.float64], pixel_m: float, E_star: float, hardness: float | None, st: BemCurveSettings
) -> list[bem.ContactSummary]:
    from sims import bem

    out: list[bem.ContactSummary] = []
    for p in _pressure_ramp(z, pixel_m, E_star, hardness, st):
        res = bem.solve_contact(
            z, pixel_m, E_star, float(p), hardness=hardness, tol=st.tol, max_iter=st.max_iter, workers=st.workers
        )
        out.append(res.summary())
    return out


def _monotone_table(
    peak_m: float, sols: list[bem.ContactSummary], area: str
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], int]:
    """(h ascending, p, A/A₀, number of area fixes) with the onset point (peak, 0, 0) appended."""
    h = np.array([peak_m - s.approach for s in sols])
    p = np.array([s.mean_pressure for s in sols])
    a = np.array([s.area_fraction_corrected if area == "corrected" else s.area_fraction for s in sols])
    order = np.argsort(h, kind="stable")
    h, p, a = h[order], p[order], a[order]
    keep = np.concatenate([[True], np.diff(h) > 0.0]) & (p > 0.0) & (a > 0.0) & (h < peak_m)
    h, p, a = h[keep], p[keep], a[keep]
    a_mono = np.maximum.accumulate(a[::-1])[::-1]  # non-increasing in h
    p_mono = np.maximum.accumulate(p[::-1])[::-1]
    fixes = int(np.count_nonzero(a_mono != a))
    return np.append(h, peak_m), np.append(p_mono, 0.0), np.append(a_mono, 0.0), fixes


def bem_curve(
    z: NDArray[np.float64],
    pixel_m: float,
    E_star: float,
    *,
    hardness: float | None = None,
    settings: BemCurveSettings | None = None,
    key: str = BEM_KEY,
) -> ContactCurve:
    """The BEM reference p(h) and A(h)/A₀ of the composite surface ``z`` (m, periodic, ny×nx, both even) on a
    half-space of modulus ``E_star`` (Pa), capped at ``hardness`` (Pa) if given and ``settings.plastic``.

    h is the separation of the mean planes (m, module doc); pressures in Pa. ``parameters`` holds the solver record:
    pressures, approach, mean gap ū, counted and corrected areas, contact spots, iterations, residuals, plastic
    fraction, grid (``n`` points along x, ``shape`` (ny, nx)), and the Fourier refinement factor.
    """
    from sims import bem
    from sims.database import ContactCurve

    st = settings or BemCurveSettings()
    cap = hardness if st.plastic else None
    zz = np.asarray(z, dtype=np.float64)
    pix = pixel_m
    if st.refine > 1:
        zz, pix = bem.refine(zz, st.refine), pixel_m / st.refine
    peak = float(zz.max() - zz.mean())
    sols = _solve_points(zz, pix, E_star, cap, st)
    h, p, a, fixes = _monotone_table(peak, sols, st.area)
    params: dict[str, Any] = {
        "E_star_pa": E_star,
        "H_pa": cap,
        "n": int(zz.shape[1]),
        "shape": [int(k) for k in zz.shape],
        "pixel_m": pix,
        "refine": st.refine,
        "area": st.area,
        "tol": st.tol,
        "solved_pressure_pa": [s.mean_pressure for s in sols],
        "solved_mean_gap_m": [s.mean_gap for s in sols],
        "solved_area_counted": [s.area_fraction for s in sols],
        "solved_area_corrected": [s.area_fraction_corrected for s in sols],
        "solved_n_spots": [s.n_spots for s in sols],
        "solved_plastic_fraction": [s.plastic_fraction for s in sols],
        "nit": int(sum(s.nit for s in sols)),
        "max_residual": float(max(s.residual for s in sols)),
        "all_converged": bool(all(s.success for s in sols)),
        "area_monotone_fixes": fixes,
        "area_m2": float((zz.shape[0] * pix) * (zz.shape[1] * pix)),
    }
    return ContactCurve(key, h, p, a, params)


def _build_bem(ctx: BuildContext) -> ContactCurve:
    z, pixel = composite_surface(ctx)
    curve = bem_curve(z, pixel, ctx.E_star, hardness=ctx.materials.H, settings=BemCurveSettings())
    if not curve.parameters["all_converged"]:
        ctx.warn("bem: a boundary-element solve did not converge (see parameters['max_residual'])")
    h_min_scene = ctx.settings.h_min_sigma * ctx.sigma_m
    if curve.h_min > h_min_scene:
        curve.parameters["note"] = (
            f"BEM curve starts at h = {curve.h_min:.3g} m (real area {curve.area_fraction[0]:.2f}); the scene's "
            f"h_min = {h_min_scene:.3g} m lies below (tangent extrapolation there, in_range False)"
        )
    return curve


def _register() -> None:
    from sims.models import ContactModel, register

    register(
        ContactModel(
            BEM_KEY,
            "BEM (reference)",
            build=_build_bem,
            equations="FFT boundary elements, Polonsky & Keer (1999)",
            description="periodic FFT-BEM of the full composite surface, hardness-capped: the reference",
            elastic_only=False,
            needs_surface=True,
            default=False,
            style={"color": "#000000", "linestyle": "-", "marker": "*"},
        ),
        replace=True,
    )


_register()
