"""Contact-area error against mesh size: uniform vs variable skirt meshes, per contact model (issue 4).

Reference: the equilibrium solved with adaptive quadrature (scipy.integrate.quad) of the exact-gap integrals
F(h0) = 2 R_p L ∫ p(h(θ)) cos θ dθ and A = 2 R_p L ∫ a(h(θ)) dθ on the same database curve, the gap written here
from the geometry (offset circle in a circle) and the kink where it reaches the curve's h_max found here by Brent's
method and given to quad — no code shared with the rig's mesh or geometry.

Rules compared, each solving its own equilibrium F(h0) = W and reporting the real area's error:

- ``uniform``: n equal cells on θ ∈ [0, π] (``sims.rig.mesh.uniform_mesh``), every n from 2 to 1024;
- ``variable``: n equal cells on the contact zone [0, θ_z] (θ_z where the gap at the reference h0 reaches h_max),
  plus the graded tail cells to π only when ``sims.rig.loads.tail_bound`` says the tail matters — the rule the
  adaptive scheme uses on its last level (``sims.rig.mesh.variable_mesh``), every n from 1 to 64;
- ``gauss``: n Gauss–Legendre nodes on [0, θ_z] (the positive half of the symmetric 2n-point rule on [−θ_z, θ_z],
  which uses the integrand's evenness), implemented here, no tail — the higher-order alternative, for comparison.

Fair axial treatment: the skirt is straight, so the integrand does not vary along y and every rule uses ONE axial
cell (the uniform default's n_axial = 8 would multiply its node count by 8 for the same answer). "Nodes to 1e-3"
is the fewest nodes from which the error stays below 1e-3 for every larger n tried (errors of the uniform mesh jump
about while its few cells in the contact zone move).

Goal: the variable mesh reaches 1e-3 relative area error with at least 10× fewer nodes than the uniform one.

Run:  /tmp/venv/bin/python tests/benchmarks/bench_rig_mesh.py [--weights 5.44,25.966] [--models ...] [--verbose]
"""

from __future__ import annotations

import argparse
import math
import time
import warnings

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq

from contactrig.core.scene import load_scene
from sims.config import SimConfig
from sims.database import build_database
from sims.rig.equilibrium import equilibrium
from sims.rig.loads import tail_bound, tail_matters
from sims.rig.mesh import uniform_mesh, variable_mesh
from sims.rig.settings import RigSettings

GOAL = 1e-3
# quad on tabulated, kinked curves reports round-off near its tolerance; the reference is still ~1e-10 (also when
# imported by bench_rig_sweep.py)
warnings.filterwarnings("ignore", "The occurrence of roundoff error")


def exact_gap(theta, h0: float, r_l: float, c: float):
    """Offset circle in a circle: liner radius r_l, piston radius r_l − c, centre e = c − h0 below the liner's."""
    e, r_p = c - h0, r_l - c
    return r_l - e * np.cos(theta) - np.sqrt(r_p * r_p - (e * np.sin(theta)) ** 2)


def edge_angle(curve, h0: float, r_l: float, c: float) -> float:
    """Angle where the gap reaches the curve's h_max (0 or π outside), by Brent's method on the gap above."""
    f = lambda t: float(exact_gap(t, h0, r_l, c)) - curve.h_max  # noqa: E731
    if f(0.0) >= 0:
        return 0.0
    if f(math.pi) <= 0:
        return math.pi
    return brentq(f, 0.0, math.pi, xtol=1e-15)


def reference(curve, s: RigSettings, weight_kg: float) -> tuple[float, float]:
    R_l, c, L, R_p = s.liner_radius_m, s.clearance_m, s.skirt_length_m, s.piston_radius_m
    W = s.load_n(weight_kg)

    def edge(h0: float) -> list[float]:
        t = edge_angle(curve, h0, R_l, c)
        return [t] if 0 < t < math.pi else []

    def force(h0: float) -> float:
        def f(t: float) -> float:
            return float(curve.pressure(exact_gap(t, h0, R_l, c))) * math.cos(t)

        return 2 * R_p * L * quad(f, 0, math.pi, points=edge(h0), limit=400, epsabs=0, epsrel=1e-10)[0]

    h0 = brentq(lambda h: force(h) - W, curve.h_min, curve.h_max, xtol=1e-18, rtol=1e-14)
    a = quad(
        lambda t: float(curve.area_fraction_at(exact_gap(t, h0, R_l, c))),
        0,
        math.pi,
        points=edge(h0),
        limit=400,
        epsabs=0,
        epsrel=1e-10,
    )[0]
    return h0, 2 * R_p * L * a


