"""R/R₀ at the first weight (seed Fig. 12), with the uncertainty that the repeats carry.

Every normalised point shares the reference R₀, so the ratios are correlated with each other, and when the
repeats are measurement series (column k of Tab. 1 is one series) R_i and R₀ are correlated too. First-order
(delta-method) propagation with the full covariance of the means::

    r_i = R̄_i / R̄₀,   J_ii = 1/R̄₀,  J_i0 = −R̄_i/R̄₀²  (i ≥ 1),  row 0 of J = 0,   cov(r) = J C Jᵀ

with C the covariance of the means: C_ik = cov(R_i·, R_k·)/n for paired series (sample covariance over series),
diagonal s_i²/n_i otherwise. r₀ = 1 exactly, with zero variance. Valid while the relative SEMs are small (a few
per cent); the Monte Carlo test checks it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analysis.measured import MeasuredCurve
from contactrig.core.validation import SettingError

__all__ = ["NormalisedCurve", "normalise_measured", "normalise_simulated"]


@dataclass(frozen=True)
class NormalisedCurve:
    """``ratio[i]`` = R_i/R₀ (dimensionless), ``se`` its standard error, ``cov`` the (m, m) covariance (None beyond
    :data:`DENSE_COV_MAX` weights);
    ``reference_ohm`` R₀ and ``reference_se_ohm`` its standard error; ``paired`` whether series correlation was
    used."""

    weight_kg: np.ndarray
    ratio: np.ndarray
    se: np.ndarray
    cov: np.ndarray | None
    reference_ohm: float
    reference_se_ohm: float
    paired: bool


def _mean_covariance(curve: MeasuredCurve, paired: bool) -> np.ndarray:
    if paired:
        _check_paired(curve)
        return np.cov(curve.values_ohm, ddof=1) / curve.values_ohm.shape[1]
    return np.diag(_mean_covariance_diagonal(curve))


def _check_paired(curve: MeasuredCurve) -> None:
    if not curve.paired:
        raise SettingError("paired", True, "expected a complete weights × series matrix (no missing repeats)")
    if curve.values_ohm.shape[1] < 2:
        raise SettingError("repeats", curve.values_ohm.shape[1], "expected >= 2 series for an uncertainty")


def _mean_covariance_diagonal(curve: MeasuredCurve) -> np.ndarray:
    """Independent repeats: the variance of each weight's mean, s²/n (Ω²)."""
    n = curve.n
    if np.any(n < 2):
        w = curve.weight_kg[n < 2][0]
        raise SettingError("repeats", f"1 at {w:g} kg", "expected >= 2 repeats at every weight for an uncertainty")
    return curve.sd_ohm**2 / n


#: The full (m, m) covariance of R/R₀ is formed only up to this many weights (32 MB); beyond (an imported table of
#: 10 000 weights: 800 MB, and J C Jᵀ a minute of matrix products) ``cov`` is None — the standard errors, the only
#: part any caller uses, are computed from the needed entries of C alone, in O(m × series).
DENSE_COV_MAX = 2000


def normalise_measured(curve: MeasuredCurve, paired: bool | None = None) -> NormalisedCurve:
    """Normalise the repeat means of ``curve`` to the first weight (module docstring).

    ``paired`` None uses the series covariance when the curve is paired (complete matrix of series), else the
    repeats at different weights are taken as independent.
    """
    use_pairs = curve.paired if paired is None else bool(paired)
    mean = curve.mean_ohm
    m = mean.size
    c_diag, c_0 = _covariance_parts(curve, use_pairs)  # C_ii and C_i0 (Ω²)
    r0 = mean[0]
    ratio = mean / r0
    ratio[0] = 1.0
    # var(r_i) = J_ii² C_ii + J_i0² C_00 + 2 J_ii J_i0 C_i0 with J_ii = 1/R̄₀, J_i0 = −R̄_i/R̄₀² (i ≥ 1); 0 for i = 0
    j_ii, j_i0 = 1.0 / r0, -mean / r0**2
    var = j_ii**2 * c_diag + j_i0**2 * c_diag[0] + 2.0 * j_ii * j_i0 * c_0
    var[0] = 0.0
    se = np.sqrt(np.clip(var, 0.0, None))
    cov = None
    if m <= DENSE_COV_MAX:
        c = _mean_covariance(curve, use_pairs)
        jac = np.zeros((m, m))
        idx = np.arange(1, m)
        jac[idx, idx] = 1.0 / r0
        jac[idx, 0] = -mean[idx] / r0**2
        cov = jac @ c @ jac.T
        cov = 0.5 * (cov + cov.T)
    return NormalisedCurve(
        weight_kg=curve.weight_kg.copy(),
        ratio=ratio,
        se=se,
        cov=cov,
        reference_ohm=float(r0),
        reference_se_ohm=float(np.sqrt(c_diag[0])),
        paired=use_pairs,
    )


def _covariance_parts(curve: MeasuredCurve, paired: bool) -> tuple[np.ndarray, np.ndarray]:
    """The diagonal C_ii and the first column C_i0 of :func:`_mean_covariance` (Ω²), without forming C."""
    if not paired:
        c_diag = _mean_covariance_diagonal(curve)
        c_0 = np.zeros_like(c_diag)
        c_0[0] = c_diag[0]
        return c_diag, c_0
    _check_paired(curve)
    v = np.asarray(curve.values_ohm, dtype=float)
    r = v.shape[1]
    d = v - v.mean(axis=1, keepdims=True)
    c_diag = np.einsum("ij,ij->i", d, d) / (r - 1) / r
    c_0 = d @ d[0] / (r - 1) / r
    return c_diag, c_0


def normalise_simulated(weight_kg: np.ndarray, resistance_ohm: np.ndarray) -> NormalisedCurve:
    """Normalise a simulated (deterministic) curve R(W) to its first value; zero uncertainty.

    For seed eq. 23 this is A₀/A(W): ζ and h cancel.
    """
    w = np.asarray(weight_kg, dtype=float)
    r = np.asarray(resistance_ohm, dtype=float)
    if r.shape != w.shape or r.ndim != 1 or r.size < 1:
        raise SettingError("resistance_ohm", f"shape {r.shape}", f"expected shape {w.shape}")
    if not np.all(np.isfinite(r)) or np.any(r <= 0):
        raise SettingError("resistance_ohm", r.tolist(), "expected finite resistances > 0 Ω")
    ratio = r / r[0]
    ratio[0] = 1.0
    m = r.size
    return NormalisedCurve(
        weight_kg=w.copy(),
        ratio=ratio,
        se=np.zeros(m),
        cov=np.zeros((m, m)),
        reference_ohm=float(r[0]),
        reference_se_ohm=0.0,
        paired=False,
    )
