"""Benchmark of the analysis fit: error against run time, each method beside its baseline in one run.

1. Point fit of R = R_s + s·h/A to 8 weights × 6 repeats. Reference: the weighted normal equations solved in
   50-digit arithmetic (mpmath). Methods: ``analysis.fit.fit_model`` (scipy.optimize.least_squares, 'lm'), the
   baseline scipy.optimize.curve_fit, and the closed-form normal equations in float64.
2. Bootstrap of the repeats (B resamples). Reference and baseline: refitting every resample with
   least_squares. Method: the vectorised closed form used by ``fit_model`` (weights held fixed, same estimator).
   Error: largest difference of the 95 % interval end points, relative to the interval width.
3. Bootstrap interval coverage with 6 paired series (Tab. 1's design), over N simulated data sets with known R_s
   and s. Baseline: percentile intervals; method: studentized (bootstrap-t) intervals, the default; beside them the
   Student-t intervals. Error: |coverage − 0.95| averaged over R_s and s (binomial SD ≈ 0.007 at N = 1000).

Run: ``python tests/benchmarks/bench_fit.py`` (prints one row per method: study, method, setting, error, seconds).
"""

from __future__ import annotations

import time

import numpy as np


def _best_time(fn, repeat: int = 5, number: int = 20) -> tuple[object, float]:
    best = float("inf")
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            out = fn()
        best = min(best, (time.perf_counter() - t0) / number)
    return out, best


def main() -> None:
    import mpmath
    from scipy.optimize import curve_fit, least_squares

    from analysis.fit import fit_model
    from analysis.measured import MeasuredCurve

    rng = np.random.default_rng(1)
    w = np.array([5.44, 7.44, 10.526, 13.616, 16.708, 19.795, 22.882, 25.966])
    area = 1e-7 * (w / w[0]) ** 0.8
    h = 5e-3
    x = h / area
    truth = 2e-4 + 1e-7 * x
    v = truth[:, None] * (1 + 0.05 * rng.normal(size=(w.size, 6)))
    curve = MeasuredCurve(w, v, paired=True)
    y, sig = curve.mean_ohm, curve.sem_ohm

    # reference: weighted normal equations in 50 digits
    mpmath.mp.dps = 50
    sw = [mpmath.mpf(1) / mpmath.mpf(float(s)) ** 2 for s in sig]
    xs = [mpmath.mpf(float(t)) for t in x]
    ys = [mpmath.mpf(float(t)) for t in y]
    s0, s1, s2 = (
        sum(sw),
        sum(a * b for a, b in zip(sw, xs, strict=True)),
        sum(a * b * b for a, b in zip(sw, xs, strict=True)),
    )
    t0_, t1_ = (
        sum(a * b for a, b in zip(sw, ys, strict=True)),
        sum(a * b * c for a, b, c in zip(sw, xs, ys, strict=True)),
    )
    det = s0 * s2 - s1 * s1
    ref = np.array([float((s2 * t0_ - s1 * t1_) / det), float((s0 * t1_ - s1 * t0_) / det)])

    def err(p: np.ndarray) -> float:
        return float(np.max(np.abs(np.asarray(p) - ref) / np.abs(ref)))

    rows = []
    p, t = _best_time(lambda: curve_fit(lambda xx, a, b: a + b * xx, x, y, sigma=sig, absolute_sigma=True)[0])
    rows.append(("point fit", "curve_fit (baseline)", "8 weights", err(p), t))
    f, t = _best_time(lambda: fit_model(curve, area, height_m=h, n_boot=0, weighting="repeats"))
    rows.append(("point fit", "fit_model least_squares lm", "8 weights", err(f.estimate.params), t))

    def closed() -> np.ndarray:
        a = np.column_stack((np.ones_like(x), x)) / sig[:, None]
        return np.linalg.solve(a.T @ a, a.T @ (y / sig))

    p, t = _best_time(closed)
    rows.append(("point fit", "closed-form normal equations", "8 weights", err(p), t))

    for n_boot in (200, 2000):
        cols = np.random.default_rng(7).integers(0, v.shape[1], size=(n_boot, v.shape[1]))
        means = v[:, cols].mean(axis=2).T  # (B, m)

        def refit(means=means) -> np.ndarray:
            out = np.empty((means.shape[0], 2))
            for i, yb in enumerate(means):
                out[i] = least_squares(lambda q, yb=yb: (q[0] + q[1] * x - yb) / sig, ref, method="lm").x
            return out

        base, t_base = _best_time(refit, repeat=1, number=1)
        a = np.column_stack((np.ones_like(x), x)) / sig[:, None]
        m = np.linalg.solve(a.T @ a, a.T / sig)

        fast, t_fast = _best_time(lambda means=means, m=m: means @ m.T)
        ci_b = np.percentile(base, [2.5, 97.5], axis=0)
        ci_f = np.percentile(fast, [2.5, 97.5], axis=0)
        e = float(np.max(np.abs(ci_b - ci_f) / (ci_b[1] - ci_b[0])))
        rows.append(("bootstrap", "least_squares per resample (baseline)", f"B={n_boot}", 0.0, t_base))
        rows.append(("bootstrap", "vectorised closed form", f"B={n_boot}", e, t_fast))

    rows += _coverage_rows(w, area, h)
    print(f"{'study':<10} {'method':<46} {'setting':<10} {'error':>10} {'seconds':>11}")
    for r in rows:
        print(f"{r[0]:<10} {r[1]:<46} {r[2]:<10} {r[3]:>10.2e} {r[4]:>11.3e}")


