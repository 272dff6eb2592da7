"""Fit of measured R(W) against each contact model's simulated A(W), and whether the data tell the models apart.

Model (seed eq. 23 plus the series resistance the paper leaves unexplained)::

    R(W) = R_s + s · x(W),   x = h/A(W)            (conversion "bulk", seed eq. 23; s is an effective ζ [Ω·m])
                             x = √π / (2 √A(W))     (conversion "holm": all of A in one Holm spot; s again in Ω·m)

R_s [Ω] is the series resistance of leads, other contacts and bodies; s the effective resistivity. The "holm"
form is also Greenwood's cluster formula for a fixed number n of spots on a fixed nominal patch
(:func:`analysis.resistance.greenwood_patch_resistance_ohm`): its area-independent cluster term goes into R_s and
s = ζ/√n. Both enter
linearly, so the weighted least-squares optimum is unique; it is found with :func:`scipy.optimize.least_squares`
(diagnostics kept on the result) and checked against the closed-form normal equations (``linear_check``).

Weights 1/σ_i² for the mean over the n_i repeats at each weight (``weighting``):

* ``"relative"`` (default): σ_i = c·R̄_i/√n_i with c the pooled relative SD, c² = Σ(n_i−1)(s_i/R̄_i)²/Σ(n_i−1).
  Scatter proportional to R, as in Tab. 1 (11–14 % at every weight); c rests on Σ(n_i−1) degrees of freedom.
* ``"pooled"``: one SD pooled over all weights, σ_i = s_p/√n_i (scatter independent of R).
* ``"repeats"``: each weight's own SEM, σ_i = s_i/√n_i. With few repeats s_i is noisy and the fit leans on the
  weights whose scatter came out small by chance: the standard errors then run low (measured 95 % coverage
  0.88–0.89 with 6 repeats, 0.91 with 12; ``tests/analysis/test_fit.py``) and χ² is inflated (each term is a
  squared Student t with n_i − 1 degrees of freedom, mean (n_i−1)/(n_i−3)). Kept for many repeats (≳ 30).
* ``"blocks"``: the within-block standard errors of single repeats (instrument noise only).

The parameter covariance is estimated from the scatter of the repeats themselves for the weights chosen
(:func:`_parameter_covariance`), so the t-intervals hold their level whichever weights are used; the weights only
set the efficiency. Bootstrap: the repeats are resampled (whole series when paired, else within each weight), the
weighted estimator is recomputed with the weights held fixed, and **studentized** (bootstrap-t) intervals are
reported (``boot_interval="percentile"`` for plain percentile intervals). Why not percentile intervals: with r
resampling units (6 series in Tab. 1) the bootstrap distribution of a mean has the plug-in spread s·√((r−1)/r)/√r
and normal-like tails, so the 95 % percentile interval is about ±1.96·√((r−1)/r) standard errors where Student's
t needs ±t_{r−1} (2.57 for r = 6): its coverage is P(|T_{r−1}| ≤ 1.96·√((r−1)/r)) ≈ 0.87 for r = 6, 0.92 for 12,
what the first version measured (0.81–0.88). The studentized interval divides each resample's deviation by that
resample's own standard error, which restores the t tails: measured 0.95 ± 0.01 with 6 series.

Model choice: χ², AIC = χ² + 2k and BIC = χ² + k ln n (Gaussian errors with known σ; k = 2 for every model, so
ΔAIC = ΔBIC = Δχ²; χ² uses the σ_i above and ignores the correlation between weights that paired series
carry — the parameter covariance includes it). Goodness of fit: with σ estimated from pooled scatter
("relative", "pooled") χ²/dof is referred to F(dof, Σ(n_i−1)), otherwise to χ²(dof)/dof. Models within ΔAIC < 2
of the best are not distinguishable (Burnham & Anderson's rule of thumb); the bootstrap also says how often the
best model stays first when the repeats are resampled.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from analysis.measured import MeasuredCurve
from analysis.resistance import CONVERSIONS
from contactrig.core.validation import SettingError, check_choice, check_int, check_range

__all__ = [
    "WEIGHTINGS",
    "ModelComparison",
    "ModelFit",
    "area_at_weights",
    "compare_models",
    "fit_model",
    "regressor",
]

WEIGHTINGS = ("relative", "repeats", "pooled", "blocks")
BOOT_INTERVALS = ("studentized", "percentile")
BOOTSTRAPS = ("auto", "series", "within")
#: ΔAIC below which two models are called indistinguishable.
DELTA_AIC_INDISTINGUISHABLE = 2.0


def regressor(area_m2: np.ndarray, height_m: float, conversion: str = "bulk") -> np.ndarray:
    """x(A) [1/m] such that R = R_s + s·x with s in Ω·m: h/A (seed eq. 23) or √π/(2√A) (Holm, one spot)."""
    check_choice("conversion", conversion, CONVERSIONS)
    a = np.asarray(area_m2, dtype=float)
    if not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise SettingError("contact_area_m2", a.tolist(), "expected finite areas > 0 m² (zero area: no contact)")
    if conversion == "bulk":
        h = check_range("height_m", height_m, 0.0, None, lo_open=True, unit="m")
        return h / a
    return math.sqrt(math.pi) / (2.0 * np.sqrt(a))


def area_at_weights(weight_sim_kg: np.ndarray, area_sim_m2: np.ndarray, weight_kg: np.ndarray) -> np.ndarray:
    """Simulated contact area [m²] at the measured weights.

    Where the weights coincide (to 1e-9 relative) the simulated values are used as they are; otherwise A(W) is
    interpolated monotonically (PCHIP) in log–log. Weights outside the simulated range are an error (no
    extrapolation).
    """
    ws = np.asarray(weight_sim_kg, dtype=float)
    a = np.asarray(area_sim_m2, dtype=float)
    w = np.asarray(weight_kg, dtype=float)
    if ws.shape != a.shape or ws.ndim != 1:
        raise SettingError("contact_area_m2", f"shape {a.shape}", f"expected shape {ws.shape}")
    if not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise SettingError("contact_area_m2", a.tolist(), "expected finite simulated areas > 0 m²")
    order = np.argsort(ws)
    ws, a = ws[order], a[order]
    if np.any(np.diff(ws) <= 0):
        raise SettingError("weight_kg", ws.tolist(), "expected distinct simulated weights")
    out = np.empty(w.shape)
    for i, wi in enumerate(w):
        hit = np.flatnonzero(np.abs(ws - wi) <= 1e-9 * max(abs(wi), 1e-12))
        if hit.size:
            out[i] = a[hit[0]]
            continue
        if wi < ws[0] or wi > ws[-1] or ws.size < 2 or wi <= 0 or ws[0] <= 0:
            raise SettingError(
                "weight_kg", float(wi), f"measured weight outside the simulated range [{ws[0]:g}, {ws[-1]:g}] kg"
            )
        from scipy.interpolate import PchipInterpolator

        out[i] = math.exp(float(PchipInterpolator(np.log(ws), np.log(a))(math.log(wi))))
    return out


def _sigma(curve: MeasuredCurve, weighting: str) -> np.ndarray:
    check_choice("weighting", weighting, WEIGHTINGS)
    n = curve.n
    if weighting == "blocks":
        if curve.block_sem_ohm is None:
            raise SettingError("weighting", weighting, "expected block standard errors (a session summary)")
        sem = np.where(np.isfinite(curve.values_ohm), curve.block_sem_ohm, np.nan)
        sigma = np.sqrt(np.nansum(sem**2, axis=1)) / n
    else:
        if np.any(n < 2):
            w = curve.weight_kg[n < 2][0]
            raise SettingError(
                "weighting", weighting, f"needs >= 2 repeats at every weight (1 at {w:g} kg); use 'blocks'"
            )
        if weighting == "repeats":
            sigma = curve.sem_ohm
        elif weighting == "relative":
            rel = curve.sd_ohm / curve.mean_ohm
            c = math.sqrt(float(np.sum((n - 1) * rel**2) / np.sum(n - 1)))
            sigma = c * curve.mean_ohm / np.sqrt(n)
        else:
            sd = curve.sd_ohm
            pooled = math.sqrt(float(np.sum((n - 1) * sd**2) / np.sum(n - 1)))
            sigma = pooled / np.sqrt(n)
    bad = ~np.isfinite(sigma) | (sigma <= 0)
    if np.any(bad):
        w = curve.weight_kg[bad][0]
        raise SettingError("weighting", weighting, f"zero or undefined scatter at {w:g} kg; use 'pooled'")
    return sigma


@dataclass(frozen=True)
class _Resamples:
    """Bootstrap resamples of the repeats, shared by every model (weights held fixed).

    ``means`` (B, m) repeat means [Ω]; ``cols`` (B, r) the series drawn (mode "series"); ``var_of_mean`` (B, m)
    the resampled s_i²/n_i [Ω²] (mode "within"), for studentizing.
    """

    mode: str
    means: np.ndarray
    cols: np.ndarray | None = None
    var_of_mean: np.ndarray | None = None


def _resample(curve: MeasuredCurve, mode: str, n_boot: int, rng: np.random.Generator) -> _Resamples:
    """Resample the repeats with replacement: whole series (``"series"``) or within each weight (``"within"``)."""
    v = curve.values_ohm
    m, r = v.shape
    if mode == "series":
        cols = rng.integers(0, r, size=(n_boot, r))
        return _Resamples(mode, v[:, cols].mean(axis=2).T, cols=cols)
    means = np.empty((n_boot, m))
    var = np.zeros((n_boot, m))
    for i in range(m):
        row = v[i][np.isfinite(v[i])]
        draw = row[rng.integers(0, row.size, size=(n_boot, row.size))]
        means[:, i] = draw.mean(axis=1)
        if row.size >= 2:
            var[:, i] = draw.var(axis=1, ddof=1) / row.size
    return _Resamples(mode, means, var_of_mean=var)


def _repeat_se(curve: MeasuredCurve, wls: np.ndarray, mode: str) -> np.ndarray:
    """Standard error of p = M ȳ from the repeats, computed the way :func:`_bootstrap_ci` computes it per resample."""
    if mode == "series":
        q = curve.values_ohm.T @ wls.T  # (r, 2) per-series estimates
        return q.std(axis=0, ddof=1) / math.sqrt(q.shape[0])
    n = curve.n
    var = np.where(n >= 2, np.nan_to_num(curve.sd_ohm) ** 2 / n, 0.0)
    return np.sqrt((wls**2) @ var)


def _quantiles(x: np.ndarray, probs: tuple[float, float]) -> np.ndarray:
    """Order-statistic quantiles along axis 0 (infinite values allowed: no interpolation into them)."""
    return np.quantile(x, probs, axis=0, method="inverted_cdf")


def _bootstrap_ci(
    curve: MeasuredCurve, wls: np.ndarray, p: np.ndarray, res: _Resamples, level: float, interval: str
) -> tuple[np.ndarray, np.ndarray]:
    """Bootstrap parameters (B, 2) and the (2, 2) interval [[lo_R, lo_s], [hi_R, hi_s]] (module docstring).

    Studentized: t*_b = (p*_b − p̂)/se*_b with se* the resample's own repeat standard error; interval
    [p̂ − t*_(1−α/2)·se, p̂ − t*_(α/2)·se]. A resample that drew one series r times has se* = 0 and t* = ±∞
    (probability r^(1−r)); it is kept, so very few series give wide (honest) intervals rather than NaN.
    """
    probs = (0.5 * (1.0 - level), 0.5 * (1.0 + level))
    if res.mode == "series":
        q = curve.values_ohm.T @ wls.T  # (r, 2)
        qb = q[res.cols]  # (B, r, 2)
        boot = qb.mean(axis=1)
        se_b = qb.std(axis=1, ddof=1) / math.sqrt(q.shape[0]) if interval == "studentized" else None
    else:
        boot = res.means @ wls.T
        se_b = np.sqrt(res.var_of_mean @ (wls**2).T) if interval == "studentized" else None
    if se_b is None:
        return boot, _quantiles(boot, probs)
    se = _repeat_se(curve, wls, res.mode)
    dev = boot - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(se_b > 0, dev / np.where(se_b > 0, se_b, 1.0), np.sign(dev) * np.inf)
    t = np.nan_to_num(t, nan=0.0, posinf=np.inf, neginf=-np.inf)
    tq = _quantiles(t, probs)
    with np.errstate(invalid="ignore"):
        ci = np.vstack((p - tq[1] * se, p - tq[0] * se))
    return boot, ci


@dataclass(frozen=True)
class ModelFit:
    """One model's fit R = R_s + s·x(A(W)) (module docstring). SI units: Ω, Ω·m, 1/m.

    Estimates ``R_series_ohm``, ``scale`` (effective resistivity s [Ω·m]) with standard errors, covariance
    ``cov`` (order R_s, s; series correlation included when paired, see :func:`_parameter_covariance`), ``cov_ls``
    the solver's (JᵀJ)⁻¹, Student-t intervals ``*_ci`` with ``ci_dof`` degrees of freedom and bootstrap
    intervals ``*_boot_ci`` at ``ci_level`` (``boot_interval``: studentized by default; percentile intervals run
    narrow with few repeats, see the module docstring); per weight: ``fitted_ohm``, ``residuals_ohm``
    (measured − fitted), ``sigma_ohm`` and ``normalised_residuals``; goodness of fit ``chi2``, ``dof``,
    ``reduced_chi2``, ``p_value`` (tail probability of ``gof_reference``: F(dof, ν) when σ is pooled, else
    χ²(dof)), ``aic``, ``bic``, ``rmse_ohm`` (unweighted); solver diagnostics ``nfev``, ``njev``, ``status``,
    ``message``, ``cost``, ``optimality``, ``success``; ``linear_check`` the largest relative difference from the
    closed-form weighted least-squares solution.
    """

    model: str
    conversion: str
    weighting: str
    weight_kg: np.ndarray
    area_m2: np.ndarray
    regressor_per_m: np.ndarray
    measured_ohm: np.ndarray
    sigma_ohm: np.ndarray
    R_series_ohm: float
    R_series_se: float
    scale: float
    scale_se: float
    cov: np.ndarray
    ci_level: float
    ci_dof: tuple[float, float]
    cov_ls: np.ndarray
    R_series_ci: tuple[float, float]
    scale_ci: tuple[float, float]
    R_series_boot_ci: tuple[float, float]
    scale_boot_ci: tuple[float, float]
    n_boot: int
    bootstrap: str
    boot_interval: str
    fitted_ohm: np.ndarray
    residuals_ohm: np.ndarray
    normalised_residuals: np.ndarray
    chi2: float
    dof: int
    reduced_chi2: float
    p_value: float
    gof_reference: str
    aic: float
    bic: float
    rmse_ohm: float
    nfev: int
    njev: int
    status: int
    message: str
    cost: float
    optimality: float
    success: bool
    linear_check: float
    notes: tuple[str, ...] = ()
    boot_params: np.ndarray = field(default=None, repr=False, compare=False)  # type: ignore[assignment]

    @property
    def correlation(self) -> float:
        """Correlation coefficient of the estimates of R_s and s."""
        return float(self.cov[0, 1] / math.sqrt(self.cov[0, 0] * self.cov[1, 1]))

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (floats, lists, strings)."""
        return {
            "R_series_ohm": self.R_series_ohm,
            "R_series_se": self.R_series_se,
            "R_series_ci": list(self.R_series_ci),
            "R_series_boot_ci": list(self.R_series_boot_ci),
            "scale": self.scale,
            "scale_se": self.scale_se,
            "scale_units": "ohm*m",
            "scale_ci": list(self.scale_ci),
            "scale_boot_ci": list(self.scale_boot_ci),
            "correlation": self.correlation,
            "ci_level": self.ci_level,
            "ci_dof": list(self.ci_dof),
            "chi2": self.chi2,
            "dof": self.dof,
            "reduced_chi2": self.reduced_chi2,
            "p_value": self.p_value,
            "aic": self.aic,
            "bic": self.bic,
            "rmse_ohm": self.rmse_ohm,
            "residuals_ohm": self.residuals_ohm.tolist(),
            "normalised_residuals": self.normalised_residuals.tolist(),
            "conversion": self.conversion,
            "weighting": self.weighting,
            "bootstrap": self.bootstrap,
            "boot_interval": self.boot_interval,
            "gof_reference": self.gof_reference,
            "n_boot": self.n_boot,
            "nfev": self.nfev,
            "status": self.status,
            "message": self.message,
            "cost": self.cost,
            "success": self.success,
            "notes": list(self.notes),
        }


