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

When a bootstrap interval cannot be computed honestly it is reported as not available, with the reason
(:func:`_bootstrap_availability`): too few distinct resamples (r series have C(2r−1, r) distinct resamples: 10 for
3 series, 35 for 4, while a 95 % interval needs its 2.5 % tails resolved, ≥ 2/(1 − level) = 40), too many degenerate
resamples (one series drawn r times has no spread, so its studentized t is infinite: probability r^(1−r), 11 % for
3 series), or a non-finite interval.

**One rule for every fitted quantity** (``fit``, :mod:`analysis.resistance_model`, the report): paired series that
are arithmetic copies of others (:func:`independent_series`, :mod:`analysis.series_dependence`) are counted once —
left out of the fit, its degrees of freedom and its bootstrap. The errors are the covariance from the repeats above,
unless the fit is over-dispersed (ĉ = χ²/ν > :data:`OVERDISPERSION`): then each parameter's error is the larger of
its repeats' one and its curvature error scaled by √ĉ, decided per parameter (:func:`_error_rule`;
``Estimate.error_rule`` says which, ``Estimate.chi2_scaled`` per (R_s, s)), the models are ranked by QAIC =
χ²/ĉ + 2(k + 1) (ĉ of the best physical fit; Burnham & Anderson 2002 §2.5) and "how often is the best first" resamples
the residuals about the best fit instead of the repeats, which cannot show a lack of fit common to every series.

A fit is **unphysical** when the series resistance is significantly below zero (its t upper limit < 0) or the scale
significantly ≤ 0 (resistance would grow with the area). Unphysical fits are ranked after every physical fit whatever
their AIC, flagged in the ranking (``ModelFit.unphysical`` says why) and named in the verdict; they are never "best"
while a physical fit exists.

