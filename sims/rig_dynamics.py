"""Damped release-to-rest dynamics of the piston (the MBS run of seed section 2.1, eq. 22).

The piston (mass ``m`` = weight + piston mass) is released from rest just touching the liner and falls onto its
asperities: ``m ẍ = m g − F_c(x) − B ẋ`` (seed eq. 22 with ``F_c = P_c A_c`` on the skirt mesh), ``x`` the downward
displacement, ``h0 = c − x`` the minimum gap. In the state ``y = (h0, v = ḣ0)``::

    ḣ0 = v,   v̇ = −g + F(h0)/m − (B/m) v,     Jacobian [[0, 1], [F′(h0)/m, −B/m]]

with the analytic slope ``F′`` from the contact law (:meth:`sims.rig_loads.SkirtLoads.force_and_slope`).

Linearised at rest (contact stiffness ``k = −F′``) the eigenvalues are ``−(B/2m) ± √((B/2m)² − k/m)``. Heavy damping
(``ζ = B / (2√(km)) ≫ 1``) separates them — a fast ``≈ −B/m`` and a slow ``≈ −k/B`` — and the problem is stiff
(ratio ``≈ 4ζ²``): explicit Runge–Kutta needs steps ``≲ m/B`` over a settling time ``≈ B/k``, implicit methods do not.
Light damping (``ζ ≲ 1``) is not stiff, and an explicit method is cheaper (implicit ones then damp the oscillation
numerically). ``method="auto"`` takes BDF when the stiffness ratio exceeds :data:`STIFF_RATIO`, else RK45 (in
``tests/benchmarks/bench_rig_dynamics.py`` BDF settles the stiff case with a third of Radau's evaluations at the
same error; LSODA, which switches by itself, is as cheap in both cases).

The run stops when the piston is at rest (``|F − W| ≤ tol·W`` and ``|v| ≤ tol·(W/k)·ω``) or at ``t_max_s``. The
mesh is the static solution's (fixed during the run), so the rest state is that static solution exactly.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from sims.rig_law import ContactLaw
from sims.rig_loads import SkirtLoads
from sims.rig_settings import STANDARD_GRAVITY, RigSettings
from sims.rig_statics import Equilibrium, RigLoadError, equilibrium

__all__ = ["METHODS", "STIFF_RATIO", "Settle", "settle", "stiffness_ratio"]

#: Stiffness ratio (fast/slow decay rate at rest) above which ``method="auto"`` takes an implicit method.
STIFF_RATIO = 100.0

METHODS = ("auto", "RK45", "DOP853", "Radau", "BDF", "LSODA")
_IMPLICIT = ("Radau", "BDF", "LSODA")


@dataclass(frozen=True)
class Settle:
    """A release-to-rest run: trajectory, final state against the static solution, and solver diagnostics."""

    method: str
    stiff: bool
    t_s: np.ndarray = field(repr=False)
    min_separation_m: np.ndarray = field(repr=False)
    velocity_m_per_s: np.ndarray = field(repr=False)
    final_separation_m: float
    static_separation_m: float
    separation_error_m: float
    area_relative_error: float
    settled: bool
    settle_time_s: float
    nfev: int
    njev: int
    nlu: int
    status: int
    message: str
    elapsed_s: float
    damping_ratio: float
    stiffness_n_per_m: float
    stiffness_ratio: float
    static: Equilibrium = field(repr=False)


def stiffness_ratio(stiffness_n_per_m: float, mass_kg: float, damping_n_s_per_m: float) -> tuple[float, float]:
    """Damping ratio ζ = B/(2√(km)) and stiffness ratio |λ_fast/λ_slow| of the linearised oscillator (1 if ζ ≤ 1)."""
    if stiffness_n_per_m <= 0:
        return math.inf, math.inf
    zeta = damping_n_s_per_m / (2.0 * math.sqrt(stiffness_n_per_m * mass_kg))
    if zeta <= 1.0:
        return zeta, 1.0
    root = math.sqrt(zeta * zeta - 1.0)
    return zeta, (zeta + root) / (zeta - root)


def settle(
    law: ContactLaw,
    settings: RigSettings,
    weight_kg: float,
    *,
    method: str = "auto",
    damping_n_s_per_m: float | None = None,
    static: Equilibrium | None = None,
    tol: float = 1e-6,
    rtol: float = 1e-9,
    t_max_s: float | None = None,
    name: str = "law",
) -> Settle:
    """Release the piston under ``weight_kg`` from rest, just touching, and integrate seed eq. 22 to rest.

    ``method``: one of :data:`METHODS` (``"auto"`` picks per case). ``damping_n_s_per_m`` overrides the settings'
    damping B. ``static`` reuses a computed equilibrium (its mesh is used). ``tol`` is the rest criterion,
    ``rtol`` the integrator's relative tolerance.
    """
    from sims.validation import check_choice, check_range

    check_choice("method", method, METHODS)
    damping = settings.damping_n_s_per_m if damping_n_s_per_m is None else damping_n_s_per_m
    damping = check_range("damping_n_s_per_m", damping, 0.0, 1e12, unit="N·s/m")
    tol = check_range("tol", tol, 0.0, 0.1, lo_open=True)
    mass = weight_kg + settings.piston_mass_kg
    if mass <= 0:
        raise RigLoadError(f"{name}: the dynamics need a moving mass: weight + piston mass = {mass} kg")
    if static is None:
        static = equilibrium(law, settings, weight_kg, name=name)
    loads = SkirtLoads(law, settings, static.mesh)
    load = static.load_n
    k = static.stiffness_n_per_m
    zeta, ratio = stiffness_ratio(k, mass, damping)
    stiff = ratio > STIFF_RATIO
    chosen = ("BDF" if stiff else "RK45") if method == "auto" else method
    omega = math.sqrt(k / mass)
    decay = omega * (zeta - math.sqrt(zeta * zeta - 1.0)) if zeta > 1.0 else max(zeta * omega, 1e-3 * omega)
    h_eq = static.min_separation_m
    start = min(float(law.h_max), settings.clearance_m)
    if start <= h_eq:
        start = h_eq + (float(law.h_max) - float(law.h_min))
    t_fall = math.sqrt(2.0 * (start - h_eq) / STANDARD_GRAVITY)
    t_end = t_max_s if t_max_s is not None else t_fall + 60.0 / decay
    h_tol = tol * load / k
    v_tol = h_tol * omega

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        return np.array([y[1], -STANDARD_GRAVITY + loads.force_n(y[0]) / mass - damping / mass * y[1]])

    def jac(t: float, y: np.ndarray) -> np.ndarray:
        _, slope = loads.force_and_slope(y[0])
        return np.array([[0.0, 1.0], [slope / mass, -damping / mass]])

    def at_rest(t: float, y: np.ndarray) -> float:
        return max(abs(loads.force_n(y[0]) - load) / (tol * load), abs(y[1]) / v_tol) - 1.0

    at_rest.terminal = True  # type: ignore[attr-defined]
    at_rest.direction = -1  # type: ignore[attr-defined]
    options: dict = {"rtol": rtol, "atol": np.array([1e-3 * h_tol, 1e-3 * v_tol])}
    if chosen in _IMPLICIT:
        options["jac"] = jac
    began = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, t_end), np.array([start, 0.0]), method=chosen, events=at_rest, **options)
    elapsed = time.perf_counter() - began
    h_final = float(sol.y[0, -1])
    area_final = loads.area_m2(h_final)
    area_static = static.contact_area_m2
    settled = bool(sol.status == 1)
    return Settle(
        method=chosen,
        stiff=stiff,
        t_s=sol.t,
        min_separation_m=sol.y[0],
        velocity_m_per_s=sol.y[1],
        final_separation_m=h_final,
        static_separation_m=h_eq,
        separation_error_m=h_final - h_eq,
        area_relative_error=abs(area_final - area_static) / area_static if area_static > 0 else 0.0,
        settled=settled,
        settle_time_s=float(sol.t[-1]),
        nfev=int(sol.nfev),
        njev=int(sol.njev),
        nlu=int(sol.nlu),
        status=int(sol.status),
        message=str(sol.message),
        elapsed_s=elapsed,
        damping_ratio=zeta,
        stiffness_n_per_m=k,
        stiffness_ratio=ratio,
        static=static,
    )
