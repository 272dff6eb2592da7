"""Rough surfaces: generation, measured height maps, roughness, summits and their statistics.

Heights ``z`` are n×m arrays in metres on a square grid of pitch ``pixel_m``; generated surfaces are periodic.

* :func:`gaussian` — Gaussian autocorrelation ``Sq² exp(−r²/λ²)`` (power spectrum ∝ exp(−q²λ²/4)), exact Sq.
* :func:`self_affine` — power spectrum ∝ q^−2(1+H) between a roll-off and a short-wavelength cut-off, exact Sq.
  Both use deterministic spectral amplitudes with random phases, so the spectral moments of a realisation are
  those of the prescribed spectrum (:func:`expected_spectral_moments`), not a random draw around them.
* :func:`level_height_map` — a measured grid of heights (an array: files are read by ``contactrig.core.scene``),
  converted to metres, its mean plane removed.
* :func:`rms_roughness` (Sq), :func:`combined_sigma` (seed eq. 3), :func:`summits` (8-neighbour),
  :func:`radius_of_curvature` (seed eq. 8, per point, x and y, negative at peaks), :func:`summit_statistics`
  (η, β, σ_s from the summits) and :func:`mccool` (the same from spectral moments, McCool 1986 after Nayak 1971).

Scene tables ``[surfaces.liner]`` and ``[surfaces.piston]``: see :class:`SurfaceSpec`. Physics only, no file I/O:
a measured height map (``kind = "file"``) is read when the scene is loaded (``Scene.height_maps``) and reaches
:meth:`SurfaceSpec.from_table` as an array; in a notebook pass one directly (:meth:`SurfaceSpec.from_heights`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contactrig.core.validation import SettingError, check_choice, check_int, check_keys, check_range

if TYPE_CHECKING:
    from contactrig.core.scene import Scene

__all__ = [
    "SURFACE_KINDS",
    "Conditioning",
    "SpectralMoments",
    "SummitData",
    "SummitStatistics",
    "SurfaceSpec",
    "combined_sigma",
    "condition_height_map",
    "curvature",
    "expected_spectral_moments",
    "finite_difference_moments",
    "gaussian",
    "kurtosis",
    "level_height_map",
    "mccool",
    "radius_of_curvature",
    "rms_roughness",
    "rms_slope",
    "self_affine",
    "skewness",
    "spectral_moments",
    "statistics_of",
    "summit_data",
    "summit_statistics",
    "summits",
    "surfaces_from_scene",
]

SURFACE_KINDS = ("gaussian", "self_affine", "file")

#: Largest RMS slope |∇z| a surface may have: the contact models (and their small-slope geometry) assume gentle
#: asperities; real engineering surfaces have 0.01–0.3. A larger value is almost always a unit slip (mm or µm for m).
MAX_RMS_SLOPE = 1.0

#: Largest pixel a profilometer file may declare, m (a scene's ``pixel_m`` may give any): coarser is a unit slip
#: in the file's metadata (a reader taking nm for mm), not an instrument's grid.
MAX_FILE_PIXEL_M = 1e-3


# ---------------------------------------------------------------------------------------------------------------
# Generation.


def _wavenumbers(n: int, pixel_m: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """q_x (full axis) and q_y (half axis, rfft layout), rad/m."""
    qx = np.asarray(2.0 * np.pi * np.fft.fftfreq(n, d=pixel_m), dtype=np.float64)
    qy = np.asarray(2.0 * np.pi * np.fft.rfftfreq(n, d=pixel_m), dtype=np.float64)
    return qx, qy


def _check_grid(n: int, pixel_m: float) -> tuple[int, float]:
    n = check_int("n", n, 8, 8192)
    if n % 2:
        raise SettingError("n", n, "expected an even number of points (FFT layout)")
    pixel_m = check_range("pixel_m", pixel_m, 0.0, 1.0, lo_open=True, unit="m")
    return n, pixel_m


def _gaussian_psd(q2: NDArray[np.float64], correlation_m: float) -> NDArray[np.float64]:
    return np.exp(-q2 * correlation_m**2 / 4.0)


def _self_affine_psd(q2: NDArray[np.float64], hurst: float, q_roll: float, q_cut: float) -> NDArray[np.float64]:
    q = np.sqrt(q2)
    with np.errstate(divide="ignore"):
        c = np.power(np.maximum(q, q_roll), -2.0 * (1.0 + hurst))
    return np.where(q <= q_cut, c, 0.0)


def _synthesise(psd: NDArray[np.float64], n: int, sq_m: float, seed: int) -> NDArray[np.float64]:
    rng = np.random.default_rng(seed)
    phase = rng.uniform(0.0, 2.0 * np.pi, size=psd.shape)
    spec = np.sqrt(psd) * np.exp(1j * phase)
    # The q_y = 0 and Nyquist columns of the half spectrum must be Hermitian themselves; otherwise irfft2 keeps
    # only their Hermitian part and the realised power there is random, not the prescribed spectrum.
    half = n // 2
    for col in (0, spec.shape[1] - 1):
        c = spec[:, col]
        c[half + 1 :] = np.conj(c[1:half][::-1])
        c[0] = abs(c[0])
        c[half] = abs(c[half])
    spec[0, 0] = 0.0
    z = np.fft.irfft2(spec, s=(n, n))
    z -= z.mean()
    s = float(np.sqrt(np.mean(z * z)))
    if not s > 0.0:
        raise SettingError("surface", "spectrum", "the spectrum has no power between the cut-offs on this grid")
    z *= sq_m / s
    return z


def gaussian(n: int, *, pixel_m: float, sq_m: float, correlation_m: float, seed: int = 0) -> NDArray[np.float64]:
    """n×n periodic Gaussian surface, heights in m, RMS exactly ``sq_m``.

    Autocorrelation ``sq_m² exp(−r²/λ²)`` with λ = ``correlation_m`` (its 1/e length). Resolve λ with at least
    8 pixels for summit statistics that agree with McCool's (resolution-independent) values.
    """
    n, pixel_m = _check_grid(n, pixel_m)
    sq_m = check_range("sq_m", sq_m, 0.0, 1.0, lo_open=True, unit="m")
    correlation_m = check_range("correlation_m", correlation_m, 0.0, 1.0, lo_open=True, unit="m")
    qx, qy = _wavenumbers(n, pixel_m)
    q2 = qx[:, None] ** 2 + qy[None, :] ** 2
    return _synthesise(_gaussian_psd(q2, correlation_m), n, sq_m, check_int("seed", seed, 0))


def _self_affine_q(n: int, pixel_m: float, rolloff_m: float | None, cutoff_m: float | None) -> tuple[float, float]:
    box = n * pixel_m
    rolloff_m = box if rolloff_m is None else check_range("rolloff_m", rolloff_m, 2 * pixel_m, box, unit="m")
    cutoff_m = 2 * pixel_m if cutoff_m is None else check_range("cutoff_m", cutoff_m, 2 * pixel_m, box, unit="m")
    if cutoff_m > rolloff_m:
        raise SettingError("cutoff_m", cutoff_m, f"expected a value <= rolloff_m = {rolloff_m:g} m")
    return 2 * np.pi / rolloff_m, 2 * np.pi / cutoff_m


def self_affine(
    n: int,
    *,
    pixel_m: float,
    sq_m: float,
    hurst: float,
    rolloff_m: float | None = None,
    cutoff_m: float | None = None,
    seed: int = 0,
) -> NDArray[np.float64]:
    """n×n periodic self-affine surface (heights in m, RMS exactly ``sq_m``).

    Isotropic power spectrum C(q) ∝ q^−2(1+H) for 2π/``rolloff_m`` ≤ q ≤ 2π/``cutoff_m``, flat below the
    roll-off, zero above the cut-off. Defaults: roll-off at the box size, cut-off at 2 pixels (Nyquist). Summit
    statistics of such broadband surfaces depend on the cut-off/pixel size: report them together.
    """
    n, pixel_m = _check_grid(n, pixel_m)
    sq_m = check_range("sq_m", sq_m, 0.0, 1.0, lo_open=True, unit="m")
    hurst = check_range("hurst", hurst, 0.0, 1.0, lo_open=True)
    q_roll, q_cut = _self_affine_q(n, pixel_m, rolloff_m, cutoff_m)
    qx, qy = _wavenumbers(n, pixel_m)
    q2 = qx[:, None] ** 2 + qy[None, :] ** 2
    return _synthesise(_self_affine_psd(q2, hurst, q_roll, q_cut), n, sq_m, check_int("seed", seed, 0))



def _check_map_slope(slope: float, where: str, height_unit_m: float, pixel_m: float) -> None:
    """Refuse a map whose RMS slope [-] exceeds :data:`MAX_RMS_SLOPE`: its heights are almost surely not in the unit
    ``height_unit_m`` [m] says (µm numbers read as metres)."""
    if not slope <= MAX_RMS_SLOPE:
        raise SettingError(
            "height_unit_m",
            height_unit_m,
            f"the heights of {where} in units of {height_unit_m:g} m at pixel_m = {pixel_m:g} m have an RMS slope "
            f"of {slope:.3g}; expected <= {MAX_RMS_SLOPE:g} (gentle asperities): are the numbers in that unit "
            "(1e-6 for µm)?",
        )

def level_height_map(
    heights: ArrayLike, *, pixel_m: float, height_unit_m: float = 1.0, key: str = "heights", source: str | None = None
) -> NDArray[np.float64]:
    """A measured height map in metres with its least-squares mean plane removed (form and tilt are not roughness).

    ``heights`` are the numbers as measured (rows × columns; a file is read by ``contactrig.core.scene``);
    ``height_unit_m`` converts them to metres (1e-6 for µm). The map is not periodic: summits on its border are not
    counted. Errors name ``key`` with ``source`` (the file, when there is one) as the value; an RMS slope above
    :data:`MAX_RMS_SLOPE` (a unit slip) names ``height_unit_m``.
    """
    pixel_m = check_range("pixel_m", pixel_m, 0.0, 1.0, lo_open=True, unit="m")
    height_unit_m = check_range("height_unit_m", height_unit_m, 0.0, 1e3, lo_open=True, unit="m")
    raw = np.asarray(heights, dtype=np.float64)
    where = source if source is not None else f"array of shape {raw.shape}"
    if raw.ndim != 2:
        raise SettingError(key, where, f"expected a 2-D grid of heights, got {raw.ndim} dimension(s)")
    if raw.shape[0] < 8 or raw.shape[1] < 8:
        raise SettingError(key, where, f"expected at least 8×8 heights, got {raw.shape[0]}×{raw.shape[1]}")
    if not np.isfinite(raw).all():
        raise SettingError(key, where, "contains non-finite heights")
    z = raw * height_unit_m
    ny, nx = z.shape
    yy, xx = np.mgrid[0:ny, 0:nx]
    a = np.column_stack([np.ones(z.size), xx.ravel(), yy.ravel()])
    coef, *_ = np.linalg.lstsq(a, z.ravel(), rcond=None)
    levelled = z - (a @ coef).reshape(z.shape)
    slope = rms_slope(levelled, pixel_m, periodic=False)
    _check_map_slope(slope, where, height_unit_m, pixel_m)
    return levelled


@dataclass(frozen=True)
class Conditioning:
    """How a measured map becomes a roughness surface (scene keys of ``kind = "file"``; see :mod:`sims.surface_filter`).

    ``form``: F-operator (``plane`` | ``cylinder`` | ``polynomial``), ``form_degree`` its degree (polynomial),
    ``bore_axis`` (``x`` | ``y``: the direction of the bore's axis on the map), ``lambda_s_m`` / ``lambda_c_m``:
    ISO 16610-61 S- and L-filter nesting indices, m (None: not applied), ``max_missing_fraction``: most missing
    points (NaN) a map may have.
    """

    form: str = "plane"
    form_degree: int = 2
    bore_axis: str = "x"
    lambda_s_m: float | None = None
    lambda_c_m: float | None = None
    max_missing_fraction: float = 0.05
    edges: str = "mirror"

    @classmethod
    def from_table(cls, table: Mapping[str, Any]) -> Conditioning:
        from sims.surface_filter import EDGES, FORMS

        def length(key: str) -> float | None:
            value = table.get(key)
            return None if value is None else check_range(key, value, 0.0, 1.0, lo_open=True, unit="m")

        out = cls(
            form=check_choice("form", table.get("form", "plane"), FORMS),
            form_degree=check_int("form_degree", table.get("form_degree", 2), 1, 6),
            bore_axis=check_choice("bore_axis", table.get("bore_axis", "x"), ("x", "y")),
            lambda_s_m=length("lambda_s_m"),
            lambda_c_m=length("lambda_c_m"),
            max_missing_fraction=check_range(
                "max_missing_fraction", table.get("max_missing_fraction", 0.05), 0.0, 1.0, hi_open=True
            ),
            edges=check_choice("edges", table.get("edges", "mirror"), EDGES),
        )
        if out.lambda_s_m is not None and out.lambda_c_m is not None and not out.lambda_s_m < out.lambda_c_m:
            raise SettingError("lambda_s_m", out.lambda_s_m, f"expected < lambda_c_m = {out.lambda_c_m:g} m")
        return out


def _from_file_or_table(table: Mapping[str, Any], meta: Mapping[str, Any], key: str, source: str | None) -> Any:
    """The scene's ``key`` if given (an override), else the file's; neither is an error naming the quantity."""
    if key in table:
        return table[key]
    if meta.get(key) is not None:
        return meta[key]
    what = "pixel size" if key == "pixel_m" else "height unit"
    where = f"the file {source}" if source else "the heights"
    raise SettingError(key, None, f"the {what} is missing: {where} does not give it; set {key} (metres) in the scene")


def _check_measured_shape(raw: NDArray[np.float64], key: str, where: str) -> None:
    if raw.ndim not in (1, 2):
        raise SettingError(key, where, f"expected a 2-D grid of heights or a 1-D profile, got {raw.ndim} dimensions")
    if raw.ndim == 2 and (raw.shape[0] < 8 or raw.shape[1] < 8):
        raise SettingError(key, where, f"expected at least 8×8 heights, got {raw.shape[0]}×{raw.shape[1]}")
    if raw.ndim == 1 and raw.size < 64:
        raise SettingError(key, where, f"expected a profile of at least 64 points, got {raw.size}")
    if np.isinf(raw).any():
        raise SettingError(key, where, "contains infinite heights")


def condition_height_map(
    heights: ArrayLike,
    *,
    pixel_m: float,
    height_unit_m: float,
    conditioning: Conditioning | None = None,
    key: str = "heights",
    source: str | None = None,
) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """A measured map (2-D, or a 1-D profile) in metres after S-filter, form removal and L-filter.

    ``heights`` as measured (NaN: missing points), ``height_unit_m`` converts them to metres. Returns the surface
    (missing points filled, never with zeros; see :func:`sims.surface_filter.s_l_surface`) and the record of what
    was done (provenance). An RMS slope above :data:`MAX_RMS_SLOPE` (a unit slip) names ``height_unit_m``.
    """
    from sims.surface_filter import s_l_surface

    c = conditioning or Conditioning()
    raw = np.asarray(heights, dtype=np.float64)
    where = source if source is not None else f"array of shape {raw.shape}"
    _check_measured_shape(raw, key, where)
    grid = raw[None, :] if raw.ndim == 1 else raw  # a profile is a one-row map (its bore axis across the row)
    axis = "y" if raw.ndim == 1 else c.bore_axis
    result = s_l_surface(
        grid * height_unit_m,
        pixel_m,
        form=c.form,
        degree=c.form_degree,
        axis=axis,
        lambda_s_m=c.lambda_s_m,
        lambda_c_m=c.lambda_c_m,
        max_missing_fraction=c.max_missing_fraction,
        key=key,
    )
    z = result.z[0] if raw.ndim == 1 else result.z
    slope = math.sqrt(2.0 * finite_difference_moments(np.where(np.isfinite(raw), z, np.nan), pixel_m).m2)
    _check_map_slope(slope, where, height_unit_m, pixel_m)
    return z, result.record


def _mean_measured(a: NDArray[np.float64], what: str) -> float:
    """Mean of the finite values of ``a`` (NaN: a missing point took part); none is an error naming ``what``."""
    finite = a[np.isfinite(a)]
    if finite.size == 0:
        raise SettingError("heights", what, "no measured points (or pairs of neighbours) to compute it from")
    return float(np.mean(finite))


def finite_difference_moments(z: ArrayLike, pixel_m: float) -> SpectralMoments:
    """m0, m2, m4 of a non-periodic map or profile from finite differences (no wrap across the edges), the
    isotropic estimate averaging x and y: m2 = ⟨z_x²⟩ by forward differences, m4 = ⟨z_xx²⟩ by 3-point second
    differences. The definition SurfaceTopography's ``rms_slope_from_profile``/``rms_curvature_from_profile`` use.

    NaN marks a point that was not measured: m0 is taken over the measured points, m2 over the pairs and m4 over
    the triples of neighbours that were all measured (ISO 25178-2's parameters belong to the measured surface)."""
    a = np.asarray(z, dtype=np.float64)
    a = a - _mean_measured(a, "mean height")
    axes = range(a.ndim)
    m2 = float(np.mean([_mean_measured((np.diff(a, axis=k) / pixel_m) ** 2, "slope") for k in axes]))
    m4 = float(np.mean([_mean_measured((np.diff(a, 2, axis=k) / pixel_m**2) ** 2, "curvature") for k in axes]))
    return SpectralMoments(_mean_measured(a * a, "Sq"), m2, m4)


# ---------------------------------------------------------------------------------------------------------------
# Roughness and summits.


def rms_roughness(z: ArrayLike) -> float:
    """Sq: RMS of heights about their mean, m."""
    z = np.asarray(z, dtype=float)
    return float(np.sqrt(np.mean((z - z.mean()) ** 2)))


def skewness(z: ArrayLike) -> float:
    """Ssk = ⟨(z − z̄)³⟩ / Sq³ (ISO 25178-2), −."""
    a = np.asarray(z, dtype=float)
    a = a - a.mean()
    return float(np.mean(a**3) / np.mean(a * a) ** 1.5)


def kurtosis(z: ArrayLike) -> float:
    """Sku = ⟨(z − z̄)⁴⟩ / Sq⁴ (ISO 25178-2; 3 for a Gaussian height distribution), −."""
    a = np.asarray(z, dtype=float)
    a = a - a.mean()
    return float(np.mean(a**4) / np.mean(a * a) ** 2)


def rms_slope(z: ArrayLike, pixel_m: float, *, periodic: bool = True) -> float:
    """RMS gradient √⟨z_x² + z_y²⟩ (Sdq) by forward differences, −; ``periodic=False``: no wrap at the edges, and
    NaN (a point not measured) allowed: each mean is over the pairs of neighbours that were both measured."""
    a = np.asarray(z, dtype=np.float64)
    if periodic:
        dx, dy = np.roll(a, -1, axis=0) - a, np.roll(a, -1, axis=1) - a
        return float(np.sqrt(np.mean(dx * dx) + np.mean(dy * dy))) / pixel_m
    dx, dy = np.diff(a, axis=0), np.diff(a, axis=1)
    return math.sqrt(_mean_measured(dx * dx, "Sdq") + _mean_measured(dy * dy, "Sdq")) / pixel_m


def combined_sigma(sq1_m: float, sq2_m: float) -> float:
    """σ = √(Sq1² + Sq2²), m (seed eq. 3)."""
    return math.hypot(check_range("sq1_m", sq1_m, 0.0), check_range("sq2_m", sq2_m, 0.0))


def summits(z: ArrayLike, *, periodic: bool = True) -> NDArray[np.bool_]:
    """Boolean mask of summits: points strictly higher than all 8 neighbours.

    ``periodic=False`` (measured maps): border points are never summits.
    """
    z = np.asarray(z, dtype=float)
    if periodic:
        mask = np.ones(z.shape, dtype=bool)
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                if dx or dy:
                    mask &= z > np.roll(np.roll(z, dx, axis=0), dy, axis=1)
        return mask
    mask = np.zeros(z.shape, dtype=bool)
    c = z[1:-1, 1:-1]
    inner = np.ones(c.shape, dtype=bool)
    ny, nx = z.shape
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            if dx or dy:
                inner &= c > z[1 + dx : ny - 1 + dx, 1 + dy : nx - 1 + dy]
    mask[1:-1, 1:-1] = inner
    return mask


def _derivatives(z: NDArray[np.float64], pixel_m: float, axis: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Central 3-point first and second derivatives along ``axis`` (periodic wrap; edges of measured maps are
    never summits, so their wrapped values are not used there)."""
    zp = np.roll(z, -1, axis=axis)
    zm = np.roll(z, 1, axis=axis)
    return (zp - zm) / (2.0 * pixel_m), (zp - 2.0 * z + zm) / pixel_m**2


def curvature(z: ArrayLike, pixel_m: float, axis: int) -> NDArray[np.float64]:
    """Profile curvature z″/(1 + z′²)^(3/2) along ``axis`` (0: x = rows, 1: y), 1/m; negative at peaks."""
    z = np.asarray(z, dtype=float)
    d1, d2 = _derivatives(z, pixel_m, axis)
    return d2 / (1.0 + d1 * d1) ** 1.5


def radius_of_curvature(z: ArrayLike, pixel_m: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Seed eq. 8 per point: (R_x, R_y) = (1 + z′²)^(3/2) / z″ in x and y, m; negative at peaks, ±inf where flat."""
    out = []
    for axis in (0, 1):
        k = curvature(z, pixel_m, axis)
        with np.errstate(divide="ignore"):
            out.append(1.0 / k)
    return out[0], out[1]


@dataclass(frozen=True)
class SummitStatistics:
    """Asperity statistics: ``eta`` summit density (m⁻²), ``beta`` mean summit radius (m), ``sigma_s`` SD of summit
    heights (m), ``n_summits`` (0 for the spectral estimate), ``alpha`` bandwidth (spectral estimate only) and
    ``mean_height`` the mean summit height above the mean plane of the surface heights (m; > 0: summits are the
    high points — Greenwood–Tripp's F_n(h/σ) silently assumes it is 0, see MODELS.md)."""

    eta: float
    beta: float
    sigma_s: float
    n_summits: int = 0
    alpha: float = math.nan
    mean_height: float = math.nan

    def as_dict(self) -> dict[str, float]:
        return {k: float(v) for k, v in asdict(self).items()}


@dataclass(frozen=True)
class SummitData:
    """The summits of one height map: heights (m, from the mean plane) and mean-curvature radii (m)."""

    height_m: NDArray[np.float64]
    radius_m: NDArray[np.float64]
    area_m2: float


def summit_data(z: ArrayLike, pixel_m: float, *, periodic: bool = True) -> SummitData:
    """Heights and radii of all summits; radius = 1/κ with κ = −(κ_x + κ_y)/2 from eq. 8's curvatures (> 0).

    The curvatures are evaluated at the summits only (3-point stencils, periodic wrap for generated maps).
    """
    z = np.asarray(z, dtype=float)
    pixel_m = check_range("pixel_m", pixel_m, 0.0, 1.0, lo_open=True, unit="m")
    zc = z - z.mean()
    mask = summits(zc, periodic=periodic)
    i, j = np.nonzero(mask)
    ny, nx = zc.shape
    c = zc[i, j]
    neighbours = (
        (zc[(i + 1) % ny, j], zc[(i - 1) % ny, j]),  # x (axis 0)
        (zc[i, (j + 1) % nx], zc[i, (j - 1) % nx]),  # y (axis 1)
    )
    kappa = np.zeros(c.shape)
    for zp, zm in neighbours:
        slope = (zp - zm) / (2.0 * pixel_m)
        kappa -= (zp - 2.0 * c + zm) / pixel_m**2 / (1.0 + slope * slope) ** 1.5  # eq. 8 curvature, < 0 at peaks
    kappa /= 2.0  # strictly positive: a summit is above its 4 axial neighbours
    if periodic:
        area = z.size * pixel_m**2
    else:
        area = (ny - 2) * (nx - 2) * pixel_m**2
    return SummitData(height_m=c, radius_m=1.0 / kappa, area_m2=area)


def statistics_of(d: SummitData) -> SummitStatistics:
    """η, β, σ_s of the summits in ``d`` (see :func:`summit_statistics`)."""
    n = d.height_m.size
    if n < 2:
        raise SettingError("surface", n, "fewer than 2 summits: no statistics (grid too small or too smooth)")
    return SummitStatistics(
        eta=n / d.area_m2,
        beta=float(1.0 / np.mean(1.0 / d.radius_m)),
        sigma_s=float(np.std(d.height_m)),
        n_summits=int(n),
        mean_height=float(np.mean(d.height_m)),
    )


def summit_statistics(z: ArrayLike, pixel_m: float, *, periodic: bool = True) -> SummitStatistics:
    """η (m⁻²), β (m), σ_s (m) directly from the 8-neighbour summits of ``z``.

    β = 1/mean(κ) with κ the mean curvature at a summit (mean(1/κ) is dominated by the flattest summits).
    """
    return statistics_of(summit_data(z, pixel_m, periodic=periodic))


# ---------------------------------------------------------------------------------------------------------------
# Spectral moments and McCool.


@dataclass(frozen=True)
class SpectralMoments:
    """Profile moments of an isotropic surface: m0 = Sq² (m²), m2 = ⟨z_x²⟩ (−), m4 = ⟨z_xx²⟩ (m⁻²)."""

    m0: float
    m2: float
    m4: float

    @property
    def alpha(self) -> float:
        """Nayak's bandwidth parameter α = m0 m4 / m2²."""
        return self.m0 * self.m4 / self.m2**2


def _moments_from_power(
    power: NDArray[np.float64], qx: NDArray[np.float64], qy: NDArray[np.float64]
) -> SpectralMoments:
    """``power[i, j]`` at (qx[i], qy[j]) over the full plane; x/y averaged (isotropic estimate)."""
    qx2 = (qx**2)[:, None]
    qy2 = (qy**2)[None, :]
    m0 = float(power.sum())
    m2 = float(0.5 * ((power * qx2).sum() + (power * qy2).sum()))
    m4 = float(0.5 * ((power * qx2**2).sum() + (power * qy2**2).sum()))
    return SpectralMoments(m0, m2, m4)


def spectral_moments(z: ArrayLike, pixel_m: float) -> SpectralMoments:
    """m0, m2, m4 of a height map from its Fourier transform (spectral derivatives; periodic assumption)."""
    a = np.asarray(z, dtype=np.float64)
    a = a - a.mean()
    ny, nx = a.shape
    power = np.abs(np.fft.fft2(a)) ** 2 / (a.size**2)
    qx = np.asarray(2.0 * np.pi * np.fft.fftfreq(ny, d=pixel_m), dtype=np.float64)
    qy = np.asarray(2.0 * np.pi * np.fft.fftfreq(nx, d=pixel_m), dtype=np.float64)
    return _moments_from_power(power, qx, qy)


def expected_spectral_moments(psd_half: NDArray[np.float64], n: int, pixel_m: float, sq_m: float) -> SpectralMoments:
    """Moments of the surface :func:`_synthesise` makes from ``psd_half`` (rfft layout), without making it."""
    qx, qy = _wavenumbers(n, pixel_m)
    w = np.full(psd_half.shape[1], 2.0)  # the rfft half-plane stands for both halves ...
    w[0] = 1.0  # ... except the q_y = 0 column
    if n % 2 == 0:
        w[-1] = 1.0  # and the Nyquist column
    power = psd_half * w[None, :]
    power[0, 0] = 0.0
    m = _moments_from_power(power, qx, qy)
    scale = sq_m**2 / m.m0
    return SpectralMoments(sq_m**2, m.m2 * scale, m.m4 * scale)


def mccool(moments: SpectralMoments) -> SummitStatistics:
    """Summit statistics from spectral moments (McCool 1986, after Nayak 1971), for an isotropic Gaussian surface.

    η = m4/(6π√3 m2) (m⁻²), β = 0.375 √(π/m4) (m), σ_s = √(1 − 0.8968/α) σ (m), α = m0 m4/m2², and the mean
    summit height above the mean plane of the heights z̄_s = 4σ/√(πα) (m). All are McCool's large-α forms; on
    Gaussian surfaces resolved with ≥ 8 pixels per correlation length (α ≈ 3) they match direct 8-neighbour
    summit statistics within a few per cent (tests/sims/test_surface.py).
    (A public generator library writes β with √(m4/m2): dimensionally wrong.)
    """
    m0, m2, m4 = moments.m0, moments.m2, moments.m4
    if not (m0 > 0 and m2 > 0 and m4 > 0):
        raise SettingError("moments", (m0, m2, m4), "expected positive spectral moments")
    alpha = moments.alpha
    if alpha <= 0.8968:  # pragma: no cover - impossible for a real spectrum (α >= 1 by Cauchy–Schwarz)
        raise SettingError("alpha", alpha, "expected a bandwidth parameter > 0.8968")
    return SummitStatistics(
        eta=m4 / (6.0 * math.pi * math.sqrt(3.0) * m2),
        beta=0.375 * math.sqrt(math.pi / m4),
        sigma_s=math.sqrt(1.0 - 0.8968 / alpha) * math.sqrt(m0),
        n_summits=0,
        alpha=alpha,
        mean_height=4.0 * math.sqrt(m0 / (math.pi * alpha)),
    )


# ---------------------------------------------------------------------------------------------------------------
# Scene specification.

_KIND_KEYS = {
    "gaussian": ("kind", "n", "pixel_m", "sq_m", "correlation_m", "seed"),
    "self_affine": ("kind", "n", "pixel_m", "sq_m", "hurst", "rolloff_m", "cutoff_m", "seed"),
    "file": (
        "kind",
        "path",
        "pixel_m",
        "height_unit_m",
        "form",
        "form_degree",
        "bore_axis",
        "lambda_s_m",
        "lambda_c_m",
        "max_missing_fraction",
        "edges",
    ),
}
_REQUIRED = {
    "gaussian": ("n", "pixel_m", "sq_m", "correlation_m"),
    "self_affine": ("n", "pixel_m", "sq_m", "hurst"),
    "file": (),  # ``path`` unless the heights are given directly; pixel and unit from the file or the table
}


def _check_table(section: str, table: Any) -> str:
    """The ``kind`` of ``table`` after checking its keys (unknown or missing keys name ``[section] key``)."""
    if not isinstance(table, dict):
        raise SettingError(section, table, "expected a TOML table")
    if "kind" not in table:
        raise SettingError(f"{section}.kind", None, "required key is missing; one of " + ", ".join(SURFACE_KINDS))
    kind: str = check_choice(f"{section}.kind", table["kind"], SURFACE_KINDS)
    check_keys(section, table, _KIND_KEYS[kind])
    for key in _REQUIRED[kind]:
        if key not in table:
            raise SettingError(f"{section}.{key}", None, f"required key for kind {kind!r} is missing")
    return kind


def _in_section(section: str, exc: SettingError) -> SettingError:
    """``exc`` with its field named as the scene key ``section.field`` (unchanged when it already is one)."""
    if exc.field == section or exc.field.startswith(section + "."):
        return exc
    return SettingError(f"{section}.{exc.field}", exc.value, exc.allowed)


def _check_slope(key: str, value: float, slope: float, how: str) -> None:
    if not slope <= MAX_RMS_SLOPE:
        raise SettingError(
            key,
            value,
            f"{how} gives an RMS slope of {slope:.3g}; expected <= {MAX_RMS_SLOPE:g} (gentle asperities): "
            "is it in metres?",
        )


def _self_affine_slope(sq_m: float, hurst: float, q_box: float, q_roll: float, q_cut: float) -> float:
    """RMS slope of the self-affine spectrum up to the cut-off: the continuous isotropic integral, from the radius
    of a disc of one lattice cell (the q = 0 cell is the only one left out), within ~5 % of the realisation's."""
    q = np.geomspace(q_box / math.sqrt(math.pi), q_cut, 2001)
    c = np.power(np.maximum(q, q_roll), -2.0 * (1.0 + hurst))
    dq = np.diff(q)

    def integral(f: NDArray[np.float64]) -> float:  # trapezoid rule (np.trapezoid needs numpy >= 2)
        return float(np.sum(0.5 * (f[1:] + f[:-1]) * dq))

    return sq_m * math.sqrt(integral(c * q**3) / integral(c * q))


def _path_of(table: dict[str, Any], path: str | None) -> str | None:
    """The height map's file for provenance: ``path`` (as resolved by the scene reader) or the table's."""
    value = path if path is not None else table.get("path")
    if value is not None and (not isinstance(value, str) or not value):
        raise SettingError("path", value, "expected a file name")
    return value


@dataclass(frozen=True)
class SurfaceSpec:
    """One ``[surfaces.<body>]`` table, validated. Keys (SI):

    ``kind``           ``"gaussian"`` | ``"self_affine"`` | ``"file"``
    ``n``              grid points per side (even, 8…8192) — generated kinds
    ``pixel_m``        grid pitch, m (all kinds; for ``file`` the measured pixel size)
    ``sq_m``           RMS roughness Sq, m — generated kinds (exact in the realisation)
    ``correlation_m``  1/e autocorrelation length λ, m — ``gaussian``
    ``hurst``          Hurst exponent H in (0, 1] — ``self_affine``
    ``rolloff_m``      roll-off wavelength, m (default: box size) — ``self_affine``
    ``cutoff_m``       short-wavelength cut-off, m (default: 2 pixels) — ``self_affine``
    ``seed``           random seed, integer ≥ 0 (default 0) — generated kinds
    ``path``           height-map file, relative to the scene file — ``file`` (read by the scene reader)
    ``height_unit_m``  metres per unit of the file's numbers — ``file`` (default: the file's own unit)
    ``pixel_m``, ``height_unit_m`` for ``file`` override the file's metadata; a plain-text grid has none, so both
    are required for it (a missing one is refused, naming it). Form and filtering (``file``, see
    :mod:`sims.surface_filter`): ``form`` (``"plane"`` default | ``"cylinder"`` | ``"polynomial"``),
    ``form_degree`` (polynomial, default 2), ``bore_axis`` (``"x"`` default: the bore's axis runs along the map's
    columns | ``"y"``), ``lambda_s_m`` and ``lambda_c_m`` (ISO 16610-61 S- and L-filter nesting indices, m;
    default: no filter), ``max_missing_fraction`` (default 0.05), ``edges`` (``"mirror"`` default | ``"window"``: how
    the summation models and BEM use the non-periodic map, :data:`sims.surface_filter.EDGES`; statistics use the map
    itself).

    Every surface must have an RMS slope ≤ :data:`MAX_RMS_SLOPE` (a larger one is a unit slip, reported on ``sq_m``
    or ``height_unit_m``). For ``file``, ``measured`` holds the levelled heights in metres, filled where ``missing``
    is True (both read-only; not part of :meth:`as_dict`, equality or the repr); ``sq_m`` and :meth:`moments` are of
    the measured points only (:meth:`measured_points`). A file's non-square pixels are resampled to square ones
    (:func:`sims.surface_filter.square_pixels`, recorded as ``resampled``) unless the table gives ``pixel_m``.
    """

    section: str
    kind: str
    pixel_m: float
    n: int = 0
    sq_m: float = 0.0
    correlation_m: float | None = None
    hurst: float | None = None
    rolloff_m: float | None = None
    cutoff_m: float | None = None
    seed: int = 0
    path: str | None = None
    height_unit_m: float = 1.0
    measured: NDArray[np.float64] | None = field(default=None, repr=False, compare=False)
    #: where ``measured`` was filled because the instrument measured no point there (True), read-only
    missing: NDArray[np.bool_] | None = field(default=None, repr=False, compare=False)
    #: how a measured map was conditioned (form, filters, missing points, file metadata): provenance
    conditioning: dict[str, Any] | None = field(default=None, compare=False)

    @classmethod
    def from_table(
        cls,
        section: str,
        table: dict[str, Any],
        heights: ArrayLike | None = None,
        *,
        path: str | None = None,
        metadata: Mapping[str, Any] | None = None,
    ) -> SurfaceSpec:
        """Validate a ``[surfaces.<body>]`` table; errors name the scene key (``[surfaces.liner] sq_m``).

        ``kind = "file"`` needs ``heights``, the height map's numbers as read from its file (the scene reader
        passes ``Scene.height_maps[section]``; a notebook may pass any 2-D array, ``path`` then optional);
        ``path`` is the file they came from, kept for provenance (default: the table's ``path``); ``metadata`` what
        the file says (``pixel_m``, ``height_unit_m`` in m, ``instrument``, ``file_format``; None values: unknown).
        """
        kind = _check_table(section, table)
        if heights is not None and kind != "file":
            raise SettingError(f"{section}.kind", kind, "heights were given: expected kind 'file' (a measured map)")
        try:
            if kind == "file":
                return cls._measured(section, table, heights, path, metadata)
            return cls._generated(section, kind, table)
        except SettingError as exc:
            raise _in_section(section, exc) from None

    @classmethod
    def from_heights(
        cls,
        heights: ArrayLike,
        *,
        pixel_m: float,
        height_unit_m: float = 1.0,
        section: str = "surface",
        path: str | None = None,
    ) -> SurfaceSpec:
        """A measured surface from an array of heights (in units of ``height_unit_m``), for notebooks."""
        table = {"kind": "file", "pixel_m": pixel_m, "height_unit_m": height_unit_m}
        return cls.from_table(section, table, heights, path=path)

    @classmethod
    def _measured(
        cls,
        section: str,
        table: dict[str, Any],
        heights: ArrayLike | None,
        path: str | None,
        metadata: Mapping[str, Any] | None = None,
    ) -> SurfaceSpec:
        source = _path_of(table, path)
        if heights is None:
            if source is None:
                raise SettingError("path", None, "required key for kind 'file' is missing")
            raise SettingError(
                "path",
                source,
                "the height map was not read: load the scene from its file (contactrig.core.scene.load_scene) "
                "or pass the heights (SurfaceSpec.from_table(..., heights=...))",
            )
        meta = dict(metadata or {})
        pixel_m = check_range("pixel_m", _from_file_or_table(table, meta, "pixel_m", source), 0.0, 1.0, lo_open=True)
        if "pixel_m" not in table and pixel_m > MAX_FILE_PIXEL_M:
            raise SettingError(
                "pixel_m",
                pixel_m,
                f"the file {source} says its pixel is {pixel_m:g} m, more than a profilometer's "
                f"({MAX_FILE_PIXEL_M:g} m at most): its metadata are doubtful; set pixel_m (metres) in the scene",
            )
        unit = check_range(
            "height_unit_m", _from_file_or_table(table, meta, "height_unit_m", source), 0.0, 1e3, lo_open=True
        )
        key = "path" if source is not None else "heights"
        conditioning = Conditioning.from_table(table)
        raw = np.asarray(heights, dtype=np.float64)
        resampled: dict[str, Any] = {}
        pixel_y = meta.get("pixel_y_m")
        if "pixel_m" not in table and pixel_y is not None and raw.ndim == 2:
            from sims.surface_filter import square_pixels

            raw, pixel_m, resampled = square_pixels(raw, pixel_m, check_range("pixel_y_m", pixel_y, 0.0, 1.0))
        z, record = condition_height_map(
            raw, pixel_m=pixel_m, height_unit_m=unit, conditioning=conditioning, key=key, source=source
        )
        z.setflags(write=False)
        missing = ~np.isfinite(raw)
        missing.setflags(write=False)
        record.update(resampled)
        record.update({k: v for k, v in meta.items() if k in ("instrument", "file_format") and v is not None})
        record["edges"] = conditioning.edges
        record["pixel_m_from"] = "scene" if "pixel_m" in table else "file"
        record["height_unit_m_from"] = "scene" if "height_unit_m" in table else "file"
        return cls(
            section=section,
            kind="file",
            pixel_m=pixel_m,
            path=source,
            height_unit_m=unit,
            sq_m=math.sqrt(finite_difference_moments(np.where(missing, np.nan, z), pixel_m).m0),  # measured points
            measured=z,
            missing=missing,
            conditioning=record,
        )

    @classmethod
    def _generated(cls, section: str, kind: str, table: dict[str, Any]) -> SurfaceSpec:
        n, pixel_m = _check_grid(table["n"], table["pixel_m"])
        sq_m = check_range("sq_m", table["sq_m"], 0.0, 1e-2, lo_open=True, unit="m")
        spec = cls(
            section=section, kind=kind, n=n, pixel_m=pixel_m, sq_m=sq_m, seed=check_int("seed", table.get("seed", 0), 0)
        )
        if kind == "gaussian":
            return spec._with_correlation(table["correlation_m"])
        return spec._with_spectrum(table["hurst"], table.get("rolloff_m"), table.get("cutoff_m"))

    def _with_correlation(self, value: Any) -> SurfaceSpec:
        """Gaussian: λ between 2 pixels and a quarter box; RMS slope 2 Sq/λ."""
        lam = check_range("correlation_m", value, 0.0, 1.0, lo_open=True, unit="m")
        lo, hi = 2 * self.pixel_m, self.n * self.pixel_m / 4
        if lam < lo or lam > hi:
            raise SettingError("correlation_m", lam, f"expected 2 pixels to a quarter box: [{lo:g}, {hi:g}] m")
        _check_slope("sq_m", self.sq_m, 2.0 * self.sq_m / lam, f"sq_m with correlation_m = {lam:g} m")
        return replace(self, correlation_m=lam)

    def _with_spectrum(self, hurst_value: Any, rolloff_m: Any, cutoff_m: Any) -> SurfaceSpec:
        """Self-affine: H, roll-off and cut-off (defaults: box, 2 pixels)."""
        hurst = check_range("hurst", hurst_value, 0.0, 1.0, lo_open=True)
        q_roll, q_cut = _self_affine_q(self.n, self.pixel_m, rolloff_m, cutoff_m)
        q_box = 2 * np.pi / (self.n * self.pixel_m)
        slope = _self_affine_slope(self.sq_m, hurst, q_box, q_roll, q_cut)
        _check_slope("sq_m", self.sq_m, slope, f"sq_m with hurst = {hurst:g}, cut-off {2 * np.pi / q_cut:g} m")
        return replace(self, hurst=hurst, rolloff_m=2 * np.pi / q_roll, cutoff_m=2 * np.pi / q_cut)

    def _value(self, key: str) -> float:
        """A key the kind needs (set by :meth:`from_table`; a hand-built spec may lack it)."""
        value = getattr(self, key)
        if value is None:
            raise SettingError(f"{self.section}.{key}", None, f"required for kind {self.kind!r}")
        return float(value)

    @property
    def periodic(self) -> bool:
        return self.kind != "file"

    def heights(self) -> NDArray[np.float64]:
        """The height map, m (generated, or the measured one conditioned and its edges treated as ``edges`` says; a
        fresh array either way). A measured line profile has none (an error saying so)."""
        if self.kind == "gaussian":
            lam = self._value("correlation_m")
            return gaussian(self.n, pixel_m=self.pixel_m, sq_m=self.sq_m, correlation_m=lam, seed=self.seed)
        if self.kind == "self_affine":
            return self_affine(
                self.n,
                pixel_m=self.pixel_m,
                sq_m=self.sq_m,
                hurst=self._value("hurst"),
                rolloff_m=self._value("rolloff_m"),
                cutoff_m=self._value("cutoff_m"),
                seed=self.seed,
            )
        if self.measured is None:
            raise SettingError(f"{self.section}.path", self.path, "no height map: build it with from_table(heights=)")
        if self.is_profile:
            raise SettingError(
                f"{self.section}.path",
                self.path,
                "is a line profile (stylus trace): the summation models and BEM need an areal height map; "
                "statistics-only models (greenwood_tripp) accept a profile",
            )
        from sims.surface_filter import treat_edges

        return treat_edges(self.measured, (self.conditioning or {}).get("edges", "mirror"))

    def measured_points(self) -> NDArray[np.float64]:
        """The conditioned measured map (m) with NaN where no point was measured: what statistics are taken on."""
        if self.measured is None:
            raise SettingError(f"{self.section}.path", self.path, "no height map")
        if self.missing is None:
            return self.measured.copy()
        return np.where(self.missing, np.nan, self.measured)

    @property
    def is_profile(self) -> bool:
        """A measured line profile (1-D): statistics only."""
        return self.measured is not None and self.measured.ndim == 1

    def moments(self) -> SpectralMoments:
        """Spectral moments without generating the surface (generated kinds); of the map for measured ones."""
        if self.kind == "file":
            return finite_difference_moments(self.measured_points(), self.pixel_m)
        qx, qy = _wavenumbers(self.n, self.pixel_m)
        q2 = qx[:, None] ** 2 + qy[None, :] ** 2
        if self.kind == "gaussian":
            psd = _gaussian_psd(q2, self._value("correlation_m"))
        else:
            q_roll = 2 * np.pi / self._value("rolloff_m")
            psd = _self_affine_psd(q2, self._value("hurst"), q_roll, 2 * np.pi / self._value("cutoff_m"))
        return expected_spectral_moments(psd, self.n, self.pixel_m, self.sq_m)

    def as_dict(self) -> dict[str, Any]:
        """The settings as plain values (for provenance; the measured array is left out, its ``path`` kept)."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("measured", "missing")}
        return {k: v for k, v in out.items() if v is not None}


def surfaces_from_scene(scene: Scene) -> tuple[SurfaceSpec, SurfaceSpec]:
    """Parse ``[surfaces.liner]`` and ``[surfaces.piston]`` of ``scene`` (with its height maps, already read)."""
    table = scene.table("surfaces")
    check_keys("surfaces", table, ("liner", "piston"))
    maps = scene.height_maps
    out = []
    for body in ("liner", "piston"):
        section = f"surfaces.{body}"
        if body not in table:
            raise SettingError(section, None, "required table is missing")
        loaded = maps.get(section)
        if loaded is None:
            out.append(SurfaceSpec.from_table(section, table[body]))
        else:
            out.append(
                SurfaceSpec.from_table(
                    section, table[body], loaded.heights, path=loaded.path, metadata=loaded.metadata()
                )
            )
    return out[0], out[1]
