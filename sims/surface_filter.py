"""Form removal and ISO 16610-61 areal Gaussian filtering of a measured height map (numpy/scipy on arrays).

The order is ISO 25178-2/-3's: the **S-filter** (nesting index λs, a Gaussian low-pass) turns the measured map into
the primary surface; the **F-operator** removes the form (a plane, the cylinder of a bore, or a polynomial) and gives
the *S-F surface*; the **L-filter** (nesting index λc) removes the waviness, giving the *S-L surface* = S-F surface
minus its Gaussian mean surface at λc.

ISO 16610-61 weighting function (areal, isotropic): s(x, y) = 1/(α²λc²) · exp(−π (x² + y²)/(α λc)²), α = √(ln 2/π);
its transmission for a sinusoid of wavelength λ is exp(−π (α λc/λ)²) = 2^(−(λc/λ)²): 50 % at the cut-off. It is
separable, so the filter is two 1-D convolutions with the sampled weights, truncated at ±λc (where s has fallen to
6e-7 of its peak) and normalised to sum 1. At the map's edges and at missing points (NaN: optical dropouts) the
weights are renormalised over the measured points (normalised convolution), so no point is ever taken as zero.

Missing points are counted; the finished surface is filled at them with the Gaussian mean of the measured
neighbours (never with zeros), and a map with more than ``max_missing_fraction`` of them is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from contactrig.core.validation import SettingError

__all__ = [
    "ALPHA",
    "EDGES",
    "FORMS",
    "FilterResult",
    "fit_cylinder",
    "gaussian_mean_surface",
    "gaussian_transmission",
    "remove_form",
    "s_l_surface",
    "square_pixels",
    "treat_edges",
]

#: ISO 16610-61 constant α = √(ln 2/π) ≈ 0.4697 (50 % transmission at the cut-off).
ALPHA = math.sqrt(math.log(2.0) / math.pi)

#: F-operators: ``plane`` (least-squares mean plane), ``cylinder`` (a bore: circle across the axis, straight along
#: it), ``polynomial`` (total degree ``form_degree``).
FORMS = ("plane", "cylinder", "polynomial")


#: How a non-periodic measured map is made fit for the periodic FFT-BEM and the summation models, never by
#: wrapping its edge step: ``window`` (a cosine taper of the outer :data:`TAPER_FRACTION` of each side to the mean
#: plane: same grid, the border band loses its roughness) or ``mirror`` (even reflection to twice the size in each
#: direction: every measured height kept, continuous across the seams, 4× the points).
EDGES = ("window", "mirror")

#: Fraction of each side tapered by ``edges = "window"``.
TAPER_FRACTION = 0.1


def _taper(n: int) -> NDArray[np.float64]:
    w = np.ones(n)
    k = max(1, int(TAPER_FRACTION * n))
    ramp = 0.5 * (1 - np.cos(np.pi * (np.arange(k) + 0.5) / k))
    w[:k] = ramp
    w[n - k :] = ramp[::-1]
    return w


def treat_edges(z: NDArray[np.float64], how: str) -> NDArray[np.float64]:
    """``z`` (m, zero mean) made periodic without an edge step (see :data:`EDGES`), m."""
    if how == "window":
        return np.asarray(z * _taper(z.shape[0])[:, None] * _taper(z.shape[1])[None, :], dtype=np.float64)
    if how == "mirror":
        top = np.concatenate([z, z[:, ::-1]], axis=1)
        return np.concatenate([top, top[::-1, :]], axis=0)
    raise SettingError("edges", how, "expected one of " + ", ".join(EDGES))


def gaussian_transmission(wavelength_m: float | NDArray[np.float64], cutoff_m: float) -> Any:
    """Amplitude transmission of the ISO 16610-61 Gaussian low-pass (mean-surface) filter: exp(−π (α λc/λ)²)."""
    return np.exp(-math.pi * (ALPHA * cutoff_m / np.asarray(wavelength_m, dtype=float)) ** 2)


def _weights(cutoff_m: float, pixel_m: float) -> NDArray[np.float64]:
    """The 1-D sampled ISO weighting function on ±λc, normalised to sum 1."""
    half = max(1, math.ceil(cutoff_m / pixel_m))
    x = np.arange(-half, half + 1) * pixel_m
    w = np.exp(-math.pi * (x / (ALPHA * cutoff_m)) ** 2)
    return np.asarray(w / w.sum(), dtype=np.float64)


def _convolve(a: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]:
    from scipy.ndimage import convolve1d

    out = a
    for axis in range(a.ndim):
        out = convolve1d(out, w, axis=axis, mode="constant", cval=0.0)
    return np.asarray(out, dtype=np.float64)


def gaussian_mean_surface(z: NDArray[np.float64], pixel_m: float, cutoff_m: float) -> NDArray[np.float64]:
    """The ISO 16610-61 Gaussian mean surface (low-pass at ``cutoff_m``) of ``z`` (m; NaN = missing), m.

    Normalised convolution: at edges and around missing points the weights are renormalised over measured points.
    Points whose whole window is missing stay NaN.
    """
    valid = np.isfinite(z)
    w = _weights(cutoff_m, pixel_m)
    num = _convolve(np.where(valid, z, 0.0), w)
    den = _convolve(valid.astype(np.float64), w)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 1e-12, num / np.maximum(den, 1e-300), np.nan)


def _coords(shape: tuple[int, ...], pixel_m: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]]
    return xx * pixel_m, yy * pixel_m


def _polynomial(z: NDArray[np.float64], pixel_m: float, degree: int) -> NDArray[np.float64]:
    """Least-squares 2-D polynomial of total degree ``degree`` over the measured points (normalised coordinates)."""
    x, y = _coords(z.shape, pixel_m)
    x = x / max(float(x.max()), pixel_m) - 0.5
    y = y / max(float(y.max()), pixel_m) - 0.5
    terms = [x**i * y**j for i in range(degree + 1) for j in range(degree + 1 - i)]
    valid = np.isfinite(z)
    a = np.column_stack([t[valid] for t in terms])
    coef, *_ = np.linalg.lstsq(a, z[valid], rcond=None)
    return np.asarray(sum(c * t for c, t in zip(coef, terms, strict=True)), dtype=np.float64)


@dataclass(frozen=True)
class CylinderFit:
    """A bore's cylinder: ``radius_m``, the axis position across it ``centre_m`` and the height there ``height_m``,
    the tilt along the axis ``tilt`` (−), ``concave`` (a bore seen from inside), RMS residual ``rms_m``, and the
    cylinder's sagitta ``sagitta_m`` = R − √(R² − (c/2)²) over the chord ``chord_m`` = c, the field across the axis."""

    radius_m: float
    centre_m: float
    height_m: float
    tilt: float
    concave: bool
    rms_m: float
    sagitta_m: float = math.nan
    chord_m: float = math.nan