def _t_quantile(level: float, dof: float) -> float:
    """Two-sided Student-t quantile (normal for infinite ``dof``)."""
    from scipy.special import ndtri, stdtrit

    q = 0.5 + level / 2.0
    return float(ndtri(q)) if not math.isfinite(dof) else float(stdtrit(dof, q))


def _parameter_covariance(
    curve: MeasuredCurve, wls: np.ndarray, sigma: np.ndarray, *, paired: bool, weighting: str
) -> tuple[np.ndarray, np.ndarray]:
    """Covariance of p = M ȳ and the degrees of freedom of each standard error.

    Paired series: p is the mean of the per-series estimates M y_k, so cov = M C Mᵀ with C the sample covariance
    of the series / r (correlation across weights included), r − 1 degrees of freedom. Independent repeats:
    cov = M diag(u²) Mᵀ with u_i = s_i/√n_i each weight's own standard error (= (JᵀJ)⁻¹ of the fit when weighting
    by repeats) and Welch–Satterthwaite degrees of freedom ν = (Σ c_i² u_i²)² / Σ (c_i² u_i²)²/(n_i − 1).
    Within-block standard errors ("blocks"): cov = M diag(σ²) Mᵀ, normal quantiles.

    With the weights taken from each weight's own repeats ("repeats"), weights and variance estimate are
    correlated and the intervals run narrow for few repeats (95 % nominal, 6 paired series: 0.90–0.91 over 600
    data sets); pooled weights ("relative", "pooled") give 0.94–0.96 (``tests/analysis/test_fit.py``).
    """
    n = curve.n
    if paired:
        r = curve.values_ohm.shape[1]
        c = np.cov(curve.values_ohm, ddof=1) / r
        return wls @ c @ wls.T, np.full(2, float(r - 1))
    if weighting == "blocks" or np.any(n < 2):
        return (wls * sigma**2) @ wls.T, np.full(2, math.inf)
    var = curve.sem_ohm**2  # each weight's own scatter, whatever the weighting
    cov = (wls * var) @ wls.T
    terms = (wls**2) * var  # (2, m)
    dof = np.sum(terms, axis=1) ** 2 / np.sum(terms**2 / (n - 1), axis=1)
    return cov, dof


