"""Benchmark: contact database build time and summit-statistics error against surface size.

For a Gaussian pair (the default scene's materials and surfaces, 10 µm pixels, λ = 80/100 µm) of 256² … 2048²
points: direct 8-neighbour summit statistics of the composite surface against McCool's values from its spectral
moments (η, β, σ_s and mean summit height z̄_s relative differences), and the wall time of ``build_database``
for all five models over 256 separations (surfaces generated inside; GT tables warm after the first size).
Baselines in the same run: the
Greenwood–Tripp-only build (statistics, no surfaces), and for the summation itself the contacting-prefix sum over
height-sorted summits against a dense (separations × summits) evaluation.

Run: /tmp/venv/bin/python tests/benchmarks/bench_database.py
"""

from __future__ import annotations

import time

import numpy as np

from contactrig.core.scene import default_scene_text, parse_scene
from sims import asperity, surface
from sims.database import asperity_sums, build_database


def scene_of(n: int):
    return parse_scene(default_scene_text().replace("n = 512", f"n = {n}"), f"<default n={n}>")


def main() -> None:
    t0 = time.perf_counter()
    build_database(scene_of(256), models=["greenwood_tripp"])
    print(f"first GT build (F-table construction, cold): {time.perf_counter() - t0:.3f} s")
    head = (
        "n",
        "summits",
        "eta err",
        "beta err",
        "sig_s err",
        "zbar err",
        "GT-only s",
        "all 5 s",
        "sum ms",
        "dense ms",
    )
    widths = (6, 8, 8, 9, 9, 9, 10, 8, 8, 9)
    print(" ".join(f"{h:>{w}s}" for h, w in zip(head, widths, strict=True)))
    for n in (256, 512, 1024, 2048):
        sc = scene_of(n)
        t0 = time.perf_counter()
        build_database(sc, models=["greenwood_tripp"])
        t_gt = time.perf_counter() - t0
        t0 = time.perf_counter()
        db = build_database(sc)
        t_all = time.perf_counter() - t0
        liner, piston = surface.surfaces_from_scene(sc)
        z = liner.heights() + piston.heights()
        direct = surface.summit_statistics(z, liner.pixel_m)
        mc = surface.mccool(surface.spectral_moments(z, liner.pixel_m))
        assert len(db) == 5
        # the summation alone: contacting prefix of sorted summits vs a dense (separations × summits) evaluation
        d = surface.summit_data(z, liner.pixel_m)
        order = np.argsort(-d.height_m)
        zs, rs = d.height_m[order], d.radius_m[order]
        h = db["hertz"].separation_m
        m = asperity.model("hertz", E_star=db.provenance["materials"]["E_star_pa"], R=rs)
        t0 = time.perf_counter()
        p_sum, _ = asperity_sums(m, zs, h, d.area_m2)
        t_sum = time.perf_counter() - t0
        t0 = time.perf_counter()
        p_dense = m.force(zs[None, :] - h[:, None]).sum(axis=1) / d.area_m2
        t_dense = time.perf_counter() - t0
        assert np.allclose(p_sum, p_dense, rtol=1e-10, atol=0)
        print(
            f"{n:6d} {direct.n_summits:8d} {direct.eta / mc.eta - 1:+8.3f} {direct.beta / mc.beta - 1:+9.3f} "
            f"{direct.sigma_s / mc.sigma_s - 1:+9.3f} {direct.mean_height / mc.mean_height - 1:+9.3f} "
            f"{t_gt:10.4f} {t_all:8.3f} {t_sum * 1e3:8.1f} {t_dense * 1e3:9.1f}"
        )


if __name__ == "__main__":
    main()
