"""Damped release-to-rest (seed eq. 22): explicit RK45 against implicit Radau, BDF, LSODA, stiff and non-stiff.

The piston under the heaviest Tab. 1 weight (25.966 kg) is released just touching the liner and integrated to rest
on the Greenwood–Tripp database curve of the default scene (mesh: the converged static solution's). For each
damping B — light (not stiff) and heavy (stiff, stiffness ratio ≈ 4ζ²) — and each method: the error of the rest
state against the static equilibrium (minimum gap and real area), function and Jacobian evaluations, LU
decompositions and wall time. The implicit methods get the analytic Jacobian from the law's slope.

Run:  /tmp/venv/bin/python tests/benchmarks/bench_rig_dynamics.py [--model greenwood_tripp] [--dampings 2e4,1e7]
"""

from __future__ import annotations

import argparse
import time

from sims.database import build_database
from sims.rig_dynamics import settle
from sims.rig_settings import RigSettings
from sims.rig_statics import equilibrium
from sims.scene import load_scene


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", default="greenwood_tripp")
    ap.add_argument("--weight", type=float, default=25.966)
    ap.add_argument("--dampings", default="2e4,1e7", help="N·s/m: light (default scene) and heavy")
    ap.add_argument("--methods", default="auto,RK45,Radau,BDF,LSODA")
    args = ap.parse_args()
    scene = load_scene()
    s = RigSettings.from_scene(scene)
    t = time.perf_counter()
    curve = build_database(scene, models=[args.model])[args.model]
    print(f"database build ({args.model}): {time.perf_counter() - t:.3f} s (excluded)")
    static = equilibrium(curve, s, args.weight)
    print(
        f"static: h0 = {static.min_separation_m:.6e} m, A = {static.contact_area_m2:.6e} m², "
        f"k = {static.stiffness_n_per_m:.3e} N/m, {static.n_nodes} nodes"
    )
    print(
        f"{'B N·s/m':>9s} {'method':7s} {'stiff':5s} {'zeta':>8s} {'ratio':>9s} {'settled':7s} {'h0 rel err':>11s} "
        f"{'A rel err':>10s} {'t_rest s':>9s} {'nfev':>8s} {'njev':>5s} {'nlu':>6s} {'time s':>8s}"
    )
    for damping in (float(x) for x in args.dampings.split(",")):
        for method in args.methods.split(","):
            run = settle(curve, s, args.weight, method=method, damping_n_s_per_m=damping, static=static)
            label = f"{method}→{run.method}" if method == "auto" else run.method
            print(
                f"{damping:9.1e} {label:7s} {run.stiff!s:5s} {run.damping_ratio:8.3g} {run.stiffness_ratio:9.3g} "
                f"{run.settled!s:7s} {abs(run.separation_error_m) / abs(run.static_separation_m):11.2e} "
                f"{run.area_relative_error:10.2e} {run.settle_time_s:9.4f} {run.nfev:8d} {run.njev:5d} {run.nlu:6d} "
                f"{run.elapsed_s:8.3f}"
            )


if __name__ == "__main__":
    main()