Model choice: χ², AIC = χ² + 2k and BIC = χ² + k ln n (Gaussian errors with known σ; k = 2 for every model, so
ΔAIC = ΔBIC = Δχ²; χ² uses the σ_i above and ignores the correlation between weights that paired series
carry — the parameter covariance includes it). Goodness of fit: with σ estimated from pooled scatter
("relative", "pooled") χ²/dof is referred to F(dof, Σ(n_i−1)), otherwise to χ²(dof)/dof. Models within ΔAIC < 2
of the best are not distinguishable (Burnham & Anderson's rule of thumb); the bootstrap also says how often the
best model stays first when the repeats are resampled.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, fields, is_dataclass
from typing import Any

import numpy as np

from analysis.measured import MeasuredCurve
from analysis.resistance import CONVERSIONS, resistance_unit
from contactrig.core.validation import SettingError, check_choice, check_int, check_range
from sims.models import model_label

__all__ = [
    "WEIGHTINGS",
    "BootstrapIntervals",
    "Diagnostics",
    "Estimate",
    "FitPoints",
    "GoodnessOfFit",
    "Intervals",
    "ModelComparison",
    "ModelFit",
    "TIntervals",
    "area_at_weights",
    "compare_models",
    "fit_model",
    "regressor",
    "regressor_label",
]

WEIGHTINGS = ("relative", "repeats", "pooled", "blocks")
BOOT_INTERVALS = ("studentized", "percentile")
BOOTSTRAPS = ("auto", "series", "within")
#: ΔAIC below which two models are called indistinguishable.
DELTA_AIC_INDISTINGUISHABLE = 2.0
#: A Δ(Q)AIC within this fraction of the criterion's own size (at least 1) is round-off, a tie: stored, printed and
#: exported as exactly 0 (two models with the same A(W) differ by ~1e-15 from the order of the arithmetic alone).
TIE_TOLERANCE = 1e-9


def regressor(area_m2: np.ndarray, height_m: float, conversion: str = "bulk") -> np.ndarray:
    """x(A) such that R = R_s + s·x: h/A [1/m] (seed eq. 23, s in Ω·m), √π/(2√A) [1/m] (Holm, one spot, s in Ω·m)
    or 1/A [1/m²] (``"physical"``: the film term σ_f/A, s = σ_f in Ω·m², the clean-metal terms a known offset)."""
    check_choice("conversion", conversion, CONVERSIONS)
    a = np.asarray(area_m2, dtype=float)
    if not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise SettingError("contact_area_m2", a.tolist(), "expected finite areas > 0 m² (zero area: no contact)")
    if conversion == "physical":
        return 1.0 / a
    if conversion == "bulk":
        h = check_range("height_m", height_m, 0.0, None, lo_open=True, unit="m")
        return h / a
    return math.sqrt(math.pi) / (2.0 * np.sqrt(a))


def regressor_label(conversion: str) -> str:
    """How x(A) reads in titles and tables: "h/A (eq. 23)", or for ``holm`` "√π/(2√A) (Holm single spot — an upper
    bound on the clean-metal constriction)" (all of A in one circle: Pólya–Szegő, :mod:`analysis.resistance_model`)."""
    check_choice("conversion", conversion, CONVERSIONS)
    if conversion == "bulk":
        return "h/A (eq. 23)"
    if conversion == "physical":
        return "1/A (film σ_f/A; + Barber clean-metal and band constriction, computed)"
    return "√π/(2√A) (Holm single spot — an upper bound on the clean-metal constriction)"


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
    # the simulated weight within 1e-9 of each measured one (the lower if two are): ws sorted, so a neighbour
    j = np.clip(np.searchsorted(ws, w), 1, max(ws.size - 1, 1)) - 1
    tol = 1e-9 * np.maximum(np.abs(w), 1e-12)
    j = np.where(np.abs(ws[j] - w) <= tol, j, np.minimum(j + 1, ws.size - 1))
    hit = np.abs(ws[j] - w) <= tol
    out[hit] = a[j[hit]]
    bad = ~hit & ((w < ws[0]) | (w > ws[-1]) | (ws.size < 2) | (w <= 0) | (ws[0] <= 0))
    if np.any(bad):
        wi = float(w[np.argmax(bad)])
        raise SettingError("weight_kg", wi, f"measured weight outside the simulated range [{ws[0]:g}, {ws[-1]:g}] kg")
    if not np.all(hit):  # one PCHIP, evaluated at every other weight in one call (was a call per weight: ~1 s)
        from scipy.interpolate import PchipInterpolator

        interpolate = PchipInterpolator(np.log(ws), np.log(a))
        log_a = interpolate(np.array([math.log(wi) for wi in w[~hit]]))
        out[~hit] = [math.exp(v) for v in log_a.tolist()]
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


#: Bootstrap rows generated and consumed at a time: the (B, m) resample matrix is never held (160 MB for 2000
#: resamples of 10 000 weights), only (CHUNK, m) blocks (10 MB each).
BOOT_CHUNK = 128


@dataclass(frozen=True)
class _Resamples:
    """Bootstrap resamples of the repeats, shared by every model (weights held fixed).

    Mode "series": ``cols`` (B, r) the series drawn and ``counts`` (B, r) how often each; the resampled means are
    made ``chunk`` rows at a time by :meth:`blocks` (never all B × m at once). Mode "within": ``stored`` (B, m) the
    resampled repeat means [Ω] and ``var_of_mean`` (B, m) the resampled s_i²/n_i [Ω²], for studentizing (drawn weight
    by weight, so they are generated whole). ``series_ohm`` (r, m) the series / r [Ω] and ``offset`` (m,) a known
    term subtracted from every resampled mean [Ω] (:func:`_shifted`).
    """

    mode: str
    n_boot: int
    cols: np.ndarray | None = None
    counts: np.ndarray | None = None
    series_ohm: np.ndarray | None = None
    stored: np.ndarray | None = None
    var_of_mean: np.ndarray | None = None
    offset: np.ndarray | None = None
    chunk: int = BOOT_CHUNK

    def blocks(self) -> Iterator[tuple[slice, np.ndarray]]:
        """(rows, resampled means [Ω] of those rows) for consecutive blocks of ``chunk`` rows.

        Each row is computed on its own, in a fixed order (Σ_k counts_k · series_k, then − offset: no BLAS, whose
        blocking and threads change the rounding with the number of rows), so every row is the same bit for bit
        whatever the block size."""
        for a in range(0, self.n_boot, self.chunk):
            rows = slice(a, min(a + self.chunk, self.n_boot))
            if self.stored is not None:
                means = self.stored[rows]
            else:
                assert self.counts is not None and self.series_ohm is not None
                c = self.counts[rows]
                means = c[:, :1] * self.series_ohm[0]
                for k in range(1, c.shape[1]):
                    means += c[:, k : k + 1] * self.series_ohm[k]
            yield rows, means if self.offset is None else means - self.offset


def _resample(
    curve: MeasuredCurve, mode: str, n_boot: int, rng: np.random.Generator, chunk: int | None = None
) -> _Resamples:
    """Resample the repeats with replacement: whole series (``"series"``) or within each weight (``"within"``);
    ``chunk`` the rows per block of :meth:`_Resamples.blocks` (default :data:`BOOT_CHUNK`; the result is the same
    bit for bit whatever it is)."""
    chunk = BOOT_CHUNK if chunk is None else chunk
    v = curve.values_ohm
    m, r = v.shape
    if mode == "series":
        cols = rng.integers(0, r, size=(n_boot, r))  # (B, r): small; the (B, m) means are made block by block
        counts = np.zeros((n_boot, r))  # how often each series is drawn: no (m, n_boot, r) copy (1 GB at m = 10 000)
        np.add.at(counts, (np.arange(n_boot)[:, None], cols), 1.0)
        return _Resamples(mode, n_boot, cols=cols, counts=counts, series_ohm=v.T / r, chunk=chunk)
    means = np.empty((n_boot, m))
    var = np.zeros((n_boot, m))
    for i in range(m):
        row = v[i][np.isfinite(v[i])]
        draw = row[rng.integers(0, row.size, size=(n_boot, row.size))]
        means[:, i] = draw.mean(axis=1)
        if row.size >= 2:
            var[:, i] = draw.var(axis=1, ddof=1) / row.size
    return _Resamples(mode, n_boot, stored=means, var_of_mean=var, chunk=chunk)


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


#: A resample's standard error below this fraction of the sample's is zero up to rounding (one series drawn r times).
_DEGENERATE = 1e-9


def _distinct_resamples(curve: MeasuredCurve, mode: str) -> float:
    """How many different resamples exist: multisets of r out of r series (C(2r−1, r)), or the product of these over
    the weights when resampling within each weight."""
    if mode == "series":
        r = curve.values_ohm.shape[1]
        return float(math.comb(2 * r - 1, r))
    total = 1.0
    for n in curve.n:
        total *= float(math.comb(2 * int(n) - 1, int(n)))
    return total


def _units_text(curve: MeasuredCurve, mode: str) -> str:
    if mode == "series":
        return f"{curve.values_ohm.shape[1]} series"
    return f"{int(np.min(curve.n))} repeats per weight"


def _bootstrap_availability(
    curve: MeasuredCurve, mode: str, level: float, boot: np.ndarray | None, ci: np.ndarray, degenerate: float
) -> str:
    """Why the bootstrap interval is not available ("" when it is): no resamples, too few distinct resamples to
    resolve the tails, too many degenerate resamples (infinite studentized t), or a non-finite interval."""
    units = _units_text(curve, mode)
    if boot is None:
        return "not computed (no bootstrap resamples were asked for)"
    needed = math.ceil(2.0 / (1.0 - level))
    distinct = _distinct_resamples(curve, mode)
    if distinct < needed:
        return (
            f"not available with {units}: only {distinct:.0f} distinct resamples exist, and a {level:.0%} interval "
            f"needs ≥ {needed} to resolve its {(1 - level) / 2:.1%} tails"
        )
    tail = (1.0 - level) / 2.0
    if degenerate >= tail:
        return (
            f"not available with {units}: {degenerate:.1%} of the resamples have no spread (one series drawn every "
            f"time), so their studentized t is infinite; a {level:.0%} interval needs fewer than {tail:.1%}"
        )
    if not np.all(np.isfinite(ci)):
        return f"not available with {units}: the bootstrap distribution is degenerate (non-finite interval)"
    return ""


def _bootstrap_ci(
    curve: MeasuredCurve,
    wls: np.ndarray,
    p: np.ndarray,
    res: _Resamples,
    level: float,
    interval: str,
    inflate: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Bootstrap parameters (B, 2) and the (2, 2) interval [[lo_R, lo_s], [hi_R, hi_s]] (module docstring).

    Studentized: t*_b = (p*_b − p̂)/se*_b with se* the resample's own repeat standard error; interval
    [p̂ − t*_(1−α/2)·se, p̂ − t*_(α/2)·se]. A resample that drew one series r times has se* = 0 and t* = ±∞
    (probability r^(1−r)); it is kept, so very few series give wide (honest) intervals rather than NaN.
    ``inflate`` (2,) widens the interval about p̂ by the error rule's factor (χ²-scaled errors larger than the
    repeats' own: :func:`_error_rule`), so the bootstrap follows the same rule as the t-intervals.
    """
    k = np.ones(2) if inflate is None else np.asarray(inflate, dtype=float)
    probs = (0.5 * (1.0 - level), 0.5 * (1.0 + level))
    if res.mode == "series":
        q = curve.values_ohm.T @ wls.T  # (r, 2)
        qb = q[res.cols]  # (B, r, 2)
        boot = qb.mean(axis=1)
        se_b = qb.std(axis=1, ddof=1) / math.sqrt(q.shape[0]) if interval == "studentized" else None
    else:
        assert res.stored is not None
        boot = res.stored @ wls.T
        se_b = np.sqrt(res.var_of_mean @ (wls**2).T) if interval == "studentized" else None
    if se_b is None:
        q = _quantiles(boot, probs)
        return boot, p + k * (q - p)
    se = _repeat_se(curve, wls, res.mode) * k
    dev = boot - p
    ok = se_b > _DEGENERATE * se  # a resample of one series: spread zero up to rounding, t infinite
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(ok, dev / np.where(ok, se_b, 1.0), np.sign(dev) * np.inf)
    t = np.nan_to_num(t, nan=0.0, posinf=np.inf, neginf=-np.inf)
    tq = _quantiles(t, probs)
    with np.errstate(invalid="ignore"):
        ci = np.vstack((p - tq[1] * se, p - tq[0] * se))
    return boot, ci


def _export(obj: Any) -> Any:
    """JSON-ready copy of a result: dataclass fields (recursively) as dicts, arrays and tuples as lists, non-finite
    floats as None. A field with ``metadata={"export": False}`` is left out, ``metadata={"key": ...}`` renames it."""
    if is_dataclass(obj) and not isinstance(obj, type):
        return {
            f.metadata.get("key", f.name): _export(getattr(obj, f.name))
            for f in fields(obj)
            if f.metadata.get("export", True)
        }
    if isinstance(obj, Mapping):
        return {str(k): _export(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_export(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _export(obj.tolist())
    if isinstance(obj, np.generic):
        return _export(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


class _Result:
    """Base of the result objects: :meth:`as_dict` is generated from the fields (see :func:`_export`)."""

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready nested dict of every field (floats, lists, strings; NaN and ±inf as None)."""
        out: dict[str, Any] = _export(self)
        return out


@dataclass(frozen=True, eq=False)
class Estimate(_Result):
    """The parameters of R = R_s + s·x: ``R_series_ohm`` R_s [Ω] and ``scale`` s [Ω·m] (an effective resistivity;
    Ω·m² for the film term, ``scale_units``), their standard errors and covariance ``cov`` (order R_s, s), the
    correlation coefficient of the two estimates, ``c_hat`` ĉ = χ²/ν of this fit and ``error_rule`` which
    covariance the errors come from, in words (:func:`_error_rule`: the paired-series / repeat covariance, or the
    curvature covariance scaled by ĉ when the data are over-dispersed and that is larger), and ``chi2_scaled``
    which of (R_s, s) has the χ²-scaled error (decided per parameter)."""

    R_series_ohm: float
    R_series_se: float
    scale: float
    scale_se: float
    cov: np.ndarray
    correlation: float
    scale_units: str = "ohm*m"
    error_rule: str = ""
    c_hat: float = math.nan
    chi2_scaled: tuple[bool, bool] = (False, False)

    @property
    def params(self) -> np.ndarray:
        """(R_s, s) as an array, the order of ``cov``."""
        return np.array([self.R_series_ohm, self.scale])


@dataclass(frozen=True)
class TIntervals(_Result):
    """Student-t intervals p̂ ± t_ν·SE per parameter, ν = ``dof`` (one per parameter; inf: normal quantile)."""

    R_series_ohm: tuple[float, float]
    scale: tuple[float, float]
    dof: tuple[float, float]
    method: str = "student-t"


@dataclass(frozen=True)
class BootstrapIntervals(_Result):
    """Bootstrap intervals per parameter. ``method``: "studentized" (bootstrap-t) or "percentile"; ``resampling``:
    the repeats resampled as whole "series" or "within" each weight. ``available`` false (intervals NaN) when they
    cannot be computed honestly — no resamples, too few distinct resamples, too many degenerate ones — and ``note``
    says which, e.g. "not available with 3 series: only 10 distinct resamples exist, …"."""

    R_series_ohm: tuple[float, float]
    scale: tuple[float, float]
    method: str
    n_boot: int
    resampling: str
    available: bool = True
    note: str = ""


@dataclass(frozen=True)
class Intervals(_Result):
    """Confidence intervals at ``level`` by both methods: ``t`` (:class:`TIntervals`) and ``bootstrap``
    (:class:`BootstrapIntervals`)."""

    level: float
    t: TIntervals
    bootstrap: BootstrapIntervals


@dataclass(frozen=True)
class GoodnessOfFit(_Result):
    """χ² with ``dof`` = weights − 2 degrees of freedom, ``reduced_chi2`` = χ²/dof, ``p_value`` the tail
    probability of ``reference`` (F(dof, ν) when σ is pooled over ν degrees of freedom, else χ²(dof)); ``aic`` =
    χ² + 2k, ``bic`` = χ² + k ln n (k = ``n_parameters``); ``rmse_ohm`` the unweighted RMS residual [Ω]."""

    chi2: float
    dof: int
    reduced_chi2: float
    p_value: float
    reference: str
    aic: float
    bic: float
    rmse_ohm: float
    n_parameters: int = 2


@dataclass(frozen=True, eq=False)
class Diagnostics(_Result):
    """What :func:`scipy.optimize.least_squares` reported (``nfev``, ``njev``, ``status``, ``message``, ``success``,
    ``cost``, ``optimality``; ``cov_ls`` its (JᵀJ)⁻¹), ``linear_check`` the largest relative difference from the
    closed-form weighted least-squares solution, and ``warnings`` about the fit in words."""

    nfev: int
    njev: int
    status: int
    message: str
    success: bool
    cost: float
    optimality: float
    cov_ls: np.ndarray
    linear_check: float
    warnings: tuple[str, ...] = ()


@dataclass(frozen=True, eq=False)
class FitPoints(_Result):
    """Per weight: ``weight_kg``, the model's ``area_m2``, ``regressor_per_m`` x(A), the ``measured_ohm`` means,
    their ``sigma_ohm`` (the weighting's σ), ``fitted_ohm``, ``residuals_ohm`` (measured − fitted) and
    ``normalised_residuals`` (residual/σ)."""

    weight_kg: np.ndarray
    area_m2: np.ndarray
    regressor_per_m: np.ndarray
    measured_ohm: np.ndarray
    sigma_ohm: np.ndarray
    fitted_ohm: np.ndarray
    residuals_ohm: np.ndarray
    normalised_residuals: np.ndarray


@dataclass(frozen=True, eq=False)
class ModelFit(_Result):
    """One model's fit R = R_s + s·x(A(W)) (module docstring). SI units: Ω, Ω·m, 1/m.

    ``model``, ``conversion`` (x = h/A or the Holm form), ``weighting`` (σ per weight); ``estimate``
    (:class:`Estimate`), ``intervals`` (:class:`Intervals`: t and bootstrap), ``goodness`` (:class:`GoodnessOfFit`),
    ``diagnostics`` (:class:`Diagnostics`), ``points`` (:class:`FitPoints`, per weight). ``boot_params`` (B, 2) the
    bootstrap estimates (None without bootstrap; not exported by :meth:`as_dict`). ``unphysical``: why the fit is
    unphysical, in words (empty: physical; module docstring). ``shares`` each term's share of the measured mean per
    weight (:func:`_shares`); ``load_independent`` why the slope says the resistance does not depend on the load
    ("" when it does; such a fit is not ranked).
    """

    model: str
    conversion: str
    weighting: str
    estimate: Estimate
    intervals: Intervals
    goodness: GoodnessOfFit
    diagnostics: Diagnostics
    points: FitPoints
    boot_params: np.ndarray | None = field(default=None, repr=False, metadata={"export": False})
    unphysical: tuple[str, ...] = ()
    shares: dict[str, np.ndarray] = field(default_factory=dict)
    load_independent: str = ""

    @property
    def physical(self) -> bool:
        """False when a parameter is significantly outside its physical range (``unphysical`` says which)."""
        return not self.unphysical


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
        d = curve.values_ohm - curve.values_ohm.mean(axis=1, keepdims=True)
        q = wls @ d  # M C Mᵀ with C = d dᵀ/((r − 1) r), never formed: (m, m) is 800 MB for 10 000 weights
        return q @ q.T / ((r - 1) * r), np.full(2, float(r - 1))
    if weighting == "blocks" or np.any(n < 2):
        return (wls * sigma**2) @ wls.T, np.full(2, math.inf)
    var = curve.sem_ohm**2  # each weight's own scatter, whatever the weighting
    cov = (wls * var) @ wls.T
    terms = (wls**2) * var  # (2, m)
    dof = np.sum(terms, axis=1) ** 2 / np.sum(terms**2 / (n - 1), axis=1)
    return cov, dof


def _solve(x: np.ndarray, y: np.ndarray, sigma: np.ndarray) -> tuple[Any, np.ndarray]:
    """least_squares ('lm') on the weighted residuals, and the closed-form WLS matrix M (p = M ȳ, shape (2, m))."""
    from scipy.optimize import least_squares

    def residuals(p: np.ndarray) -> np.ndarray:
        return (p[0] + p[1] * x - y) / sigma

    jac_const = np.column_stack((1.0 / sigma, x / sigma))
    # A deliberately crude start (line through the end points); the optimum does not depend on it.
    slope0 = (y[-1] - y[0]) / (x[-1] - x[0]) if x[-1] != x[0] else y.mean() / x.mean()
    p0 = np.array([y[0] - slope0 * x[0], slope0])
    res = least_squares(
        residuals, p0, jac=lambda p: jac_const, method="lm", x_scale="jac", ftol=1e-14, xtol=1e-14, gtol=1e-14
    )
    # Closed-form weighted least squares: the same estimator, p = M ȳ; a check on the solver, and what the
    # covariance, the per-series estimates and the bootstrap are built on.
    wls = np.linalg.solve(jac_const.T @ jac_const, jac_const.T / sigma)
    return res, wls


def _goodness(curve: MeasuredCurve, resid: np.ndarray, sigma: np.ndarray, weighting: str) -> GoodnessOfFit:
    from scipy.special import chdtrc, fdtrc

    m = resid.size
    k = 2
    chi2 = float(np.sum((resid / sigma) ** 2))
    dof = m - k
    nu = float(np.sum(curve.n - 1))
    if dof <= 0:
        p_value, reference = math.nan, "none (dof = 0)"
    elif weighting in ("relative", "pooled"):
        p_value, reference = float(fdtrc(dof, nu, chi2 / dof)), f"F({dof}, {nu:g})"
    else:
        p_value, reference = float(chdtrc(dof, chi2)), f"chi2({dof})"
    return GoodnessOfFit(
        chi2=chi2,
        dof=dof,
        reduced_chi2=chi2 / dof if dof > 0 else math.nan,
        p_value=p_value,
        reference=reference,
        aic=chi2 + 2 * k,
        bic=chi2 + k * math.log(m),
        rmse_ohm=float(np.sqrt(np.mean(resid**2))),
        n_parameters=k,
    )


def _warnings(
    curve: MeasuredCurve, est: Estimate, t_hi_r: float, gof: GoodnessOfFit, weighting: str, level: float
) -> tuple[str, ...]:
    """The fit's caveats in words (excess scatter, narrow intervals, unphysical parameters)."""
    notes = []
    if gof.dof > 0 and gof.reduced_chi2 > 1.5:
        notes.append(
            f"χ²/dof = {gof.reduced_chi2:.3g}: the scatter about the fit exceeds the repeat scatter (over-dispersed); "
            f"errors: {est.error_rule}"
        )
    if weighting == "repeats" and int(np.min(curve.n)) < 30:
        notes.append(
            f"weights from each weight's own {int(np.min(curve.n))}+ repeats: intervals run narrow and χ² high "
            "(module docstring); weighting 'relative' or 'pooled' holds the stated level"
        )
    if t_hi_r < 0:
        notes.append(
            f"negative series resistance ({est.R_series_ohm:.3g} Ω, {level:.0%} upper limit {t_hi_r:.3g} Ω): the "
            "model's shape does not follow the data"
        )
    elif est.R_series_ohm < 0:
        notes.append(
            f"negative series resistance estimate ({est.R_series_ohm:.3g} ± {est.R_series_se:.2g} Ω), not "
            f"significantly below zero at {level:.0%} ({level:.0%} upper limit {t_hi_r:.3g} Ω)"
        )
    if est.scale <= 0:
        notes.append(f"non-positive scale ({est.scale:.3g} Ω·m): resistance does not fall as the model's area grows")
    return tuple(notes)


def _intervals(
    curve: MeasuredCurve,
    wls: np.ndarray,
    est: Estimate,
    dof_eff: np.ndarray,
    resamples: _Resamples | None,
    *,
    bootstrap: str,
    ci_level: float,
    boot_interval: str,
    inflate: np.ndarray | None = None,
) -> tuple[Intervals, np.ndarray | None]:
    """t and bootstrap intervals of both parameters, and the bootstrap estimates (None without resamples)."""
    p, se = est.params, np.array([est.R_series_se, est.scale_se])
    half = np.array([_t_quantile(ci_level, nu) for nu in dof_eff]) * se
    t = TIntervals(
        R_series_ohm=(float(p[0] - half[0]), float(p[0] + half[0])),
        scale=(float(p[1] - half[1]), float(p[1] + half[1])),
        dof=(float(dof_eff[0]), float(dof_eff[1])),
    )
    boot: np.ndarray | None = None
    ci = np.full((2, 2), math.nan)
    degenerate = 0.0
    if resamples is not None:
        boot, ci = _bootstrap_ci(curve, wls, p, resamples, ci_level, boot_interval, inflate)
        if boot_interval == "studentized":
            degenerate = _degenerate_fraction(curve, wls, resamples)
    why = _bootstrap_availability(curve, bootstrap, ci_level, boot, ci, degenerate)
    if why:
        ci = np.full((2, 2), math.nan)
    b = BootstrapIntervals(
        R_series_ohm=(float(ci[0, 0]), float(ci[1, 0])),
        scale=(float(ci[0, 1]), float(ci[1, 1])),
        method=boot_interval,
        n_boot=0 if boot is None else int(boot.shape[0]),
        resampling=bootstrap,
        available=not why,
        note=why,
    )
    return Intervals(level=ci_level, t=t, bootstrap=b), boot


def _degenerate_fraction(curve: MeasuredCurve, wls: np.ndarray, res: _Resamples) -> float:
    """Share of resamples whose own standard error of R_s is zero up to rounding (studentized t infinite)."""
    se = _repeat_se(curve, wls, res.mode)[0]
    if res.mode == "series":
        q = (curve.values_ohm.T @ wls.T)[:, 0]
        se_b = q[res.cols].std(axis=1, ddof=1) / math.sqrt(q.size)
    else:
        assert res.var_of_mean is not None
        se_b = np.sqrt(res.var_of_mean @ (wls[0] ** 2))
    return float(np.mean(~(se_b > _DEGENERATE * se)))


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
    offset_ohm: np.ndarray | None = None,
    scale_units: str = "ohm*m",
    offset_terms: Mapping[str, np.ndarray] | None = None,
) -> ModelFit:
    offset = np.zeros_like(sigma) if offset_ohm is None else np.asarray(offset_ohm, dtype=float)
    if offset_ohm is not None:  # known terms (the clean-metal constriction) subtracted from every repeat
        curve, resamples = _shifted(curve, resamples, offset_ohm)
    y = curve.mean_ohm
    if np.ptp(x) <= 1e-12 * np.max(np.abs(x)):
        raise SettingError(f"{model} contact area", area.tolist(), "expected an area that changes with weight")
    res, wls = _solve(x, y, sigma)
    p = res.x
    p_lin = wls @ y
    paired = bootstrap == "series" and curve.values_ohm.shape[1] >= 2 and weighting != "blocks"
    fitted = p[0] + p[1] * x
    resid = y - fitted
    gof = _goodness(curve, resid, sigma, weighting)
    cov_rep, dof_rep = _parameter_covariance(curve, wls, sigma, paired=paired, weighting=weighting)
    cov, dof_eff, rule, scaled = _error_rule(
        cov_rep, dof_rep, (wls * sigma**2) @ wls.T, gof, paired=paired, curve=curve
    )
    se = np.sqrt(np.diag(cov))
    est = Estimate(
        R_series_ohm=float(p[0]),
        R_series_se=float(se[0]),
        scale=float(p[1]),
        scale_se=float(se[1]),
        cov=cov,
        correlation=float(cov[0, 1] / math.sqrt(cov[0, 0] * cov[1, 1])),
        scale_units=scale_units,
        error_rule=rule,
        c_hat=gof.reduced_chi2,
        chi2_scaled=scaled,
    )
    intervals, boot = _intervals(
        curve, wls, est, dof_eff, resamples, bootstrap=bootstrap, ci_level=ci_level, boot_interval=boot_interval,
        inflate=se / np.sqrt(np.diag(cov_rep)),
    )  # fmt: skip
    diagnostics = Diagnostics(
        nfev=int(res.nfev),
        njev=int(res.njev or 0),
        status=int(res.status),
        message=str(res.message),
        success=bool(res.success),
        cost=float(res.cost),
        optimality=float(res.optimality),
        cov_ls=np.linalg.inv(res.jac.T @ res.jac),
        linear_check=float(np.max(np.abs(p - p_lin) / np.maximum(np.abs(p_lin), se * 1e-6))),
        warnings=_warnings(curve, est, intervals.t.R_series_ohm[1], gof, weighting, ci_level),
    )
    points = FitPoints(
        weight_kg=curve.weight_kg.copy(),
        area_m2=area,
        regressor_per_m=x,
        measured_ohm=y + offset,
        sigma_ohm=sigma,
        fitted_ohm=fitted + offset,
        residuals_ohm=resid,
        normalised_residuals=resid / sigma,
    )
    return ModelFit(
        model=model,
        conversion=conversion,
        weighting=weighting,
        estimate=est,
        intervals=intervals,
        goodness=gof,
        diagnostics=diagnostics,
        points=points,
        boot_params=boot,
        unphysical=_unphysical(est, intervals, curve),
        shares=_shares(est, x, y + offset, conversion, offset_terms),
        load_independent=_load_independent(est, intervals),
    )


def _shares(
    est: Estimate, x: np.ndarray, measured: np.ndarray, conversion: str, terms: Mapping[str, np.ndarray] | None
) -> dict[str, np.ndarray]:
    """Each term's share of the measured mean per weight [-]: "series" R_s, the area term s·x ("film" for the
    physical model, else "area_term"), every known term (e.g. "barber", "macro") and last "residual", the part of
    the measured mean the fit does not reach, (measured − fitted)/measured: the terms add up to fitted/measured, so
    with the residual every weight's shares add up to 1 (100 %)."""
    out = {
        "series": np.full(x.shape, est.R_series_ohm) / measured,
        ("film" if conversion == "physical" else "area_term"): est.scale * x / measured,
    }
    for name, values in (terms or {}).items():
        out[name] = np.asarray(values, dtype=float) / measured
    out["residual"] = 1.0 - np.sum(list(out.values()), axis=0)
    return out


def load_independent_slope(scale_low: Any) -> Any:
    """True where the slope's t-interval lower limit ≤ 0 (the resistance does not depend on the load; not ranked).
    Arrays welcome (the design's simulated sessions apply the same rule)."""
    return np.asarray(scale_low) <= 0


def unphysical_limits(series_high_ohm: Any, scale_high: Any) -> Any:
    """True where a fit is unphysical: R_s significantly < 0 (t upper limit < 0) or s significantly ≤ 0 (upper limit
    ≤ 0). Arrays welcome (the design's simulated sessions apply the same rule)."""
    return (np.asarray(series_high_ohm) < 0) | (np.asarray(scale_high) <= 0)


def scaled_errors(c_hat: Any, dof: Any, curvature_var: Any, repeat_var: Any) -> Any:
    """True where a parameter's error is the χ²-scaled curvature one (:func:`_error_rule`): over-dispersed (ĉ >
    :data:`OVERDISPERSION`, ν > 0) and its ĉ·(JᵀJ)⁻¹ variance ``curvature_var``·ĉ larger than its repeats' variance
    ``repeat_var``; decided for each parameter on its own. Arrays welcome."""
    c = np.asarray(c_hat, dtype=float)
    return (np.asarray(dof) > 0) & (c > OVERDISPERSION) & (np.asarray(curvature_var) * c > np.asarray(repeat_var))


def _load_independent(est: Estimate, intervals: Intervals) -> str:
    """Why the fit says the resistance does not depend on the load ("" when it does): the slope s is consistent with
    zero or negative (the t-interval's lower limit ≤ 0, :func:`load_independent_slope`). Such a fit is not ranked."""
    lo, hi = intervals.t.scale
    if not load_independent_slope(lo):
        return ""
    return (
        f"s = {est.scale:.3g} ± {est.scale_se:.2g} (t-interval [{lo:.3g}, {hi:.3g}]) is consistent with zero or "
        "negative: the resistance does not depend on the load: this is not a contact-area measurement"
    )


#: ĉ = χ²/ν above which the data count as over-dispersed: errors scaled, models ranked by QAIC (Burnham & Anderson
#: 2002 §2.5 use ĉ > 1 beyond chance; 1.5 keeps the ordinary rule for the chance excess of a well-fitting model).
OVERDISPERSION = 1.5


def _error_rule(
    cov_rep: np.ndarray,
    dof_rep: np.ndarray,
    cov_curv: np.ndarray,
    gof: GoodnessOfFit,
    *,
    paired: bool,
    curve: MeasuredCurve,
) -> tuple[np.ndarray, np.ndarray, str, tuple[bool, bool]]:
    """The one rule for every fitted quantity: (covariance, degrees of freedom per parameter, the rule in words,
    which of (R_s, s) have the χ²-scaled error).

    Errors come from the repeats — the paired-series covariance (series correlation across weights included) or
    each weight's own scatter — unless the fit is over-dispersed (ĉ = χ²/ν > :data:`OVERDISPERSION`): a lack of fit
    common to every series is invisible to the repeat scatter, so then the curvature covariance (JᵀJ)⁻¹ scaled by
    ĉ (quasi-likelihood, ν degrees of freedom: what ``scipy.optimize.curve_fit(absolute_sigma=False)`` gives) is
    used for each parameter whose χ²-scaled variance is the larger, parameter by parameter (so R_s and s can follow
    different sources). The covariance is then SE_R·SE_s·ρ off the diagonal, ρ the correlation of the χ²-scaled
    covariance when either error is χ²-scaled (the design's correlation, which the lack of fit does not change),
    else the repeats'.
    """
    c_hat = gof.reduced_chi2
    r = curve.values_ohm.shape[1]
    if paired:
        base = f"paired-series covariance ({r} independent series, {r - 1} dof)"
    elif np.all(np.isinf(dof_rep)):
        base = "within-block standard errors"
    else:
        base = "each weight's own repeat scatter (Welch dof)"
    scaled_var = np.diag(cov_curv) * c_hat
    scaled = (
        bool(scaled_errors(c_hat, gof.dof, cov_curv[0, 0], cov_rep[0, 0])),
        bool(scaled_errors(c_hat, gof.dof, cov_curv[1, 1], cov_rep[1, 1])),
    )
    extra = f"; χ²/ν = {c_hat:.3g}" if gof.dof > 0 and math.isfinite(c_hat) else ""
    if not any(scaled):
        return cov_rep, dof_rep, base + extra, scaled
    if all(scaled):
        rule = f"χ²-scaled: (JᵀJ)⁻¹·χ²/ν, χ²/ν = {c_hat:.3g} ({gof.dof} dof; larger than the {base})"
        return cov_curv * c_hat, np.full(2, float(gof.dof)), rule, scaled
    se = np.sqrt(np.where(scaled, scaled_var, np.diag(cov_rep)))
    rho = cov_curv[0, 1] / math.sqrt(cov_curv[0, 0] * cov_curv[1, 1])
    cov = np.array([[se[0] ** 2, rho * se[0] * se[1]], [rho * se[0] * se[1], se[1] ** 2]])
    source = {True: f"χ²-scaled ((JᵀJ)⁻¹·χ²/ν, {gof.dof} dof)", False: f"from the {base}"}
    rule = f"per parameter, the larger: R_s {source[scaled[0]]}, s {source[scaled[1]]}; χ²/ν = {c_hat:.3g}"
    return cov, np.where(scaled, float(gof.dof), dof_rep), rule, scaled


def _shifted(
    curve: MeasuredCurve, resamples: _Resamples | None, offset_ohm: np.ndarray
) -> tuple[MeasuredCurve, _Resamples | None]:
    """``curve`` and its bootstrap resamples with a known term ``offset_ohm`` (per weight) [Ω] subtracted."""
    import dataclasses

    off = np.asarray(offset_ohm, dtype=float)
    if off.shape != curve.weight_kg.shape or not np.all(np.isfinite(off)):
        raise SettingError("offset_ohm", off.tolist(), f"expected finite values, shape {curve.weight_kg.shape}")
    shifted = dataclasses.replace(curve, values_ohm=curve.values_ohm - off[:, None])
    if resamples is not None and resamples.stored is not None:
        resamples = dataclasses.replace(resamples, stored=resamples.stored - off)
    elif resamples is not None:  # subtracted block by block (:meth:`_Resamples.blocks`)
        resamples = dataclasses.replace(resamples, offset=off)
    return shifted, resamples


def _unphysical(est: Estimate, intervals: Intervals, curve: MeasuredCurve) -> tuple[str, ...]:
    """Why the fit is physically impossible (empty when it is not): R_s significantly < 0, s significantly ≤ 0."""
    out = []
    factor, unit = resistance_unit(curve.mean_ohm)
    hi_r, hi_s, lvl = intervals.t.R_series_ohm[1], intervals.t.scale[1], f"{intervals.level:.0%}"
    if not unphysical_limits(hi_r, hi_s):
        return ()
    if hi_r < 0:
        out.append(
            f"R_s = {est.R_series_ohm * factor:.3g} ± {est.R_series_se * factor:.2g} {unit} is significantly below "
            f"zero ({lvl} upper limit {hi_r * factor:.3g} {unit}): a series resistance cannot be negative"
        )
    if hi_s <= 0:
        out.append(
            f"s = {est.scale:.3g} ± {est.scale_se:.2g} Ω·m is significantly ≤ 0 ({lvl} upper limit {hi_s:.3g}): "
            "the resistance would grow with the contact area"
        )
    return tuple(out)


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


def series_dependence(curve: MeasuredCurve) -> Any:
    """:func:`analysis.series_dependence.find_dependence` of ``curve``'s series, its notes naming the weights [kg]
    and showing resistances in the unit the data call for (:func:`analysis.resistance.resistance_unit`)."""
    from analysis.resistance import resistance_unit
    from analysis.series_dependence import find_dependence

    rows = tuple(f"{w:g} kg" for w in curve.weight_kg)
    return find_dependence(curve.values_ohm, curve.repeat_labels, rows=rows, unit=resistance_unit(curve.values_ohm))


def independent_series(curve: MeasuredCurve) -> tuple[MeasuredCurve, tuple[str, ...]]:
    """``curve`` with the series that are arithmetic copies of others left out (:mod:`analysis.series_dependence`:
    Tab. 1's M4 = mean(M1..M3) at 7 of 8 weights — a print error at 5.44 kg — and M5, M6 = M4 + offsets that change
    with weight), and what was found, in words (:func:`series_dependence`); unchanged (and no notes) when nothing is
    derived or the repeats are not paired series."""
    import dataclasses

    if not curve.paired:
        return curve, ()
    dep = series_dependence(curve)
    if not dep.dropped:
        return curve, dep.notes
    keep = list(dep.keep)
    labels = tuple(curve.repeat_labels[k] for k in keep) if curve.repeat_labels else ()
    dropped = ", ".join(curve.repeat_labels[k] if curve.repeat_labels else f"series {k + 1}" for k in dep.dropped)
    sem = None if curve.block_sem_ohm is None else curve.block_sem_ohm[:, keep]
    reduced = dataclasses.replace(curve, values_ohm=curve.values_ohm[:, keep], repeat_labels=labels, block_sem_ohm=sem)
    note = (
        f"{'; '.join(dep.notes)}: {dropped} counted once — left out of the fit, the degrees of freedom and the "
        f"bootstrap ({dep.n_independent} independent series)"
    )
    return reduced, (note,)


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


@dataclass(frozen=True, eq=False)
class ModelComparison(_Result):
    """Fits of every model to the same data, ranked by AIC, with a plain statement of what the data can tell.

    ``fits[name]`` each model's :class:`ModelFit` (``"models"`` in :meth:`as_dict`); ``delta_aic[name]`` AIC − min
    AIC, exactly 0 for a tie within ``tie_tolerance`` (:data:`TIE_TOLERANCE`, relative: round-off);
    ``akaike_weights`` exp(−Δ/2) normalised; ``first_fraction[name]`` the share of bootstrap resamples in which
    the model has the lowest χ² (weights held fixed); ``decisive_fraction`` the share in which the overall best model
    is first by Δχ²/ĉ ≥ 2; ``criterion`` "AIC", or "QAIC" = χ²/ĉ + 2(k + 1) when the best physical fit is
    over-dispersed (``c_hat`` = its χ²/ν > :data:`OVERDISPERSION`; ``delta_aic`` and the Akaike weights are then
    QAIC differences and weights); ``n_repeats`` the independent series or repeats fitted and ``series_notes`` the
    series left out as copies of others (:func:`independent_series`); ``discriminates`` true when the runner-up
    is at Δ(Q)AIC ≥ 2, the best model is first by ≥ 2 in ≥ 95 % of the resamples (residuals resampled when
    over-dispersed, :func:`_bootstrap_ranking`) *and* it fits within the repeat scatter (χ² tail probability ≥
    0.01); otherwise the statement says which condition failed.
    """

    fits: dict[str, ModelFit] = field(metadata={"key": "models"})
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
    criterion: str = "AIC"
    c_hat: float = math.nan
    series_notes: tuple[str, ...] = ()
    tie_tolerance: float = TIE_TOLERANCE

    @property
    def best(self) -> ModelFit:
        """The fit of the model with the lowest AIC."""
        return self.fits[self.ranking[0]]


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
    offset_terms: Mapping[str, Mapping[str, np.ndarray]] | None = None,
    scale_units: str | None = None,
) -> ModelComparison:
    """Fit every model in ``areas_m2`` (name → contact area at ``curve.weight_kg``) and rank them.

    The same bootstrap resamples are used for every model, so "how often is the best model first" compares
    like with like. Series that are copies of others are counted once (:func:`independent_series`).
    ``offset_terms[name]`` known terms per weight [Ω] by name (the physical model's "barber" and "macro"
    constriction), their sum subtracted before the fit and each term's share of the measured mean reported;
    ``scale_units`` the unit of s (default Ω·m, Ω·m² for ``conversion="physical"``). Other arguments as
    :func:`fit_model`.
    """
    if scale_units is None:
        scale_units = "ohm*m2" if conversion == "physical" else "ohm*m"
    offsets_ohm = None
    if offset_terms is not None:
        offsets_ohm = {n: np.sum([np.asarray(v, float) for v in t.values()], axis=0) for n, t in offset_terms.items()}
    if not areas_m2:
        raise SettingError("models", [], "expected at least one model")
    curve, series_notes = independent_series(curve)
    sigma, mode = _prepare(curve, weighting, bootstrap, ci_level, n_boot, boot_interval, seed)
    res = _resample(curve, mode, n_boot, np.random.default_rng(seed)) if n_boot else None
    fits: dict[str, ModelFit] = {}
    for name, area in areas_m2.items():
        area = np.asarray(area, dtype=float)
        if area.shape != curve.weight_kg.shape:
            raise SettingError(f"{name} contact area", f"shape {area.shape}", f"expected {curve.weight_kg.shape}")
        x = regressor(area, height_m, conversion)
        fits[name] = _fit_arrays(
            name, curve, area, x, sigma, res, conversion=conversion, weighting=weighting, bootstrap=mode,
            ci_level=ci_level, boot_interval=boot_interval,
            offset_ohm=None if offsets_ohm is None else offsets_ohm[name], scale_units=scale_units,
            offset_terms=None if offset_terms is None else offset_terms[name],
        )  # fmt: skip
    names = list(fits)
    c_hat, criterion = _overdispersion(fits)
    ic = {n: _criterion(fits[n].goodness, c_hat) for n in names}
    # physical fits first, by (Q)AIC; an unphysical fit is never ranked above a physical one
    ranking = tuple(sorted(names, key=lambda n: (not fits[n].physical, bool(fits[n].load_independent), ic[n])))
    best = ranking[0]
    delta = {n: _tie_to_zero(ic[n] - ic[best], ic[n], ic[best]) for n in names}
    lowest = min(ic.values())  # an unphysical fit may have a lower AIC than the best
    raw = {n: math.exp(-0.5 * (ic[n] - lowest)) for n in names}
    total = sum(raw.values())
    weights = {n: raw[n] / total for n in names}

    candidates = [n for n in names if fits[n].physical and not fits[n].load_independent] or names
    first, decisive = _bootstrap_ranking(
        fits, candidates, best, res, sigma, offsets_ohm, c_hat if criterion == "QAIC" else math.nan, seed
    )
    names = list(fits)

    discriminates, statement = _statement(
        fits, ranking, delta, first, decisive, n_boot if res is not None else 0, criterion=criterion, c_hat=c_hat
    )
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
        criterion=criterion,
        c_hat=c_hat,
        series_notes=series_notes,
    )