#: A cylinder is resolved when its sagitta over the field across the axis is at least this many times the RMS of
#: what is left after removing it (the roughness and noise): below that, a waviness of the roughness at the field's
#: scale sets the fitted radius (a flat map gives anything from millimetres to 10¹³ m). At the ratio 2 the radius is
#: known to about ±50 % (δR/R = δs/s with δs ≈ the RMS left).
MIN_SAGITTA_RATIO = 2.0


def _cylinder_model(p: NDArray[np.float64], u: NDArray[np.float64], v: NDArray[np.float64], s: float) -> Any:
    h, b, u0, r = p
    return h + b * v + s * (r - np.sqrt(np.maximum(r * r - (u - u0) ** 2, 0.0)))


def fit_cylinder(z: NDArray[np.float64], pixel_m: float, axis: str = "x") -> tuple[NDArray[np.float64], CylinderFit]:
    """Least-squares cylinder whose axis runs along the map's ``axis`` (``"x"``: along columns, ``"y"``: rows).

    Model z = h + b·v + s·(R − √(R² − (u − u0)²)), u across the axis, v along it, s = ±1 (concave/convex, from the
    sign of the curvature); started from a quadratic fit, refined by SciPy's ``least_squares``. Returns the fitted
    form (m, on the whole grid) and the :class:`CylinderFit`. A cylinder the field does not resolve (sagitta below
    :data:`MIN_SAGITTA_RATIO` × the RMS left) is an error naming ``form``.
    """
    from scipy.optimize import least_squares

    x, y = _coords(z.shape, pixel_m)
    u, v = (y, x) if axis == "x" else (x, y)
    valid = np.isfinite(z)
    uu, vv, zz = u[valid], v[valid], z[valid]
    q = np.linalg.lstsq(np.column_stack([np.ones_like(uu), vv, uu, uu * uu]), zz, rcond=None)[0]
    if q[3] == 0:
        raise SettingError("form", "cylinder", "the map has no curvature across the axis: use form = 'plane'")
    s = 1.0 if q[3] > 0 else -1.0
    r0 = 1.0 / (2.0 * abs(q[3]))
    u0 = -q[2] / (2.0 * q[3])
    p0 = np.array([q[0] + q[2] * u0 + q[3] * u0 * u0, q[1], u0, r0])
    span = float(uu.max() - uu.min())
    p0[3] = max(p0[3], span)  # the chord must fit inside the circle

    def resid(p: NDArray[np.float64]) -> Any:
        return _cylinder_model(p, uu, vv, s) - zz

    res = least_squares(resid, p0, x_scale=np.array([abs(zz).max() + pixel_m, 1.0, span, p0[3]]))
    form = _cylinder_model(res.x, u, v, s)
    radius = float(res.x[3])
    fit = CylinderFit(
        radius, float(res.x[2]), float(res.x[0]), float(res.x[1]), s > 0, float(np.sqrt(np.mean(res.fun**2))),
        sagitta_m=radius - math.sqrt(max(radius * radius - (span / 2) ** 2, 0.0)), chord_m=span,
    )  # fmt: skip
    if not fit.sagitta_m >= MIN_SAGITTA_RATIO * fit.rms_m:
        raise SettingError(
            "form",
            "cylinder",
            f"the map does not resolve a cylinder: the fitted one (radius {radius:.4g} m) rises "
            f"{fit.sagitta_m:.3g} m over the {span:.4g} m field across the axis, less than {MIN_SAGITTA_RATIO:g}× the "
            f"roughness left ({fit.rms_m:.3g} m RMS), so its radius is set by the roughness, not by a form; "
            "use form = 'plane' or 'polynomial', or measure a wider field",
        )
    return np.asarray(form, dtype=np.float64), fit


