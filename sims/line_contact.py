"""Elastic line contact of smooth bodies: a half-plane boundary-element solver and Johnson's closed forms.

Plane strain, two elastic bodies with composite modulus ``E*`` (seed eq. 4) and initial gap ``g(x)``, pressed
together by a load ``P′`` per unit length. The surface is cut into strips of uniform pressure ``p_j``; the normal
surface displacement of a half-plane under a strip (Johnson, *Contact Mechanics*, eq. 2.25b) is::

    u(x) = −(2/(π E*)) ∫ p(s) ln|x − s| ds  (+ a constant),   ∫_{s−a}^{s+a} ln|x − t| dt = f(x − s + a) − f(x − s − a)

with ``f(u) = u ln|u| − u``. The gap after loading is ``h_i = g_i − δ + Σ_j K_ij p_j`` (δ the rigid approach) and the
contact conditions ``p ≥ 0, h ≥ 0, p·h = 0, Σ p_j w_j = P′`` are solved by an active-set method (Kalker): solve
for pressure and approach on the trial contact set, drop strips with tension, add strips that interpenetrate,
repeat. Lengths are scaled by twice the domain's span, which makes the log kernel positive definite.

Closed form for a parabolic gap ``x²/(2R)`` (Johnson eq. 4.43, 4.45): half-width ``b = √(4 P′ R/(π E*))``, peak
``p0 = 2P′/(π b) = √(P′ E*/(π R))``, ``p(x) = p0 √(1 − x²/b²)``.

:func:`conformal_line_contact` applies the solver to the exact piston-in-liner gap (a test of the small-contact
assumption behind Johnson's formulas, used for the roughness parameter σ R_eff / b² of the rig model).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["LineContact", "conformal_line_contact", "hertz_line_contact", "influence_matrix", "solve_line_contact"]


@dataclass(frozen=True)
class LineContact:
    """Solution of a smooth elastic line contact: pressure per strip and diagnostics.

    ``half_width_m`` is half the extent of the loaded strips (to within one strip width ``dx_m``);
    ``residual`` is the largest violation of ``h ≥ 0`` outside the contact set, relative to the gap's range.
    """

    x_m: np.ndarray = field(repr=False)
    pressure_pa: np.ndarray = field(repr=False)
    gap_m: np.ndarray = field(repr=False)
    dx_m: float
    load_per_length_n_per_m: float
    half_width_m: float
    peak_pressure_pa: float
    approach_m: float
    iterations: int
    residual: float
    converged: bool
    status: str


def hertz_line_contact(
    load_per_length_n_per_m: float, effective_radius_m: float, composite_modulus_pa: float
) -> tuple[float, float]:
    """Johnson's smooth line contact: half-width ``b`` [m] and peak pressure ``p0`` [Pa] (eq. 4.43, 4.45)."""
    b = math.sqrt(4.0 * load_per_length_n_per_m * effective_radius_m / (math.pi * composite_modulus_pa))
    p0 = math.sqrt(load_per_length_n_per_m * composite_modulus_pa / (math.pi * effective_radius_m))
    return b, p0