def _fit_arrays(
    model: str,
    curve: MeasuredCurve,
    area: np.ndarray,
    x: np.ndarray,
    sigma: np.ndarray,
    resamples: _Resamples | None,
    *,
    conversion: str,
    weighting: str,
    bootstrap: str,
    ci_level: float,
    boot_interval: str = "studentized",
) -> ModelFit:
    from scipy.optimize import least_squares
    from scipy.special import chdtrc, fdtrc

    y = curve.mean_ohm
    m = y.size
    if np.ptp(x) <= 1e-12 * np.max(np.abs(x)):
        raise SettingError(f"{model} contact area", area.tolist(), "expected an area that changes with weight")

    def residuals(p: np.ndarray) -> np.ndarray:
        return (p[0] + p[1] * x - y) / sigma

    jac_const = np.column_stack((1.0 / sigma, x / sigma))
    # A deliberately crude start (line through the end points); the optimum does not depend on it.
    slope0 = (y[-1] - y[0]) / (x[-1] - x[0]) if x[-1] != x[0] else y.mean() / x.mean()
    p0 = np.array([y[0] - slope0 * x[0], slope0])
    res = least_squares(
        residuals, p0, jac=lambda p: jac_const, method="lm", x_scale="jac", ftol=1e-14, xtol=1e-14, gtol=1e-14
    )
    p = res.x
    cov_ls = np.linalg.inv(res.jac.T @ res.jac)

    # Closed-form weighted least squares: the same estimator, p = M ȳ; a check on the solver, and what the
    # covariance, the per-series estimates and the bootstrap are built on.
    wls = np.linalg.solve(jac_const.T @ jac_const, jac_const.T / sigma)  # M, shape (2, m)
    p_lin = wls @ y
    paired = bootstrap == "series" and curve.values_ohm.shape[1] >= 2 and weighting != "blocks"
    cov, dof_eff = _parameter_covariance(curve, wls, sigma, paired=paired, weighting=weighting)
    se = np.sqrt(np.diag(cov))
    linear_check = float(np.max(np.abs(p - p_lin) / np.maximum(np.abs(p_lin), se * 1e-6)))

    fitted = p[0] + p[1] * x
    resid = y - fitted
    norm_resid = resid / sigma
    chi2 = float(np.sum(norm_resid**2))
    dof = m - 2
    k = 2
    t_q = [_t_quantile(ci_level, nu) for nu in dof_eff]
    if resamples is not None:
        boot, ci = _bootstrap_ci(curve, wls, p, resamples, ci_level, boot_interval)
        r_ci = (float(ci[0, 0]), float(ci[1, 0]))
        s_ci = (float(ci[0, 1]), float(ci[1, 1]))
        n_boot = boot.shape[0]
    else:
        boot = None
        r_ci = s_ci = (math.nan, math.nan)
        n_boot = 0
    nu = float(np.sum(curve.n - 1))
    if dof <= 0:
        p_value, gof = math.nan, "none (dof = 0)"
    elif weighting in ("relative", "pooled"):
        p_value, gof = float(fdtrc(dof, nu, chi2 / dof)), f"F({dof}, {nu:g})"
    else:
        p_value, gof = float(chdtrc(dof, chi2)), f"chi2({dof})"
    notes = []
    if dof > 0 and chi2 / dof > 1.5:
        notes.append(
            f"χ²/dof = {chi2 / dof:.3g}: the scatter about the fit exceeds the repeat scatter; standard errors "
            f"scaled by √(χ²/dof) would be {math.sqrt(chi2 / dof):.3g}× larger"
        )
    if weighting == "repeats" and int(np.min(curve.n)) < 30:
        notes.append(
            f"weights from each weight's own {int(np.min(curve.n))}+ repeats: intervals run narrow and χ² high "
            "(module docstring); weighting 'relative' or 'pooled' holds the stated level"
        )
    r_hi = p[0] + t_q[0] * se[0]
    if r_hi < 0:
        notes.append(
            f"negative series resistance ({p[0]:.3g} Ω, {ci_level:.0%} upper limit {r_hi:.3g} Ω): the model's shape "
            "does not follow the data"
        )
    if p[1] <= 0:
        notes.append(f"non-positive scale ({p[1]:.3g} Ω·m): resistance does not fall as the model's area grows")
    return ModelFit(
        model=model,
        conversion=conversion,
        weighting=weighting,
        weight_kg=curve.weight_kg.copy(),
        area_m2=area,
        regressor_per_m=x,
        measured_ohm=y,
        sigma_ohm=sigma,
        R_series_ohm=float(p[0]),
        R_series_se=float(se[0]),
        scale=float(p[1]),
        scale_se=float(se[1]),
        cov=cov,
        ci_level=ci_level,
        R_series_ci=(float(p[0] - t_q[0] * se[0]), float(p[0] + t_q[0] * se[0])),
        scale_ci=(float(p[1] - t_q[1] * se[1]), float(p[1] + t_q[1] * se[1])),
        ci_dof=(float(dof_eff[0]), float(dof_eff[1])),
        cov_ls=cov_ls,
        R_series_boot_ci=r_ci,  # type: ignore[arg-type]
        scale_boot_ci=s_ci,  # type: ignore[arg-type]
        n_boot=n_boot,
        bootstrap=bootstrap,
        boot_interval=boot_interval,
        fitted_ohm=fitted,
        residuals_ohm=resid,
        normalised_residuals=norm_resid,
        chi2=chi2,
        dof=dof,
        reduced_chi2=chi2 / dof if dof > 0 else math.nan,
        p_value=p_value,
        gof_reference=gof,
        aic=chi2 + 2 * k,
        bic=chi2 + k * math.log(m),
        rmse_ohm=float(np.sqrt(np.mean(resid**2))),
        nfev=int(res.nfev),
        njev=int(res.njev or 0),
        status=int(res.status),
        message=str(res.message),
        cost=float(res.cost),
        optimality=float(res.optimality),
        success=bool(res.success),
        linear_check=linear_check,
        notes=tuple(notes),
        boot_params=boot,
    )


