"""Damped release-to-rest (seed eq. 22): explicit RK45 against implicit Radau, BDF, LSODA, stiff and non-stiff.

The piston under the heaviest Tab. 1 weight (25.966 kg) is released just touching the liner and integrated to rest
on the Greenwood–Tripp database curve of the default scene (mesh: the converged static solution's). For each
damping B — light (not stiff) and heavy (stiff, stiffness ratio ≈ 4ζ²) — and each method: the error of the rest
state against the static equilibrium (minimum gap and real area), function and Jacobian evaluations, LU
decompositions and wall time. The implicit methods get the analytic Jacobian from the law's slope. Explicit runs
on the stiff case stop at the evaluation budget (``--max-evaluations``, default ``sims.rig.dynamics.MAX_EVALUATIONS``;
0 lifts it: RK45 then needs ~1.7e5 evaluations at 25.966 kg and ~3.5e6 at 5.44 kg).

Second part, numerical damping (light damping, not stiff): the piston released δ = 1e-3·W/k above rest (linear
regime) against the analytic linearised oscillator — first overshoot δ·exp(−πζ/√(1−ζ²)), and the amplitude after
20 periods δ·exp(−ζω_n·20T) — for every method at rtol 1e-9, 1e-6, 1e-3.

Run:  /tmp/venv/bin/python tests/benchmarks/bench_rig_dynamics.py [--model greenwood_tripp] [--dampings 2e4,1e7]
"""

from __future__ import annotations

import argparse
import math
import time
import warnings

import numpy as np

from contactrig.core.scene import load_scene
from sims.config import SimConfig
from sims.database import build_database
from sims.rig.dynamics import MAX_EVALUATIONS, settle
from sims.rig.equilibrium import equilibrium
from sims.rig.settings import RigSettings


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", default="greenwood_tripp")
    ap.add_argument("--weight", type=float, default=25.966)
    ap.add_argument("--dampings", default="2e4,1e7", help="N·s/m: light (default scene) and heavy")
    ap.add_argument("--methods", default="auto,RK45,Radau,BDF,LSODA")
    ap.add_argument("--max-evaluations", type=int, default=MAX_EVALUATIONS, help="0: no budget")
    ap.add_argument("--light", type=float, default=2e3, help="damping of the numerical-damping part, N·s/m")
    args = ap.parse_args()
    warnings.simplefilter("ignore", RuntimeWarning)  # the explicit-on-stiff warnings: shown as status below
    budget = args.max_evaluations or None
    config = SimConfig.from_scene(load_scene())
    s = config.rig
    t = time.perf_counter()
    curve = build_database(config, models=[args.model])[args.model]
    print(f"database build ({args.model}): {time.perf_counter() - t:.3f} s (excluded)")
    static = equilibrium(curve, s, args.weight)
    print(
        f"static: h0 = {static.min_separation_m:.6e} m, A = {static.contact_area_m2:.6e} m², "
        f"k = {static.stiffness_n_per_m:.3e} N/m, {static.n_nodes} nodes"
    )
    print(
        f"{'B N·s/m':>9s} {'method':7s} {'stiff':5s} {'zeta':>8s} {'ratio':>9s} {'settled':7s} {'h0 rel err':>11s} "
        f"{'A rel err':>10s} {'t_rest s':>9s} {'nfev':>8s} {'njev':>5s} {'nlu':>6s} {'time s':>8s} status"
    )
    for damping in (float(x) for x in args.dampings.split(",")):
        for method in args.methods.split(","):
            run = settle(
                curve, s, args.weight, method=method, damping_n_s_per_m=damping, static=static, max_evaluations=budget
            )
            label = f"{method}→{run.method}" if method == "auto" else run.method
            print(
                f"{damping:9.1e} {label:7s} {run.stiff!s:5s} {run.damping_ratio:8.3g} {run.stiffness_ratio:9.3g} "
                f"{run.settled!s:7s} {abs(run.separation_error_m) / abs(run.static_separation_m):11.2e} "
                f"{run.area_relative_error:10.2e} {run.settle_time_s:9.4f} {run.nfev:8d} {run.njev:5d} {run.nlu:6d} "
                f"{run.elapsed_s:8.3f} {run.status}"
            )
    numerical_damping(curve, s, args.weight, static, args.light)


def numerical_damping(curve, s: RigSettings, weight: float, static, damping: float) -> None:
    m, k = weight + s.piston_mass_kg, static.stiffness_n_per_m
    zeta = damping / (2 * math.sqrt(k * m))
    omega = math.sqrt(k / m)
    period = 2 * math.pi / (omega * math.sqrt(1 - zeta**2))
    delta = 1e-3 * static.load_n / k
    first = delta * math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2))
    n = 20
    late = delta * math.exp(-zeta * omega * n * period)
    print(
        f"\nnumerical damping: B = {damping:g} N·s/m, ζ = {zeta:.4g}, period {period:.4g} s, released "
        f"δ = {delta:.3g} m above rest; ratios to the analytic linear oscillator (1 = no numerical damping; "
        "the common offset of ~3e-4 is the contact's nonlinearity)"
    )
    print(f"{'rtol':>7s} {'method':7s} {'1st overshoot':>14s} {'amp. after 20 T':>16s} {'nfev (20 T)':>12s}")
    for rtol in (1e-9, 1e-6, 1e-3):
        for method in ("RK45", "Radau", "BDF", "LSODA"):
            common = dict(method=method, damping_n_s_per_m=damping, static=static, rtol=rtol, tol=1e-4)
            common["start_m"] = static.min_separation_m + delta
            t1 = np.linspace(0.0, period, 4001)
            r1 = settle(curve, s, weight, t_eval_s=t1, t_max_s=period, **common)
            over = static.min_separation_m - r1.min_separation_m.min()
            t2 = np.linspace((n - 0.5) * period, (n + 0.5) * period, 4001)
            r2 = settle(curve, s, weight, t_eval_s=t2, t_max_s=(n + 0.5) * period, **common)
            x = r2.min_separation_m - static.min_separation_m
            amp = 0.5 * (x.max() - x.min())
            print(f"{rtol:7.0e} {method:7s} {over / first:14.5f} {amp / late:16.4f} {r2.nfev:12d}")


if __name__ == "__main__":
    main()