def remove_form(
    z: NDArray[np.float64], pixel_m: float, form: str = "plane", *, degree: int = 2, axis: str = "x"
) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """The S-F surface: ``z`` (m; NaN kept) minus its form; returns it and what was fitted (for provenance)."""
    if form == "plane":
        return z - _polynomial(z, pixel_m, 1), {"form": "plane"}
    if form == "polynomial":
        return z - _polynomial(z, pixel_m, degree), {"form": "polynomial", "form_degree": degree}
    if form == "cylinder":
        fitted, fit = fit_cylinder(z, pixel_m, axis)
        return z - fitted, {"form": "cylinder", "bore_axis": axis, "cylinder_radius_m": fit.radius_m,
                            "cylinder_concave": fit.concave, "cylinder_rms_residual_m": fit.rms_m,
                            "cylinder_sagitta_m": fit.sagitta_m, "cylinder_chord_m": fit.chord_m}
    raise SettingError("form", form, "expected one of " + ", ".join(FORMS))


def square_pixels(
    z: NDArray[np.float64], pixel_x_m: float, pixel_y_m: float
) -> tuple[NDArray[np.float64], float, dict[str, Any]]:
    """A map on a rectangular grid (rows = y at ``pixel_y_m``, columns = x at ``pixel_x_m``) on a square one at the
    coarser pitch: the finer axis is resampled by linear interpolation between its two nearest measured points (NaN
    when either is missing), so no point is invented at a finer pitch than the instrument measured across the other
    axis. Returns the map, its pitch (m) and what was done (provenance)."""
    coarse = max(pixel_x_m, pixel_y_m)
    axis = 1 if pixel_x_m < pixel_y_m else 0
    fine = min(pixel_x_m, pixel_y_m)
    n = z.shape[axis]
    pos = np.arange(math.floor((n - 1) * fine / coarse * (1 + 1e-12)) + 1) * (coarse / fine)  # in fine pixels
    lo = np.minimum(np.floor(pos).astype(int), n - 1)
    hi = np.minimum(lo + 1, n - 1)
    w = pos - lo
    a = np.moveaxis(z, axis, 0)
    shape = (-1,) + (1,) * (a.ndim - 1)
    with np.errstate(invalid="ignore"):
        out = a[lo] * (1.0 - w).reshape(shape) + a[hi] * w.reshape(shape)
    exact = w < 1e-9
    out[exact] = a[lo[exact]]  # on a measured point: that point (NaN only if it was missing)
    out = np.ascontiguousarray(np.moveaxis(out, 0, axis))
    record = {
        "resampled": f"non-square pixels ({pixel_x_m:.6g} m in x × {pixel_y_m:.6g} m in y): {'xy'[1 - axis]} "
        f"resampled to {coarse:.6g} m by linear interpolation, {z.shape[1]} × {z.shape[0]} → "
        f"{out.shape[1]} × {out.shape[0]} points",
        "pixel_x_m_file": pixel_x_m,
        "pixel_y_m_file": pixel_y_m,
    }
    return out, coarse, record


