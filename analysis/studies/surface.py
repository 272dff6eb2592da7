"""Study ``surface``: summit statistics and database values against surface resolution and size.

A Gaussian surface with autocorrelation Sq² exp(−r²/λ²) has, in the continuum, the spectral moments
m0 = Sq², m2 = 2Sq²/λ², m4 = 12Sq²/λ⁴ (bandwidth α = 3), so McCool's estimates are known in closed form:
η = 1/(π√3 λ²), β = 0.375 λ²√(π/12)/Sq, σ_s = √(1 − 0.8968/3) Sq. Those closed forms are the reference for the
summit statistics (8-neighbour summits, 3-point curvatures) measured on generated surfaces of increasing
resolution (pixels per λ) and size (n × n at 8 pixels per λ); the error is the largest of the three relative
errors. Database values: the Hertz nominal pressure at a separation of 1·Sq from deterministic summation over the
summits, against the same quantity on the largest surface of the size series (a converged reference; the
remaining scatter between sizes is the sampling error of a finite surface). Seconds: generating the surface, its
summit statistics and (size series) the 64-separation Hertz summation.
"""

from __future__ import annotations

import math
import time

import numpy as np

from analysis.studies.rows import Row

REFERENCE = "McCool's closed forms for a Gaussian autocorrelation (statistics); the largest surface (database)"
_SQ_M = 0.5e-6
_LAMBDA_M = 8e-6
_E_STAR_PA = 49e9


def mccool_gaussian(sq_m: float, correlation_m: float) -> dict[str, float]:
    """McCool's η (m⁻²), β (m), σ_s (m) for a Gaussian autocorrelation, from the continuum spectral moments."""
    eta = 1.0 / (math.pi * math.sqrt(3.0) * correlation_m**2)
    beta = 0.375 * correlation_m**2 * math.sqrt(math.pi / 12.0) / sq_m
    sigma_s = math.sqrt(1.0 - 0.8968 / 3.0) * sq_m
    return {"eta": eta, "beta": beta, "sigma_s": sigma_s}


def _statistics_row(setting: str, n: int, pixels_per_lambda: int, seed: int) -> tuple[Row, np.ndarray, float]:
    from sims.surface import gaussian, summit_statistics

    pixel = _LAMBDA_M / pixels_per_lambda
    t0 = time.perf_counter()
    z = gaussian(n, pixel_m=pixel, sq_m=_SQ_M, correlation_m=_LAMBDA_M, seed=seed)
    stats = summit_statistics(z, pixel)
    seconds = time.perf_counter() - t0
    ref = mccool_gaussian(_SQ_M, _LAMBDA_M)
    errs = {k: getattr(stats, k) / ref[k] - 1.0 for k in ref}
    worst = max(errs, key=lambda k: abs(errs[k]))
    row = Row(
        study="surface",
        method=f"summit statistics, {pixels_per_lambda} px/λ",
        setting=setting,
        error=abs(errs[worst]),
        seconds=seconds,
        extra={
            "error_kind": f"max relative (worst: {worst})",
            "n_summits": int(stats.n_summits),
            **{f"err_{k}": float(v) for k, v in errs.items()},
        },
    )
    return row, z, pixel


def _hertz_pressure(z: np.ndarray, pixel: float) -> tuple[float, float]:
    from sims.asperity import model
    from sims.database import asperity_sums
    from sims.surface import summit_data

    t0 = time.perf_counter()
    d = summit_data(z, pixel)
    order = np.argsort(-d.height_m)
    hertz = model("hertz", E_star=_E_STAR_PA, R=d.radius_m[order])
    h = np.linspace(-2 * _SQ_M, 4 * _SQ_M, 64)
    h[0] = _SQ_M  # the separation we score
    p, _ = asperity_sums(hertz, d.height_m[order], h, d.area_m2)
    return float(p[0]), time.perf_counter() - t0


def run(quick: bool) -> list[Row]:
    rows: list[Row] = []
    # resolution at a fixed box of 64 λ
    for k in (2, 4, 8, 16) if not quick else (2, 4, 8):
        row, _, _ = _statistics_row(f"{64 * k}² grid, box 64 λ", 64 * k, k, seed=11)
        rows.append(row)
    # size at 8 px/λ
    sizes = (128, 256, 512, 1024, 2048) if not quick else (128, 256, 512, 1024)
    pressures = []
    for n in sizes:
        row, z, pixel = _statistics_row(f"{n}² grid", n, 8, seed=n)
        p, t_db = _hertz_pressure(z, pixel)
        rows.append(row)
        pressures.append((n, p, row.seconds + t_db))
    p_ref = pressures[-1][1]
    for n, p, seconds in pressures[:-1]:
        rows.append(
            Row(
                study="surface",
                method="database (Hertz p at h = Sq)",
                setting=f"{n}² grid",
                error=abs(p / p_ref - 1.0),
                seconds=seconds,
                extra={"error_kind": f"relative to the {sizes[-1]}² surface", "pressure_pa": p},
            )
        )
    return rows