def _prepare(
    curve: MeasuredCurve,
    weighting: str,
    bootstrap: str,
    ci_level: float,
    n_boot: int,
    boot_interval: str,
    seed: int | None = None,
) -> tuple:
    check_choice("weighting", weighting, WEIGHTINGS)
    check_choice("boot_interval", boot_interval, BOOT_INTERVALS)
    check_choice("bootstrap", bootstrap, BOOTSTRAPS)
    check_range("ci_level", ci_level, 0.0, 1.0, lo_open=True, hi_open=True)
    check_int("n_boot", n_boot, 0, 1_000_000)
    if seed is not None:
        check_int("seed", seed, 0)
    if curve.weight_kg.size < 3:
        raise SettingError("weights", curve.weight_kg.size, "expected >= 3 weights for a two-parameter fit")
    sigma = _sigma(curve, weighting)
    mode = ("series" if curve.paired else "within") if bootstrap == "auto" else bootstrap
    if mode == "series" and not curve.paired:
        raise SettingError("bootstrap", "series", "expected a complete weights × series matrix")
    if n_boot and np.all(curve.n < 2):
        raise SettingError("n_boot", n_boot, "bootstrapping repeats needs >= 2 repeats; use n_boot=0")
    return sigma, mode


def fit_model(
    curve: MeasuredCurve,
    area_m2: np.ndarray,
    *,
    height_m: float,
    model: str = "model",
    conversion: str = "bulk",
    weighting: str = "relative",
    ci_level: float = 0.95,
    n_boot: int = 2000,
    bootstrap: str = "auto",
    boot_interval: str = "studentized",
    seed: int | None = 0,
) -> ModelFit:
    """Fit R = R_s + s·x(A) to ``curve`` with ``area_m2`` the model's contact area at ``curve.weight_kg``.

    ``height_m`` h_R of seed eq. 23 [m] (unused by ``conversion="holm"``); ``weighting`` one of
    :data:`WEIGHTINGS`; ``n_boot`` bootstrap resamples (0: none); ``bootstrap`` "series", "within" or "auto";
    ``boot_interval`` "studentized" (bootstrap-t, default) or "percentile"; ``seed`` of the resampling.
    """
    area = np.asarray(area_m2, dtype=float)
    if area.shape != curve.weight_kg.shape:
        raise SettingError("area_m2", f"shape {area.shape}", f"expected one area per weight {curve.weight_kg.shape}")
    comparison = compare_models(
        curve, {model: area}, height_m=height_m, conversion=conversion, weighting=weighting, ci_level=ci_level,
        n_boot=n_boot, bootstrap=bootstrap, boot_interval=boot_interval, seed=seed,
    )  # fmt: skip
    return comparison.fits[model]


