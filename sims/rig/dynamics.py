"""Damped release-to-rest dynamics of the piston (the MBS run of seed section 2.1, eq. 22).

The piston (mass ``m`` = weight + piston mass) is released from rest just touching the liner and falls onto its
asperities: ``m ẍ = m g − F_c(x) − B ẋ`` (seed eq. 22 with ``F_c = P_c A_c`` on the skirt mesh), ``x`` the downward
displacement, ``h0 = c − x`` the minimum gap. In the state ``y = (h0, v = ḣ0)``::

    ḣ0 = v,   v̇ = −g + F(h0)/m − (B/m) v,     Jacobian [[0, 1], [F′(h0)/m, −B/m]]

with the analytic slope ``F′`` from the contact law (:meth:`sims.rig.loads.SkirtLoads.force_and_slope`).

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
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import BDF, DOP853, LSODA, RK45, Radau

from sims.rig.equilibrium import Equilibrium, RigLoadError, equilibrium
from sims.rig.geometry import OutOfGeometryError
from sims.rig.law import ContactLaw
from sims.rig.loads import SkirtLoads
from sims.rig.settings import STANDARD_GRAVITY, RigSettings

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
    without rest, −1 step failure; −2: evaluation budget ``max_evaluations`` exhausted; −3: a step took the piston
    outside the geometry (:class:`~sims.rig.geometry.OutOfGeometryError`: the skirt would cross the liner wall).
    ``nfev``, ``njev``, ``nlu``: right-hand-side and Jacobian evaluations, LU decompositions. ``warnings``: e.g.
    an explicit method on a stiff case.
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
    """Release the piston under ``weight_kg`` [kg] from rest, just touching, and integrate seed eq. 22 to rest.

    ``method``: one of :data:`METHODS` (``"auto"`` picks per case). ``damping_n_s_per_m`` overrides the settings'
    damping B [N·s/m]. ``static`` reuses a computed equilibrium (its mesh is used). ``tol`` is the rest criterion,
    ``rtol`` the integrator's relative tolerance. ``start_m`` is the minimum gap [m] at release (default: just
    touching, ``min(h_max, c)``); ``t_eval_s`` [s] samples the trajectory at those times (from each step's dense
    output) instead of at the steps. ``max_evaluations`` caps the right-hand-side evaluations (``None``: no cap):
    a run that reaches it stops with ``status = -2`` and a message, like SciPy's ``maxfev``. An explicit method on
    a stiff case (stiffness ratio > :data:`STIFF_RATIO`) adds a warning (in ``warnings`` and as a RuntimeWarning)
    recommending an implicit one.

    Steps: check the options, set up the problem at the static solution (:class:`_Problem`: stiffness, method,
    start, tolerances), step the solver to rest (:func:`_integrate`), collect the result.
    """
    import warnings as pywarnings

    options = _check_options(method, settings, damping_n_s_per_m, tol, rtol, max_evaluations)
    mass = weight_kg + settings.piston_mass_kg
    if mass <= 0:
        raise RigLoadError(f"{name}: the dynamics need a moving mass: weight + piston mass = {mass} kg")
    if static is None:
        static = equilibrium(law, settings, weight_kg, name=name)
    problem = _Problem.at_rest_of(law, settings, static, mass, options, start_m, t_max_s, name)
    run = _integrate(problem, t_eval_s, options.max_evaluations, name)
    notes = problem.notes + run.notes
    for note in notes:
        pywarnings.warn(note, RuntimeWarning, stacklevel=2)
    h_final = float(run.y_last[0])
    area_final = problem.loads.area_m2(h_final)
    area_static = static.contact_area_m2
    return Settle(
        method=problem.method,
        stiff=problem.stiff,
        t_s=np.array(run.ts, dtype=float),
        min_separation_m=run.y_all[0],
        velocity_m_per_s=run.y_all[1],
        final_separation_m=h_final,
        static_separation_m=static.min_separation_m,
        separation_error_m=h_final - static.min_separation_m,
        area_relative_error=abs(area_final - area_static) / area_static if area_static > 0 else 0.0,
        settled=run.status == 1,
        settle_time_s=float(run.t_last),
        nfev=run.nfev,
        njev=run.njev,
        nlu=run.nlu,
        status=run.status,
        message=run.message,
        elapsed_s=run.elapsed_s,
        damping_ratio=problem.zeta,
        stiffness_n_per_m=problem.stiffness,
        stiffness_ratio=problem.ratio,
        static=static,
        warnings=tuple(notes),
    )


@dataclass(frozen=True)
class _Options:
    method: str
    damping: float
    tol: float
    rtol: float
    max_evaluations: int | None


def _check_options(
    method: str,
    settings: RigSettings,
    damping_n_s_per_m: float | None,
    tol: float,
    rtol: float,
    max_evaluations: int | None,
) -> _Options:
    """Validated options of :func:`settle` (errors name the argument); the damping defaults to the settings'."""
    from contactrig.core.validation import check_choice, check_int, check_range

    check_choice("method", method, METHODS)
    damping = settings.damping_n_s_per_m if damping_n_s_per_m is None else damping_n_s_per_m
    return _Options(
        method=method,
        damping=check_range("damping_n_s_per_m", damping, 0.0, 1e12, unit="N·s/m"),
        tol=check_range("tol", tol, 0.0, 0.1, lo_open=True),
        rtol=check_range("rtol", rtol, 1e-14, 0.1),
        max_evaluations=None if max_evaluations is None else check_int("max_evaluations", max_evaluations, 10, 10**12),
    )