@dataclass(frozen=True)
class FilterResult:
    """The filtered surface ``z`` (m, complete: missing points filled as the module says) and its ``record``."""

    z: NDArray[np.float64]
    record: dict[str, Any]


def _fill_missing(z: NDArray[np.float64], pixel_m: float, missing: NDArray[np.bool_]) -> NDArray[np.float64]:
    """``z`` with its missing points set to the Gaussian mean of measured neighbours (cut-off growing until every
    hole is reached)."""
    if not missing.any():
        return z
    cutoff = 4.0 * pixel_m
    out = z.copy()
    while True:
        mean = gaussian_mean_surface(np.where(missing, np.nan, z), pixel_m, cutoff)
        if np.isfinite(mean[missing]).all():
            out[missing] = mean[missing]
            return out
        cutoff *= 2.0


def s_l_surface(
    z: NDArray[np.float64],
    pixel_m: float,
    *,
    form: str = "plane",
    degree: int = 2,
    axis: str = "x",
    lambda_s_m: float | None = None,
    lambda_c_m: float | None = None,
    max_missing_fraction: float = 0.05,
    key: str = "heights",
) -> FilterResult:
    """S-filter (λs), F-operator (``form``), L-filter (λc) of a measured map ``z`` in m (NaN = missing point).

    None for a nesting index skips that filter. Refused (naming ``key``) when more than ``max_missing_fraction``
    of the points are missing. The record (for provenance) names every step, the counts and the fitted form.
    """
    missing = ~np.isfinite(z)
    n_missing = int(missing.sum())
    if n_missing > max_missing_fraction * z.size:
        raise SettingError(
            key,
            f"{n_missing} of {z.size} points missing",
            f"expected at most max_missing_fraction = {max_missing_fraction:g} of the points measured as missing (NaN)",
        )
    zz = np.where(missing, np.nan, z)
    if lambda_s_m is not None:
        zz = np.where(missing, np.nan, gaussian_mean_surface(zz, pixel_m, lambda_s_m))
    zz, record = remove_form(zz, pixel_m, form, degree=degree, axis=axis)
    if lambda_c_m is not None:
        zz = zz - gaussian_mean_surface(zz, pixel_m, lambda_c_m)
    zz = _fill_missing(zz, pixel_m, missing)
    zz = zz - float(zz.mean())
    record.update(
        filter="ISO 16610-61 areal Gaussian",
        lambda_s_m=lambda_s_m,
        lambda_c_m=lambda_c_m,
        missing_points=n_missing,
        missing_filled="Gaussian mean of measured neighbours" if n_missing else "none missing",
    )
    return FilterResult(zz, record)