@dataclass(frozen=True)
class ModelComparison:
    """Fits of every model to the same data, ranked by AIC, with a plain statement of what the data can tell.

    ``delta_aic[name]`` AIC − min AIC; ``akaike_weights`` exp(−Δ/2) normalised; ``first_fraction[name]`` the
    share of bootstrap resamples in which the model has the lowest χ² (weights held fixed); ``decisive_fraction``
    the share in which the overall best model is first by Δχ² ≥ 2; ``discriminates`` true when the runner-up is at
    ΔAIC ≥ 2, the best model is first by ≥ 2 in ≥ 95 % of the resamples *and* it fits within the repeat scatter
    (χ² tail probability ≥ 0.01); otherwise the statement says which condition failed.
    """

    fits: dict[str, ModelFit]
    ranking: tuple[str, ...]
    delta_aic: dict[str, float]
    akaike_weights: dict[str, float]
    first_fraction: dict[str, float]
    decisive_fraction: float
    discriminates: bool
    statement: str
    n_weights: int
    n_repeats: int
    source: str = ""

    def as_dict(self) -> dict[str, Any]:
        """``{"models": {name: {...}}, "ranking": [...], "statement": ..., ...}`` (JSON-ready)."""
        models = {}
        for name, fit in self.fits.items():
            d = fit.as_dict()
            d["delta_aic"] = self.delta_aic[name]
            d["akaike_weight"] = self.akaike_weights[name]
            d["first_fraction"] = self.first_fraction.get(name, math.nan)
            models[name] = d
        out = {
            "models": models,
            "ranking": list(self.ranking),
            "discriminates": self.discriminates,
            "decisive_fraction": self.decisive_fraction,
            "statement": self.statement,
            "n_weights": self.n_weights,
            "n_repeats": self.n_repeats,
            "source": self.source,
        }
        return _json_clean(out)