def _bootstrap_ranking(
    fits: Mapping[str, ModelFit],
    names: list[str],
    best: str,
    res: _Resamples | None,
    sigma: np.ndarray,
    offsets_ohm: Mapping[str, np.ndarray] | None,
    c_hat: float,
    seed: int | None,
) -> tuple[dict[str, float], float]:
    """(share of resamples in which each model has the lowest χ², share in which ``best`` is first by ≥ 2).

    Ordinarily the repeats' resamples ``res`` are used, with each model's bootstrap parameters. When the data are
    over-dispersed (``c_hat`` finite) the lack of fit is common to every series and resampling the repeats cannot
    show it: the residuals about the best fit are resampled instead (wild bootstrap, a random sign per weight),
    every model refitted, ĉ re-estimated per resample, and the margin is in Δχ²/ĉ. Both run ``res.chunk`` resamples
    at a time (no (B, m) array).
    """
    if res is None:
        return {}, math.nan
    if len(names) < 2:
        return {best: 1.0}, 1.0
    off = {n: np.zeros_like(sigma) if offsets_ohm is None else np.asarray(offsets_ohm[n], float) for n in names}
    table = np.empty((len(names), res.n_boot))  # χ² (models, B)
    if math.isfinite(c_hat):
        pb = fits[best].points
        rng = np.random.default_rng(None if seed is None else seed + 1)
        for a in range(0, res.n_boot, res.chunk):
            rows = slice(a, min(a + res.chunk, res.n_boot))
            signs = rng.choice([-1.0, 1.0], (rows.stop - a, sigma.size))  # the same stream as all B rows at once
            y_star = pb.fitted_ohm + pb.residuals_ohm * signs  # raw R (fitted_ohm includes the offset)
            for i, n in enumerate(names):
                table[i, rows] = _refit_chi2(fits[n].points.regressor_per_m, y_star - off[n], sigma)
        table = table / (np.min(table, axis=0) / max(sigma.size - 2, 1))
    else:
        for rows, means in res.blocks():
            for i, n in enumerate(names):
                params = fits[n].boot_params
                assert params is not None
                table[i, rows] = _chi2_rows(means, params[rows], fits[n].points.regressor_per_m, sigma, off[n])
    winner = np.argmin(table, axis=0)
    first = {n: float(np.mean(winner == i)) for i, n in enumerate(names)}
    ordered = np.sort(table, axis=0)
    margin = ordered[1] - ordered[0]
    return first, float(np.mean((winner == names.index(best)) & (margin >= DELTA_AIC_INDISTINGUISHABLE)))


