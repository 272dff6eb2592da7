"""The simulated contact database: nominal pressure and real-area fraction against separation (seed Fig. 2).

For the scene's surface pair and materials, each requested model gives a :class:`ContactCurve` on a uniform grid
of separations h (distance between the mean planes of the two surfaces, m):

* ``"greenwood_tripp"`` — seed eq. 1–3 from statistics only (McCool's values from each surface's spectral moments;
  no surface is generated for it). GT's asperity-pair integral needs η = √(η1 η2), β^(3/2) = √(β1 β2 (β1 + β2)/2)
  for the pressure and β = √(β1 β2) for the area (both exact for unlike surfaces), and the distribution of the
  summed summit heights. ``gt_heights = "summits"`` (default) takes that from the summits: mean z̄_s1 + z̄_s2
  above the mean planes of the surface heights (McCool: z̄_s = 4 Sq/√(πα) ≈ 1.3 Sq at α = 3) and SD
  σ_s = √(σ_s1² + σ_s2²), i.e. p = GT(h − z̄; σ_s) — the same origin of h as the asperity models.
  ``gt_heights = "seed"`` is seed eq. 1–3 as printed: summit heights centred on the mean planes with
  σ = √(Sq1² + Sq2²), p = GT(h; σ) — 6–120× less pressure at equal h on the default surfaces (MODELS.md).
  Grid: h from ``h_min_sigma``·σ to ``h_max_sigma``·σ, σ = √(Sq1² + Sq2²).
* the asperity models (:mod:`sims.asperity`) — deterministic summation over the summits of the composite surface
  z = z_liner + z_piston against a flat (the standard reduction of two rough surfaces to one: the gap at a point is
  h − z_liner − z_piston). A summit of height z_i and mean-curvature radius R_i (seed eq. 8) has interference
  δ_i = z_i − h; pressure = Σ F(δ_i)/A0 and area fraction = Σ A(δ_i)/A0 with A0 the map's nominal area.
  Grid: h from ``h_min_sigma``·σ up to the highest summit (first contact, where p = 0).

Curves interpolate ln p and ln(A/A0) with a monotone cubic (Fritsch–Carlson) so ``pressure(h)`` is smooth,
monotone, positive and has the analytic slope ``dpressure_dh``. Between the last tabulated point in contact and the
first contact (asperity models) p and A/A0 follow a power law (h_top − h)^m, m ≥ 1 matched to the slope of the
last cubic (a single Hertzian summit would give 3/2 and 1; the shape-preserving limiter may steepen it); above
``h_max`` p = 0 (asperity) or the log-linear tail (GT); below ``h_min`` the curve continues along its tangent
(linear in p: a log-linear extrapolation overflows a few µm below the table) and ``in_range`` is False (the rig
warns).

Scene table ``[database]``: ``models`` (list), ``n_separations`` (16…100000), ``h_min_sigma`` (deepest separation
/ σ, −3…3), ``h_max_sigma`` (GT's largest separation / σ, 1…10), ``gt_heights`` ("summits" | "seed").

Models come from the registry (:mod:`sims.models`): each registered :class:`~sims.models.ContactModel` builds its
curve from a :class:`BuildContext` — ``ctx.greenwood_tripp_curve`` for statistics-only models, ``ctx.summed_curve``
for summation over the composite surface's summits. Model-validity warnings (e.g. Jackson & Green's fit used beyond
ω/ω_c = 110, its fitted range) are ``RuntimeWarning``s at build time, also listed in ``provenance["warnings"]``.

Physics only: the HDF5 file of a database is written and read by :mod:`daq.database_file`.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicHermiteSpline, PchipInterpolator, PPoly

from contactrig.core.provenance import software_version
from contactrig.core.validation import SettingError, check_choice, check_int, check_keys, check_range
from sims.budget import check_database

if TYPE_CHECKING:
    from contactrig.core.scene import Scene
    from sims.config import SimConfig
    from sims.materials import ContactMaterials

__all__ = [
    "DATABASE_KEYS",
    "GT_HEIGHTS",
    "BuildContext",
    "ContactCurve",
    "ContactDatabase",
    "DatabaseSettings",
    "MissingModelError",
    "Summits",
    "asperity_sums",
    "build_database",
    "check_models",
    "greenwood_tripp_parameters",
]

DATABASE_KEYS = ("models", "n_separations", "h_min_sigma", "h_max_sigma", "gt_heights")
GT_HEIGHTS = ("summits", "seed")
_ONSET_EXPONENT_P = 1.5  # a single Hertzian summit: F ∝ δ^(3/2)
_ONSET_EXPONENT_A = 1.0  # ... and A ∝ δ


class MissingModelError(KeyError, ValueError):
    """A model that is not in the database was asked for."""

    def __str__(self) -> str:  # KeyError quotes its argument; keep the message readable
        return str(self.args[0]) if self.args else ""


# ---------------------------------------------------------------------------------------------------------------
# Monotone interpolation in log space.


def _pchip_slopes(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Node slopes of SciPy's shape-preserving PCHIP (Fritsch–Carlson/Butland) through (x, y)."""
    if y.size == 2:
        return np.full(2, (y[1] - y[0]) / (x[1] - x[0]))
    return np.asarray(PchipInterpolator(x, y).derivative()(x), dtype=float)


