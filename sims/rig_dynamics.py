"""Damped release-to-rest dynamics of the piston (the MBS run of seed section 2.1, eq. 22).

The piston (mass ``m`` = weight + piston mass) is released from rest just touching the liner and falls onto its
asperities: ``m ẍ = m g − F_c(x) − B ẋ`` (seed eq. 22 with ``F_c = P_c A_c`` on the skirt mesh), ``x`` the downward
displacement, ``h0 = c − x`` the minimum gap. In the state ``y = (h0, v = ḣ0)``::

    ḣ0 = v,   v̇ = −g + F(h0)/m − (B/m) v,     Jacobian [[0, 1], [F′(h0)/m, −B/m]]

with the analytic slope ``F′`` from the contact law (:meth:`sims.rig_loads.SkirtLoads.force_and_slope`).

Linearised at rest (contact stiffness ``k = −F′``) the eigenvalues are ``−(B/2m) ± √((B/2m)² − k/m)``. Heavy damping
(``ζ = B / (2√(km)) ≫ 1``) separates them — a fast ``≈ −B/m`` and a slow ``≈ −k/B`` — and the problem is stiff
(ratio ``≈ 4ζ²``): explicit Runge–Kutta needs steps ``≲ m/B`` over a settling time ``≈ B/k``, implicit methods do not.
Light damping (``ζ ≲ 1``) is not stiff, and an explicit method is cheaper (at 25.966 kg, B = 2e4 N·s/m, rtol 1e-9:
RK45 1.0e4 evaluations, Radau 4.0e4 plus 626 LU decompositions). Numerical damping of the implicit methods, released
δ = 1e-3·W/k above rest against the analytic linear oscillator: the first overshoot ``δ·exp(−πζ/√(1−ζ²))`` of every
method agrees to 5e-3 at rtol 1e-9…1e-3 (RK45 and Radau to 4e-4); after 20 periods BDF has lost 2 % (rtol 1e-9,
1e-6) to 12 % (rtol 1e-3) of the amplitude relative to RK45, LSODA 1–4 %, Radau none
(``tests/benchmarks/bench_rig_dynamics.py``).
``method="auto"`` takes BDF when the stiffness ratio exceeds :data:`STIFF_RATIO`, else RK45 (in the same benchmark
BDF settles the stiff case with a third of Radau's evaluations at the same error; LSODA, which switches by itself,
is as cheap in both cases).

The run stops when the piston is at rest (``|F − W| ≤ tol·W`` and ``|v| ≤ tol·(W/k)·ω``), at ``t_max_s``, or when
the right-hand side has been evaluated ``max_evaluations`` times (status −2, a message like SciPy's ``maxfev``):
RK45 on the stiff case (B = 1e7 N·s/m) needs ~1.7e5 evaluations at 25.966 kg and ~3.5e6 at 5.44 kg, so without the
cap an explicit method on a stiff case runs for minutes; it also gets a warning recommending an implicit method.
The solver is stepped here (SciPy's ``OdeSolver`` classes) so the budget is checked after every step. The mesh is
the static solution's (fixed during the run), so the rest state is that static solution exactly.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import BDF, DOP853, LSODA, RK45, Radau

from sims.rig_law import ContactLaw
from sims.rig_loads import SkirtLoads
from sims.rig_settings import STANDARD_GRAVITY, RigSettings
from sims.rig_statics import Equilibrium, RigLoadError, equilibrium

__all__ = [
    "MAX_EVALUATIONS",
    "METHODS",
    "STIFF_RATIO",
    "Settle",
    "explicit_cost_estimate",
    "settle",
    "stiffness_ratio",
]

#: Stiffness ratio (fast/slow decay rate at rest) above which ``method="auto"`` takes an implicit method.
STIFF_RATIO = 100.0

METHODS = ("auto", "RK45", "DOP853", "Radau", "BDF", "LSODA")
_IMPLICIT = ("Radau", "BDF", "LSODA")
_SOLVERS = {"RK45": RK45, "DOP853": DOP853, "Radau": Radau, "BDF": BDF, "LSODA": LSODA}

#: Default cap on right-hand-side evaluations of one run (an explicit method on a stiff case stops there).
MAX_EVALUATIONS = 100_000


@dataclass(frozen=True)
class Settle:
    """A release-to-rest run: trajectory, final state against the static solution, and solver diagnostics.

    ``t_s`` [s], ``min_separation_m`` [m], ``velocity_m_per_s`` [m/s]: the trajectory (at the steps, or at
    ``t_eval_s``). ``status`` as SciPy's ``solve_ivp``: 1 at rest (terminal event), 0 end of the interval reached
    without rest, −1 step failure; and −2: evaluation budget ``max_evaluations`` exhausted. ``nfev``, ``njev``,
    ``nlu``: right-hand-side and Jacobian evaluations, LU decompositions. ``warnings``: e.g. an explicit method on a
    stiff case.
    """

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
    warnings: tuple[str, ...] = ()


def stiffness_ratio(stiffness_n_per_m: float, mass_kg: float, damping_n_s_per_m: float) -> tuple[float, float]:
    """Damping ratio ζ = B/(2√(km)) and stiffness ratio |λ_fast/λ_slow| of the linearised oscillator (1 if ζ ≤ 1)."""
    if stiffness_n_per_m <= 0:
        return math.inf, math.inf
    zeta = damping_n_s_per_m / (2.0 * math.sqrt(stiffness_n_per_m * mass_kg))
    if zeta <= 1.0:
        return zeta, 1.0
    root = math.sqrt(zeta * zeta - 1.0)
    return zeta, (zeta + root) / (zeta - root)


def explicit_cost_estimate(stiffness_n_per_m: float, mass_kg: float, damping_n_s_per_m: float, tol: float) -> float:
    """Lower estimate of the right-hand-side evaluations an explicit RK45 run to rest needs (stability-limited) [-].

    Steps of at most ``3.3/|λ_fast|`` (Dormand–Prince's real stability limit) over the time ``ln(1/tol)/|λ_slow|`` the
    slow mode takes to decay to the rest tolerance, six evaluations a step; NaN unless overdamped (ζ > 1). Measured
    runs take 2–2.5× this (step rejections at the stability limit): a lower bound, not a prediction.
    """
    zeta, _ = stiffness_ratio(stiffness_n_per_m, mass_kg, damping_n_s_per_m)
    if not (math.isfinite(zeta) and zeta > 1.0):
        return math.nan
    omega = math.sqrt(stiffness_n_per_m / mass_kg)
    root = math.sqrt(zeta * zeta - 1.0)
    fast, slow = omega * (zeta + root), omega * (zeta - root)
    return 6.0 * fast * math.log(1.0 / tol) / (3.3 * slow)


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
    start_m: float | None = None,
    t_eval_s: np.ndarray | None = None,
    max_evaluations: int | None = MAX_EVALUATIONS,
    name: str = "law",
) -> Settle:
    """Release the piston under ``weight_kg`` from rest, just touching, and integrate seed eq. 22 to rest.

    ``method``: one of :data:`METHODS` (``"auto"`` picks per case). ``damping_n_s_per_m`` overrides the settings'
    damping B [N·s/m]. ``static`` reuses a computed equilibrium (its mesh is used). ``tol`` is the rest criterion,
    ``rtol`` the integrator's relative tolerance. ``start_m`` is the minimum gap [m] at release (default: just
    touching, ``min(h_max, c)``); ``t_eval_s`` [s] samples the trajectory at those times (from each step's dense
    output) instead of at the steps. ``max_evaluations`` caps the right-hand-side evaluations (``None``: no cap):
    a run that reaches it stops with ``status = -2`` and a message, like SciPy's ``maxfev``. An explicit method on
    a stiff case (stiffness ratio > :data:`STIFF_RATIO`) adds a warning (in ``warnings`` and as a RuntimeWarning)
    recommending an implicit one.
    """
    import warnings as pywarnings

    from scipy.optimize import brentq

    from contactrig.core.validation import check_choice, check_int, check_range

    check_choice("method", method, METHODS)
    damping = settings.damping_n_s_per_m if damping_n_s_per_m is None else damping_n_s_per_m
    damping = check_range("damping_n_s_per_m", damping, 0.0, 1e12, unit="N·s/m")
    tol = check_range("tol", tol, 0.0, 0.1, lo_open=True)
    rtol = check_range("rtol", rtol, 1e-14, 0.1)
    if max_evaluations is not None:
        max_evaluations = check_int("max_evaluations", max_evaluations, 10, 10**12)
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
    notes: list[str] = []
    if stiff and chosen not in _IMPLICIT:
        estimate = explicit_cost_estimate(k, mass, damping, tol)
        notes.append(
            f"{name}: explicit {chosen} on a stiff case (stiffness ratio {ratio:.3g}, damping ratio {zeta:.3g}): "
            f"its steps are limited by stability, not accuracy — at least ~{estimate:.2g} evaluations to rest; use an "
            "implicit method (BDF, Radau or LSODA, or method='auto')"
        )
    omega = math.sqrt(k / mass)
    decay = omega * (zeta - math.sqrt(zeta * zeta - 1.0)) if zeta > 1.0 else max(zeta * omega, 1e-3 * omega)
    h_eq = static.min_separation_m
    if start_m is None:
        start = min(float(law.h_max), settings.clearance_m)
        if start <= h_eq:
            start = h_eq + (float(law.h_max) - float(law.h_min))
    else:
        start = check_range("start_m", start_m, -settings.clearance_m - 1.0, settings.clearance_m, unit="m")
    t_fall = math.sqrt(2.0 * max(start - h_eq, 0.0) / STANDARD_GRAVITY)
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

    options: dict = {"rtol": rtol, "atol": np.array([1e-3 * h_tol, 1e-3 * v_tol])}
    if chosen in _IMPLICIT:
        options["jac"] = jac
    samples = None if t_eval_s is None else np.sort(np.asarray(t_eval_s, dtype=float))
    began = time.perf_counter()
    solver = _SOLVERS[chosen](rhs, 0.0, np.array([start, 0.0]), t_end, **options)
    ts, ys = [0.0], [solver.y.copy()]
    if samples is not None:
        ts, ys = [], []
        first = samples[samples <= 0.0]
        ts.extend(first.tolist())
        ys.extend([solver.y.copy()] * first.size)
    n_sampled = 0 if samples is None else int(np.count_nonzero(samples <= 0.0))
    g_old = at_rest(0.0, solver.y)
    status, message = None, ""
    t_last, y_last = 0.0, solver.y.copy()
    while status is None:
        message = solver.step() or ""
        if solver.status == "failed":
            status = -1
            break
        t, y = solver.t, solver.y.copy()
        g_new = at_rest(t, y)
        dense = None
        if g_old > 0.0 >= g_new:  # entered the rest region (terminal event, direction −1)
            dense = solver.dense_output()
            t = brentq(lambda tau, d=dense: at_rest(tau, d(tau)), solver.t_old, t, xtol=1e-14 * max(t, 1e-30))
            y = dense(t)
            status, message = 1, "A termination event occurred: the piston is at rest."
        elif solver.status == "finished":
            status, message = 0, "The solver successfully reached the end of the integration interval."
        if samples is None:
            ts.append(t)
            ys.append(y)
        else:
            upto = int(np.searchsorted(samples, t, side="right"))
            if upto > n_sampled:
                dense = dense or solver.dense_output()
                for tau in samples[n_sampled:upto]:
                    ts.append(float(tau))
                    ys.append(dense(tau))
                n_sampled = upto
        g_old = g_new
        t_last, y_last = t, y
        if status is None and max_evaluations is not None and solver.nfev >= max_evaluations:
            status = -2
            message = (
                f"Maximum number of function evaluations has been exceeded: nfev = {solver.nfev} >= "
                f"max_evaluations = {max_evaluations} at t = {t:.4g} s of {t_end:.4g} s (not at rest)"
            )
            notes.append(f"{name}: {chosen} stopped: {message}")
    elapsed = time.perf_counter() - began
    for note in notes:
        pywarnings.warn(note, RuntimeWarning, stacklevel=2)
    y_all = np.array(ys).reshape(-1, 2).T if ys else np.empty((2, 0))
    h_final = float(y_last[0])
    area_final = loads.area_m2(h_final)
    area_static = static.contact_area_m2
    return Settle(
        method=chosen,
        stiff=stiff,
        t_s=np.array(ts, dtype=float),
        min_separation_m=y_all[0],
        velocity_m_per_s=y_all[1],
        final_separation_m=h_final,
        static_separation_m=h_eq,
        separation_error_m=h_final - h_eq,
        area_relative_error=abs(area_final - area_static) / area_static if area_static > 0 else 0.0,
        settled=status == 1,
        settle_time_s=float(t_last),
        nfev=int(solver.nfev),
        njev=int(getattr(solver, "njev", 0)),
        nlu=int(getattr(solver, "nlu", 0)),
        status=int(status),
        message=str(message),
        elapsed_s=elapsed,
        damping_ratio=zeta,
        stiffness_n_per_m=k,
        stiffness_ratio=ratio,
        static=static,
        warnings=tuple(notes),
    )