@dataclass(frozen=True)
class _Problem:
    """Seed eq. 22 in the state ``y = (h0 [m], v [m/s])`` on the static solution's mesh, with its rest criterion.

    ``load`` W [N], ``stiffness`` k = −F′ at rest [N/m], ``zeta``/``ratio`` damping and stiffness ratios,
    ``method`` the solver chosen, ``start`` h0 at release [m], ``t_end`` [s], ``h_tol`` [m] and ``v_tol`` [m/s] the
    rest tolerances, ``notes`` warnings known before the run (an explicit method on a stiff case).
    """

    loads: SkirtLoads
    mass: float
    damping: float
    load: float
    stiffness: float
    zeta: float
    ratio: float
    stiff: bool
    method: str
    start: float
    t_end: float
    tol: float
    rtol: float
    h_tol: float
    v_tol: float
    notes: list[str]

    @classmethod
    def at_rest_of(
        cls,
        law: ContactLaw,
        settings: RigSettings,
        static: Equilibrium,
        mass: float,
        options: _Options,
        start_m: float | None,
        t_max_s: float | None,
        name: str,
    ) -> _Problem:
        """The problem linearised at ``static``: stiffness, damping ratio, method and time scales."""
        k, damping = static.stiffness_n_per_m, options.damping
        zeta, ratio = stiffness_ratio(k, mass, damping)
        stiff = ratio > STIFF_RATIO
        chosen = ("BDF" if stiff else "RK45") if options.method == "auto" else options.method
        notes: list[str] = []
        if stiff and chosen not in _IMPLICIT:
            estimate = explicit_cost_estimate(k, mass, damping, options.tol)
            notes.append(
                f"{name}: explicit {chosen} on a stiff case (stiffness ratio {ratio:.3g}, damping ratio {zeta:.3g}): "
                f"its steps are limited by stability, not accuracy — at least ~{estimate:.2g} evaluations to rest; "
                "use an implicit method (BDF, Radau or LSODA, or method='auto')"
            )
        omega = math.sqrt(k / mass)
        decay = omega * (zeta - math.sqrt(zeta * zeta - 1.0)) if zeta > 1.0 else max(zeta * omega, 1e-3 * omega)
        start = _release_gap(law, settings, static.min_separation_m, start_m)
        t_fall = math.sqrt(2.0 * max(start - static.min_separation_m, 0.0) / STANDARD_GRAVITY)
        h_tol = options.tol * static.load_n / k
        return cls(
            loads=SkirtLoads(law, settings, static.mesh),
            mass=mass,
            damping=damping,
            load=static.load_n,
            stiffness=k,
            zeta=zeta,
            ratio=ratio,
            stiff=stiff,
            method=chosen,
            start=start,
            t_end=t_max_s if t_max_s is not None else t_fall + 60.0 / decay,
            tol=options.tol,
            rtol=options.rtol,
            h_tol=h_tol,
            v_tol=h_tol * omega,
            notes=notes,
        )

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """``(ḣ0, v̇) = (v, −g + F(h0)/m − (B/m) v)`` (seed eq. 22)."""
        force = self.loads.force_n(y[0])
        return np.array([y[1], -STANDARD_GRAVITY + force / self.mass - self.damping / self.mass * y[1]])

    def jac(self, t: float, y: np.ndarray) -> np.ndarray:
        """Jacobian ``[[0, 1], [F′(h0)/m, −B/m]]`` from the law's analytic slope."""
        _, slope = self.loads.force_and_slope(y[0])
        return np.array([[0.0, 1.0], [slope / self.mass, -self.damping / self.mass]])

    def at_rest(self, t: float, y: np.ndarray) -> float:
        """≤ 0 at rest: ``|F − W| ≤ tol·W`` and ``|v| ≤ v_tol``."""
        return max(abs(self.loads.force_n(y[0]) - self.load) / (self.tol * self.load), abs(y[1]) / self.v_tol) - 1.0

    def solver(self) -> Any:
        """The SciPy ``OdeSolver`` of the chosen method, released from rest at ``start`` (implicit: with Jacobian)."""
        options: dict[str, Any] = {"rtol": self.rtol, "atol": np.array([1e-3 * self.h_tol, 1e-3 * self.v_tol])}
        if self.method in _IMPLICIT:
            options["jac"] = self.jac
        return _SOLVERS[self.method](self.rhs, 0.0, np.array([self.start, 0.0]), self.t_end, **options)