def _json_clean(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _json_clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_clean(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, np.generic):
        return _json_clean(obj.item())
    return obj


def compare_models(
    curve: MeasuredCurve,
    areas_m2: Mapping[str, np.ndarray],
    *,
    height_m: float,
    conversion: str = "bulk",
    weighting: str = "relative",
    ci_level: float = 0.95,
    n_boot: int = 2000,
    bootstrap: str = "auto",
    boot_interval: str = "studentized",
    seed: int | None = 0,
) -> ModelComparison:
    """Fit every model in ``areas_m2`` (name → contact area at ``curve.weight_kg``) and rank them.

    The same bootstrap resamples are used for every model, so "how often is the best model first" compares
    like with like. Arguments as :func:`fit_model`.
    """
    if not areas_m2:
        raise SettingError("models", [], "expected at least one model")
    sigma, mode = _prepare(curve, weighting, bootstrap, ci_level, n_boot, boot_interval, seed)
    res = _resample(curve, mode, n_boot, np.random.default_rng(seed)) if n_boot else None
    boot = res.means if res is not None else None
    fits: dict[str, ModelFit] = {}
    for name, area in areas_m2.items():
        area = np.asarray(area, dtype=float)
        if area.shape != curve.weight_kg.shape:
            raise SettingError(f"{name} contact area", f"shape {area.shape}", f"expected {curve.weight_kg.shape}")
        x = regressor(area, height_m, conversion)
        fits[name] = _fit_arrays(
            name, curve, area, x, sigma, res, conversion=conversion, weighting=weighting, bootstrap=mode,
            ci_level=ci_level, boot_interval=boot_interval,
        )  # fmt: skip
    names = list(fits)
    ranking = tuple(sorted(names, key=lambda n: fits[n].aic))
    best = ranking[0]
    delta = {n: fits[n].aic - fits[best].aic for n in names}
    raw = {n: math.exp(-0.5 * delta[n]) for n in names}
    total = sum(raw.values())
    weights = {n: raw[n] / total for n in names}

    first: dict[str, float] = {}
    if boot is not None and len(names) > 1:
        chi2s = []
        for n in names:
            f = fits[n]
            design = np.column_stack((np.ones_like(f.regressor_per_m), f.regressor_per_m))
            pred = f.boot_params @ design.T  # (B, m)
            chi2s.append(np.sum(((boot - pred) / sigma) ** 2, axis=1))
        table = np.vstack(chi2s)  # (models, B)
        winner = np.argmin(table, axis=0)
        first = {n: float(np.mean(winner == i)) for i, n in enumerate(names)}
        ordered = np.sort(table, axis=0)
        margin = ordered[1] - ordered[0]
        decisive = float(np.mean((winner == names.index(best)) & (margin >= DELTA_AIC_INDISTINGUISHABLE)))
    elif boot is not None:
        first = {best: 1.0}
        decisive = 1.0
    else:
        decisive = math.nan

    discriminates, statement = _statement(fits, ranking, delta, first, decisive, n_boot if boot is not None else 0)
    return ModelComparison(
        fits=fits,
        ranking=ranking,
        delta_aic=delta,
        akaike_weights=weights,
        first_fraction=first,
        decisive_fraction=decisive,
        discriminates=discriminates,
        statement=statement,
        n_weights=int(curve.weight_kg.size),
        n_repeats=int(curve.values_ohm.shape[1]),
        source=curve.source,
    )


def _statement(
    fits: dict[str, ModelFit],
    ranking: tuple[str, ...],
    delta: dict[str, float],
    first: dict[str, float],
    decisive: float,
    n_boot: int,
) -> tuple[bool, str]:
    best = ranking[0]
    fb = fits[best]
    parts = []
    close: list[str] = []
    if len(ranking) == 1:
        parts.append(f"Only one model ({best}) was fitted: nothing to discriminate.")
        discriminates = False
    else:
        close = [n for n in ranking[1:] if delta[n] < DELTA_AIC_INDISTINGUISHABLE]
        runner = ranking[1]
        if close:
            listed = ", ".join(f"{n} (ΔAIC = {delta[n]:.2g})" for n in close)
            parts.append(
                f"The data do not discriminate between {best} (lowest AIC, χ² = {fb.chi2:.2f}) and {listed}: "
                f"ΔAIC < {DELTA_AIC_INDISTINGUISHABLE:g}. Every model has 2 parameters, so ΔAIC = Δχ²."
            )
        else:
            parts.append(
                f"{best} has the lowest AIC (χ² = {fb.chi2:.3g}); the runner-up {runner} is at ΔAIC = "
                f"{delta[runner]:.3g} (≥ 2: less support; ≥ 10: essentially none)."
            )
        if n_boot:
            parts.append(
                f"Resampling the repeats ({n_boot} bootstrap resamples), {best} has the lowest χ² in "
                f"{first.get(best, 0.0):.0%} of them, and by Δχ² ≥ {DELTA_AIC_INDISTINGUISHABLE:g} in {decisive:.0%}."
            )
        discriminates = not close and (decisive >= 0.95 if n_boot else True)
    if fb.dof > 0 and fb.p_value < 0.01:
        parts.append(
            f"No model fits within the repeat scatter: the best has χ²/dof = {fb.reduced_chi2:.2f} "
            f"(p = {fb.p_value:.2g}), so the ranking compares misfits and confirms none of the models."
        )
        discriminates = False
    if discriminates:
        parts.append("Verdict: the data discriminate between the models.")
    elif fb.dof > 0 and fb.p_value < 0.01 and len(ranking) > 1 and not close:
        parts.append("Verdict: a robust ranking of models none of which fits; no model is confirmed.")
    else:
        parts.append("Verdict: the models are not distinguishable with these data.")
    return discriminates, " ".join(parts)
