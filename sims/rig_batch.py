"""Static equilibria of many weights at once on a shared skirt mesh (the fast path of :func:`sims.rig.sweep`).

Same model as :mod:`sims.rig_statics` — ``F(h0) = Σ p(h_i) ΔA_i cos θ_i = W`` per weight — but all weights of a
sweep are solved together, so each evaluation of the contact law covers every weight (one call on a
``weights × nodes`` array instead of one call per weight and iteration). The root solve is a safeguarded Newton
iteration with the law's analytic slope inside a bracket ``[lo, hi]`` kept for every weight (``g(lo) ≥ 0 ≥ g(hi)``):
a Newton step that leaves the bracket is replaced by bisection, so it cannot fail to converge.

The variable mesh is shared: its fine zone ends where the gap of the heaviest weight reaches the law's ``h_max``
(the widest contact), and it is refined (cells doubled) until every weight's real area changes by less than
``mesh_tol``; the skirt beyond the zone gets cells only when :func:`sims.rig_loads.tail_bound` cannot show it
negligible for every weight (as in :mod:`sims.rig_statics`). A uniform-mesh scene uses its fixed
``n_theta × n_axial`` mesh.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sims.rig_geometry import (
    axial_profile_m,
    contact_edge_angle_rad,
    contact_half_length_m,
    dgap_dh0,
    gap_m,
)
from sims.rig_law import ContactLaw
from sims.rig_loads import tail_matters
from sims.rig_mesh import SkirtMesh, uniform_mesh, variable_mesh
from sims.rig_settings import STANDARD_GRAVITY, RigSettings, check_weights
from sims.rig_statics import bracket_error, search_limits

__all__ = ["BatchEquilibrium", "batch_equilibrium"]


@dataclass(frozen=True)
class BatchEquilibrium:
    """Equilibria of ``weight_kg`` (in the given order) on one mesh; see :class:`sims.rig_statics.Equilibrium`.

    ``law_calls`` counts calls of the contact law (each covers all weights), ``iterations`` the Newton/bisection
    iterations summed over the mesh levels, ``residual_n`` is ``F(h0) − W`` per weight.
    """

    weight_kg: np.ndarray
    load_n: np.ndarray
    min_separation_m: np.ndarray
    contact_force_n: np.ndarray
    contact_area_m2: np.ndarray
    contact_width_m: np.ndarray
    peak_pressure_pa: np.ndarray
    residual_n: np.ndarray
    converged: np.ndarray
    in_range: np.ndarray
    mesh: SkirtMesh = field(repr=False)
    law_calls: int
    iterations: int
    mesh_levels: int
    mesh_change: float
    warnings: tuple[str, ...] = ()

    @property
    def n_nodes(self) -> int:
        """Nodes of the (shared) mesh."""
        return self.mesh.n_nodes


class _Batch:
    """Force and slope of several minimum gaps at once on one mesh."""

    def __init__(self, law: ContactLaw, s: RigSettings, mesh: SkirtMesh) -> None:
        self.law, self.s, self.mesh = law, s, mesh
        self.theta = mesh.theta_rad
        area = mesh.area_m2
        self.area = area
        self.cos_area = area * np.cos(self.theta)[:, None]
        self.profile = axial_profile_m(mesh.y_m, s.skirt_length_m, s.crown_m)[None, None, :]
        self.calls = 0

    def gap(self, h0: np.ndarray) -> np.ndarray:
        """Gap [m], shape ``(weights, n_theta, n_y)``, for minimum gaps ``h0`` [m]."""
        s = self.s
        g = gap_m(self.theta[None, :], h0[:, None], s.liner_radius_m, s.clearance_m, s.exact_gap)
        return g[:, :, None] + self.profile

    def force(self, h0: np.ndarray) -> np.ndarray:
        """Vertical contact force F(h0) = Σ p ΔA cos θ [N] per weight (seed eq. 22, P_c A_c)."""
        self.calls += 1
        h = self.gap(h0)
        p = np.asarray(self.law.pressure(h.ravel()), dtype=float).reshape(h.shape)
        return np.einsum("wty,ty->w", p, self.cos_area)

    def force_and_slope(self, h0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """F(h0) [N] and dF/dh0 [N/m] per weight, from the law's analytic slope."""
        self.calls += 2
        s = self.s
        h = self.gap(h0)
        flat = h.ravel()
        p = np.asarray(self.law.pressure(flat), dtype=float).reshape(h.shape)
        dp = np.asarray(self.law.dpressure_dh(flat), dtype=float).reshape(h.shape)
        dh = dgap_dh0(self.theta[None, :], h0[:, None], s.liner_radius_m, s.clearance_m, s.exact_gap)[:, :, None]
        return np.einsum("wty,ty->w", p, self.cos_area), np.einsum("wty,ty->w", dp * dh, self.cos_area)

    def area_m2(self, h0: np.ndarray) -> np.ndarray:
        """Real contact area Σ a ΔA [m²] per weight."""
        self.calls += 1
        h = self.gap(h0)
        a = np.asarray(self.law.area_fraction_at(h.ravel()), dtype=float).reshape(h.shape)
        return np.einsum("wty,ty->w", a, self.area)