@dataclass(frozen=True)
class _LogCurve:
    """ln y(x) by SciPy's monotone cubic Hermite on [x0, x_last]; log-linear beyond; optional power-law onset at
    x_top. The spline's node slopes are PCHIP's except the last one when an onset law follows (see ``build``)."""

    spline: CubicHermiteSpline
    slope: PPoly
    x_top: float | None  # y(x_top) = 0 (contact onset); None: y > 0 everywhere (log-linear above)
    exponent: float

    @property
    def x(self) -> NDArray[np.float64]:
        return np.asarray(self.spline.x, dtype=float)

    @classmethod
    def build(cls, x: NDArray[np.float64], y: NDArray[np.float64], onset: bool, exponent: float) -> _LogCurve:
        if onset:
            xs, ys, x_top = x[:-1], y[:-1], float(x[-1])
        else:
            xs, ys, x_top = x, y, None
        ly = np.log(ys)
        d = _pchip_slopes(xs, ly)
        if x_top is not None:
            # slope of the onset law at the last node, limited to keep the last cubic monotone
            s_last = (ly[-1] - ly[-2]) / (xs[-1] - xs[-2])
            d_top = -exponent / (x_top - xs[-1])
            d[-1] = max(d_top, 3.0 * s_last) if s_last < 0 else d_top
            # the onset law (x_top − x)^m meets the cubic with a continuous slope; m >= 1 keeps dp/dh finite
            exponent = max(-d[-1] * (x_top - xs[-1]), 1.0)
            d[-1] = -exponent / (x_top - xs[-1])
        spline = CubicHermiteSpline(xs, ly, d, extrapolate=False)
        return cls(spline, spline.derivative(), x_top, exponent)

    def _below(self, xq: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        # Linear in y (tangent at the first node): finite for every h, where a log-linear tail would overflow.
        x0 = float(self.spline.x[0])
        y0 = math.exp(float(self.spline(x0)))
        d0 = float(self.slope(x0))
        return y0 * (1.0 + d0 * (xq - x0)), np.full_like(xq, d0 * y0)

    def _above(self, xq: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        x1 = float(self.spline.x[-1])
        l1, d1 = float(self.spline(x1)), float(self.slope(x1))
        if self.x_top is None:
            with np.errstate(under="ignore"):
                v = np.exp(l1 + d1 * (xq - x1))
            return v, d1 * v
        span = self.x_top - x1
        r = np.clip((self.x_top - xq) / span, 0.0, None)
        v = math.exp(l1) * r**self.exponent
        with np.errstate(divide="ignore", invalid="ignore"):
            dv = np.where(r > 0, -self.exponent * v / (r * span), 0.0)
        return v, dv

    def __call__(self, xq: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(y, dy/dx) at ``xq``."""
        x = self.spline.x
        y = np.zeros_like(xq)
        dy = np.zeros_like(xq)
        lo = xq < x[0]
        hi = xq > x[-1]
        mid = ~(lo | hi)
        if lo.any():
            y[lo], dy[lo] = self._below(xq[lo])
        if mid.any():
            v = np.exp(self.spline(xq[mid]))
            y[mid] = v
            dy[mid] = self.slope(xq[mid]) * v
        if hi.any():
            y[hi], dy[hi] = self._above(xq[hi])
        return y, dy


# ---------------------------------------------------------------------------------------------------------------
# Curves and the database.


def _positive_monotone(name: str, values: NDArray[np.float64], model: str) -> None:
    if not np.all(np.isfinite(values)) or values.min() < 0:
        raise SettingError(f"{model}.{name}", "table", "expected finite, non-negative values")
    if np.any(np.diff(values) > 0):
        k = int(np.argmax(np.diff(values) > 0))
        raise SettingError(f"{model}.{name}", f"index {k}", "expected values non-increasing in separation")


@dataclass(frozen=True, eq=False)
class ContactCurve:
    """Tabulated p(h) and A(h)/A0 of one model with smooth monotone interpolation (see the module docstring).

    ``separation_m`` increasing (m); ``pressure_pa`` (Pa) and ``area_fraction`` (−) non-increasing and >= 0; at
    most the last point may be 0 (the contact onset of an asperity model).
    """

    model: str
    separation_m: NDArray[np.float64]
    pressure_pa: NDArray[np.float64]
    area_fraction: NDArray[np.float64]
    parameters: dict[str, Any] = field(default_factory=dict)
    _p: _LogCurve = field(init=False, repr=False, compare=False)
    _a: _LogCurve = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        h = np.asarray(self.separation_m, dtype=float)
        p = np.asarray(self.pressure_pa, dtype=float)
        a = np.asarray(self.area_fraction, dtype=float)
        if not (h.ndim == p.ndim == a.ndim == 1 and h.size == p.size == a.size and h.size >= 3):
            raise SettingError(self.model, h.size, "expected three 1-D tables of equal length >= 3")
        if not np.all(np.isfinite(h)) or np.any(np.diff(h) <= 0):
            raise SettingError(f"{self.model}.separation_m", "table", "expected finite, strictly increasing values")
        _positive_monotone("pressure_pa", p, self.model)
        _positive_monotone("area_fraction", a, self.model)
        if a.max() > 1.0:
            raise SettingError(f"{self.model}.area_fraction", float(a.max()), "expected values <= 1")
        onset = p[-1] == 0.0
        if np.any(p[:-1] <= 0) or np.any(a[:-1] <= 0) or (onset != (a[-1] == 0.0)):
            raise SettingError(self.model, "table", "only the last point may be out of contact (p = A = 0)")
        for name, arr in (("separation_m", h), ("pressure_pa", p), ("area_fraction", a)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "_p", _LogCurve.build(h, p, onset, _ONSET_EXPONENT_P))
        object.__setattr__(self, "_a", _LogCurve.build(h, a, onset, _ONSET_EXPONENT_A))

    @property
    def h_min(self) -> float:
        return float(self.separation_m[0])

    @property
    def h_max(self) -> float:
        return float(self.separation_m[-1])

    def in_range(self, h: ArrayLike) -> NDArray[np.bool_]:
        """True where ``h`` (m) is not below the tabulated range (above it the curve is exact: no contact/tail)."""
        return np.asarray(h, dtype=float) >= self.h_min

    def _eval(self, curve: _LogCurve, h: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        hh = np.asarray(h, dtype=float)
        if hh.size and np.isnan(hh).any():
            raise SettingError("h", "nan", "expected separations in m (got NaN)")
        flat = np.atleast_1d(hh).ravel()
        y, dy = curve(flat)
        return y.reshape(hh.shape), dy.reshape(hh.shape)

    def pressure(self, h: ArrayLike) -> NDArray[np.float64]:
        """Nominal contact pressure at separation ``h`` (m), Pa: finite and >= 0 for every real ``h``.

        Below ``h_min`` the value is the tangent extrapolation (``in_range`` False); no Python warning is raised
        per call because solvers evaluate there while bracketing — callers check ``in_range`` on their results.
        """
        return self._eval(self._p, h)[0]

    def dpressure_dh(self, h: ArrayLike) -> NDArray[np.float64]:
        """Analytic slope of :meth:`pressure`, Pa/m (<= 0)."""
        return self._eval(self._p, h)[1]

    def area_fraction_at(self, h: ArrayLike) -> NDArray[np.float64]:
        """Real / nominal contact area at ``h`` (m), in [0, 1].

        The bound 1 (real area cannot exceed the nominal one) can only act below ``h_min``, on the extrapolated
        tangent, where :meth:`in_range` is False — the caller's signal (the rig warns and extends the database).
        """
        return np.minimum(self._eval(self._a, h)[0], 1.0)


@dataclass(frozen=True)
class ContactDatabase(Mapping[str, ContactCurve]):
    """Curves by model name, with ``provenance`` (dict: scene, materials, surface statistics, software version)."""

    curves: dict[str, ContactCurve]
    provenance: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, name: str) -> ContactCurve:
        try:
            return self.curves[name]
        except KeyError:
            have = ", ".join(self.curves) or "none"
            raise MissingModelError(f"model {name!r} is not in this database (it has: {have})") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.curves)

    def __len__(self) -> int:
        return len(self.curves)


# ---------------------------------------------------------------------------------------------------------------
# Settings.


def _default_models() -> tuple[str, ...]:
    from sims.models import default_model_names

    return default_model_names()


@dataclass(frozen=True)
class DatabaseSettings:
    """The ``[database]`` table: which registered models to build, and the separation grid."""

    models: tuple[str, ...] = field(default_factory=_default_models)
    n_separations: int = 256
    h_min_sigma: float = -0.25
    h_max_sigma: float = 6.0
    gt_heights: str = "summits"

    def __post_init__(self) -> None:
        models = check_models("database.models", self.models)
        object.__setattr__(self, "models", models)
        check_int("database.n_separations", self.n_separations, 16, 100_000)
        check_range("database.h_min_sigma", self.h_min_sigma, -3.0, 3.0)
        check_range("database.h_max_sigma", self.h_max_sigma, 1.0, 10.0)
        if self.h_max_sigma <= self.h_min_sigma:
            raise SettingError(
                "database.h_max_sigma", self.h_max_sigma, f"expected > h_min_sigma = {self.h_min_sigma}"
            )
        check_choice("database.gt_heights", self.gt_heights, GT_HEIGHTS)

    @classmethod
    def from_scene(cls, scene: Scene) -> DatabaseSettings:
        table = scene.table("database")
        check_keys("database", table, DATABASE_KEYS)
        kwargs = {k: table[k] for k in DATABASE_KEYS if k in table}
        return cls(**kwargs)


def check_models(field_name: str, models: object) -> tuple[str, ...]:
    """``models`` as a tuple of registered model keys (duplicates dropped, order kept); a SettingError naming
    ``field_name`` otherwise. Accepts a list or a comma-separated string (the CLI's ``--models a,b``)."""
    from sims.models import model_names

    known = model_names()
    if isinstance(models, str):
        models = [m.strip() for m in models.split(",") if m.strip()]
    if not isinstance(models, Sequence) or len(models) == 0:
        raise SettingError(field_name, models, "expected a non-empty list of: " + ", ".join(known))
    out: list[str] = []
    for m in models:
        if m not in known:
            raise SettingError(field_name, m, "unknown model; expected one of " + ", ".join(known))
        if m not in out:
            out.append(m)
    return tuple(out)


# ---------------------------------------------------------------------------------------------------------------
# Building.


def greenwood_tripp_parameters(
    liner: Any, piston: Any, sq_liner_m: float, sq_piston_m: float, heights: str = "summits"
) -> dict[str, Any]:
    """Greenwood–Tripp parameters of a surface pair from each surface's summit statistics (``SummitStatistics``,
    e.g. :func:`sims.surface.mccool`) and RMS roughness Sq (m).

    Returns ``sigma_m`` (√(Sq1² + Sq2²), seed eq. 3: the grid unit), ``eta_per_m2`` = √(η1 η2), ``beta_m`` =
    √(β1 β2) (area), ``beta_pressure_m`` = (β1 β2 (β1 + β2)/2)^(1/3) (pressure; both exact in GT's asperity-pair
    integral for unlike surfaces and equal for alike ones), and the distribution of the summed summit heights that
    F_n integrates over: ``sigma_summits_m`` (its SD) and ``offset_m`` (its mean above the mean planes of the
    surface heights). ``heights="summits"``: √(σ_s1² + σ_s2²) and z̄_s1 + z̄_s2; ``"seed"`` (eq. 1–3 as printed):
    σ and 0.
    """
    from sims.surface import combined_sigma

    check_choice("database.gt_heights", heights, GT_HEIGHTS)
    b1, b2 = liner.beta, piston.beta
    out: dict[str, Any] = {
        "heights": heights,
        "sigma_m": combined_sigma(sq_liner_m, sq_piston_m),
        "eta_per_m2": math.sqrt(liner.eta * piston.eta),
        "beta_m": math.sqrt(b1 * b2),
        "beta_pressure_m": (b1 * b2 * (b1 + b2) / 2.0) ** (1.0 / 3.0),
    }
    if heights == "summits":
        offset = liner.mean_height + piston.mean_height
        if not math.isfinite(offset):
            raise SettingError("database.gt_heights", heights, "needs the mean summit height of both surfaces")
        out["sigma_summits_m"] = math.hypot(liner.sigma_s, piston.sigma_s)
        out["offset_m"] = offset
    else:
        out["sigma_summits_m"] = out["sigma_m"]
        out["offset_m"] = 0.0
    return out


#: Largest number of (separation, summit) pairs :func:`asperity_sums` evaluates at once: its memory is bounded
#: (~100 bytes a pair) whatever the grid and the number of separations (``sims.budget`` counts it).
PAIR_CHUNK = 1 << 18


def asperity_sums(
    asp_model: Any, heights_m: NDArray[np.float64], h: NDArray[np.float64], area_m2: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Σ force/A0 (Pa) and Σ area/A0 over summits for each separation in ``h`` (the model's R per summit).

    Summits must be sorted by height, highest first (``asp_model.R`` in the same order); at each h only the
    contacting prefix is evaluated, a run of separations at a time (at most :data:`PAIR_CHUNK` pairs, or one
    separation) so that memory does not grow with separations × summits.
    """
    n_contact = np.searchsorted(-heights_m, -h, side="left")  # summits with z > h: a prefix of the sorted list
    p = np.zeros(h.size)
    af = np.zeros(h.size)
    ends = np.cumsum(n_contact)
    start = 0
    while start < h.size:
        before = ends[start] - n_contact[start]
        stop = max(int(np.searchsorted(ends, before + PAIR_CHUNK, side="right")), start + 1)
        p[start:stop], af[start:stop] = _summed_rows(asp_model, heights_m, h[start:stop], n_contact[start:stop])
        start = stop
    return p / area_m2, af / area_m2


def _summed_rows(
    asp_model: Any, heights_m: NDArray[np.float64], h: NDArray[np.float64], n_contact: NDArray[np.intp]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Σ force (N) and Σ area (m²) over the contacting prefix of the summits, for each separation in ``h``."""
    rows = np.repeat(np.arange(h.size), n_contact)
    starts = np.cumsum(n_contact) - n_contact
    cols = np.arange(rows.size) - np.repeat(starts, n_contact)  # 0 … n_contact[k]−1 for each row k
    delta = heights_m[cols] - h[rows]
    R = np.asarray(asp_model.R, dtype=float)
    sub = replace(asp_model, R=R[cols] if R.ndim else R)
    f = sub.force(delta)
    a = sub.area(delta)
    force = np.bincount(rows, weights=f, minlength=h.size).astype(np.float64, copy=False)
    return force, np.bincount(rows, weights=a, minlength=h.size).astype(np.float64, copy=False)


@dataclass(frozen=True)
class Summits:
    """Summits of the composite surface z_liner + z_piston, highest first: heights (m) and mean-curvature radii
    (m, seed eq. 8), the map's nominal area A0 (m²), and the separation grid the summation models share (m); with
    the composite height map itself (m, pitch ``pixel_m``) for models that solve the whole topography (BEM)."""

    height_m: NDArray[np.float64]
    radius_m: NDArray[np.float64]
    area_m2: float
    separation_m: NDArray[np.float64]
    composite_m: NDArray[np.float64] | None = field(default=None, repr=False)
    pixel_m: float = math.nan


@dataclass
class BuildContext:
    """What a registered model's ``build`` gets: settings, materials, Greenwood–Tripp parameters of the pair and,
    for models that need a surface (``ContactModel.needs_surface``), the composite surface's summits. ``warn``
    records a model-validity warning in the database's provenance (and raises it as a RuntimeWarning)."""

    settings: DatabaseSettings
    materials: ContactMaterials
    greenwood_tripp: dict[str, Any]
    summits: Summits | None = None
    warnings: list[str] = field(default_factory=list)

    @property
    def E_star(self) -> float:
        """Composite modulus E* (Pa, seed eq. 4)."""
        return self.materials.E_star

    @property
    def sigma_m(self) -> float:
        """Combined RMS roughness σ = √(Sq1² + Sq2²) (m, seed eq. 3): the unit of the separation grid."""
        return float(self.greenwood_tripp["sigma_m"])

    def warn(self, message: str) -> None:
        self.warnings.append(message)
        warnings.warn(message, RuntimeWarning, stacklevel=3)

    def greenwood_tripp_curve(self, key: str) -> ContactCurve:
        """Seed eq. 1–3 on h = h_min_sigma·σ … h_max_sigma·σ, from the statistics only (no surface)."""
        from sims import greenwood_tripp as gt

        g, st = self.greenwood_tripp, self.settings
        h = np.linspace(st.h_min_sigma * self.sigma_m, st.h_max_sigma * self.sigma_m, st.n_separations)
        hs = h - g["offset_m"]
        s, eta = g["sigma_summits_m"], g["eta_per_m2"]
        p = gt.pressure(hs, sigma=s, eta=eta, beta=g["beta_pressure_m"], E_star=self.E_star)
        try:
            a = gt.area_fraction(hs, sigma=s, eta=eta, beta=g["beta_m"])
        except SettingError as exc:
            raise SettingError(
                "database.h_min_sigma", st.h_min_sigma, f"Greenwood–Tripp: {exc.allowed}; raise h_min_sigma"
            ) from None
        return ContactCurve(key, h, p, a, {**g, "E_star_pa": self.E_star})

    def summed_curve(self, key: str, asperity: Any, parameters: dict[str, Any] | None = None) -> ContactCurve:
        """Deterministic summation of the single-asperity model ``asperity`` (its ``R`` one radius per summit,
        highest summit first) over the composite surface's summits: p = ΣF(δ_i)/A0, A/A0 = ΣA(δ_i)/A0."""
        if self.summits is None:
            raise RuntimeError(f"model {key!r} needs a surface, but none was generated (needs_surface is False)")
        sm = self.summits
        p, af = asperity_sums(asperity, sm.height_m, sm.separation_m, sm.area_m2)
        p[-1] = 0.0
        af[-1] = 0.0
        if af.max() > 1.0:
            raise SettingError(
                "database.h_min_sigma",
                self.settings.h_min_sigma,
                f"model {key!r}: real-area fraction {af.max():.3g} > 1 at the deepest separation "
                "(independent-asperity models fail there); raise h_min_sigma",
            )
        params = {"E_star_pa": self.E_star, "H_pa": self.materials.H, "n_summits": int(sm.height_m.size)}
        params.update(area_m2=sm.area_m2, **(parameters or {}))
        try:
            return ContactCurve(key, sm.separation_m, p, af, params)
        except SettingError as exc:
            raise RuntimeError(f"model {key!r}: the summed curve is not monotone ({exc})") from None


def _surface_statistics(config: SimConfig, heights: dict[str, NDArray[np.float64]], prov: dict[str, Any]) -> Any:
    """McCool statistics of each surface (from the generated map when there is one) → GT parameters."""
    from sims.surface import mccool

    sq, stats = {}, {}
    for body, spec in (("liner", config.liner), ("piston", config.piston)):
        mom = spec.moments()  # a measured map's (or profile's) from finite differences: it is not periodic
        st = mccool(mom)
        sq[body], stats[body] = math.sqrt(mom.m0), st
        prov["surfaces"][body].update(mccool=st.as_dict(), sq_m=sq[body])
    return greenwood_tripp_parameters(
        stats["liner"], stats["piston"], sq["liner"], sq["piston"], config.database.gt_heights
    )


def _composite_summits(
    config: SimConfig, heights: dict[str, NDArray[np.float64]], sigma_m: float, prov: dict[str, Any]
) -> Summits:
    from sims.surface import statistics_of, summit_data

    liner, piston = config.liner, config.piston
    z1, z2 = heights["liner"], heights["piston"]
    if z1.shape != z2.shape or not math.isclose(liner.pixel_m, piston.pixel_m, rel_tol=1e-9):
        raise SettingError(
            "surfaces.piston",
            f"{z2.shape} at {piston.pixel_m:g} m",
            f"the asperity models need both surfaces on one grid: liner is {z1.shape} at {liner.pixel_m:g} m",
        )
    composite = z1 + z2
    data = summit_data(composite, liner.pixel_m, periodic=liner.periodic and piston.periodic)
    if data.height_m.size < 2:
        raise SettingError("surfaces", data.height_m.size, "the composite surface has fewer than 2 summits")
    order = np.argsort(-data.height_m, kind="stable")
    zs = data.height_m[order]
    prov["composite_surface"] = {
        "sq_m": float(np.std(composite)),
        "summits": statistics_of(data).as_dict(),
        "highest_summit_m": float(zs[0]),
        "area_m2": data.area_m2,
    }
    st = config.database
    h_lo = st.h_min_sigma * sigma_m
    if float(zs[0]) <= h_lo:
        raise SettingError("database.h_min_sigma", st.h_min_sigma, "is above the highest summit")
    h = np.linspace(h_lo, float(zs[0]), st.n_separations)
    return Summits(zs, data.radius_m[order], data.area_m2, h, composite_m=composite, pixel_m=liner.pixel_m)


def _with_overrides(
    settings: DatabaseSettings, models: Sequence[str] | str | None, n_separations: int | None, gt_heights: str | None
) -> DatabaseSettings:
    if models is not None:
        settings = replace(settings, models=check_models("--models", models))
    if n_separations is not None:
        settings = replace(settings, n_separations=check_int("--n-separations", n_separations, 16, 100_000))
    if gt_heights is not None:
        settings = replace(settings, gt_heights=check_choice("--gt-heights", gt_heights, GT_HEIGHTS))
    return settings


def build_database(
    config: SimConfig,
    models: Sequence[str] | str | None = None,
    *,
    n_separations: int | None = None,
    gt_heights: str | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> ContactDatabase:
    """Build the curves of ``models`` (registered keys; default: the scene's ``[database] models``);
    ``progress(done, total)`` after each model (the command draws it; nothing is printed here).

    Only the models asked for are built (each by its registered ``build``); surfaces are generated only when a
    model that needs one is asked for, or a surface is a measured map. ``n_separations`` and ``gt_heights``
    (``"summits"`` | ``"seed"``) override the scene's. Raises :class:`~contactrig.core.validation.SettingError`
    (a ValueError) naming the scene key on bad settings.
    """
    from sims.models import get_model

    t_start = time.perf_counter()
    settings = _with_overrides(config.database, models, n_separations, gt_heights)
    config = config.with_changes(database=settings)
    check_database(config)  # before any surface is generated
    mats = config.materials
    prov: dict[str, Any] = {
        "software": "contactrig",
        "software_version": software_version(),
        **config.provenance(),
        "models": list(settings.models),
        "settings": {
            "n_separations": settings.n_separations,
            "h_min_sigma": settings.h_min_sigma,
            "h_max_sigma": settings.h_max_sigma,
            "gt_heights": settings.gt_heights,
        },
        "materials": mats.as_dict(),
        "surfaces": {"liner": config.liner.as_dict(), "piston": config.piston.as_dict()},
    }
    specs = [get_model(m) for m in settings.models]
    need_surface = any(s.needs_surface for s in specs)
    heights: dict[str, NDArray[np.float64]] = {}
    if need_surface:  # a measured map is already held (a profile has no map: its statistics are enough)
        heights = {"liner": config.liner.heights(), "piston": config.piston.heights()}
    g = _surface_statistics(config, heights, prov)
    prov["greenwood_tripp"] = g
    # Greenwood & Williamson's plasticity index (E*/H) √(σ/β), σ = √(Sq1² + Sq2²), β = √(β1 β2)
    prov["plasticity_index"] = (mats.E_star / mats.H) * math.sqrt(g["sigma_m"] / g["beta_m"])
    ctx = BuildContext(settings, mats, g)
    if need_surface:
        ctx.summits = _composite_summits(config, heights, g["sigma_m"], prov)
    curves = {}
    for i, spec in enumerate(specs):
        curves[spec.key] = spec.build(ctx)
        if progress is not None:
            progress(i + 1, len(specs))
    if ctx.warnings:
        prov["warnings"] = list(ctx.warnings)
    prov["build_time_s"] = time.perf_counter() - t_start
    return ContactDatabase(curves, prov)
