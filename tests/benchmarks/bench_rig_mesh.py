"""Contact-area error against mesh size: uniform vs variable skirt meshes, per contact model (issue 4).

Reference: the equilibrium solved with adaptive quadrature (scipy.integrate.quad) of the exact-gap integrals
F(h0) = 2 R_p L ∫ p(h(θ)) cos θ dθ and A = 2 R_p L ∫ a(h(θ)) dθ on the same database curve, with the kink where
the gap reaches the curve's contact onset given to quad — independent of the mesh code. Straight skirt, so both
meshes use one axial cell (the uniform default's n_axial = 8 would cost 8× more nodes for the same answer).

Goal: the variable mesh reaches 1e-3 relative area error with at least 10× fewer nodes than the uniform one.

Run:  /tmp/venv/bin/python tests/benchmarks/bench_rig_mesh.py [--weights 5.44,25.966]
"""

from __future__ import annotations

import argparse
import math
import time

from scipy.integrate import quad
from scipy.optimize import brentq

from sims.database import build_database
from sims.rig_geometry import contact_edge_angle_rad, contact_half_angle_rad, gap_m
from sims.rig_mesh import uniform_mesh, variable_mesh
from sims.rig_settings import RigSettings
from sims.rig_statics import equilibrium, solve_on_mesh
from sims.scene import load_scene

GOAL = 1e-3


def reference(curve, s: RigSettings, weight_kg: float) -> tuple[float, float]:
    R_l, c, L, R_p = s.liner_radius_m, s.clearance_m, s.skirt_length_m, s.piston_radius_m
    W = s.load_n(weight_kg)

    def edge(h0: float) -> list[float]:
        t = contact_half_angle_rad(curve.h_max, h0, c)
        return [t] if 0 < t < math.pi else []

    def gap(t: float, h0: float) -> float:
        return float(gap_m(t, h0, R_l, c, True))

    def force(h0: float) -> float:
        f = quad(lambda t: float(curve.pressure(gap(t, h0))) * math.cos(t), 0, math.pi, points=edge(h0), limit=400)
        return 2 * R_p * L * f[0]

    h0 = brentq(lambda h: force(h) - W, curve.h_min, curve.h_max, xtol=1e-18, rtol=1e-14)
    area = quad(lambda t: float(curve.area_fraction_at(gap(t, h0))), 0, math.pi, points=edge(h0), limit=400)[0]
    return h0, 2 * R_p * L * area


def nodes_to_goal(rows: list[tuple[int, float]]) -> int | None:
    """Fewest nodes from which the error stays below GOAL for every larger mesh tried."""
    best = None
    for nodes, err in sorted(rows, reverse=True):
        if err >= GOAL:
            break
        best = nodes
    return best


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--weights", default="5.44,25.966")
    ap.add_argument("--models", default="greenwood_tripp,hertz,pasaribu_schipper")
    args = ap.parse_args()
    scene = load_scene()
    s = RigSettings.from_scene(scene)
    t0 = time.perf_counter()
    db = build_database(scene, models=args.models.split(","))
    print(f"database build: {time.perf_counter() - t0:.3f} s (excluded below)")
    for name in db:
        curve = db[name]
        for w in (float(x) for x in args.weights.split(",")):
            h_ref, a_ref = reference(curve, s, w)
            print(f"\n{name}, {w:g} kg: reference h0 = {h_ref:.6e} m, A = {a_ref:.6e} m² (quad)")
            print(f"  {'mesh':9s} {'n_theta':>8s} {'nodes':>7s} {'rel. area error':>16s} {'time ms':>9s}")
            results = {}
            for kind in ("uniform", "variable"):
                rows = []
                sizes = [2**k for k in range(3, 17)] if kind == "uniform" else [2**k for k in range(1, 10)]
                for n in sizes:
                    if kind == "uniform":
                        mesh = uniform_mesh(s.piston_radius_m, s.skirt_length_m, n, 1)
                    else:
                        zone = contact_edge_angle_rad(curve.h_max, h_ref, s.liner_radius_m, s.clearance_m)
                        mesh = variable_mesh(s.piston_radius_m, s.skirt_length_m, zone, n)
                    t = time.perf_counter()
                    eq = solve_on_mesh(curve, s, mesh, w, guess_m=h_ref)
                    dt = time.perf_counter() - t
                    err = abs(eq.contact_area_m2 - a_ref) / a_ref
                    rows.append((mesh.n_nodes, err))
                    print(f"  {kind:9s} {n:8d} {mesh.n_nodes:7d} {err:16.3e} {dt * 1e3:9.2f}")
                results[kind] = nodes_to_goal(rows)
            t = time.perf_counter()
            adaptive = equilibrium(curve, s, w)
            dt = time.perf_counter() - t
            err = abs(adaptive.contact_area_m2 - a_ref) / a_ref
            print(
                f"  adaptive variable (mesh_tol = {s.mesh_tol:g}, n_theta = {s.n_theta}): {adaptive.n_nodes} nodes, "
                f"{adaptive.mesh_levels} levels, {adaptive.evaluations} force evaluations, error {err:.3e}, "
                f"{dt * 1e3:.2f} ms"
            )
            u, v = results["uniform"], results["variable"]
            ratio = f"{u / v:.1f}×" if u and v else "n/a"
            print(f"  nodes to reach {GOAL:g}: uniform {u}, variable {v}  → ratio {ratio} (goal ≥ 10×)")


if __name__ == "__main__":
    main()
