"""Greenwood–Tripp contact of two nominally flat rough surfaces (seed eq. 1–3).

The Gaussian integrals (Greenwood & Tripp 1970)::

    F_n(t) = 1/√(2π) ∫_t^∞ (s − t)^n exp(−s²/2) ds ,    t = h/σ

have the closed form ``F_n(t) = Γ(n+1)/√(2π) · exp(−t²/4) · D_−(n+1)(t)`` (D: parabolic cylinder function), and
equivalently the Laplace integral ``F_n(t) = φ(t) ∫_0^∞ u^n exp(−t u − u²/2) du`` (substitute s = t + u).

Methods of :func:`F` (``method=``):

``"table"`` (default)
    F_n on a uniform grid (step 1/768) over [−12, 14], cubic Hermite interpolation with the exact slopes
    dF_n/dt = −n F_(n−1) (relative error ≈ h⁴ t⁴/384: ≲ 1e-10 on [−8, 10]; F itself rather than ln F is
    tabulated because ``np.exp`` costs more than the whole interpolation); asymptotic series outside the grid
    (t → +∞: Γ(n+1) φ(t) t^−(n+1) Σ …;
    t → −∞: |t|^n Σ_k C(n, 2k) (2k−1)!! t^−2k), matched continuously at the grid ends. Relative error ≲ 1e-11 on
    [−8, 10]. Monotone, positive, no overflow or warning for any t from :func:`t_min` (−e^(700/n): −1e121 for
    n = 5/2, −1e30 for n = 10, every finite t for n = 0) to +∞; below it an explicit SettingError.
``"exact"``
    The reference used to build the table: ``scipy.special.pbdv`` for t < 2, 40-point generalised Gauss–Laguerre
    quadrature of the Laplace integral for t ≥ 2 (pbdv loses accuracy for half-integer n near t ≈ 6: 1e-9).
``"closed_form"``
    ``pbdv`` everywhere, as printed in the references (for the benchmark; n ≤ 8, |t| ≤ 37).
``"paper_polynomial"``
    The seed paper's method (§1.1): the 8th-degree polynomial through the nine tabulated F_5/2 values at
    t = 0, 0.5, …, 4 (n = 5/2 only). See :func:`paper_polynomial`.
``"power_fit"``
    The widely copied fit F_5/2 ≈ 4.4086e-5 (4 − t)^6.804 for t < 4, 0 beyond (n = 5/2 only).

Pressure (seed eq. 1–2 with E′ = E*, seed eq. 4)::

    p(h) = (16√2 π/15) (ηβσ)² √(σ/β) E* F_5/2(h/σ)

and real-area fraction ``A/A0 = π² (ηβσ)² F_2(h/σ)``. η: asperity density per surface (m⁻²), β: asperity radius
(m), σ: combined RMS roughness (seed eq. 3), h: separation of the mean planes (m). Codes that print 8√2π/15 use
Stachowiak's E′ = 2E* — the factor-2 trap; :mod:`tests.sims.test_greenwood_tripp` checks the prefactor against a
direct integration over asperity pairs.
"""

from __future__ import annotations

import math
import sys
import warnings
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contactrig.core.validation import SettingError, check_choice, check_int, check_range

__all__ = [
    "METHODS",
    "F",
    "PaperPolynomialWarning",
    "area_fraction",
    "dF_dt",
    "log_F",
    "paper_coefficients",
    "paper_polynomial",
    "paper_table",
    "power_fit",
    "pressure",
    "pressure_prefactor",
    "t_min",
]

METHODS = ("table", "exact", "closed_form", "paper_polynomial", "power_fit")

_T_LO = -12.0
_T_HI = 14.0
_STEPS_PER_UNIT = 768
_N_MAX = 10.0
_LN_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)
_LN_MAX = 700.0  # exp(700) ~ 1e304


class PaperPolynomialWarning(RuntimeWarning):
    """The paper's interpolating polynomial went negative and was replaced by 0 (never silently)."""


def _as_order(n: float) -> float:
    return check_range("n", n, 0.0, _N_MAX)


def _as_t(t: ArrayLike) -> NDArray[np.float64]:
    return np.asarray(t, dtype=float)  # NaN is caught by the min() check of the table path


