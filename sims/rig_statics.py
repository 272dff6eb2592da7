"""Static equilibrium of the piston resting in its liner: the minimum gap at which the contact carries the weight.

Solves ``F(h0) = W`` (seed section 2.1 at rest, eq. 22 with v = 0) for the minimum gap ``h0``, with
``F(h0) = Σ p(h_i) ΔA_i cos θ_i`` on the skirt mesh (:mod:`sims.rig_loads`) and ``W = (weight + piston mass)·g``.
``F`` is strictly decreasing in ``h0``, so the root is bracketed (expanding steps from a guess) and found by
Brent's method (:func:`scipy.optimize.brentq`), which cannot fail to converge on a bracket.

With ``mesh = "variable"`` the mesh is fitted to the contact zone of the previous solution and the number of cells
doubled until the real area changes by less than ``mesh_tol`` (midpoint cells: exponentially convergent on the
smooth Greenwood–Tripp integrand, second order at worst, so the remaining error is at most about a third of the
last change) or the node budget ``max_nodes`` is reached (then a warning). The skirt beyond the contact zone gets
cells only when :func:`sims.rig_loads.tail_bound` cannot show that it carries less than ``TAIL_SHARE·mesh_tol`` of
the load and of the area (an asperity law is exactly zero there; Greenwood–Tripp's tail beyond 6σ is ~1e-8).

Zero load with the clearance larger than the law's contact range (``c ≥ h_max``): no contact; the piston is
reported centred (``h0 = c``, the limit of the loaded solutions as the load goes to zero), with zero area and
force.

Assumptions are checked and reported in ``warnings``: a minimum gap below the law's tabulated range (extrapolated)
and, when roughness and modulus are given, the roughness parameter ``α = σ R_eff / b²``
(:func:`roughness_parameter`) below :data:`ALPHA_WARN`: bulk elastic deformation is then no longer small against
asperity deformation and the rigid-body model (the paper's) loses accuracy.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

from sims.rig_geometry import contact_edge_angle_rad, contact_half_length_m
from sims.rig_law import ContactLaw
from sims.rig_loads import TAIL_SHARE, SkirtLoads, tail_matters
from sims.rig_mesh import SkirtMesh, uniform_mesh, variable_mesh
from sims.rig_settings import RigSettings

__all__ = [
    "ALPHA_WARN",
    "TAIL_SHARE",
    "Equilibrium",
    "RigLoadError",
    "equilibrium",
    "preload_note",
    "roughness_parameter",
    "solve_on_mesh",
]

#: Warn when the roughness parameter σ R_eff / b² falls below this (bulk elastic deformation no longer small).
ALPHA_WARN = 5.0


class RigLoadError(ValueError):
    """The contact law cannot carry the load within its (extended) range, or the input is outside the model."""


@dataclass(frozen=True)
class Equilibrium:
    """Static equilibrium of the piston for one weight; arrays are on ``mesh`` (a quarter of the skirt).

    ``contact_width_m`` is the arc length (at the skirt's middle) over which the gap is below the law's ``h_max``,
    i.e. inside its contact range. ``residual_n = F(h0) − W``. ``status`` is ``"converged"``, ``"no load"`` or
    ``"mesh budget reached"``; ``converged`` is True unless the mesh budget stopped the refinement.
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


@dataclass(frozen=True)
class _Root:
    h0: float
    iterations: int
    evaluations: int


def roughness_parameter(load_n: float, skirt_length_m: float, roughness_m: float, composite_modulus_pa: float) -> float:
    """Johnson's roughness parameter of the line contact, ``α = σ R_eff / b²`` [-].

    With Johnson's smooth half-width ``b = √(4 P′ R_eff / (π E*))``, ``P′ = W/L``, this is ``π σ E* / (4 P′)``:
    independent of ``R_eff``, finite at zero clearance, infinite at zero load.
    """
    p_line = load_n / skirt_length_m
    if p_line <= 0:
        return math.inf
    return math.pi * roughness_m * composite_modulus_pa / (4.0 * p_line)


def _bracket(g: Callable[[float], float], x0: float, step: float, lo: float, hi: float) -> tuple[float, float]:
    """``a ≤ b`` with ``g(a) ≥ 0 ≥ g(b)`` for a decreasing ``g``, expanding by ×4 from ``x0``; ``None`` side fails."""
    g0 = g(x0)
    if g0 == 0.0:
        return x0, x0
    if g0 > 0:
        a = x0
        while a < hi:
            b = min(a + step, hi)
            if g(b) <= 0:
                return a, b
            a, step = b, 4 * step
        raise _NoBracket("above")
    b = x0
    while b > lo:
        a = max(b - step, lo)
        if g(a) >= 0:
            return a, b
        b, step = a, 4 * step
    raise _NoBracket("below")


class _NoBracket(Exception):
    pass


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


def _solve(loads: SkirtLoads, load_n: float, guess: float, step: float, name: str) -> _Root:
    law, s = loads.law, loads.settings
    lo, hi, span = search_limits(law, s)
    before = loads.evaluations

    def g(h0: float) -> float:
        return loads.force_n(h0) - load_n

    try:
        a, b = _bracket(g, min(max(guess, lo), hi), step, lo, hi)
    except _NoBracket as exc:
        side = str(exc)
        raise bracket_error(name, law, load_n, side, lo if side == "below" else hi) from None
    if a == b:
        return _Root(a, 0, loads.evaluations - before)
    h0, info = brentq(g, a, b, xtol=1e-10 * span, rtol=4 * np.finfo(float).eps, maxiter=200, full_output=True)
    return _Root(float(h0), int(info.iterations), loads.evaluations - before)


def solve_on_mesh(
    law: ContactLaw,
    settings: RigSettings,
    mesh: SkirtMesh,
    weight_kg: float,
    *,
    guess_m: float | None = None,
    name: str = "law",
) -> Equilibrium:
    """Equilibrium on a given, fixed ``mesh`` (no refinement): what the uniform-mesh baseline and the dynamics use."""
    loads = SkirtLoads(law, settings, mesh)
    load_n = settings.load_n(weight_kg)
    if load_n == 0.0 and settings.clearance_m >= law.h_max:
        return _no_load(law, settings, mesh, weight_kg)
    span = float(law.h_max) - float(law.h_min)
    guess = float(law.h_min) if guess_m is None else guess_m
    root = _solve(loads, load_n, guess, 0.05 * span if guess_m is None else 1e-3 * span, name)
    return _result(loads, weight_kg, load_n, root, root.evaluations, root.iterations, 1, math.nan, True, name)


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
    """Static equilibrium of the piston under ``weight_kg`` (plus its own mass) on the contact law ``law``.

    ``mesh`` fixes the mesh; otherwise ``settings.mesh`` decides (uniform: ``n_theta × n_axial`` cells; variable:
    refined until converged). ``roughness_m`` (combined RMS σ) and ``composite_modulus_pa`` (E*, seed eq. 4) enable
    the roughness-parameter check. ``guess_m`` is a starting minimum gap (e.g. the previous weight's).
    """
    from sims.rig_settings import check_weights

    weight_kg = check_weights([weight_kg], "weight_kg")[0]
    s = settings
    if mesh is not None:
        result = solve_on_mesh(law, s, mesh, weight_kg, guess_m=guess_m, name=name)
    elif s.mesh == "uniform":
        mesh = uniform_mesh(s.piston_radius_m, s.skirt_length_m, s.n_theta, s.n_axial)
        result = solve_on_mesh(law, s, mesh, weight_kg, guess_m=guess_m, name=name)
    else:
        result = _refine(law, s, weight_kg, guess_m, name)
    extra = []
    if roughness_m is not None and composite_modulus_pa is not None:
        alpha = roughness_parameter(result.load_n, s.skirt_length_m, roughness_m, composite_modulus_pa)
        if alpha < ALPHA_WARN:
            extra.append(
                f"{name}: weight {weight_kg:g} kg: roughness parameter σ·R_eff/b² = {alpha:.3g} < {ALPHA_WARN:g}: "
                "bulk elastic deformation is no longer small against asperity deformation; the rigid-body model "
                "underestimates the contact width"
            )
    if extra:
        result = _replace_warnings(result, result.warnings + tuple(extra))
    return result


def _refine(law: ContactLaw, s: RigSettings, weight_kg: float, guess_m: float | None, name: str) -> Equilibrium:
    load_n = s.load_n(weight_kg)
    h_edge = float(law.h_max)
    span = h_edge - float(law.h_min)
    if load_n == 0.0 and s.clearance_m >= h_edge:
        mesh = variable_mesh(s.piston_radius_m, s.skirt_length_m, 0.0, s.n_theta)
        return _no_load(law, s, mesh, weight_kg)
    h = float(law.h_min) if guess_m is None else guess_m
    step = 0.05 * span if guess_m is None else 1e-3 * span
    n_theta, n_axial = s.n_theta, s.n_axial
    crowned = s.crown_m > 0
    tail = True  # cells beyond the contact zone: dropped once a solution shows (tail_bound) they do not matter
    keep_tail = False  # set when levels without tail failed their check three times: no going back and forth
    refits = 0
    evaluations = iterations = levels = 0
    previous: tuple[SkirtLoads, _Root, float] | None = None
    change = area = math.nan
    while True:
        # The fine zone ends where the gap reaches the law's h_max: for the asperity models that is the contact onset,
        # a kink in p and a; putting a cell edge on it keeps the midpoint cells second order.
        theta_zone = contact_edge_angle_rad(h_edge, h, s.liner_radius_m, s.clearance_m, s.exact_gap)
        y_zone = contact_half_length_m(h_edge, h, s.skirt_length_m, s.crown_m) if crowned else None
        if levels and not keep_tail:
            tail = tail_matters(law, s, theta_zone, h, load_n, area)
        mesh = variable_mesh(s.piston_radius_m, s.skirt_length_m, theta_zone, n_theta, y_zone, n_axial, tail=tail)
        if previous is not None and mesh.n_nodes > s.max_nodes:
            warning = (
                f"{name}: weight {weight_kg:g} kg: mesh not converged within max_nodes = {s.max_nodes} "
                f"(last relative area change {change:.2e} > mesh_tol = {s.mesh_tol:g})"
            )
            loads, root, _ = previous
            eq = _result(loads, weight_kg, load_n, root, evaluations, iterations, levels, change, False, name)
            return _replace(eq, evaluations, iterations, levels, change, False, "mesh budget reached", warning)
        loads = SkirtLoads(law, s, mesh)
        root = _solve(loads, load_n, h, step, name)
        evaluations += root.evaluations
        iterations += root.iterations
        levels += 1
        area = loads.area_m2(root.h0)
        if not tail and tail_matters(law, s, float(mesh.theta_edges_rad[-1]), root.h0, load_n, area):
            # The solution moved the contact edge past the zone's: refit the zone, same level (mesh the tail if
            # that keeps happening).
            refits += 1
            tail = keep_tail = refits > 2
            h, step = root.h0, 1e-3 * span
            continue
        if previous is not None:
            change = abs(area - previous[2]) / area if area > 0 else 0.0
            if change <= s.mesh_tol:
                return _result(loads, weight_kg, load_n, root, evaluations, iterations, levels, change, True, name)
        previous, h, step = (loads, root, area), root.h0, 1e-3 * span
        n_theta *= 2
        if crowned:
            n_axial *= 2


def _result(
    loads: SkirtLoads,
    weight_kg: float,
    load_n: float,
    root: _Root,
    evaluations: int,
    iterations: int,
    levels: int,
    change: float,
    converged: bool,
    name: str = "law",
) -> Equilibrium:
    law, s, mesh = loads.law, loads.settings, loads.mesh
    h0 = root.h0
    force, slope = loads.force_and_slope(h0)
    pressure = loads.pressure_pa(h0)
    fraction = loads.area_fraction(h0)
    area = float(np.sum(fraction * mesh.area_m2))
    width = (
        2.0
        * s.piston_radius_m
        * contact_edge_angle_rad(float(law.h_max), h0, s.liner_radius_m, s.clearance_m, s.exact_gap)
    )
    peak = float(np.asarray(law.pressure(np.array([h0])), dtype=float)[0])
    in_range = h0 >= float(law.h_min)
    warnings: tuple[str, ...] = ()
    if not in_range:
        warnings = (
            f"{name}: weight {weight_kg:g} kg: minimum gap {h0:.4g} m is below the contact law's range "
            f"(h_min = {float(law.h_min):.4g} m): the law is extrapolated; extend the database's separation range",
        )
    return Equilibrium(
        weight_kg=weight_kg,
        load_n=load_n,
        min_separation_m=h0,
        contact_force_n=force,
        contact_area_m2=area,
        contact_width_m=width,
        peak_pressure_pa=peak,
        stiffness_n_per_m=-slope,
        mesh=mesh,
        pressure_pa=pressure,
        area_fraction=fraction,
        evaluations=evaluations,
        iterations=iterations,
        residual_n=force - load_n,
        status="converged",
        converged=converged,
        mesh_levels=levels,
        mesh_change=change,
        in_range=in_range,
        warnings=warnings,
    )


def _no_load(law: ContactLaw, s: RigSettings, mesh: SkirtMesh, weight_kg: float) -> Equilibrium:
    zeros = np.zeros(mesh.shape)
    return Equilibrium(
        weight_kg=weight_kg,
        load_n=0.0,
        min_separation_m=s.clearance_m,
        contact_force_n=0.0,
        contact_area_m2=0.0,
        contact_width_m=0.0,
        peak_pressure_pa=0.0,
        stiffness_n_per_m=0.0,
        mesh=mesh,
        pressure_pa=zeros,
        area_fraction=zeros,
        evaluations=0,
        iterations=0,
        residual_n=0.0,
        status="no load",
        converged=True,
        mesh_levels=0,
        mesh_change=0.0,
        in_range=True,
    )


def _replace(
    eq: Equilibrium,
    evaluations: int,
    iterations: int,
    levels: int,
    change: float,
    converged: bool,
    status: str,
    warning: str | None,
) -> Equilibrium:
    from dataclasses import replace

    warnings = eq.warnings + ((warning,) if warning else ())
    return replace(
        eq,
        evaluations=evaluations,
        iterations=iterations,
        mesh_levels=levels,
        mesh_change=change,
        converged=converged,
        status=status,
        warnings=warnings,
    )


def _replace_warnings(eq: Equilibrium, warnings: tuple[str, ...]) -> Equilibrium:
    from dataclasses import replace

    return replace(eq, warnings=warnings)
