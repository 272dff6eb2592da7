"""Study ``mesh``: real contact area of the rig against the number of mesh nodes, uniform and variable.

Reference: the equilibrium computed without a mesh — adaptive quadrature (``scipy.integrate.quad``) of the
exact-gap integrals F(h0) = 2 R_p L ∫₀^π p(h(θ)) cos θ dθ and A = 2 R_p L ∫₀^π a(h(θ)) dθ, with
h(θ) = R_l − e cos θ − √(R_p² − e² sin² θ), e = c − h0, the contact edge handed to quad as a breakpoint, and h0
found by Brent's method to a relative 1e-14 — written here from the geometry, sharing no code with the rig's mesh,
gap or load modules. Error: relative error of the real contact area. Uniform meshes: n_theta cells on [0, π] and
one axial cell (the skirt is straight, so more axial cells change nothing; the scene default of 8 would cost 8×
the nodes); variable meshes: the rig's own adaptive scheme (``mesh = "variable"``) at decreasing ``mesh_tol``.
Seconds: the rig's equilibrium solve, best of three (database build excluded).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from functools import partial
from typing import Any

from analysis.studies.rows import Row, Stopwatch

REFERENCE = "adaptive quadrature of the exact-gap force and area integrals (no mesh), h0 by Brent to 1e-14"


def exact_gap_m(theta: float, h0_m: float, liner_radius_m: float, clearance_m: float) -> float:
    """Gap between an offset circle of radius R_l − c and a circle of radius R_l at angle θ from the closest point."""
    e = clearance_m - h0_m
    rp = liner_radius_m - clearance_m
    return liner_radius_m - e * math.cos(theta) - math.sqrt(rp * rp - (e * math.sin(theta)) ** 2)


def quad_reference(curve: Any, settings: Any, weight_kg: float) -> tuple[float, float]:
    """(h0, real area) of the equilibrium by quadrature; ``settings`` gives geometry and load."""
    from scipy.integrate import IntegrationWarning, quad
    from scipy.optimize import brentq

    R_l, c, L = settings.liner_radius_m, settings.clearance_m, settings.skirt_length_m
    R_p = R_l - c
    load = settings.load_n(weight_kg)

    def edge(h0: float) -> list[float]:
        g = lambda t: exact_gap_m(t, h0, R_l, c) - curve.h_max  # noqa: E731
        if g(0.0) >= 0.0 or g(math.pi) <= 0.0:
            return []
        return [brentq(g, 0.0, math.pi, xtol=1e-15)]

    def integral(f: Any, h0: float) -> float:
        with warnings.catch_warnings():
            # quad's round-off notice at ~1e-10 relative is the reference's own accuracy floor, stated in the rows
            warnings.simplefilter("ignore", IntegrationWarning)
            return quad(f, 0.0, math.pi, points=edge(h0), limit=500, epsabs=0.0, epsrel=1e-11)[0]

    def force(h0: float) -> float:
        return 2 * R_p * L * integral(lambda t: float(curve.pressure(exact_gap_m(t, h0, R_l, c))) * math.cos(t), h0)

    h0 = brentq(lambda h: force(h) - load, curve.h_min, curve.h_max, xtol=1e-18, rtol=1e-14)
    area = 2 * R_p * L * integral(lambda t: float(curve.area_fraction_at(exact_gap_m(t, h0, R_l, c))), h0)
    return h0, area


def run(quick: bool) -> list[Row]:
    from contactrig.core.scene import load_scene
    from sims.config import SimConfig
    from sims.database import build_database
    from sims.rig import equilibrium

    config = SimConfig.from_scene(load_scene())
    base = config.rig
    models = ("greenwood_tripp", "hertz")
    weights = (5.44,) if quick else (5.44, 25.966)
    db = build_database(config, models=list(models))
    stopwatch = Stopwatch(repeat=3)
    rows: list[Row] = []
    for name in models:
        curve = db[name]
        for w in weights:
            _, a_ref = quad_reference(curve, base, w)
            variants = [
                ("uniform", dataclasses.replace(base, mesh="uniform", n_theta=n, n_axial=1), f"n_theta = {n}")
                for n in ((8, 32, 128, 512) if quick else (8, 16, 32, 64, 128, 256, 512, 1024, 4096))
            ] + [
                ("variable", dataclasses.replace(base, mesh="variable", mesh_tol=tol), f"mesh_tol = {tol:g}")
                for tol in ((1e-2, 1e-3, 1e-5) if quick else (1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6))
            ]
            for kind, settings, label in variants:
                eq, seconds = stopwatch(partial(equilibrium, curve, settings, w, name=name))
                rows.append(
                    Row(
                        study="mesh",
                        method=f"{kind} ({name}, {w:g} kg)",
                        setting=label,
                        error=abs(eq.contact_area_m2 / a_ref - 1.0),
                        seconds=seconds,
                        extra={
                            "error_kind": "relative error of the real contact area",
                            "nodes": int(eq.n_nodes),
                            "evaluations": int(eq.evaluations),
                        },
                    )
                )
    return rows
