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
    """``ratio[i]`` = R_i/R₀ (dimensionless), ``se`` its standard error, ``cov`` the (m, m) covariance;
    ``reference_ohm`` R₀ and ``reference_se_ohm`` its standard error; ``paired`` whether series correlation was
    used."""

    weight_kg: np.ndarray
    ratio: np.ndarray
    se: np.ndarray
    cov: np.ndarray
    reference_ohm: float
    reference_se_ohm: float
    paired: bool


def _mean_covariance(curve: MeasuredCurve, paired: bool) -> np.ndarray:
    v = curve.values_ohm
    n = curve.n
    if paired:
        if not curve.paired:
            raise SettingError("paired", True, "expected a complete weights × series matrix (no missing repeats)")
        r = v.shape[1]
        if r < 2:
            raise SettingError("repeats", r, "expected >= 2 series for an uncertainty")
        return np.cov(v, ddof=1) / r
    sd = curve.sd_ohm
    if np.any(n < 2):
        w = curve.weight_kg[n < 2][0]
        raise SettingError("repeats", f"1 at {w:g} kg", "expected >= 2 repeats at every weight for an uncertainty")
    return np.diag(sd**2 / n)


def normalise_measured(curve: MeasuredCurve, paired: bool | None = None) -> NormalisedCurve:
    """Normalise the repeat means of ``curve`` to the first weight (module docstring).

    ``paired`` None uses the series covariance when the curve is paired (complete matrix of series), else the
    repeats at different weights are taken as independent.
    """
    use_pairs = curve.paired if paired is None else bool(paired)
    c = _mean_covariance(curve, use_pairs)
    mean = curve.mean_ohm
    r0 = mean[0]
    ratio = mean / r0
    ratio[0] = 1.0
    m = mean.size
    jac = np.zeros((m, m))
    idx = np.arange(1, m)
    jac[idx, idx] = 1.0 / r0
    jac[idx, 0] = -mean[idx] / r0**2
    cov = jac @ c @ jac.T
    cov = 0.5 * (cov + cov.T)
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return NormalisedCurve(
        weight_kg=curve.weight_kg.copy(),
        ratio=ratio,
        se=se,
        cov=cov,
        reference_ohm=float(r0),
        reference_se_ohm=float(np.sqrt(c[0, 0])),
        paired=use_pairs,
    )


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
