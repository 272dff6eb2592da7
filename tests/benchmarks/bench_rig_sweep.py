"""Full load sweep (8 Tab. 1 weights × all five models): time and contact-area error, pair-wise against baselines.

Compared in one run, each against the same independent reference (adaptive quadrature of the exact-gap integrals
on each database curve, see bench_rig_mesh.py):

- ``sweep``: the default (variable mesh, all weights of a model solved together, safeguarded Newton);
- ``per-weight``: :func:`sims.rig.equilibrium` (the same solver, one weight at a time) for every (model, weight),
  variable mesh;
- ``uniform 512``: per-weight on a uniform mesh of 512 cells over the half circumference.

Goal: the sweep to 1e-3 relative area error in under 0.2 s (database build stated separately).

Run:  /tmp/venv/bin/python tests/benchmarks/bench_rig_sweep.py
"""

from __future__ import annotations

import time

import numpy as np
from bench_rig_mesh import reference  # same directory: run as a script

from contactrig.core.scene import load_scene
from sims.config import SimConfig
from sims.database import build_database
from sims.rig import equilibrium, sweep
from sims.rig.mesh import uniform_mesh


def best_of(fn, repeat: int = 7) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def main() -> None:
    config = SimConfig.from_scene(load_scene())
    s = config.rig
    t = time.perf_counter()
    db = build_database(config)
    print(f"database build (all {len(db)} models): {time.perf_counter() - t:.3f} s — excluded from the times below")
    t = time.perf_counter()
    ref = {n: np.array([reference(db[n], s, w)[1] for w in s.weights_kg]) for n in db}
    print(f"quadrature reference: {time.perf_counter() - t:.1f} s")

    def run_sweep():
        r = sweep(config, database=db)
        return {n: m.contact_area_m2 for n, m in r.models.items()}

    def run_per_weight():
        return {n: np.array([equilibrium(db[n], s, w).contact_area_m2 for w in s.weights_kg]) for n in db}

    mesh = uniform_mesh(s.piston_radius_m, s.skirt_length_m, 512, 1)

    def run_uniform():
        return {n: np.array([equilibrium(db[n], s, w, mesh=mesh).contact_area_m2 for w in s.weights_kg]) for n in db}

    print(f"{'method':18s} {'time ms (best of 7)':>20s} {'max rel. area error':>20s}   per model")
    for label, fn in (("sweep", run_sweep), ("per-weight", run_per_weight), ("uniform 512", run_uniform)):
        dt, areas = best_of(fn)
        errs = {n: float(np.max(np.abs(areas[n] - ref[n]) / ref[n])) for n in db}
        detail = ", ".join(f"{n} {e:.1e}" for n, e in errs.items())
        print(f"{label:18s} {dt * 1e3:20.1f} {max(errs.values()):20.2e}   {detail}")
    print("goal: sweep under 200 ms with max error below 1e-3")


if __name__ == "__main__":
    main()
