"""Bulk elasticity under an asperity layer: the rough contact of elastic bodies (Greenwood & Tripp 1967).

The rigid rig (:mod:`sims.rig.equilibrium`) lets only the asperities deform. When the roughness parameter
``α = σ R_eff / b²`` is of order one or less, the bodies' bulk deformation is as large as the asperities' and
changes how the load spreads. Here the asperity law is a nonlinear spring layer on elastic bodies (Greenwood &
Tripp, J. Appl. Mech. 34 (1967) 153; Johnson, *Contact Mechanics* §13.5):

    p_i = P(h_i),   h_i = h0 + g_i + Σ_j C_ij p_j,   Σ_i w_i p_i = W

with ``P(h)`` the nominal pressure of the contact law [Pa] at mean-plane separation ``h`` [m], ``g_i`` the rigid
geometric gap at node ``i`` [m] (zero at the closest point), ``C`` the influence coefficients of the two elastic
bodies [m/Pa] (displacement at node ``i`` per unit pressure on element ``j``; positive C opens the gap), ``h0`` the
rigid offset [m] found by the load balance, ``w_i`` the load weights [m²] (area of element ``i`` projected on the
load) and ``W`` the load [N].

Influence coefficients (composite modulus E*, Johnson eq. 4.22 / seed eq. 4):

* plane strain, strips of width Δ (:func:`sims.line_contact.influence_matrix`, Johnson eq. 2.25b): the log kernel
  is defined up to a constant, which ``h0`` absorbs;
* axisymmetric, rings ``[s−, s+]`` of uniform pressure (:func:`axisymmetric_influence`): a uniform pressure ``p`` on
  a disc of radius ``a`` displaces the surface by ``4pa E(r/a)/(πE*)`` inside and
  ``4pr [E(a/r) − (1 − a²/r²) K(a/r)]/(πE*)`` outside (Johnson eq. 3.39; ``K``, ``E`` complete elliptic integrals of
  the modulus k); a ring is the difference of two discs.

Solver (:func:`solve_layer`): Newton's method on ``(p, h0)`` with the bordered Jacobian
``[[I − D C, −D 1], [wᵀ, 0]]``, ``D = diag(P′(h))``, from the rigid solution (``C = 0``, a bracketed scalar root),
with a backtracking line search on the scaled residual and pressures kept non-negative; if Newton stalls a damped
fixed point (mixing 0.1, the load balance re-solved exactly at every step) finishes. The result carries SciPy-style
diagnostics (``nit``, ``nfev``, ``njev``, ``status``, ``success``, ``message``).

:func:`rig_elastic_equilibrium` applies it to the piston in its liner: plane strain along the circumference at the
skirt's middle (a straight skirt carries the same pressure at every y), strips over the contact band, half-plane
kernel on the arc length (the band's half-angle is ≲ 0.3 rad: the half-plane is an approximation there, as in the
prototype of ``reference-mechanics.md``), load balance ``Σ p_i Δx L cos θ_i = W``. It reports what the rigid model
misses: the change of the real area and of the peak nominal pressure.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk

from contactrig.core.validation import SettingError, check_int, check_range

__all__ = [
    "ElasticRigComparison",
    "LayerLaw",
    "LayerSolution",
    "axisymmetric_influence",
    "rig_elastic_comparison",
    "rig_elastic_equilibrium",
    "solve_layer",
    "weighted_width_m",
]

#: Status codes (SciPy style).
STATUS_CONVERGED = 0
STATUS_MAX_ITERATIONS = 1
STATUS_FAILED = 2

#: Mixing factor of the fall-back damped fixed point (ContactMechanics' reference solution uses 0.1).
MIXING = 0.1


class LayerLaw(Protocol):
    """What the layer needs of a contact law: nominal pressure [Pa], its slope [Pa/m], real-area fraction [-]."""

    def pressure(self, h: np.ndarray) -> np.ndarray: ...

    def dpressure_dh(self, h: np.ndarray) -> np.ndarray: ...

    def area_fraction_at(self, h: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class LayerSolution:
    """Solution of the asperity layer on elastic bodies (:func:`solve_layer`).

    ``pressure_pa`` nominal pressure per node [Pa] (≥ 0); ``gap_m`` mean-plane separation per node [m];
    ``displacement_m`` elastic displacement ``C p`` [m] (up to a constant for the log kernel); ``area_fraction``
    real-area fraction per node [-]; ``offset_m`` h0 [m]; ``load_n`` ``Σ w p`` [N]; ``residual`` largest scaled
    residual (pressure equation / mean pressure, load balance / load); ``stiffness_pa_per_m`` ``−P′(h)`` per node
    [Pa/m] (the local interfacial stiffness, for Barber's resistance). Diagnostics: ``nit`` Newton (or fixed-point)
    iterations, ``nfev`` law evaluations, ``njev`` Jacobian factorisations, ``status`` 0 converged / 1 iteration
    limit / 2 failed, ``success``, ``message``, ``method`` ``"newton"`` or ``"fixed point"``.
    """

    pressure_pa: np.ndarray = field(repr=False)
    gap_m: np.ndarray = field(repr=False)
    displacement_m: np.ndarray = field(repr=False)
    area_fraction: np.ndarray = field(repr=False)
    stiffness_pa_per_m: np.ndarray = field(repr=False)
    offset_m: float
    load_n: float
    residual: float
    nit: int
    nfev: int
    njev: int
    status: int
    success: bool
    message: str
    method: str


def _disc_displacement(r: np.ndarray, a: float, modulus: float) -> np.ndarray:
    """Surface displacement [m per Pa] at radii ``r`` under unit pressure on a disc of radius ``a`` (Johnson 3.39)."""
    out = np.empty_like(r)
    inside = r <= a
    ri = r[inside] / a
    out[inside] = 4.0 * a * ellipe(ri * ri) / (math.pi * modulus)
    ro = r[~inside]
    k2 = (a / ro) ** 2
    out[~inside] = 4.0 * ro * (ellipe(k2) - (1.0 - k2) * ellipk(k2)) / (math.pi * modulus)
    return out


def axisymmetric_influence(edges_m: ArrayLike, composite_modulus_pa: float) -> np.ndarray:
    """``C[i, j]``: displacement [m] at the centre radius of ring ``i`` per unit pressure [Pa] on ring ``j``.

    ``edges_m`` increasing ring edges [m], the first 0 (a disc in the middle). Johnson eq. 3.39, a ring is the
    difference of two discs; both bodies through E* [Pa].
    """
    e = np.asarray(edges_m, dtype=float)
    if e.ndim != 1 or e.size < 2 or e[0] != 0.0 or np.any(np.diff(e) <= 0):
        raise SettingError("edges_m", f"array of shape {e.shape}", "expected increasing ring edges starting at 0")
    modulus = check_range("composite_modulus_pa", composite_modulus_pa, 0.0, None, lo_open=True, unit="Pa")
    r = 0.5 * (e[1:] + e[:-1])
    discs = np.stack([_disc_displacement(r, float(a), modulus) for a in e[1:]], axis=1)
    c = discs.copy()
    c[:, 1:] -= discs[:, :-1]
    return c


# ---------------------------------------------------------------------------------------------------------------
# The coupled solve.


@dataclass
class _Problem:
    law: Any
    gap0: np.ndarray
    influence: np.ndarray
    load_weights: np.ndarray
    load: float
    p_ref: float
    nfev: int = 0

    def gaps(self, p: np.ndarray, h0: float) -> np.ndarray:
        return h0 + self.gap0 + self.influence @ p

    def law_p(self, h: np.ndarray) -> np.ndarray:
        self.nfev += 1
        return np.asarray(self.law.pressure(h), dtype=float)

    def residual(self, p: np.ndarray, h0: float) -> tuple[np.ndarray, float]:
        r = (p - self.law_p(self.gaps(p, h0))) / self.p_ref
        return r, (float(self.load_weights @ p) - self.load) / self.load

    def norm(self, p: np.ndarray, h0: float) -> float:
        r, rl = self.residual(p, h0)
        return max(float(np.max(np.abs(r))), abs(rl))

    def balance(self, u: np.ndarray, guess: float | None = None) -> float:
        """h0 [m] with Σ w P(h0 + g + u) = W for a fixed displacement ``u`` (a bracketed scalar root)."""

        def excess(h0: float) -> float:
            return float(self.load_weights @ self.law_p(h0 + self.gap0 + u)) - self.load

        span = float(np.ptp(self.gap0)) + 1e-9
        lo = hi = guess if guess is not None else -float(np.min(u))
        step = 1e-3 * span
        while excess(lo) < 0:
            lo -= step
            step *= 2.0
        step = 1e-3 * span
        while excess(hi) > 0:
            hi += step
            step *= 2.0
        if lo == hi:
            return lo
        return float(brentq(excess, lo, hi, xtol=1e-15 * span + 1e-18, rtol=4 * np.finfo(float).eps, maxiter=500))


def _onset(law: Any, gap0: np.ndarray, h_low: float) -> float:
    """Contact onset h_top [m] of the law (P = 0 above it), or ``inf`` for a law positive everywhere.

    ``h_low`` is a separation with P > 0. The law's ``h_max`` when P vanishes there, else found by bisection.
    """
    h_max = getattr(law, "h_max", None)
    if h_max is not None and float(np.asarray(law.pressure(np.array([float(h_max)])))[0]) == 0.0:
        return float(h_max)
    hi = h_low + 10.0 * (float(np.ptp(gap0)) + 1e-9)
    if float(np.asarray(law.pressure(np.array([hi])))[0]) > 0.0:
        return math.inf
    lo = h_low
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if float(np.asarray(law.pressure(np.array([mid])))[0]) > 0.0:
            lo = mid
        else:
            hi = mid
    return hi


def _inverse(prob: _Problem, p: np.ndarray, h_top: float) -> np.ndarray:
    """h [m] with P(h) = p (> 0) per node: vectorised bisection on the monotone law (60 halvings of the bracket)."""
    span = float(np.ptp(prob.gap0)) + 1e-9
    hi = np.full(p.shape, h_top if math.isfinite(h_top) else 0.0)
    lo = hi - span
    for _ in range(200):  # expand until P(lo) >= p and P(hi) <= p
        low = prob.law_p(lo) < p
        high = prob.law_p(hi) > p
        if not (low.any() or high.any()):
            break
        lo = np.where(low, lo - 2.0 * (hi - lo), lo)
        hi = np.where(high, hi + 2.0 * (hi - lo), hi)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        above = prob.law_p(mid) > p
        lo = np.where(above, mid, lo)
        hi = np.where(above, hi, mid)
    return 0.5 * (lo + hi)


def _compliance_step(
    prob: _Problem, p: np.ndarray, h0: float, act: np.ndarray, h_top: float
) -> tuple[np.ndarray, float, float]:
    """One Newton step on the active nodes of ``h0 + g + C p − P⁻¹(p) = 0``, ``Σ w p = W``: (p, h0, gap residual)."""
    idx = np.flatnonzero(act)
    hp = _inverse(prob, p[idx], h_top)
    gap = prob.gaps(p, h0)[idx]
    r = np.concatenate([gap - hp, [float(prob.load_weights @ p) - prob.load]])
    slope = np.asarray(prob.law.dpressure_dh(hp), dtype=float)
    inv_slope = np.where(slope < 0, 1.0 / np.where(slope < 0, slope, -1.0), -1e30)
    m = idx.size
    jac = np.zeros((m + 1, m + 1))
    jac[:m, :m] = prob.influence[np.ix_(idx, idx)] - np.diag(inv_slope)
    jac[:m, m] = 1.0
    jac[m, :m] = prob.load_weights[idx]
    step = np.linalg.solve(jac, -r)
    p_new = p.copy()
    p_new[idx] = p[idx] + step[:m]
    return p_new, h0 + float(step[m]), float(np.max(np.abs(r[:m])))


def _newton(prob: _Problem, p: np.ndarray, h0: float, tol: float, max_iter: int) -> tuple[np.ndarray, float, int, int]:
    """Active-set Newton on the compliance form (Jacobian C + diag(−1/P′), the load row bordering it).

    Nodes whose pressure a step drives to zero or below leave the active set (laws with an onset h_top), or are
    held at a fraction of their pressure (laws positive everywhere); nodes outside whose gap falls below h_top join.
    Returns (p, h0, iterations, factorisations); negative iterations: not converged.
    """
    h_top = _onset(prob.law, prob.gap0, h0)
    act = p > 0
    njev = 0
    for it in range(1, max_iter + 1):
        if prob.norm(p, h0) <= tol:
            return p, h0, it - 1, njev
        try:
            p_new, h0, _ = _compliance_step(prob, p, h0, act, h_top)
        except np.linalg.LinAlgError:
            return p, h0, -it, njev
        njev += 1
        if math.isfinite(h_top):
            act = act & (p_new > 0)
            p = np.where(act, p_new, 0.0)
            joining = ~act & (prob.gaps(p, h0) < h_top)
            p = np.where(joining, prob.law_p(prob.gaps(p, h0)), p)
            act = act | joining
        else:
            p = np.where(p_new > 0.05 * p, p_new, 0.05 * p)
        if not act.any() or not np.all(np.isfinite(p)):
            return p, h0, -it, njev
    return p, h0, (max_iter if prob.norm(p, h0) <= tol else -max_iter), njev


def _fixed_point(prob: _Problem, p: np.ndarray, h0: float, tol: float, max_iter: int) -> tuple[np.ndarray, float, int]:
    """Damped fixed point: u from p, h0 from the load balance, p mixed towards P(h); returns (p, h0, iterations)."""
    for it in range(1, max_iter + 1):
        u = prob.influence @ p
        h0 = prob.balance(u, h0)
        target = prob.law_p(h0 + prob.gap0 + u)
        if prob.norm(p, h0) <= tol:
            return p, h0, it - 1
        p = (1.0 - MIXING) * p + MIXING * target
    return p, h0, -max_iter


def solve_layer(
    law: LayerLaw,
    gap0_m: ArrayLike,
    influence_m_per_pa: ArrayLike,
    load_weights_m2: ArrayLike,
    load_n: float,
    *,
    tol: float = 1e-10,
    max_iter: int = 100,
) -> LayerSolution:
    """The asperity layer on elastic bodies (module docstring): pressures [Pa] and offset h0 [m] for load W [N].

    ``gap0_m`` rigid gap shape per node [m]; ``influence_m_per_pa`` n×n influence coefficients [m/Pa] (zeros: the
    rigid rig); ``load_weights_m2`` [m²] with ``Σ w p = W``; ``tol`` on the scaled residual; ``max_iter`` Newton
    iterations (then as many fixed-point iterations ×10 if Newton stalls).
    """
    g0 = np.asarray(gap0_m, dtype=float).reshape(-1)
    c = np.asarray(influence_m_per_pa, dtype=float)
    w = np.asarray(load_weights_m2, dtype=float).reshape(-1)
    if c.shape != (g0.size, g0.size) or w.shape != g0.shape:
        raise SettingError("influence_m_per_pa", f"array of shape {c.shape}", f"expected ({g0.size}, {g0.size})")
    load = check_range("load_n", load_n, 0.0, None, lo_open=True, unit="N")
    max_iter = check_int("max_iter", max_iter, 1, 100_000)
    prob = _Problem(law, g0, c, w, load, p_ref=load / float(w.sum()))
    h0 = prob.balance(np.zeros_like(g0))
    p = prob.law_p(h0 + g0)
    p, h0, nit, njev = _newton(prob, p, h0, tol, max_iter)
    method = "newton"
    if nit < 0:
        method = "fixed point"
        p, h0, fp = _fixed_point(prob, p, h0, tol, 10 * max_iter)
        nit = -nit + abs(fp)
        status = STATUS_CONVERGED if fp >= 0 else STATUS_MAX_ITERATIONS
    else:
        status = STATUS_CONVERGED
    residual = prob.norm(p, h0)
    if not (np.all(np.isfinite(p)) and math.isfinite(h0)):
        status = STATUS_FAILED
    messages = {
        STATUS_CONVERGED: f"converged ({method}, {nit} iterations, residual {residual:.2g})",
        STATUS_MAX_ITERATIONS: f"iteration limit reached ({method}, residual {residual:.2g} > tol {tol:.2g})",
        STATUS_FAILED: "non-finite state",
    }
    h = prob.gaps(p, h0)
    return LayerSolution(
        pressure_pa=p,
        gap_m=h,
        displacement_m=c @ p,
        area_fraction=np.asarray(law.area_fraction_at(h), dtype=float),
        stiffness_pa_per_m=-np.asarray(law.dpressure_dh(h), dtype=float),
        offset_m=h0,
        load_n=float(w @ p),
        residual=residual,
        nit=nit,
        nfev=prob.nfev,
        njev=njev,
        status=status,
        success=status == STATUS_CONVERGED,
        message=messages[status],
        method=method,
    )


# ---------------------------------------------------------------------------------------------------------------
# The piston in its liner.


@dataclass(frozen=True)
class RigElastic:
    """One weight of the rig with bulk elasticity (plane strain at the skirt's middle).

    ``weight_kg`` [kg], ``load_n`` [N]; ``x_m`` arc length of the strip centres from the bottom [m];
    ``contact_area_m2`` real area [m²]; ``peak_pressure_pa`` largest nominal pressure [Pa]; ``contact_width_m``
    width of the band with p > 0 (or, for a law without onset, p > 1e-6 of the peak), its edges interpolated
    between strips [m]; ``load_weighted_width_m`` the load-weighted RMS width 2√3·σ_x (σ_x² = Σ p (x − x̄)² / Σ p:
    the width of a uniform band with the same second moment; insensitive to the model-dependent p > 0 tail) [m];
    ``stiffness_n_per_m`` interfacial stiffness summed over the band, ``Σ −P′(h) ΔA`` [N/m] (local normals);
    ``solution`` the layer solve with its diagnostics.
    """

    weight_kg: float
    load_n: float
    x_m: np.ndarray = field(repr=False)
    contact_area_m2: float
    peak_pressure_pa: float
    contact_width_m: float
    stiffness_n_per_m: float
    solution: LayerSolution = field(repr=False)
    load_weighted_width_m: float = math.nan


def weighted_width_m(x_m: ArrayLike, weight: ArrayLike) -> float:
    """2√3·σ_x [m], σ_x the ``weight``-weighted RMS spread of the positions ``x_m`` [m] (the width of a uniform band
    with the same second moment: a uniform band of width b gives b). Weights ≥ 0 (load, stiffness, …)."""
    x = np.asarray(x_m, dtype=float)
    wt = np.clip(np.asarray(weight, dtype=float), 0.0, None)
    total = float(np.sum(wt))
    if total <= 0:
        return 0.0
    mean = float(np.sum(wt * x)) / total
    return 2.0 * math.sqrt(3.0) * math.sqrt(float(np.sum(wt * (x - mean) ** 2)) / total)


def _band_width_m(x: np.ndarray, p: np.ndarray, threshold: float) -> float:
    """Width [m] of the band where p > threshold, each edge interpolated linearly between the last strip inside and
    the first outside (a strip count would move in steps of one strip: the "+6.5 %" of issue 21 §4)."""
    inside = np.flatnonzero(p > threshold)
    if inside.size == 0:
        return 0.0

    def edge(i: int, j: int) -> float:  # i the last strip inside, j the first outside (off the grid: no edge beyond)
        if j < 0 or j >= p.size:
            return float(x[i])
        k = 2 * i - j  # the strip before i, inside too when the band is wider than one strip
        if threshold == 0.0 and 0 <= k < p.size and p[k] > p[i]:
            # compact support: an elastic contact edge goes as √distance, so p² is extrapolated linearly to zero
            f = float(p[i]) ** 2 / (float(p[k]) ** 2 - float(p[i]) ** 2)
            return float(x[i] + min(f, 1.0) * (x[j] - x[i]))
        f = (float(p[i]) - threshold) / (float(p[i]) - float(p[j]))
        return float(x[i] + f * (x[j] - x[i]))

    lo, hi = int(inside[0]), int(inside[-1])
    return edge(hi, hi + 1) - edge(lo, lo - 1)


def _band_half_angle(law: Any, settings: Any, load_n: float) -> float:
    """Half-angle [rad] of the rigid contact band (gap below the law's h_max), widened for the elastic spread."""
    from sims.rig.equilibrium import batch_equilibrium
    from sims.rig.geometry import contact_edge_angle_rad

    weight = load_n / 9.80665 - settings.piston_mass_kg
    rigid = batch_equilibrium(law, settings, [max(weight, 0.0)])
    h0 = float(rigid.min_separation_m[0])
    edge = contact_edge_angle_rad(
        float(law.h_max), h0, settings.liner_radius_m, settings.clearance_m, settings.exact_gap
    )
    return min(max(1.6 * edge, 1e-4), 0.5 * math.pi)


def rig_elastic_equilibrium(
    law: Any,
    settings: Any,
    weight_kg: float,
    composite_modulus_pa: float,
    *,
    n_strips: int = 201,
    elastic: bool = True,
    tol: float = 1e-10,
) -> RigElastic:
    """Piston in its liner under ``weight_kg`` [kg] with bulk elasticity (``elastic=False``: the same strips, rigid).

    ``law`` the contact law (:class:`sims.rig.law.ContactLaw`), ``settings`` :class:`sims.rig.RigSettings` (a
    straight skirt: ``crown_m = 0``), E* [Pa] (seed eq. 4). Plane strain over ``n_strips`` strips spanning 1.6× the
    rigid contact band; see the module docstring.
    """
    from sims.line_contact import influence_matrix
    from sims.rig.geometry import gap_m

    if settings.crown_m > 0:
        raise SettingError("rig.crown_m", settings.crown_m, "0 for the elastic rig (plane strain: a straight skirt)")
    n = check_int("n_strips", n_strips, 11, 20_000)
    load = settings.load_n(weight_kg)
    r_l = settings.liner_radius_m
    half = _band_half_angle(law, settings, load)
    theta = np.linspace(-half, half, n)
    dx = float(theta[1] - theta[0]) * r_l
    g0 = gap_m(theta, 0.0, r_l, settings.clearance_m, settings.exact_gap)
    c = influence_matrix(theta * r_l, dx, composite_modulus_pa) if elastic else np.zeros((n, n))
    length = settings.skirt_length_m
    sol = solve_layer(law, g0, c, dx * length * np.cos(theta), load, tol=tol)
    p = sol.pressure_pa
    x = theta * r_l
    width = _band_width_m(x, p, 0.0 if float(np.min(p)) == 0.0 else 1e-6 * float(p.max()))
    return RigElastic(
        weight_kg=float(weight_kg),
        load_n=load,
        x_m=theta * r_l,
        contact_area_m2=float(np.sum(sol.area_fraction) * dx * length),
        peak_pressure_pa=float(p.max()),
        contact_width_m=width,
        stiffness_n_per_m=float(np.sum(sol.stiffness_pa_per_m) * dx * length),
        solution=sol,
        load_weighted_width_m=weighted_width_m(x, p * np.cos(theta)),
    )


@dataclass(frozen=True)
class ElasticRigComparison:
    """Rigid against elastic rig at every weight (same strips, same law): the effect of bulk elasticity.

    Arrays per weight: ``weight_kg``; ``area_rigid_m2``, ``area_elastic_m2`` [m²]; ``peak_rigid_pa``,
    ``peak_elastic_pa`` [Pa]; ``width_rigid_m``, ``width_elastic_m`` [m] (p > 0 band, edges interpolated);
    ``lw_width_rigid_m``, ``lw_width_elastic_m`` [m] the load-weighted RMS widths (:func:`weighted_width_m`);
    ``stiffness_rigid_n_per_m``, ``stiffness_elastic_n_per_m`` [N/m]; ``nit`` Newton iterations of the elastic
    solves; ``success``.
    """

    weight_kg: np.ndarray
    area_rigid_m2: np.ndarray
    area_elastic_m2: np.ndarray
    peak_rigid_pa: np.ndarray
    peak_elastic_pa: np.ndarray
    width_rigid_m: np.ndarray
    width_elastic_m: np.ndarray
    stiffness_rigid_n_per_m: np.ndarray
    stiffness_elastic_n_per_m: np.ndarray
    nit: np.ndarray
    success: np.ndarray
    lw_width_rigid_m: np.ndarray = field(default_factory=lambda: np.array([]))
    lw_width_elastic_m: np.ndarray = field(default_factory=lambda: np.array([]))

    @property
    def area_change(self) -> np.ndarray:
        """Relative change of the real area by bulk elasticity [-]."""
        return self.area_elastic_m2 / self.area_rigid_m2 - 1.0

    @property
    def peak_change(self) -> np.ndarray:
        """Relative change of the peak nominal pressure by bulk elasticity [-]."""
        return self.peak_elastic_pa / self.peak_rigid_pa - 1.0

    @property
    def width_change(self) -> np.ndarray:
        """Relative change of the band width by bulk elasticity [-]."""
        return self.width_elastic_m / self.width_rigid_m - 1.0

    @property
    def lw_width_change(self) -> np.ndarray:
        """Relative change of the load-weighted RMS width by bulk elasticity [-]."""
        return self.lw_width_elastic_m / self.lw_width_rigid_m - 1.0

    def sentences(self, name: str = "") -> list[str]:
        """One line per weight: the computed effect (replaces the rigid model's roughness-parameter warning)."""
        who = f"{name}: " if name else ""
        return [
            f"{who}weight {w:g} kg: bulk elasticity changes the real area by {100 * da:+.2f} % and the peak nominal "
            f"pressure by {100 * dp:+.1f} % (band width {100 * db:+.1f} %, load-weighted width {100 * dl:+.1f} %)"
            for w, da, dp, db, dl in zip(
                self.weight_kg, self.area_change, self.peak_change, self.width_change, self.lw_width_change,
                strict=True,
            )
        ]


def rig_elastic_comparison(
    law: Any, settings: Any, weights_kg: Sequence[float], composite_modulus_pa: float, *, n_strips: int = 201
) -> ElasticRigComparison:
    """:func:`rig_elastic_equilibrium` elastic and rigid at every weight [kg]; E* [Pa] (seed eq. 4)."""
    rows = []
    for w in weights_kg:
        el = rig_elastic_equilibrium(law, settings, w, composite_modulus_pa, n_strips=n_strips)
        ri = rig_elastic_equilibrium(law, settings, w, composite_modulus_pa, n_strips=n_strips, elastic=False)
        rows.append((w, ri, el))

    def col(f: Any) -> np.ndarray:
        return np.array([f(r, e) for _, r, e in rows])

    return ElasticRigComparison(
        weight_kg=np.array([w for w, _, _ in rows], dtype=float),
        area_rigid_m2=col(lambda r, e: r.contact_area_m2),
        area_elastic_m2=col(lambda r, e: e.contact_area_m2),
        peak_rigid_pa=col(lambda r, e: r.peak_pressure_pa),
        peak_elastic_pa=col(lambda r, e: e.peak_pressure_pa),
        width_rigid_m=col(lambda r, e: r.contact_width_m),
        width_elastic_m=col(lambda r, e: e.contact_width_m),
        lw_width_rigid_m=col(lambda r, e: r.load_weighted_width_m),
        lw_width_elastic_m=col(lambda r, e: e.load_weighted_width_m),
        stiffness_rigid_n_per_m=col(lambda r, e: r.stiffness_n_per_m),
        stiffness_elastic_n_per_m=col(lambda r, e: e.stiffness_n_per_m),
        nit=col(lambda r, e: e.solution.nit),
        success=col(lambda r, e: e.solution.success and r.solution.success),
    )


def apply_bulk_elasticity(
    models: dict[str, Any],
    laws: dict[str, Any],
    settings: Any,
    composite_modulus_pa: float,
    provenance: dict[str, Any],
    warnings: list[str],
) -> dict[str, Any]:
    """The opt-in bulk-elastic step of :func:`sims.rig.sweep` (``elastic=True``).

    For every model's :class:`~sims.rig.sweep.ModelSweep` the relative changes of the real area and of the peak
    nominal pressure computed by :func:`rig_elastic_comparison` (same strips, rigid against elastic, so the
    discretisation cancels) are applied to the rigid sweep's mesh-converged values, and so is the relative change of
    the band width (the strips' own width is coarser than the converged one); the load-weighted widths go to the
    provenance; the roughness-parameter warnings are replaced by the computed effect (one line per weight, in
    ``provenance["bulk_elasticity"]``). Returns the corrected models (new objects; ``models`` is not changed).
    """
    from dataclasses import replace

    out: dict[str, Any] = {}
    record: dict[str, Any] = {}
    for name, m in models.items():
        comp = rig_elastic_comparison(laws[name], settings, [float(w) for w in m.weight_kg], composite_modulus_pa)
        out[name] = replace(
            m,
            contact_area_m2=m.contact_area_m2 * (1.0 + comp.area_change),
            peak_pressure_pa=m.peak_pressure_pa * (1.0 + comp.peak_change),
            contact_width_m=np.asarray(m.contact_width_m) * (1.0 + comp.width_change),
            converged=np.asarray(m.converged, dtype=bool) & comp.success,
        )
        record[name] = {
            "area_change": comp.area_change.tolist(),
            "peak_pressure_change": comp.peak_change.tolist(),
            "width_change": comp.width_change.tolist(),
            "load_weighted_width_m": comp.lw_width_elastic_m.tolist(),
            "load_weighted_width_change": comp.lw_width_change.tolist(),
            "newton_iterations": comp.nit.tolist(),
            "effect": comp.sentences(name),
        }
    warnings[:] = [w for w in warnings if "roughness parameter" not in w]
    provenance["bulk_elasticity"] = {
        "method": "asperity layer on elastic half-planes (Greenwood & Tripp 1967), plane strain, Newton",
        "models": record,
    }
    return out