def _reject_nan(arr: NDArray[np.float64]) -> None:
    if arr.size and np.isnan(arr).any():
        raise SettingError("t", "nan", "F_n(t) needs real t (got NaN)")


# ---------------------------------------------------------------------------------------------------------------
# Reference evaluation: ln G_m(t) with G_m = F_m / Γ(m+1) = exp(−t²/4) D_−(m+1)(t) / √(2π), m > −1 (m = −1: φ).


@lru_cache(maxsize=16)
def _laguerre(m: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    from scipy.special import roots_genlaguerre

    x, w = roots_genlaguerre(40, m)
    return x, w


def _ln_G_exact(m: float, t: NDArray[np.float64]) -> NDArray[np.float64]:
    """ln G_m(t) to ~1e-14 for −40 ≤ t ≤ 40 (pbdv for t < 2, Gauss–Laguerre for t ≥ 2)."""
    from scipy.special import gammaln, pbdv

    t = np.asarray(t, dtype=float)
    out = np.empty_like(t)
    if m == -1.0:
        return -0.5 * t * t - _LN_SQRT_2PI
    lo = t < 2.0
    if lo.any():
        d = pbdv(-(m + 1.0), t[lo])[0]
        out[lo] = -0.25 * t[lo] ** 2 + np.log(d) - _LN_SQRT_2PI
    hi = ~lo
    if hi.any():
        x, w = _laguerre(m)
        th = t[hi]
        s = np.exp(-(x[None, :] ** 2) / (2.0 * th[:, None] ** 2)) @ w
        out[hi] = -0.5 * th * th - _LN_SQRT_2PI - gammaln(m + 1.0) - (m + 1.0) * np.log(th) + np.log(s)
    return out


def _ln_F_exact(n: float, t: NDArray[np.float64]) -> NDArray[np.float64]:
    from scipy.special import gammaln

    return gammaln(n + 1.0) + _ln_G_exact(n, t)


def _dlnF_exact(n: float, t: NDArray[np.float64]) -> NDArray[np.float64]:
    """d ln F_n/dt = −G_(n−1)/G_n (= −n F_(n−1)/F_n; −φ/F_0 for n = 0)."""
    if n >= 1.0 or n == 0.0:
        return -np.exp(_ln_G_exact(n - 1.0, t) - _ln_G_exact(n, t))
    # 0 < n < 1: G_(n−1) has order in (−1, 0); pbdv handles it for all t used in the table.
    from scipy.special import pbdv

    d_lo = pbdv(-n, t)[0]
    d_n = pbdv(-(n + 1.0), t)[0]
    ratio = d_lo / d_n
    # pbdv is accurate enough here except far right; there use the Laplace integral of order n−1 > −1.
    far = t >= 2.0
    if far.any():
        x, w = _laguerre(n - 1.0)
        th = t[far]
        s1 = np.exp(-(x[None, :] ** 2) / (2.0 * th[:, None] ** 2)) @ w
        from scipy.special import gammaln

        ln_g1 = -0.5 * th * th - _LN_SQRT_2PI - gammaln(n) - n * np.log(th) + np.log(s1)
        ratio[far] = np.exp(ln_g1 - _ln_G_exact(n, th))
    return -ratio


# ---------------------------------------------------------------------------------------------------------------
# Asymptotic tails.

_N_TERMS = 24


def _right_series_coeffs(n: float) -> NDArray[np.float64]:
    """Coefficients c_k of Σ c_k t^−2k in F_n ~ Γ(n+1) φ(t) t^−(n+1) Σ (t → +∞): c_k = (−1)^k (n+1)_2k /(2^k k!)."""
    c = np.empty(_N_TERMS)
    c[0] = 1.0
    for k in range(1, _N_TERMS):
        c[k] = -c[k - 1] * (n + 2 * k - 1) * (n + 2 * k) / (2.0 * k)
    return c


def _left_series_coeffs(n: float) -> NDArray[np.float64]:
    """c_k of F_n ~ |t|^n Σ c_k t^−2k (t → −∞): c_k = C(n, 2k) (2k−1)!! = E[X^2k] C(n, 2k), X ~ N(0, 1)."""
    c = np.empty(_N_TERMS)
    c[0] = 1.0
    for k in range(1, _N_TERMS):
        j = 2 * k
        c[k] = c[k - 1] * (n - j + 2) * (n - j + 1) / j
    return c


def _series(c: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Σ c_k x^k by Horner (x = t^−2)."""
    acc = np.full_like(x, c[-1])
    for ck in c[-2::-1]:
        acc = acc * x + ck
    return acc


def _ln_right_tail(n: float, t: NDArray[np.float64]) -> NDArray[np.float64]:
    from scipy.special import gammaln

    tt = np.minimum(t, 1e150)  # F is 0.0 in double far before; keeps t² finite (and maps +inf)
    s = _series(_right_series_coeffs(n), 1.0 / (tt * tt))
    return gammaln(n + 1.0) - _LN_SQRT_2PI - 0.5 * tt * tt - (n + 1.0) * np.log(tt) + np.log(s)


def _ln_left_tail(n: float, t: NDArray[np.float64]) -> NDArray[np.float64]:
    a = -t
    with np.errstate(over="ignore"):  # a² → inf for |t| > 1e154: the correction t^−2 is then exactly 0
        s = _series(_left_series_coeffs(n), 1.0 / (a * a))
    return n * np.log(a) + np.log(s)


# ---------------------------------------------------------------------------------------------------------------
# The table.


@dataclass(frozen=True)
class _Table:
    coef: NDArray[np.float64]  # (intervals + 1, 4): c3, c2, c1, c0 of each interval, one row = one gather
    right_shift: float  # added to the right-tail ln F so that it meets the table at T_HI
    left_shift: float


@lru_cache(maxsize=32)
def _table(n: float) -> _Table:
    m = round((_T_HI - _T_LO) * _STEPS_PER_UNIT)
    t = np.linspace(_T_LO, _T_HI, m + 1)
    h = 1.0 / _STEPS_PER_UNIT
    ln_f = _ln_F_exact(n, t)
    y = np.exp(ln_f)
    d = _dlnF_exact(n, t) * y * h
    y0, y1, d0, d1 = y[:-1], y[1:], d[:-1], d[1:]
    c2 = 3.0 * (y1 - y0) - 2.0 * d0 - d1
    c3 = 2.0 * (y0 - y1) + d0 + d1

    coef = np.stack([c3, c2, d0, y0], axis=1)
    coef = np.vstack([coef, coef[-1:]])  # one extra interval so that t rounding onto T_HI stays in bounds
    coef.setflags(write=False)
    right = float(ln_f[-1] - _ln_right_tail(n, np.array([_T_HI]))[0])
    left = float(ln_f[0] - _ln_left_tail(n, np.array([_T_LO]))[0])
    return _Table(coef, right, left)


_CHUNK = 32768  # work arrays that stay in cache: ~2x faster than whole-array temporaries on 10^6 points


def _interp(tab: _Table, t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cubic Hermite on the grid; t in [T_LO, T_HI]. The hot path: chunked, in place, one row gather per point
    (the four coefficients of an interval are adjacent in memory), no temporaries."""
    out = np.empty_like(t)
    size = min(_CHUNK, t.size)
    x_buf = np.empty(size)
    g_buf = np.empty((size, 4))
    i_buf = np.empty(size, dtype=np.intp)
    for start in range(0, t.size, _CHUNK):
        tc = t[start : start + _CHUNK]
        m = tc.size
        x, g, i, y = x_buf[:m], g_buf[:m], i_buf[:m], out[start : start + m]
        np.subtract(tc, _T_LO, out=x)
        x *= _STEPS_PER_UNIT
        i[...] = x  # truncation = floor for x >= 0
        x -= i
        np.take(tab.coef, i, axis=0, out=g, mode="clip")
        np.multiply(g[:, 0], x, out=y)
        y += g[:, 1]
        y *= x
        y += g[:, 2]
        y *= x
        y += g[:, 3]
    return out


def t_min(n: float) -> float:
    """Smallest t for which F_n(t) ≈ |t|^n is a finite double: −e^(700/n) (≈ −1e121 for n = 5/2); any finite t
    for n = 0 (F_0 ≤ 1)."""
    n = _as_order(n)
    return -math.exp(_LN_MAX / n) if n > 0.0 and _LN_MAX / n < 709.0 else -sys.float_info.max


def _check_t_min(n: float, tmin: float, *, log: bool = False) -> None:
    if math.isnan(tmin):
        raise SettingError("t", "nan", "F_n(t) needs real t (got NaN)")
    limit = -sys.float_info.max if log else t_min(n)
    if tmin < limit:
        raise SettingError(
            "t", tmin, f"F_{n:g}(t) is evaluated for finite t >= {limit:.3g} (beyond, |t|^n leaves the float range)"
        )


def _F_table(n: float, t: NDArray[np.float64]) -> NDArray[np.float64]:
    tab = _table(n)
    if t.size == 0:
        return np.empty_like(t)
    tmin, tmax = float(t.min()), float(t.max())
    _check_t_min(n, tmin)
    if _T_LO <= tmin and tmax < _T_HI:
        return _interp(tab, t)
    out = np.empty_like(t)
    mid = (t >= _T_LO) & (t < _T_HI)
    out[mid] = _interp(tab, t[mid])
    with np.errstate(under="ignore"):
        right = t >= _T_HI
        if right.any():
            out[right] = np.exp(_ln_right_tail(n, t[right]) + tab.right_shift)
        left = t < _T_LO
        if left.any():
            out[left] = np.exp(_ln_left_tail(n, t[left]) + tab.left_shift)
    return out


def _ln_F_table(n: float, t: NDArray[np.float64]) -> NDArray[np.float64]:
    tab = _table(n)
    if t.size == 0:
        return np.empty_like(t)
    _check_t_min(n, float(t.min()), log=True)
    out = np.empty_like(t)
    mid = (t >= _T_LO) & (t < _T_HI)
    out[mid] = np.log(_interp(tab, t[mid]))
    right = t >= _T_HI
    if right.any():
        out[right] = _ln_right_tail(n, t[right]) + tab.right_shift
    left = t < _T_LO
    if left.any():
        out[left] = _ln_left_tail(n, t[left]) + tab.left_shift
    return out


# ---------------------------------------------------------------------------------------------------------------
# Public API.


def log_F(n: float, t: ArrayLike) -> NDArray[np.float64]:
    """ln F_n(t) (fast table with asymptotic tails); finite for every finite t, −inf only as t → +inf."""
    n = _as_order(n)
    tt = _as_t(t)
    out = _ln_F_table(n, np.atleast_1d(tt).ravel()).reshape(tt.shape)
    if np.isinf(tt).any():
        out = np.where(np.isposinf(tt), -np.inf, out)
    return out


def F(n: float, t: ArrayLike, *, method: str = "table") -> NDArray[np.float64]:
    """Gaussian integral F_n(t) of Greenwood & Tripp (dimensionless), vectorised over ``t`` (= h/σ).

    ``n`` in [0, 10] (the models use 0, 1, 3/2, 2, 5/2). ``method``: see the module docstring; ``"table"`` is
    the fast default, ``"paper_polynomial"`` and ``"power_fit"`` exist only for n = 5/2 and only to reproduce and
    benchmark the seed paper. Non-negative, non-increasing in t (to rounding: the cubic's last bits may rise by a
    few ulp, ≤ 1e-14 relative, between points closer than 1e-13); NaN input is an error.
    """
    check_choice("method", method, METHODS)
    n = _as_order(n)
    tt = _as_t(t)
    if method == "table":
        return _F_table(n, np.atleast_1d(tt).ravel()).reshape(tt.shape)
    _reject_nan(tt)
    if method in ("paper_polynomial", "power_fit"):
        if n != 2.5:
            raise SettingError("n", n, f"method {method!r} exists only for n = 2.5 (F_5/2)")
        return paper_polynomial(tt) if method == "paper_polynomial" else power_fit(tt)
    flat = np.atleast_1d(tt).ravel()
    if method == "exact":
        if flat.size and (flat.min() < -40.0 or flat.max() > 40.0):
            raise SettingError("t", float(np.abs(flat).max()), "method 'exact' is for |t| <= 40 (use 'table')")
        with np.errstate(under="ignore"):
            return np.exp(_ln_F_exact(n, flat)).reshape(tt.shape)
    # closed_form: pbdv as printed in the references
    from scipy.special import gamma, pbdv

    if flat.size and np.abs(flat).max() > 37.0:
        raise SettingError("t", float(np.abs(flat).max()), "method 'closed_form' is for |t| <= 37 (use 'table')")
    with np.errstate(under="ignore"):
        val = gamma(n + 1.0) / math.sqrt(2.0 * math.pi) * np.exp(-0.25 * flat * flat) * pbdv(-(n + 1.0), flat)[0]
    return val.reshape(tt.shape)


def dF_dt(n: float, t: ArrayLike) -> NDArray[np.float64]:
    """dF_n/dt (≤ 0): −n F_(n−1)(t) for n ≥ 1, −φ(t) for n = 0 (the analytic contact stiffness)."""
    n = _as_order(n)
    tt = _as_t(t)
    if n == 0.0:
        with np.errstate(under="ignore", over="ignore"):
            return -np.exp(-0.5 * np.minimum(tt * tt, 1e300) - _LN_SQRT_2PI)
    if n < 1.0:
        raise SettingError("n", n, "dF_dt is available for n = 0 and n >= 1")
    return -n * F(n - 1.0, tt)


# ---------------------------------------------------------------------------------------------------------------
# The seed paper's method and the power fit.

_PAPER_NODES = np.linspace(0.0, 4.0, 9)


def paper_table(decimals: int | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The nine F_5/2 values at t = 0, 0.5, …, 4 the seed paper interpolates (§1.1).

    ``decimals=None``: the exact values (closed form). An integer rounds them as a printed table would (the seed
    does not print its nine numbers; Greenwood & Tripp's table was not available to check, see MODELS.md).
    """
    v = F(2.5, _PAPER_NODES, method="exact")
    if decimals is not None:
        v = np.round(v, check_int("decimals", decimals, 1, 15))
    return _PAPER_NODES.copy(), v


@lru_cache(maxsize=8)
def paper_coefficients(decimals: int | None = None) -> NDArray[np.float64]:
    """Coefficients (highest power first, as ``np.polyval``) of the degree-8 polynomial through the nine nodes."""
    x, y = paper_table(decimals)
    coef = np.linalg.solve(np.vander(x, 9), y).astype(np.float64, copy=False)  # interpolation: 9 nodes, degree 8
    coef.setflags(write=False)
    return coef


def paper_polynomial(t: ArrayLike, *, decimals: int | None = None) -> NDArray[np.float64]:
    """F_5/2 by the seed paper's 8th-degree interpolating polynomial (seed §1.1), ``t`` in [0, 4] only.

    Outside [0, 4] the polynomial extrapolates wildly (≈ −0.04 at t = 5, −0.8 at t = 6): that is a
    :class:`~contactrig.core.validation.SettingError`. Inside, it is off by tens of per cent to several-fold between
    t = 3
    and 4, and with node values rounded to 3–4 decimals it dips below zero (t ≈ 3.0–3.5); negative values are
    replaced by 0 with a :class:`PaperPolynomialWarning` saying how many — never silently, never a negative
    (adhesive) pressure.
    """
    tt = _as_t(t)
    _reject_nan(tt)
    if tt.size and (tt.min() < 0.0 or tt.max() > 4.0):
        bad = float(tt.min()) if tt.min() < 0.0 else float(tt.max())
        raise SettingError("t", bad, "the paper's polynomial is defined on [0, 4] (its table); use method='table'")
    val: NDArray[np.float64] = np.asarray(np.polyval(paper_coefficients(decimals), tt), dtype=np.float64)
    neg = val < 0.0
    if neg.any():
        warnings.warn(
            f"paper polynomial negative at {int(neg.sum())} point(s) in [0, 4] (min {float(val.min()):.3g}); "
            "replaced by 0",
            PaperPolynomialWarning,
            stacklevel=2,
        )
        val = np.where(neg, 0.0, val)
    return val


def power_fit(t: ArrayLike) -> NDArray[np.float64]:
    """The common fit F_5/2 ≈ 4.4086e-5 (4 − t)^6.804 for t < 4, and 0 for t ≥ 4 (its definition).

    10 % low at t = 0, 74 % low at t = 3 and no contact beyond t = 4; kept for comparison only.
    """
    tt = _as_t(t)
    _reject_nan(tt)
    with np.errstate(over="ignore"):
        return np.where(tt < 4.0, 4.4086e-5 * np.power(np.maximum(4.0 - tt, 0.0), 6.804), 0.0)


# ---------------------------------------------------------------------------------------------------------------
# Pressure and area.


def _check_stats(sigma: float, eta: float, beta: float) -> tuple[float, float, float]:
    sigma = check_range("sigma", sigma, 0.0, 1.0, lo_open=True, unit="m")
    eta = check_range("eta", eta, 0.0, 1e20, lo_open=True, unit="1/m²")
    beta = check_range("beta", beta, 0.0, 10.0, lo_open=True, unit="m")
    return sigma, eta, beta


def pressure_prefactor(*, sigma: float, eta: float, beta: float, E_star: float) -> float:
    """(16√2π/15) (ηβσ)² √(σ/β) E*, Pa: p(h) = prefactor · F_5/2(h/σ) (seed eq. 1–2 with E′ = E*)."""
    sigma, eta, beta = _check_stats(sigma, eta, beta)
    E_star = check_range("E_star", E_star, 1e3, 1e13, unit="Pa")
    ebs = eta * beta * sigma
    return 16.0 * math.sqrt(2.0) * math.pi / 15.0 * ebs * ebs * math.sqrt(sigma / beta) * E_star


def pressure(
    h: ArrayLike, *, sigma: float, eta: float, beta: float, E_star: float, method: str = "table"
) -> NDArray[np.float64]:
    """Nominal asperity contact pressure p(h), Pa (seed eq. 1–2 with E′ = E*, eq. 4), vectorised over ``h`` (m).

    ``sigma`` combined RMS roughness (m, seed eq. 3), ``eta`` asperity density (m⁻²), ``beta`` asperity radius
    (m), ``E_star`` composite modulus (Pa). ``method`` selects how F_5/2 is evaluated (see :func:`F`).
    """
    c = pressure_prefactor(sigma=sigma, eta=eta, beta=beta, E_star=E_star)
    hh = np.asarray(h, dtype=float)
    with np.errstate(over="ignore"):
        t = hh / sigma
    return c * _F_of_h(2.5, t, hh, sigma, method)


def _F_of_h(n: float, t: NDArray[np.float64], h: NDArray[np.float64], sigma: float, method: str) -> NDArray[np.float64]:
    """F_n(h/σ) with errors about t restated for the separation h the caller passed."""
    try:
        return F(n, t, method=method)
    except SettingError as exc:
        if exc.field != "t":
            raise
        bad = float(np.nanmin(h)) if h.size and not np.isnan(h).any() else "nan"
        raise SettingError("h", bad, f"h/σ with σ = {sigma:g} m: {exc.allowed}") from None


def area_fraction(h: ArrayLike, *, sigma: float, eta: float, beta: float) -> NDArray[np.float64]:
    """Real / nominal contact area π² (ηβσ)² F_2(h/σ) (Greenwood & Tripp 1970), vectorised over ``h`` (m).

    Dimensionless; the formula exceeds 1 only far outside its validity (h ≪ −σ), which is then an error.
    """
    sigma, eta, beta = _check_stats(sigma, eta, beta)
    hh = np.asarray(h, dtype=float)
    with np.errstate(over="ignore"):
        t = hh / sigma
    ebs = eta * beta * sigma
    a = math.pi**2 * ebs * ebs * _F_of_h(2.0, t, hh, sigma, "table")
    if a.size and a.max() > 1.0:
        raise SettingError("h", float(hh.min()), "Greenwood–Tripp real-area fraction exceeds 1 (separation too deep)")
    return a


# ---------------------------------------------------------------------------------------------------------------
# Registration as a contact model of the database (sims.models): statistics only, no surface is generated.


def _register() -> None:
    from sims.models import ContactModel, register

    register(
        ContactModel(
            "greenwood_tripp",
            "Greenwood–Tripp",
            build=lambda ctx: ctx.greenwood_tripp_curve("greenwood_tripp"),
            equations="seed eq. 1–3",
            description="Greenwood & Tripp (1970) from McCool's summit statistics of each surface",
            elastic_only=True,
            needs_surface=False,
            style={"color": "#1f77b4", "linestyle": "-", "marker": "o"},
        ),
        replace=True,
    )


_register()
