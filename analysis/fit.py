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

Weights: the mean over repeats at each weight has standard error σ_i = s_i/√n_i (``weighting="repeats"``), or a
pooled SD over all weights (``"pooled"``, when some weight has too little scatter to trust), or the within-block
standard errors of single repeats (``"blocks"``: instrument noise only). Standard errors come from (JᵀJ)⁻¹ with
these absolute σ. Bootstrap: the repeats are resampled (whole series when paired, else within each weight), the
weighted estimator is recomputed with the weights held fixed, and percentile intervals are reported.

Model choice: χ², AIC = χ² + 2k and BIC = χ² + k ln n (Gaussian errors with known σ; k = 2 for every model, so
ΔAIC = ΔBIC = Δχ²; χ² uses each weight's own σ and ignores the correlation between weights that paired series
carry — the parameter covariance includes it). Models within ΔAIC < 2 of the best are not distinguishable
(Burnham & Anderson's rule of thumb); the bootstrap also says how often the best model stays first when the repeats
are resampled.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from analysis.measured import MeasuredCurve
from analysis.resistance import CONVERSIONS
from sims.validation import SettingError, check_choice, check_int, check_range

__all__ = [
    "WEIGHTINGS",
    "ModelComparison",
    "ModelFit",
    "area_at_weights",
    "compare_models",
    "fit_model",
    "regressor",
]

WEIGHTINGS = ("repeats", "pooled", "blocks")
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
                "weight_kg", wi, f"measured weight outside the simulated range [{ws[0]:g}, {ws[-1]:g}] kg"
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
        else:
            sd = curve.sd_ohm
            pooled = math.sqrt(float(np.sum((n - 1) * sd**2) / np.sum(n - 1)))
            sigma = pooled / np.sqrt(n)
    bad = ~np.isfinite(sigma) | (sigma <= 0)
    if np.any(bad):
        w = curve.weight_kg[bad][0]
        raise SettingError("weighting", weighting, f"zero or undefined scatter at {w:g} kg; use 'pooled'")
    return sigma


def _resampled_means(curve: MeasuredCurve, mode: str, n_boot: int, rng: np.random.Generator) -> np.ndarray:
    """(n_boot, m) repeat means after resampling the repeats with replacement."""
    v = curve.values_ohm
    m, r = v.shape
    if mode == "series":
        cols = rng.integers(0, r, size=(n_boot, r))
        return v[:, cols].mean(axis=2).T
    out = np.empty((n_boot, m))
    for i in range(m):
        row = v[i][np.isfinite(v[i])]
        out[:, i] = row[rng.integers(0, row.size, size=(n_boot, row.size))].mean(axis=1)
    return out


@dataclass(frozen=True)
class ModelFit:
    """One model's fit R = R_s + s·x(A(W)) (module docstring). SI units: Ω, Ω·m, 1/m.

    Estimates ``R_series_ohm``, ``scale`` (effective resistivity s [Ω·m]) with standard errors, covariance
    ``cov`` (order R_s, s; series correlation included when paired, see :func:`_parameter_covariance`), ``cov_ls``
    the solver's (JᵀJ)⁻¹, Student-t intervals ``*_ci`` with ``ci_dof`` degrees of freedom and bootstrap percentile
    intervals ``*_boot_ci`` at ``ci_level`` (percentile intervals are too narrow with few repeats: below ~20 they
    cover less than stated; the t intervals hold their level); per weight: ``fitted_ohm``, ``residuals_ohm``
    (measured − fitted), ``sigma_ohm`` and
    ``normalised_residuals``; goodness of fit ``chi2``, ``dof``, ``reduced_chi2``, ``p_value`` (χ² tail),
    ``aic``, ``bic``, ``rmse_ohm`` (unweighted); solver diagnostics ``nfev``, ``njev``, ``status``, ``message``,
    ``cost``, ``optimality``, ``success``; ``linear_check`` the largest relative difference from the closed-form
    weighted least-squares solution.
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
    fitted_ohm: np.ndarray
    residuals_ohm: np.ndarray
    normalised_residuals: np.ndarray
    chi2: float
    dof: int
    reduced_chi2: float
    p_value: float
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

    def predict_ohm(self, area_m2: np.ndarray, height_m: float) -> np.ndarray:
        """Fitted R [Ω] at contact areas ``area_m2`` (same conversion)."""
        return self.R_series_ohm + self.scale * regressor(area_m2, height_m, self.conversion)

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

    With the weights taken from the same repeats ("repeats"), weights and variance estimate are correlated and
    the intervals run a little narrow for few repeats (measured over 200 data sets, 95 % nominal: ≈ 0.90 with 6
    or 12 repeats, 0.95 with 30). Pooled weights with paired series give the nominal level at any count.
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
    boot_means: np.ndarray | None,
    *,
    conversion: str,
    weighting: str,
    bootstrap: str,
    ci_level: float,
) -> ModelFit:
    from scipy.optimize import least_squares
    from scipy.special import chdtrc

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
    lo_q, hi_q = 50.0 * (1.0 - ci_level), 50.0 * (1.0 + ci_level)
    if boot_means is not None:
        boot = boot_means @ wls.T  # (B, 2)
        r_ci = tuple(float(q) for q in np.percentile(boot[:, 0], [lo_q, hi_q]))
        s_ci = tuple(float(q) for q in np.percentile(boot[:, 1], [lo_q, hi_q]))
        n_boot = boot.shape[0]
    else:
        boot = None
        r_ci = s_ci = (math.nan, math.nan)
        n_boot = 0
    notes = []
    if dof > 0 and chi2 / dof > 1.5:
        notes.append(
            f"χ²/dof = {chi2 / dof:.3g}: the scatter about the fit exceeds the repeat scatter; standard errors "
            f"scaled by √(χ²/dof) would be {math.sqrt(chi2 / dof):.3g}× larger"
        )
    if p[0] < 0:
        notes.append(f"negative series resistance ({p[0]:.3g} Ω): the model's shape does not follow the data")
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
        fitted_ohm=fitted,
        residuals_ohm=resid,
        normalised_residuals=norm_resid,
        chi2=chi2,
        dof=dof,
        reduced_chi2=chi2 / dof if dof > 0 else math.nan,
        p_value=float(chdtrc(dof, chi2)) if dof > 0 else math.nan,
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


def _prepare(curve: MeasuredCurve, weighting: str, bootstrap: str, ci_level: float, n_boot: int) -> tuple:
    check_choice("weighting", weighting, WEIGHTINGS)
    check_choice("bootstrap", bootstrap, BOOTSTRAPS)
    check_range("ci_level", ci_level, 0.0, 1.0, lo_open=True, hi_open=True)
    check_int("n_boot", n_boot, 0, 1_000_000)
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
    weighting: str = "repeats",
    ci_level: float = 0.95,
    n_boot: int = 2000,
    bootstrap: str = "auto",
    seed: int | None = 0,
) -> ModelFit:
    """Fit R = R_s + s·x(A) to ``curve`` with ``area_m2`` the model's contact area at ``curve.weight_kg``.

    ``height_m`` h_R of seed eq. 23 [m] (unused by ``conversion="holm"``); ``weighting`` one of
    :data:`WEIGHTINGS`; ``n_boot`` bootstrap resamples (0: none); ``bootstrap`` "series", "within" or "auto".
    """
    area = np.asarray(area_m2, dtype=float)
    if area.shape != curve.weight_kg.shape:
        raise SettingError("area_m2", f"shape {area.shape}", f"expected one area per weight {curve.weight_kg.shape}")
    sigma, mode = _prepare(curve, weighting, bootstrap, ci_level, n_boot)
    x = regressor(area, height_m, conversion)
    boot = _resampled_means(curve, mode, n_boot, np.random.default_rng(seed)) if n_boot else None
    return _fit_arrays(
        model, curve, area, x, sigma, boot, conversion=conversion, weighting=weighting, bootstrap=mode,
        ci_level=ci_level,
    )  # fmt: skip


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
    weighting: str = "repeats",
    ci_level: float = 0.95,
    n_boot: int = 2000,
    bootstrap: str = "auto",
    seed: int | None = 0,
) -> ModelComparison:
    """Fit every model in ``areas_m2`` (name → contact area at ``curve.weight_kg``) and rank them.

    The same bootstrap resamples are used for every model, so "how often is the best model first" compares
    like with like. Arguments as :func:`fit_model`.
    """
    if not areas_m2:
        raise SettingError("models", [], "expected at least one model")
    sigma, mode = _prepare(curve, weighting, bootstrap, ci_level, n_boot)
    boot = _resampled_means(curve, mode, n_boot, np.random.default_rng(seed)) if n_boot else None
    fits: dict[str, ModelFit] = {}
    for name, area in areas_m2.items():
        area = np.asarray(area, dtype=float)
        if area.shape != curve.weight_kg.shape:
            raise SettingError(f"{name} contact area", f"shape {area.shape}", f"expected {curve.weight_kg.shape}")
        x = regressor(area, height_m, conversion)
        fits[name] = _fit_arrays(
            name, curve, area, x, sigma, boot, conversion=conversion, weighting=weighting, bootstrap=mode,
            ci_level=ci_level,
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