def _coverage_rows(w: np.ndarray, area: np.ndarray, h: float, n_sets: int = 1000, r: int = 6) -> list[tuple]:
    """Coverage of the 95 % intervals over ``n_sets`` data sets: percentile, studentized bootstrap, Student t."""
    from analysis.fit import fit_model
    from analysis.measured import MeasuredCurve

    truth_p = np.array([2e-4, 1e-7])
    truth = truth_p[0] + truth_p[1] * h / area
    rows = []
    for interval in ("percentile", "studentized"):
        hits_boot = np.zeros(2)
        hits_t = np.zeros(2)
        t0 = time.perf_counter()
        for seed in range(n_sets):
            rng = np.random.default_rng(seed)
            noise = np.sqrt(0.5) * (rng.normal(size=(1, r)) + rng.normal(size=(w.size, r)))
            curve = MeasuredCurve(w, truth[:, None] * (1 + 0.05 * noise), paired=True)
            f = fit_model(curve, area, height_m=h, n_boot=999, boot_interval=interval, seed=seed)
            b, t = f.intervals.bootstrap, f.intervals.t
            for k, (lo_hi_b, lo_hi_t) in enumerate(((b.R_series_ohm, t.R_series_ohm), (b.scale, t.scale))):
                hits_boot[k] += lo_hi_b[0] <= truth_p[k] <= lo_hi_b[1]
                hits_t[k] += lo_hi_t[0] <= truth_p[k] <= lo_hi_t[1]
        seconds = (time.perf_counter() - t0) / n_sets
        cov = hits_boot / n_sets
        label = "percentile (baseline)" if interval == "percentile" else "studentized bootstrap-t"
        rows.append(
            (
                "coverage",
                f"{label} {cov[0]:.3f}/{cov[1]:.3f}",
                f"N={n_sets}",
                float(np.mean(np.abs(cov - 0.95))),
                seconds,
            )
        )
    cov_t = hits_t / n_sets
    rows.append(
        (
            "coverage",
            f"Student t {cov_t[0]:.3f}/{cov_t[1]:.3f}",
            f"N={n_sets}",
            float(np.mean(np.abs(cov_t - 0.95))),
            seconds,
        )
    )
    return rows


if __name__ == "__main__":
    main()