def _f(u: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        out = u * np.log(np.abs(u)) - u
    return np.where(u == 0.0, 0.0, out)


def influence_matrix(x_m: ArrayLike, dx_m: float, composite_modulus_pa: float) -> np.ndarray:
    """``K[i, j]``: displacement [m] at ``x_i`` per unit pressure [Pa] on strip ``j`` (width ``dx_m``)."""
    x = np.asarray(x_m, dtype=float)
    scale = 2.0 * (x.max() - x.min() + dx_m)
    xi = (x[:, None] - x[None, :]) / scale
    half = 0.5 * dx_m / scale
    return -(2.0 * scale / (math.pi * composite_modulus_pa)) * (_f(xi + half) - _f(xi - half))


def solve_line_contact(
    x_m: ArrayLike,
    gap_m: ArrayLike,
    load_per_length_n_per_m: float,
    composite_modulus_pa: float,
    *,
    max_iterations: int | None = None,
) -> LineContact:
    """Pressure [Pa] on equally spaced strips centred at ``x_m`` for the initial gap ``gap_m`` and load ``P′`` [N/m].

    The domain must contain the whole contact (a contact reaching the domain's end is reported in ``status``).
    """
    x = np.asarray(x_m, dtype=float)
    g = np.asarray(gap_m, dtype=float)
    if x.ndim != 1 or x.size < 3 or g.shape != x.shape:
        raise ValueError("x_m and gap_m must be 1-D arrays of the same length (at least 3 strips)")
    dx = float(x[1] - x[0])
    if not np.allclose(np.diff(x), dx, rtol=1e-9, atol=0) or dx <= 0:
        raise ValueError("x_m must be equally spaced and increasing")
    if not (load_per_length_n_per_m > 0 and math.isfinite(load_per_length_n_per_m)):
        raise ValueError(f"load_per_length_n_per_m = {load_per_length_n_per_m!r}: expected a finite value > 0")
    if not (composite_modulus_pa > 0 and math.isfinite(composite_modulus_pa)):
        raise ValueError(f"composite_modulus_pa = {composite_modulus_pa!r}: expected a finite value > 0")
    n = x.size
    K = influence_matrix(x, dx, composite_modulus_pa)
    g_range = float(g.max() - g.min()) or 1.0
    active = np.ones(n, dtype=bool)
    max_iterations = max_iterations or 4 * n
    p = np.zeros(n)
    delta = 0.0
    converged = False
    iterations = 0
    residual = math.inf
    for iteration in range(1, max_iterations + 1):
        iterations = iteration
        idx = np.flatnonzero(active)
        m = idx.size
        A = np.zeros((m + 1, m + 1))
        A[:m, :m] = K[np.ix_(idx, idx)]
        A[:m, m] = -1.0
        A[m, :m] = dx
        rhs = np.concatenate([-g[idx], [load_per_length_n_per_m]])
        sol = np.linalg.solve(A, rhs)
        p_active, delta = sol[:m], float(sol[m])
        if np.any(p_active < 0):
            active[idx[p_active < 0]] = False
            if not active.any():
                active[np.argmin(g)] = True
            continue
        p = np.zeros(n)
        p[idx] = p_active
        h = g - delta + K @ p
        outside = ~active
        violation = np.where(outside, -h, 0.0)
        residual = max(float(violation.max()), 0.0) / g_range
        if residual > 1e-10:
            active |= outside & (h < 0)
            continue
        converged = True
        break
    h = g - delta + K @ p
    loaded = np.flatnonzero(p > 0)
    half_width = 0.5 * (x[loaded[-1]] - x[loaded[0]] + dx) if loaded.size else 0.0
    status = "converged" if converged else "active set did not settle"
    if converged and loaded.size and (loaded[0] == 0 or loaded[-1] == n - 1):
        status = "contact reaches the end of the domain"
    return LineContact(
        x_m=x,
        pressure_pa=p,
        gap_m=h,
        dx_m=dx,
        load_per_length_n_per_m=load_per_length_n_per_m,
        half_width_m=half_width,
        peak_pressure_pa=float(p.max()) if p.size else 0.0,
        approach_m=delta,
        iterations=iterations,
        residual=residual,
        converged=converged and status == "converged",
        status=status,
    )


def conformal_line_contact(
    liner_radius_m: float,
    clearance_m: float,
    load_per_length_n_per_m: float,
    composite_modulus_pa: float,
    *,
    n_strips: int = 201,
    extent: float = 1.6,
) -> LineContact:
    """Smooth elastic contact of the piston in its liner: the solver on the exact offset-circle gap at ``h0 = 0``.

    The domain is ``±extent·b`` (Johnson's ``b``) of arc length, at most a quarter of the circumference; ``x`` is
    arc length along the liner. The half-plane kernel assumes ``b ≪ R``: results with ``b`` near ``R`` are rough.
    """
    from sims.rig.geometry import effective_radius_m, gap_m

    r_eff = effective_radius_m(liner_radius_m, clearance_m)
    b, _ = hertz_line_contact(load_per_length_n_per_m, r_eff, composite_modulus_pa)
    half = min(extent * b, 0.5 * math.pi * liner_radius_m)
    x = np.linspace(-half, half, n_strips)
    gap = gap_m(x / liner_radius_m, 0.0, liner_radius_m, clearance_m, exact=True)
    return solve_line_contact(x, gap, load_per_length_n_per_m, composite_modulus_pa)