def _refit_chi2(x: np.ndarray, y: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """χ² of the weighted straight-line fit y ≈ a + b·x for every row of ``y`` (n, m) [-].

    Closed form about the weighted means (w = 1/σ², b = Σw(x−x̄)(y−ȳ)/Σw(x−x̄)², χ² = Σw(y−ȳ−b(x−x̄))²), row by row
    along the contiguous axis: each row's χ² is the same bit for bit however many rows are passed."""
    w = 1.0 / sigma**2
    dx = x - np.sum(w * x) / np.sum(w)
    wdx = w * dx
    ybar = np.sum(y * w, axis=1) / np.sum(w)
    r = y - ybar[:, None]
    slope = np.sum(r * wdx, axis=1) / np.sum(wdx * dx)
    r -= slope[:, None] * dx
    np.square(r, out=r)
    return np.asarray(np.sum(r * w, axis=1))


def _overdispersion(fits: Mapping[str, ModelFit]) -> tuple[float, str]:
    """(ĉ, criterion): ĉ = χ²/ν of the best-fitting physical model (every model has k = 2, so none is more general;
    the best fit's χ²/ν is the smallest over-dispersion estimate), and "QAIC" when ĉ > :data:`OVERDISPERSION`."""
    pool = [f for f in fits.values() if f.physical and f.goodness.dof > 0] or [
        f for f in fits.values() if f.goodness.dof > 0
    ]
    if not pool:
        return math.nan, "AIC"
    c_hat = min(f.goodness.reduced_chi2 for f in pool)
    return c_hat, ("QAIC" if c_hat > OVERDISPERSION else "AIC")


def _tie_to_zero(delta: float, *values: float) -> float:
    """``delta``, or 0.0 when it is round-off: |Δ| ≤ :data:`TIE_TOLERANCE`·max(1, |values|)."""
    scale = max([1.0, *(abs(v) for v in values if math.isfinite(v))])
    return 0.0 if abs(delta) <= TIE_TOLERANCE * scale else delta


def _criterion(g: GoodnessOfFit, c_hat: float) -> float:
    """AIC = χ² + 2k, or QAIC = χ²/ĉ + 2(k + 1) (ĉ counted as a parameter) when ĉ > :data:`OVERDISPERSION`."""
    if math.isfinite(c_hat) and c_hat > OVERDISPERSION:
        return g.chi2 / c_hat + 2 * (g.n_parameters + 1)
    return g.aic


def _chi2_rows(
    means: np.ndarray, params: np.ndarray, x: np.ndarray, sigma: np.ndarray, offset: np.ndarray
) -> np.ndarray:
    """Σ((means − offset − (p₀ + p₁·x))/σ)² of each row [-]: resampled means (n, m) [Ω] and their parameters (n, 2),
    elementwise and summed along the contiguous axis, so each row's value does not depend on the rows beside it."""
    z = means - offset
    z -= params[:, :1]
    z -= params[:, 1:] * x
    z /= sigma
    np.square(z, out=z)
    return np.asarray(np.sum(z, axis=1))


def _statement(
    fits: dict[str, ModelFit],
    ranking: tuple[str, ...],
    delta: dict[str, float],
    first: dict[str, float],
    decisive: float,
    n_boot: int,
    *,
    criterion: str = "AIC",
    c_hat: float = math.nan,
) -> tuple[bool, str]:
    """The verdict in words, models by their display labels (:func:`sims.models.model_label`)."""
    best = ranking[0]
    fb = fits[best].goodness
    flat = [n for n in ranking if fits[n].physical and fits[n].load_independent]
    physical = [n for n in ranking if fits[n].physical and not fits[n].load_independent]
    if flat and not physical:
        return False, _flat_phrase(fits, flat)
    parts = [_flat_phrase(fits, flat)] if flat else []
    if criterion == "QAIC":
        parts.append(
            f"The data are over-dispersed (ĉ = χ²/ν = {c_hat:.3g} for the best fit, > {OVERDISPERSION:g}): models "
            "are ranked by QAIC = χ²/ĉ + 2(k + 1), not by AIC on the raw χ², and each parameter's standard error is "
            "the larger of its repeats' and its χ²-scaled one."
        )
    ranked, close, discriminates = _ranking_phrases(fits, physical, delta, first, decisive, n_boot, criterion)
    parts += ranked
    parts += _unphysical_phrases(fits, ranking, physical)
    misfit = fb.dof > 0 and fb.p_value < 0.01
    if misfit:
        parts.append(
            f"No model fits within the repeat scatter: the best has χ²/dof = {fb.reduced_chi2:.2f} "
            f"(p = {fb.p_value:.2g}), so the ranking compares misfits and confirms none of the models."
        )
        discriminates = False
    if not physical:
        parts.append("Verdict: no model gives a physical fit; no model is confirmed.")
        return False, " ".join(parts)
    if discriminates:
        parts.append("Verdict: the data discriminate between the models.")
    elif misfit and len(physical) > 1 and not close:
        parts.append("Verdict: a robust ranking of models none of which fits; no model is confirmed.")
    else:
        parts.append("Verdict: the models are not distinguishable with these data.")
    return discriminates, " ".join(parts)


def _ranking_phrases(
    fits: dict[str, ModelFit],
    physical: list[str],
    delta: dict[str, float],
    first: dict[str, float],
    decisive: float,
    n_boot: int,
    criterion: str = "AIC",
) -> tuple[list[str], list[str], bool]:
    """What the ranking of the physical fits says: (phrases, models within Δ(Q)AIC < 2 of the best,
    discriminates)."""
    if not physical:
        return [], [], False
    best = physical[0]
    lb, fb = model_label(best), fits[best].goodness
    if len(fits) == 1:
        return [f"Only one model ({lb}) was fitted: nothing to discriminate."], [], False
    if len(physical) == 1:
        return [f"{lb} is the only model whose fit is physical (χ² = {fb.chi2:.3g})."], [], True
    close = [n for n in physical[1:] if delta[n] < DELTA_AIC_INDISTINGUISHABLE]
    runner = physical[1]
    ic, dchi = criterion, ("Δχ²/ĉ" if criterion == "QAIC" else "Δχ²")
    if close:
        listed = ", ".join(f"{model_label(n)} (Δ{ic} = {delta[n]:.2g})" for n in close)
        parts = [
            f"The data do not discriminate between {lb} (lowest {ic}, χ² = {fb.chi2:.2f}) and {listed}: "
            f"Δ{ic} < {DELTA_AIC_INDISTINGUISHABLE:g}. Every model has 2 parameters, so Δ{ic} = {dchi}."
        ]
    else:
        parts = [
            f"{lb} has the lowest {ic} (χ² = {fb.chi2:.3g}); the runner-up {model_label(runner)} is at Δ{ic} = "
            f"{delta[runner]:.3g} (≥ 2: less support; ≥ 10: essentially none)."
        ]
    if n_boot and criterion == "QAIC":
        parts.append(
            f"Resampling the residuals about the best fit ({n_boot} wild-bootstrap resamples; resampling the repeats "
            f"cannot show a lack of fit common to every series), {lb} has the lowest χ² in "
            f"{first.get(best, 0.0):.0%} of them, and by {dchi} ≥ {DELTA_AIC_INDISTINGUISHABLE:g} in {decisive:.0%}."
        )
    elif n_boot:
        parts.append(
            f"Resampling the repeats ({n_boot} bootstrap resamples), {lb} has the lowest χ² in "
            f"{first.get(best, 0.0):.0%} of them, and by {dchi} ≥ {DELTA_AIC_INDISTINGUISHABLE:g} in {decisive:.0%}."
        )
    return parts, close, not close and (decisive >= 0.95 if n_boot else True)


def _flat_phrase(fits: dict[str, ModelFit], flat: list[str]) -> str:
    """The fits whose slope is consistent with zero or negative: not ranked, and why (the data's load dependence)."""
    est = {n: fits[n].estimate for n in flat}
    listed = ", ".join(f"{model_label(n)} (s = {est[n].scale:.3g} ± {est[n].scale_se:.2g})" for n in flat)
    if len(flat) == len([f for f in fits.values() if f.physical]):
        return (
            f"The resistance does not depend on the load: this is not a contact-area measurement. Every model's "
            f"slope is consistent with zero or negative ({listed}); the models are not ranked. Verdict: no model "
            "can be tested with these data."
        )
    return f"Not ranked (slope consistent with zero or negative, the resistance does not follow the area): {listed}."


def _unphysical_phrases(fits: dict[str, ModelFit], ranking: tuple[str, ...], physical: list[str]) -> list[str]:
    """The unphysical fits, named with why; ranked after the physical ones whatever their AIC."""
    bad = [n for n in ranking if not fits[n].physical]
    if not bad:
        return []
    listed = "; ".join(f"{model_label(n)}: {fits[n].unphysical[0].split(' (')[0]}" for n in bad)
    if not physical:
        return [f"Every fit is UNPHYSICAL ({listed})."]
    return [f"UNPHYSICAL fits, ranked after every physical fit whatever their AIC — {listed}."]