def gauss_area(curve, s: RigSettings, weight_kg: float, theta_zone: float, n: int) -> float:
    """Equilibrium area with n Gauss–Legendre nodes on [0, θ_z] (symmetric 2n-point rule, positive half)."""
    x, w = np.polynomial.legendre.leggauss(2 * n)
    theta, weight = theta_zone * x[n:], theta_zone * w[n:]
    R_l, c, L, R_p = s.liner_radius_m, s.clearance_m, s.skirt_length_m, s.piston_radius_m
    W = s.load_n(weight_kg)

    def force(h0: float) -> float:
        return 2 * R_p * L * float(np.sum(curve.pressure(exact_gap(theta, h0, R_l, c)) * np.cos(theta) * weight))

    lo, hi = curve.h_min - 2 * (curve.h_max - curve.h_min), curve.h_max
    if force(lo) < W or force(hi) > W:
        return math.nan
    h0 = brentq(lambda h: force(h) - W, lo, hi, xtol=1e-18, rtol=1e-14)
    return 2 * R_p * L * float(np.sum(curve.area_fraction_at(exact_gap(theta, h0, R_l, c)) * weight))


def nodes_to_goal(rows: list[tuple[int, float]]) -> int | None:
    """Fewest nodes from which the error stays below GOAL for every larger mesh tried."""
    best = None
    for nodes, err in sorted(rows, reverse=True):
        if not err < GOAL:
            break
        best = nodes
    return best


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--weights", default="5.44,25.966")
    ap.add_argument("--models", default="greenwood_tripp,hertz,pasaribu_schipper")
    ap.add_argument("--verbose", action="store_true", help="print every mesh size")
    args = ap.parse_args()
    config = SimConfig.from_scene(load_scene())
    s = config.rig
    t0 = time.perf_counter()
    db = build_database(config, models=args.models.split(","))
    print(f"database build: {time.perf_counter() - t0:.3f} s (excluded below)")
    print("one axial cell for every rule (straight skirt); nodes = θ nodes")
    summary = []
    for name in db:
        curve = db[name]
        for w in (float(x) for x in args.weights.split(",")):
            h_ref, a_ref = reference(curve, s, w)
            zone = edge_angle(curve, h_ref, s.liner_radius_m, s.clearance_m)
            force_out, area_out = tail_bound(curve, s, zone, h_ref)
            tail = tail_matters(curve, s, zone, h_ref, s.load_n(w), a_ref)
            print(
                f"\n{name}, {w:g} kg: reference h0 = {h_ref:.6e} m, A = {a_ref:.6e} m² (quad); contact zone "
                f"θ_z = {zone:.4f} rad; tail bound: force {force_out[0]:.2e} N, area {area_out[0] / a_ref:.1e}·A "
                f"→ variable mesh {'with' if tail else 'without'} tail cells"
            )
            rows: dict[str, list[tuple[int, float]]] = {"uniform": [], "variable": [], "gauss": []}
            for n in range(2, 1025):
                mesh = uniform_mesh(s.piston_radius_m, s.skirt_length_m, n, 1)
                eq = equilibrium(curve, s, w, mesh=mesh, guess_m=h_ref)
                rows["uniform"].append((mesh.n_nodes, abs(eq.contact_area_m2 - a_ref) / a_ref))
            for n in range(1, 65):
                mesh = variable_mesh(s.piston_radius_m, s.skirt_length_m, zone, n, tail=tail)
                eq = equilibrium(curve, s, w, mesh=mesh, guess_m=h_ref)
                rows["variable"].append((mesh.n_nodes, abs(eq.contact_area_m2 - a_ref) / a_ref))
                rows["gauss"].append((n, abs(gauss_area(curve, s, w, zone, n) - a_ref) / a_ref))
            for kind, r in rows.items():
                shown = (
                    r if args.verbose else [x for x in r if x[0] in (1, 2, 3, 4, 6, 8, 12, 16, 32, 64, 128, 256, 512)]
                )
                print(f"  {kind:9s} " + "  ".join(f"{n}:{e:.1e}" for n, e in shown))
            t = time.perf_counter()
            adaptive = equilibrium(curve, s, w)
            dt = time.perf_counter() - t
            err = abs(adaptive.contact_area_m2 - a_ref) / a_ref
            print(
                f"  adaptive variable (mesh_tol = {s.mesh_tol:g}, n_theta = {s.n_theta}): {adaptive.n_nodes} nodes, "
                f"{adaptive.mesh_levels} levels, {adaptive.evaluations} force evaluations, error {err:.3e}, "
                f"{dt * 1e3:.2f} ms"
            )
            u, v, g = (nodes_to_goal(rows[k]) for k in ("uniform", "variable", "gauss"))
            ratio = f"{u / v:.1f}×" if u and v else "n/a"
            ratio_g = f"{u / g:.1f}×" if u and g else "n/a"
            print(f"  nodes to reach {GOAL:g}: uniform {u}, variable {v} → {ratio} (goal ≥ 10×); gauss {g} → {ratio_g}")
            summary.append((name, w, u, v, g, ratio, ratio_g))
    print(
        f"\n{'model':18s} {'kg':>7s} {'uniform':>8s} {'variable':>9s} {'gauss':>6s} {'ratio':>7s} {'gauss ratio':>12s}"
    )
    for name, w, u, v, g, ratio, ratio_g in summary:
        print(f"{name:18s} {w:7g} {u!s:>8s} {v!s:>9s} {g!s:>6s} {ratio:>7s} {ratio_g:>12s}")


if __name__ == "__main__":
    main()
