"""Static equilibrium of the piston resting in its liner: the minimum gap at which the contact carries the weight.

THE equilibrium solver of the rig. It solves ``F(h0) = W`` (seed section 2.1 at rest, eq. 22 with v = 0) for the
minimum gap ``h0`` [m] of every weight of a batch at once, with ``F(h0) = Σ p(h_i) ΔA_i cos θ_i`` [N] on the skirt
mesh (:class:`sims.rig.loads.SkirtLoads`) and ``W = (weight + piston mass)·g`` [N]. Each evaluation of the contact
law covers every weight (one call on a ``weights × nodes`` array). :func:`batch_equilibrium` is the solver;
:func:`equilibrium` is the same solver for one weight, returning one row of the batch (:class:`Equilibrium`).

Root solve: ``F`` is strictly decreasing in ``h0``, so each weight gets a bracket ``[lo, hi]`` with
``g(lo) ≥ 0 ≥ g(hi)`` (``g = F − W``; expanding ×4 steps from a guess), then a safeguarded Newton iteration with the
law's analytic slope: a Newton step that leaves the bracket is replaced by bisection, so it cannot fail to converge.

Mesh: a fixed mesh (given, or ``mesh = "uniform"``: ``n_theta × n_axial`` cells), or ``mesh = "variable"``: the mesh
is fitted to the widest contact zone of the previous solution (its fine zone ends where the gap of the heaviest
weight reaches the law's ``h_max``, a cell edge on the contact onset keeps midpoint cells second order) and the
number of cells doubled until every weight's real area changes by less than ``mesh_tol`` (midpoint cells:
exponentially convergent on the smooth Greenwood–Tripp integrand, second order at worst, so the remaining error is
at most about a third of the last change) or the node budget ``max_nodes`` is reached (then a warning, and the last
solved level is the answer). The skirt beyond the contact zone gets cells only when
:func:`sims.rig.loads.tail_bound` cannot show that it carries less than ``TAIL_SHARE·mesh_tol`` of the load and of
the area for every weight (an asperity law is exactly zero there; Greenwood–Tripp's tail beyond 6σ is ~1e-8).

Zero load with the clearance larger than the law's contact range (``c ≥ h_max``): no contact; the piston is
reported centred (``h0 = c``, the limit of the loaded solutions as the load goes to zero), with zero area and
force (status ``"no load"``).

Assumptions are checked and reported in ``warnings``: a minimum gap below the law's tabulated range (extrapolated)
and, for :func:`equilibrium` given roughness and modulus, the roughness parameter ``α = σ R_eff / b²``
(:func:`roughness_parameter`) below :data:`ALPHA_WARN`: bulk elastic deformation is then no longer small against
asperity deformation and the rigid-body model (the paper's) loses accuracy.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from sims.rig.geometry import contact_edge_angle_rad, contact_half_length_m
from sims.rig.law import ContactLaw
from sims.rig.loads import TAIL_SHARE, SkirtLoads, tail_matters
from sims.rig.mesh import SkirtMesh, uniform_mesh, variable_mesh
from sims.rig.settings import STANDARD_GRAVITY, RigSettings, check_weights

__all__ = [
    "ALPHA_WARN",
    "TAIL_SHARE",
    "BatchEquilibrium",
    "Equilibrium",
    "RigLoadError",
    "batch_equilibrium",
    "equilibrium",
    "preload_note",
    "roughness_parameter",
    "search_limits",
]

#: Warn when the roughness parameter σ R_eff / b² falls below this (bulk elastic deformation no longer small).
ALPHA_WARN = 5.0

#: Newton/bisection iterations per mesh level before the solve gives up refining the root (never reached in practice).
MAX_ITERATIONS = 200


class RigLoadError(ValueError):
    """The contact law cannot carry the load within its (extended) range, or the input is outside the model."""


# ---------------------------------------------------------------------------------------------------------------
# Results.


@dataclass(frozen=True)
class BatchEquilibrium:
    """Equilibria of ``weight_kg`` [kg] (in the given order) on one mesh; one entry per weight in every array.

    ``load_n`` W [N]; ``min_separation_m`` h0 [m]; ``contact_force_n`` F(h0) [N] (≥ 0); ``contact_area_m2`` real area
    [m²]; ``contact_width_m`` arc length (at the skirt's middle) where the gap is below the law's ``h_max`` [m];
    ``peak_pressure_pa`` nominal pressure at h0 [Pa]; ``residual_n`` raw ``F(h0) − W`` [N]; ``status`` per weight
    ``"converged"``, ``"no load"`` or ``"mesh budget reached"``; ``converged`` False only where the mesh budget stopped
    the refinement; ``in_range`` h0 within the law's range. Diagnostics: ``evaluations`` force evaluations,
    ``law_calls`` calls of the contact law (each covers all weights), ``iterations`` Newton/bisection iterations,
    ``mesh_levels`` solved mesh levels, ``mesh_change`` last relative area change (NaN on a fixed mesh).
    Row ``i`` as a single equilibrium (with node fields and the contact stiffness): :meth:`at`.
    """

    weight_kg: np.ndarray
    load_n: np.ndarray
    min_separation_m: np.ndarray
    contact_force_n: np.ndarray
    contact_area_m2: np.ndarray
    contact_width_m: np.ndarray
    peak_pressure_pa: np.ndarray
    residual_n: np.ndarray
    status: np.ndarray
    converged: np.ndarray
    in_range: np.ndarray
    mesh: SkirtMesh = field(repr=False)
    loads: SkirtLoads = field(repr=False, compare=False)
    evaluations: int
    law_calls: int
    iterations: int
    mesh_levels: int
    mesh_change: float
    warnings: tuple[str, ...] = ()
    weight_warnings: tuple[tuple[str, ...], ...] = field(default=(), repr=False)

    @property
    def n_nodes(self) -> int:
        """Nodes of the (shared) mesh."""
        return self.mesh.n_nodes

    def at(self, i: int) -> Equilibrium:
        """Row ``i`` as an :class:`Equilibrium` (pressure and area fraction per node, contact stiffness)."""
        h0 = float(self.min_separation_m[i])
        no_load = self.status[i] == "no load"
        loads = SkirtLoads(self.loads.law, self.loads.settings, self.mesh)
        _, slope = (0.0, 0.0) if no_load else loads.force_and_slope(h0)
        zeros = np.zeros(self.mesh.shape)
        shared = tuple(w for w in self.warnings if not any(w in ws for ws in self.weight_warnings))
        own = self.weight_warnings[i] if self.weight_warnings else ()
        return Equilibrium(
            weight_kg=float(self.weight_kg[i]),
            load_n=float(self.load_n[i]),
            min_separation_m=h0,
            contact_force_n=float(self.contact_force_n[i]),
            contact_area_m2=float(self.contact_area_m2[i]),
            contact_width_m=float(self.contact_width_m[i]),
            peak_pressure_pa=float(self.peak_pressure_pa[i]),
            stiffness_n_per_m=-slope,
            mesh=self.mesh,
            pressure_pa=zeros if no_load else loads.pressure_pa(h0),
            area_fraction=zeros if no_load else loads.area_fraction(h0),
            evaluations=self.evaluations,
            iterations=self.iterations,
            residual_n=float(self.residual_n[i]),
            status=str(self.status[i]),
            converged=bool(self.converged[i]),
            mesh_levels=self.mesh_levels,
            mesh_change=self.mesh_change,
            in_range=bool(self.in_range[i]),
            warnings=shared + own,
        )


@dataclass(frozen=True)
class Equilibrium:
    """One weight's row of a :class:`BatchEquilibrium` (see there for the fields), plus what a single weight has.

    ``stiffness_n_per_m`` contact stiffness ``−dF/dh0`` at rest [N/m]; ``pressure_pa`` [Pa] and ``area_fraction``
    [-] per node of ``mesh`` (a quarter of the skirt). The solver diagnostics are those of the batch it came from.
    """

    weight_kg: float
    load_n: float
    min_separation_m: float
    contact_force_n: float
    contact_area_m2: float
    contact_width_m: float
    peak_pressure_pa: float
    stiffness_n_per_m: float
    mesh: SkirtMesh = field(repr=False)
    pressure_pa: np.ndarray = field(repr=False)
    area_fraction: np.ndarray = field(repr=False)
    evaluations: int
    iterations: int
    residual_n: float
    status: str
    converged: bool
    mesh_levels: int
    mesh_change: float
    in_range: bool
    warnings: tuple[str, ...] = ()

    @property
    def n_nodes(self) -> int:
        """Nodes of the mesh the equilibrium was solved on."""
        return self.mesh.n_nodes


# ---------------------------------------------------------------------------------------------------------------
# Checks and messages.


def roughness_parameter(load_n: float, skirt_length_m: float, roughness_m: float, composite_modulus_pa: float) -> float:
    """Johnson's roughness parameter of the line contact, ``α = σ R_eff / b²`` [-].

    With Johnson's smooth half-width ``b = √(4 P′ R_eff / (π E*))``, ``P′ = W/L``, this is ``π σ E* / (4 P′)``:
    independent of ``R_eff``, finite at zero clearance, infinite at zero load. ``load_n`` [N], lengths [m], E* [Pa].
    """
    p_line = load_n / skirt_length_m
    if p_line <= 0:
        return math.inf
    return math.pi * roughness_m * composite_modulus_pa / (4.0 * p_line)


def search_limits(law: ContactLaw, settings: RigSettings) -> tuple[float, float, float]:
    """Where the root search for h0 may go [m]: ``(lo, hi, span)``, ``span = h_max − h_min`` of the law.

    Down to 1000 spans below the law's range (or half the piston radius of interference), up to 10 spans above it.
    """
    span = float(law.h_max) - float(law.h_min)
    lo = max(settings.clearance_m - 0.5 * settings.piston_radius_m, float(law.h_min) - 1000.0 * span)
    hi = max(float(law.h_max), settings.clearance_m) + 10.0 * span
    return lo, hi, span


def preload_note(name: str, law: ContactLaw, settings: RigSettings) -> str | None:
    """A note when the clearance is inside the law's contact range (``c < h_max``), else None.

    The centred, unloaded piston then already presses on the liner all round (an interference fit: zero clearance,
    or roughness comparable with the clearance): the real area includes that pre-load and hardly grows with weight.
    """
    if settings.clearance_m >= float(law.h_max):
        return None
    return (
        f"{name}: the clearance c = {settings.clearance_m:.3g} m is inside the contact law's range (h_max = "
        f"{float(law.h_max):.3g} m): the unloaded, centred piston is already in (possibly slight) contact all round "
        "(pre-loaded fit); the areas include that pre-load"
    )


def bracket_error(name: str, law: ContactLaw, load_n: float, side: str, limit_m: float) -> RigLoadError:
    """The error of a root search that found no bracket: the load is too large (``side="below"``) or no
    contact-free separation exists (``"above"``)."""
    if side == "below":
        return RigLoadError(
            f"{name}: the load {load_n:.6g} N exceeds what the contact law carries down to a minimum gap of "
            f"{limit_m:.4g} m (its range starts at h_min = {float(law.h_min):.4g} m): extend the database's "
            "separation range"
        )
    return RigLoadError(f"{name}: no contact-free separation found up to {limit_m:.4g} m for load {load_n:.6g} N")


# ---------------------------------------------------------------------------------------------------------------
# Root solve on one mesh: every weight at once.


def _expand(
    loads: SkirtLoads, load: np.ndarray, x: np.ndarray, step: np.ndarray, side: str, limit: float, name: str
) -> np.ndarray:
    """Move each bracket end ``x`` outward (×4 steps) until ``g = F − W`` has the sign of its side there:
    ``g(lo) ≥ 0`` (``side="below"``), ``g(hi) ≤ 0`` (``"above"``); a weight reaching ``limit`` [m] is an error."""
    width = step.copy()
    sign = -1.0 if side == "below" else 1.0
    while True:
        g = loads.forces_n(x) - load
        bad = sign * g > 0
        if not bad.any():
            return x
        at_limit = bad & (sign * (x - limit) >= 0)
        if at_limit.any():
            raise bracket_error(name, loads.law, float(load[np.argmax(at_limit)]), side, limit)
        width = np.where(bad, 4.0 * width, width)
        moved = np.clip(x - width, limit, None) if side == "below" else np.clip(x + width, None, limit)
        x = np.where(bad, moved, x)


def _newton(
    loads: SkirtLoads, load: np.ndarray, lo: np.ndarray, hi: np.ndarray, x: np.ndarray, xtol: float
) -> tuple[np.ndarray, int]:
    """Safeguarded Newton iteration inside the brackets ``[lo, hi]``; returns the roots [m] and the iterations."""
    for iteration in range(1, MAX_ITERATIONS + 1):
        f, df = loads.forces_and_slopes(x)
        g = f - load
        lo = np.where(g >= 0, x, lo)
        hi = np.where(g <= 0, x, hi)
        done = (g == 0) | (hi - lo <= xtol)
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = x - g / df
        # ">=": a Newton step below rounding leaves x on the bracket end it set; that is convergence, not failure
        ok = np.isfinite(newton) & (newton >= lo) & (newton <= hi)
        x_new = np.where(ok, newton, 0.5 * (lo + hi))
        converged = done | (np.abs(x_new - x) <= xtol)
        x = np.where(done, x, x_new)
        if converged.all():
            return x, iteration
    return x, MAX_ITERATIONS


def _roots(loads: SkirtLoads, load: np.ndarray, guess: np.ndarray | None, name: str) -> tuple[np.ndarray, int]:
    """Minimum gaps [m] with ``F(h0) = load`` (every load > 0 or pre-loaded); returns the roots and the iterations.

    Without a guess the brackets start on the law's range, else ``1e-3·span`` either side of the guess.
    """
    law = loads.law
    lo_limit, hi_limit, span = search_limits(law, loads.settings)
    if guess is None:  # the law's range, inside the region the geometry and the search allow
        lo = np.full(load.shape, max(float(law.h_min), lo_limit))
        hi = np.full(load.shape, min(max(float(law.h_max), lo_limit), hi_limit))
        step = np.full(load.shape, 0.25 * span)
    else:
        step = np.full(load.shape, 1e-3 * span)
        lo, hi = guess - step, guess + step
    lo = _expand(loads, load, lo, step, "below", lo_limit, name)
    hi = _expand(loads, load, hi, step, "above", hi_limit, name)
    x = 0.5 * (lo + hi) if guess is None else np.clip(guess, lo, hi)
    return _newton(loads, load, lo, hi, x, 1e-13 * span)


# ---------------------------------------------------------------------------------------------------------------
# Mesh levels.


@dataclass
class _Level:
    """The solution of the active weights on one mesh, and the solver work summed over every level so far."""

    loads: SkirtLoads
    h0: np.ndarray
    area: np.ndarray
    evaluations: int = 0
    law_calls: int = 0
    iterations: int = 0
    levels: int = 0
    change: float = math.nan
    converged: bool = True
    warnings: list[str] = field(default_factory=list)


def _solve_level(
    law: ContactLaw, s: RigSettings, mesh: SkirtMesh, load: np.ndarray, guess: np.ndarray | None, name: str
) -> tuple[SkirtLoads, np.ndarray, np.ndarray, int]:
    """Roots [m], real areas [m²] and iterations of the loads ``load`` [N] on ``mesh``."""
    loads = SkirtLoads(law, s, mesh)
    if not load.size:
        return loads, np.empty(0), np.empty(0), 0
    h0, iterations = _roots(loads, load, guess, name)
    return loads, h0, loads.areas_m2(h0), iterations


def _on_fixed_mesh(
    law: ContactLaw, s: RigSettings, mesh: SkirtMesh, load: np.ndarray, guess: np.ndarray | None, name: str
) -> _Level:
    loads, h0, area, iterations = _solve_level(law, s, mesh, load, guess, name)
    return _Level(loads, h0, area, loads.evaluations, loads.law_calls, iterations, 1)


class _Refinement:
    """State of the adaptive variable mesh: cells per level, the contact zone and whether the tail is meshed."""

    def __init__(self, law: ContactLaw, s: RigSettings, load: np.ndarray, guess: np.ndarray | None) -> None:
        self.law, self.s, self.load = law, s, load
        self.n_theta, self.n_axial = s.n_theta, s.n_axial
        self.guess = guess
        # the widest contact zone to mesh: the law's deepest tabulated gap, but never beyond where the root search
        # may go (a law tabulated deeper than the geometry allows would put the zone through the liner wall)
        deepest = max(float(law.h_min), search_limits(law, s)[0])
        self.h_wide = deepest if guess is None else float(np.min(guess))
        self.tail = True  # cells beyond the contact zone: dropped once a solution shows (tail_bound) they do not matter
        self.keep_tail = False  # set when levels without tail failed their check three times: no going back and forth
        self.refits = 0
        self.previous_area: np.ndarray | None = None

    def mesh(self, last: _Level | None) -> SkirtMesh:
        """The next level's mesh: fine cells over the widest contact zone, the tail where it matters."""
        s, h_edge = self.s, float(self.law.h_max)
        zone = contact_edge_angle_rad(h_edge, self.h_wide, s.liner_radius_m, s.clearance_m, s.exact_gap)
        y_zone = contact_half_length_m(h_edge, self.h_wide, s.skirt_length_m, s.crown_m) if s.crown_m > 0 else None
        if last is not None and not self.keep_tail:
            self.tail = tail_matters(self.law, s, zone, last.h0, self.load, last.area)
        r_p, length = s.piston_radius_m, s.skirt_length_m
        return variable_mesh(r_p, length, zone, self.n_theta, y_zone, self.n_axial, tail=self.tail)

    def refit(self, level: _Level) -> bool:
        """True (and the zone refitted, same cells) when a tail-less mesh's solution moved the contact past its edge.

        Meshes the tail from then on when that keeps happening (three times).
        """
        edge = float(level.loads.mesh.theta_edges_rad[-1])
        if self.tail or not tail_matters(self.law, self.s, edge, level.h0, self.load, level.area):
            return False
        self.refits += 1
        self.tail = self.keep_tail = self.refits > 2
        self.guess, self.h_wide = level.h0, float(level.h0.min())
        return True

    def area_converged(self, level: _Level) -> bool:
        """True when every weight's real area changed by at most ``mesh_tol`` since the previous level."""
        if self.previous_area is None:
            return False
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(level.area > 0, np.abs(level.area - self.previous_area) / level.area, 0.0)
        level.change = float(rel.max())
        return level.change <= self.s.mesh_tol

    def double(self, level: _Level) -> None:
        """Next level: twice the cells across the zone (and along a crowned skirt), fitted to this solution."""
        self.previous_area, self.guess = level.area, level.h0
        self.h_wide = float(level.h0.min())
        self.n_theta *= 2
        if self.s.crown_m > 0:
            self.n_axial *= 2


def _refine(law: ContactLaw, s: RigSettings, load: np.ndarray, guess: np.ndarray | None, name: str) -> _Level:
    """Solve on variable meshes of doubling cells until the areas converge (see the module docstring)."""
    state = _Refinement(law, s, load, guess)
    last: _Level | None = None
    while True:
        mesh = state.mesh(last)
        if last is not None and state.previous_area is not None and mesh.n_nodes > s.max_nodes:
            last.converged = False
            last.warnings.append(
                f"{name}: mesh not converged within max_nodes = {s.max_nodes} "
                f"(last relative area change {last.change:.2e} > mesh_tol = {s.mesh_tol:g})"
            )
            return last
        loads, h0, area, iterations = _solve_level(law, s, mesh, load, state.guess, name)
        level = _Level(loads, h0, area, loads.evaluations, loads.law_calls, iterations, 1)
        if last is not None:
            level.evaluations += last.evaluations
            level.law_calls += last.law_calls
            level.iterations += last.iterations
            level.levels += last.levels
            level.change = last.change
        last = level
        if state.refit(level):
            continue
        if state.area_converged(level):
            return level
        state.double(level)


# ---------------------------------------------------------------------------------------------------------------
# The solver.


def batch_equilibrium(
    law: ContactLaw,
    settings: RigSettings,
    weights_kg: Sequence[float] | np.ndarray,
    *,
    mesh: SkirtMesh | None = None,
    guess_m: Sequence[float] | np.ndarray | None = None,
    name: str = "law",
) -> BatchEquilibrium:
    """Static equilibria of all ``weights_kg`` [kg] (plus the piston's mass) on the contact law ``law``.

    ``mesh`` fixes the mesh; otherwise ``settings.mesh`` decides (uniform: ``n_theta × n_axial`` cells; variable:
    refined until converged, see the module docstring). ``guess_m`` [m] are starting minimum gaps, one per weight
    (e.g. a previous solution). Raises :class:`RigLoadError` when the law cannot carry a load.
    """
    s = settings
    weights = np.asarray(check_weights(weights_kg, "weights_kg"), dtype=float)
    load = (weights + s.piston_mass_kg) * STANDARD_GRAVITY
    active = ~((load == 0.0) & (s.clearance_m >= float(law.h_max)))
    guess = None if guess_m is None else np.broadcast_to(np.asarray(guess_m, dtype=float), load.shape)[active]
    if not active.any():
        empty = mesh if mesh is not None else _empty_mesh(s)
        level = _Level(SkirtLoads(law, s, empty), np.empty(0), np.empty(0), change=0.0)
    elif mesh is not None or s.mesh == "uniform":
        fixed = mesh if mesh is not None else uniform_mesh(s.piston_radius_m, s.skirt_length_m, s.n_theta, s.n_axial)
        level = _on_fixed_mesh(law, s, fixed, load[active], guess, name)
    else:
        level = _refine(law, s, load[active], guess, name)
    return _assemble(law, s, weights, load, active, level, name)


def _empty_mesh(s: RigSettings) -> SkirtMesh:
    if s.mesh == "uniform":
        return uniform_mesh(s.piston_radius_m, s.skirt_length_m, s.n_theta, s.n_axial)
    return variable_mesh(s.piston_radius_m, s.skirt_length_m, 0.0, s.n_theta)


def _assemble(
    law: ContactLaw,
    s: RigSettings,
    weights: np.ndarray,
    load: np.ndarray,
    active: np.ndarray,
    level: _Level,
    name: str,
) -> BatchEquilibrium:
    """Every weight's result from the active weights' final level: forces, peak pressures, widths, warnings."""
    n = weights.size
    loads, h = level.loads, level.h0
    calls_before = loads.law_calls
    h_all, area_all, raw_force, peak = np.full(n, s.clearance_m), np.zeros(n), np.zeros(n), np.zeros(n)
    if h.size:
        h_all[active], area_all[active] = h, level.area
        raw_force[active] = loads.forces_n(h)
        peak[active] = np.asarray(law.pressure(h), dtype=float)
        loads.law_calls += 1
    h_edge, r_l, c = float(law.h_max), s.liner_radius_m, s.clearance_m
    edge = [
        contact_edge_angle_rad(h_edge, float(h_all[i]), r_l, c, s.exact_gap) if active[i] else 0.0 for i in range(n)
    ]
    width = 2.0 * s.piston_radius_m * np.array(edge)
    in_range = h_all >= float(law.h_min)
    per_weight = tuple(
        (
            (
                f"{name}: weight {weights[i]:g} kg: minimum gap {h_all[i]:.4g} m is below the contact law's range "
                f"(h_min = {float(law.h_min):.4g} m): the law is extrapolated; extend the database's separation range",
            )
            if not in_range[i]
            else ()
        )
        for i in range(n)
    )
    status = np.where(active, "converged" if level.converged else "mesh budget reached", "no load")
    return BatchEquilibrium(
        weight_kg=weights,
        load_n=load,
        min_separation_m=h_all,
        # A rigid piston pressed down feels an upward force >= 0; a negative F can only be cancellation round-off of
        # a pre-loaded fit at zero load (equal pressure all round). residual_n keeps the raw F − W.
        contact_force_n=np.maximum(raw_force, 0.0),
        contact_area_m2=area_all,
        contact_width_m=width,
        peak_pressure_pa=peak,
        residual_n=raw_force - load,
        status=status,
        converged=np.full(n, level.converged),
        in_range=in_range,
        mesh=loads.mesh,
        loads=loads,
        evaluations=level.evaluations + (1 if h.size else 0),
        law_calls=level.law_calls + loads.law_calls - calls_before,
        iterations=level.iterations,
        mesh_levels=level.levels,
        mesh_change=level.change,
        warnings=tuple(level.warnings) + tuple(w for ws in per_weight for w in ws),
        weight_warnings=per_weight,
    )


def equilibrium(
    law: ContactLaw,
    settings: RigSettings,
    weight_kg: float,
    *,
    mesh: SkirtMesh | None = None,
    roughness_m: float | None = None,
    composite_modulus_pa: float | None = None,
    guess_m: float | None = None,
    name: str = "law",
) -> Equilibrium:
    """Static equilibrium of the piston under ``weight_kg`` [kg] (plus its own mass): :func:`batch_equilibrium` of
    one weight, its row.

    ``mesh`` fixes the mesh (else ``settings.mesh`` decides). ``roughness_m`` (combined RMS σ [m]) and
    ``composite_modulus_pa`` (E* [Pa], seed eq. 4) enable the roughness-parameter check. ``guess_m`` is a starting
    minimum gap [m] (e.g. the previous weight's).
    """
    weight_kg = check_weights([weight_kg], "weight_kg")[0]
    guess = None if guess_m is None else [guess_m]
    result = batch_equilibrium(law, settings, [weight_kg], mesh=mesh, guess_m=guess, name=name).at(0)
    if roughness_m is None or composite_modulus_pa is None:
        return result
    alpha = roughness_parameter(result.load_n, settings.skirt_length_m, roughness_m, composite_modulus_pa)
    if alpha >= ALPHA_WARN:
        return result
    from dataclasses import replace

    warning = (
        f"{name}: weight {weight_kg:g} kg: roughness parameter σ·R_eff/b² = {alpha:.3g} < {ALPHA_WARN:g}: "
        "bulk elastic deformation is no longer small against asperity deformation; the rigid-body model "
        "underestimates the contact width"
    )
    return replace(result, warnings=(*result.warnings, warning))