def _release_gap(law: ContactLaw, settings: RigSettings, h_eq: float, start_m: float | None) -> float:
    """Minimum gap at release [m]: ``start_m`` (checked), else just touching, ``min(h_max, c)`` (above rest)."""
    from contactrig.core.validation import check_range

    if start_m is not None:
        return check_range("start_m", start_m, -settings.clearance_m - 1.0, settings.clearance_m, unit="m")
    start = min(float(law.h_max), settings.clearance_m)
    if start <= h_eq:
        start = h_eq + (float(law.h_max) - float(law.h_min))
    return start


class _Trajectory:
    """The states kept: at every step, or at the sample times ``samples`` [s] from each step's dense output."""

    def __init__(self, samples: np.ndarray | None, y0: np.ndarray) -> None:
        self.samples = samples
        if samples is None:
            self.ts: list[float] = [0.0]
            self.ys: list[np.ndarray] = [y0.copy()]
            self.n_sampled = 0
        else:
            first = samples[samples <= 0.0]
            self.ts, self.ys = first.tolist(), [y0.copy()] * first.size
            self.n_sampled = int(first.size)

    def record(self, t: float, y: np.ndarray, solver: Any, dense: Callable[[float], np.ndarray] | None) -> None:
        """Keep the step's end ``(t, y)``, or the samples up to ``t`` (interpolated within the step)."""
        if self.samples is None:
            self.ts.append(t)
            self.ys.append(y)
            return
        upto = int(np.searchsorted(self.samples, t, side="right"))
        if upto <= self.n_sampled:
            return
        dense = dense if dense is not None else solver.dense_output()
        for tau in self.samples[self.n_sampled : upto]:
            self.ts.append(float(tau))
            self.ys.append(dense(tau))
        self.n_sampled = upto


@dataclass(frozen=True)
class _Step:
    t: float
    y: np.ndarray
    g: float
    dense: Callable[[float], np.ndarray] | None
    status: int | None
    message: str


def _end_of_step(problem: _Problem, solver: Any, g_old: float, message: str) -> _Step:
    """The state after a step: the rest event located inside it (Brent on the dense output), the interval's end,
    or neither (``status`` None)."""
    from scipy.optimize import brentq

    t, y = float(solver.t), solver.y.copy()
    g_new = problem.at_rest(t, y)
    if g_old > 0.0 >= g_new:  # entered the rest region (terminal event, direction −1)
        dense = solver.dense_output()
        t = brentq(lambda tau: problem.at_rest(tau, dense(tau)), solver.t_old, t, xtol=1e-14 * max(t, 1e-30))
        return _Step(t, dense(t), g_new, dense, 1, "A termination event occurred: the piston is at rest.")
    if solver.status == "finished":
        return _Step(t, y, g_new, None, 0, "The solver successfully reached the end of the integration interval.")
    return _Step(t, y, g_new, None, None, message)


@dataclass(frozen=True)
class _Run:
    ts: list[float]
    y_all: np.ndarray
    t_last: float
    y_last: np.ndarray
    status: int
    message: str
    nfev: int
    njev: int
    nlu: int
    elapsed_s: float
    notes: list[str]


def _integrate(problem: _Problem, t_eval_s: np.ndarray | None, max_evaluations: int | None, name: str) -> _Run:
    """Step the solver from release until rest (status 1), the interval's end (0), a step failure (−1) or the
    evaluation budget (−2); the solver is stepped here so the budget is checked after every step."""
    samples = None if t_eval_s is None else np.sort(np.asarray(t_eval_s, dtype=float))
    began = time.perf_counter()
    solver = problem.solver()
    trajectory = _Trajectory(samples, solver.y)
    g_old = problem.at_rest(0.0, solver.y)
    status: int | None = None
    message = ""
    notes: list[str] = []
    t_last, y_last = 0.0, solver.y.copy()
    while status is None:
        try:
            message = solver.step() or ""
        except OutOfGeometryError as exc:
            status = -3
            message = f"the state left the piston/liner geometry at t = {solver.t:.4g} s: {exc}"
            notes.append(f"{name}: {problem.method} stopped: {message}")
            break
        if solver.status == "failed":
            status = -1
            break
        step = _end_of_step(problem, solver, g_old, message)
        status, message = step.status, step.message
        trajectory.record(step.t, step.y, solver, step.dense)
        g_old, t_last, y_last = step.g, step.t, step.y
        if status is None and max_evaluations is not None and solver.nfev >= max_evaluations:
            status = -2
            message = (
                f"Maximum number of function evaluations has been exceeded: nfev = {solver.nfev} >= "
                f"max_evaluations = {max_evaluations} at t = {step.t:.4g} s of {problem.t_end:.4g} s (not at rest)"
            )
            notes.append(f"{name}: {problem.method} stopped: {message}")
    ys = trajectory.ys
    return _Run(
        ts=trajectory.ts,
        y_all=np.array(ys).reshape(-1, 2).T if ys else np.empty((2, 0)),
        t_last=t_last,
        y_last=y_last,
        status=int(status),
        message=str(message),
        nfev=int(solver.nfev),
        njev=int(getattr(solver, "njev", 0)),
        nlu=int(getattr(solver, "nlu", 0)),
        elapsed_s=time.perf_counter() - began,
        notes=notes,
    )