def _solve(batch: _Batch, load: np.ndarray, guess: np.ndarray | None, name: str) -> tuple[np.ndarray, int]:
    """Minimum gaps with ``F(h0) = load`` (all > 0); returns the roots and the iteration count."""
    law, s = batch.law, batch.s
    lo_limit, hi_limit, span = search_limits(law, s)
    if guess is None:
        lo = np.full(load.shape, float(law.h_min))
        hi = np.full(load.shape, float(law.h_max))
        step = np.full(load.shape, 0.25 * span)
    else:
        step = np.full(load.shape, 1e-3 * span)
        lo, hi = guess - step, guess + step
    # Expand each bracket until g(lo) >= 0 >= g(hi).
    for side in ("lo", "hi"):
        x = lo if side == "lo" else hi
        width = step.copy()
        while True:
            g = batch.force(x) - load
            bad = g < 0 if side == "lo" else g > 0
            if not bad.any():
                break
            at_limit = bad & (x <= lo_limit if side == "lo" else x >= hi_limit)
            if at_limit.any():
                w = float(load[np.argmax(at_limit)])
                side_name = "below" if side == "lo" else "above"
                raise bracket_error(name, law, w, side_name, lo_limit if side == "lo" else hi_limit)
            width = np.where(bad, 4.0 * width, width)
            x = np.where(
                bad, np.clip(x - width, lo_limit, None) if side == "lo" else np.clip(x + width, None, hi_limit), x
            )
        if side == "lo":
            lo = x
        else:
            hi = x
    xtol = 1e-13 * span
    x = 0.5 * (lo + hi) if guess is None else np.clip(guess, lo, hi)
    for iteration in range(1, 201):
        f, df = batch.force_and_slope(x)
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
    return x, 200


