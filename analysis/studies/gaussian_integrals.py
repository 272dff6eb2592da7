"""Study ``gaussian_integrals``: F_5/2 (Greenwood–Tripp) by each method, error against run time.

Methods: the closed form (parabolic cylinder function), the fast table (the default), the seed paper's
8th-degree interpolating polynomial, and the common power-law fit. Time: each method on the same ``n_points``
values of t (10^6; 10^5 with ``--quick``), best of three. Error: max relative error against mpmath quadrature of
the defining integral F_n(t) = (2π)^-½ ∫_t^∞ (s − t)^n e^(−s²/2) ds at 30 significant digits, on a separate set of
points (uniform in t, 400 per interval; 120 with ``--quick``). Paper polynomial and power fit are only defined on
[0, 4], so every method is scored there; table and closed form also on [−8, 10] (closed form on [−8, 6], where
scipy's pbdv is still usable — beyond it its error grows, which is why the table exists).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from functools import partial

import numpy as np

from analysis.studies.rows import Row, Stopwatch

REFERENCE = "mpmath quadrature of the defining integral, 30 digits"
N_ORDER = 2.5


def reference_F(n: float, t: np.ndarray) -> np.ndarray:
    """F_n(t) by mpmath quadrature (independent of every method measured here)."""
    import mpmath as mp

    mp.mp.dps = 30
    out = np.empty(t.size)
    for i, ti in enumerate(t.tolist()):
        tt = mp.mpf(ti)
        # split at the peak of the integrand, s* = (t + √(t² + 4n))/2, so quad sees a smooth bump
        peak = (tt + mp.sqrt(tt * tt + 4 * n)) / 2
        val = mp.quad(lambda s, tt=tt: (s - tt) ** n * mp.exp(-s * s / 2), [tt, peak, peak + 10, mp.inf])
        out[i] = float(val / mp.sqrt(2 * mp.pi))
    return out


def _methods() -> dict[str, Callable[[np.ndarray], np.ndarray]]:
    from sims import greenwood_tripp as gt

    return {
        "closed_form": partial(gt.F, N_ORDER, method="closed_form"),
        "table": partial(gt.F, N_ORDER, method="table"),
        "paper_polynomial": partial(gt.F, N_ORDER, method="paper_polynomial"),
        "power_fit": partial(gt.F, N_ORDER, method="power_fit"),
    }


_DOMAINS = {
    "closed_form": [(0.0, 4.0), (-8.0, 6.0)],
    "table": [(0.0, 4.0), (-8.0, 10.0)],
    "paper_polynomial": [(0.0, 4.0)],
    "power_fit": [(0.0, 4.0)],
}


def run(quick: bool) -> list[Row]:
    n_points = 100_000 if quick else 1_000_000
    n_ref = 120 if quick else 400
    methods = _methods()
    stopwatch = Stopwatch(repeat=3)
    rows: list[Row] = []
    refs: dict[tuple[float, float], tuple[np.ndarray, np.ndarray]] = {}
    for name, fn in methods.items():
        for lo, hi in _DOMAINS[name]:
            if (lo, hi) not in refs:
                t_ref = np.linspace(lo, hi, n_ref)
                refs[lo, hi] = (t_ref, reference_F(N_ORDER, t_ref))
            t_ref, f_ref = refs[lo, hi]
            t_time = np.linspace(lo, hi, n_points)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the paper polynomial warns where it is negative: counted below
                _, seconds = stopwatch(partial(fn, t_time))
                approx = fn(t_ref)
            rel = np.abs(approx - f_ref) / f_ref
            worst = int(np.argmax(rel))
            rows.append(
                Row(
                    study="gaussian_integrals",
                    method=name,
                    setting=f"t in [{lo:g}, {hi:g}], {n_points} points",
                    error=float(rel.max()),
                    seconds=seconds,
                    extra={
                        "error_kind": "max relative",
                        "worst_t": float(t_ref[worst]),
                        "median_error": float(np.median(rel)),
                        "ns_per_point": 1e9 * seconds / n_points,
                    },
                )
            )
    return rows