def batch_equilibrium(
    law: ContactLaw,
    settings: RigSettings,
    weights_kg: np.ndarray | list[float] | tuple[float, ...],
    *,
    name: str = "law",
) -> BatchEquilibrium:
    """Static equilibria of all ``weights_kg`` on ``law`` (see the module docstring)."""
    s = settings
    weights = np.asarray(check_weights(weights_kg, "weights_kg"), dtype=float)
    load = (weights + s.piston_mass_kg) * STANDARD_GRAVITY
    h_edge = float(law.h_max)
    no_load = (load == 0.0) & (s.clearance_m >= h_edge)
    active = ~no_load
    loads_active = load[active]
    n_theta, n_axial = s.n_theta, s.n_axial
    crowned = s.crown_m > 0
    calls = iterations = levels = 0
    change = math.nan
    guess: np.ndarray | None = None
    previous_area: np.ndarray | None = None
    result_mesh: SkirtMesh | None = None
    h = np.empty(0)
    area = np.empty(0)
    warnings: list[str] = []
    converged = True
    tail = True  # cells beyond the contact zone: dropped once a solution shows (tail_bound) they do not matter
    keep_tail = False  # set when levels without tail failed their check three times: no going back and forth
    refits = 0
    h_wide = float(law.h_min)
    while True:
        if s.mesh == "uniform":
            mesh = uniform_mesh(s.piston_radius_m, s.skirt_length_m, s.n_theta, s.n_axial)
        else:
            zone = contact_edge_angle_rad(h_edge, h_wide, s.liner_radius_m, s.clearance_m, s.exact_gap)
            y_zone = contact_half_length_m(h_edge, h_wide, s.skirt_length_m, s.crown_m) if crowned else None
            if levels and not keep_tail:
                tail = tail_matters(law, s, zone, h, loads_active, area)
            mesh = variable_mesh(s.piston_radius_m, s.skirt_length_m, zone, n_theta, y_zone, n_axial, tail=tail)
            if previous_area is not None and mesh.n_nodes > s.max_nodes:
                converged = False
                warnings.append(
                    f"{name}: mesh not converged within max_nodes = {s.max_nodes} "
                    f"(last relative area change {change:.2e} > mesh_tol = {s.mesh_tol:g})"
                )
                break
        batch = _Batch(law, s, mesh)
        if loads_active.size:
            h, its = _solve(batch, loads_active, guess, name)
            area = batch.area_m2(h)
        else:
            h, its, area = np.empty(0), 0, np.empty(0)
        calls += batch.calls
        iterations += its
        levels += 1
        result_mesh = mesh
        result = (h, area, batch)
        if s.mesh == "uniform" or not loads_active.size:
            break
        if not tail and tail_matters(law, s, float(mesh.theta_edges_rad[-1]), h, loads_active, area):
            # The solution moved the contact edge past the zone's: refit the zone, same level (mesh the tail if
            # that keeps happening).
            refits += 1
            tail = keep_tail = refits > 2
            guess, h_wide = h, float(h.min())
            continue
        if previous_area is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                rel = np.where(area > 0, np.abs(area - previous_area) / area, 0.0)
            change = float(rel.max())
            if change <= s.mesh_tol:
                break
        previous_area, guess = area, h
        h_wide = float(h.min())
        n_theta *= 2
        if crowned:
            n_axial *= 2
    h, area, batch = result
    assert result_mesh is not None
    force = batch.force(h) if h.size else np.empty(0)
    calls += 1 if h.size else 0
    n = weights.size
    h_all = np.full(n, s.clearance_m)
    area_all = np.zeros(n)
    force_all = np.zeros(n)
    # A rigid piston pressed down feels an upward force >= 0; a negative F can only be cancellation round-off of a
    # pre-loaded fit at zero load (equal pressure all round). residual_n keeps the raw F − W.
    h_all[active], area_all[active], force_all[active] = h, area, np.maximum(force, 0.0)
    peak = np.zeros(n)
    if h.size:
        peak[active] = np.asarray(law.pressure(h), dtype=float)
        calls += 1
    width = np.array(
        [
            0.0
            if no_load[i]
            else 2.0
            * s.piston_radius_m
            * contact_edge_angle_rad(h_edge, float(h_all[i]), s.liner_radius_m, s.clearance_m, s.exact_gap)
            for i in range(n)
        ]
    )
    raw_force = np.zeros(n)
    raw_force[active] = force
    in_range = h_all >= float(law.h_min)
    for i in np.flatnonzero(~in_range):
        warnings.append(
            f"{name}: weight {weights[i]:g} kg: minimum gap {h_all[i]:.4g} m is below the contact law's range "
            f"(h_min = {float(law.h_min):.4g} m): the law is extrapolated; extend the database's separation range"
        )
    return BatchEquilibrium(
        weight_kg=weights,
        load_n=load,
        min_separation_m=h_all,
        contact_force_n=force_all,
        contact_area_m2=area_all,
        contact_width_m=width,
        peak_pressure_pa=peak,
        residual_n=raw_force - load,
        converged=np.full(n, converged),
        in_range=in_range,
        mesh=result_mesh,
        law_calls=calls,
        iterations=iterations,
        mesh_levels=levels,
        mesh_change=change,
        warnings=tuple(warnings),
    )
