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

Warnings: Jackson & Green's fit used beyond ω/ω_c = 110 (its fitted range) is a ``RuntimeWarning`` at build time,
also listed in ``provenance["warnings"]``.

HDF5 layout (:func:`save_database`): one group per model with datasets ``separation_m`` (units "m"),
``pressure_pa`` ("Pa") and ``area_fraction`` ("1"); group attributes hold the model's parameters; the root
attribute ``provenance`` holds the JSON provenance (scene name and text, materials, surface statistics, software
version).
"""

from __future__ import annotations

import json
import math
import time
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contactrig.core.provenance import json_default, software_version
from contactrig.core.validation import SettingError, check_choice, check_int, check_keys, check_range
from sims.materials import ContactMaterials, materials_from_scene

__all__ = [
    "DATABASE_KEYS",
    "GT_HEIGHTS",
    "KNOWN_MODELS",
    "ContactCurve",
    "ContactDatabase",
    "DatabaseSettings",
    "MissingModelError",
    "build_database",
    "greenwood_tripp_parameters",
    "load_database",
    "save_database",
]

KNOWN_MODELS = ("greenwood_tripp", "hertz", "lagemann", "pasaribu_schipper", "jackson_green")
DATABASE_KEYS = ("models", "n_separations", "h_min_sigma", "h_max_sigma", "gt_heights")
GT_HEIGHTS = ("summits", "seed")
ASPERITY_MODELS = KNOWN_MODELS[1:]

_JG_FIT_LIMIT = 110.0  # Jackson & Green (2005) fitted ω/ω_c up to about this
_ONSET_EXPONENT_P = 1.5  # a single Hertzian summit: F ∝ δ^(3/2)
_ONSET_EXPONENT_A = 1.0  # ... and A ∝ δ


class MissingModelError(KeyError, ValueError):
    """A model that is not in the database was asked for."""

    def __str__(self) -> str:  # KeyError quotes its argument; keep the message readable
        return str(self.args[0]) if self.args else ""


# ---------------------------------------------------------------------------------------------------------------
# Monotone interpolation in log space.


def _pchip_slopes(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Fritsch–Carlson/Butland node slopes (shape preserving, as SciPy's PCHIP)."""
    h = np.diff(x)
    s = np.diff(y) / h
    d = np.zeros_like(y)
    if y.size == 2:
        d[:] = s[0]
        return d
    w1 = 2.0 * h[1:] + h[:-1]
    w2 = h[1:] + 2.0 * h[:-1]
    same = (s[:-1] * s[1:]) > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        hm = (w1 + w2) / (w1 / s[:-1] + w2 / s[1:])
    d[1:-1] = np.where(same, hm, 0.0)

    def edge(h0: float, h1: float, s0: float, s1: float) -> float:
        e = ((2.0 * h0 + h1) * s0 - h0 * s1) / (h0 + h1)
        if np.sign(e) != np.sign(s0):
            return 0.0
        if np.sign(s0) != np.sign(s1) and abs(e) > abs(3.0 * s0):
            return 3.0 * s0
        return e

    d[0] = edge(h[0], h[1], s[0], s[1])
    d[-1] = edge(h[-1], h[-2], s[-1], s[-2])
    return d


@dataclass(frozen=True)
class _LogCurve:
    """ln y(x) by monotone cubic Hermite on [x0, x_last]; log-linear beyond; optional power-law onset at x_top."""

    x: NDArray[np.float64]
    ly: NDArray[np.float64]
    d: NDArray[np.float64]
    x_top: float | None  # y(x_top) = 0 (contact onset); None: y > 0 everywhere (log-linear above)
    exponent: float

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
        return cls(xs, ly, d, x_top, exponent)

    def __call__(self, xq: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(y, dy/dx) at ``xq``."""
        x, ly, d = self.x, self.ly, self.d
        y = np.zeros_like(xq)
        dy = np.zeros_like(xq)
        lo = xq < x[0]
        mid = (xq >= x[0]) & (xq <= x[-1])
        hi = xq > x[-1]
        if lo.any():
            # Linear in y (tangent at the first node): finite for every h, where a log-linear tail would overflow.
            y0 = math.exp(ly[0])
            y[lo] = y0 * (1.0 + d[0] * (xq[lo] - x[0]))
            dy[lo] = d[0] * y0
        if mid.any():
            xm = xq[mid]
            i = np.clip(np.searchsorted(x, xm, side="right") - 1, 0, x.size - 2)
            hh = x[i + 1] - x[i]
            u = (xm - x[i]) / hh
            y0, y1, d0, d1 = ly[i], ly[i + 1], d[i] * hh, d[i + 1] * hh
            h00 = (1 + 2 * u) * (1 - u) ** 2
            h10 = u * (u - 1) ** 2
            h01 = u * u * (3 - 2 * u)
            h11 = u * u * (u - 1)
            l_val = h00 * y0 + h10 * d0 + h01 * y1 + h11 * d1
            dl = (6 * u * u - 6 * u) * (y0 - y1) / hh + (3 * u * u - 4 * u + 1) * d[i] + (3 * u * u - 2 * u) * d[i + 1]
            v = np.exp(l_val)
            y[mid] = v
            dy[mid] = dl * v
        if hi.any():
            xh = xq[hi]
            if self.x_top is None:
                with np.errstate(under="ignore"):
                    v = np.exp(ly[-1] + d[-1] * (xh - x[-1]))
                y[hi] = v
                dy[hi] = d[-1] * v
            else:
                span = self.x_top - x[-1]
                r = np.clip((self.x_top - xh) / span, 0.0, None)
                v = math.exp(ly[-1]) * r**self.exponent
                y[hi] = v
                with np.errstate(divide="ignore", invalid="ignore"):
                    dv = np.where(r > 0, -self.exponent * v / (r * span), 0.0)
                dy[hi] = dv
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

    def darea_fraction_dh(self, h: ArrayLike) -> NDArray[np.float64]:
        """Slope of :meth:`area_fraction_at`, 1/m (<= 0; 0 where the bound 1 acts)."""
        y, dy = self._eval(self._a, h)
        return np.where(y < 1.0, dy, 0.0)


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


@dataclass(frozen=True)
class DatabaseSettings:
    """The ``[database]`` table."""

    models: tuple[str, ...] = KNOWN_MODELS
    n_separations: int = 256
    h_min_sigma: float = -0.25
    h_max_sigma: float = 6.0
    gt_heights: str = "summits"

    def __post_init__(self) -> None:
        models = _check_models("database.models", self.models)
        object.__setattr__(self, "models", models)
        check_int("database.n_separations", self.n_separations, 16, 100_000)
        check_range("database.h_min_sigma", self.h_min_sigma, -3.0, 3.0)
        check_range("database.h_max_sigma", self.h_max_sigma, 1.0, 10.0)
        if self.h_max_sigma <= self.h_min_sigma:
            raise SettingError("database.h_max_sigma", self.h_max_sigma, f"expected > h_min_sigma = {self.h_min_sigma}")
        check_choice("database.gt_heights", self.gt_heights, GT_HEIGHTS)

    @classmethod
    def from_scene(cls, scene: Any) -> DatabaseSettings:
        table = scene.table("database")
        check_keys("database", table, DATABASE_KEYS)
        kwargs = {k: table[k] for k in DATABASE_KEYS if k in table}
        if "models" in kwargs:
            kwargs["models"] = _check_models("database.models", kwargs["models"])
        return cls(**kwargs)


def _check_models(field_name: str, models: Any) -> tuple[str, ...]:
    if isinstance(models, str) or not isinstance(models, Sequence) or len(models) == 0:
        raise SettingError(field_name, models, "expected a non-empty list of: " + ", ".join(KNOWN_MODELS))
    out = []
    for m in models:
        if m not in KNOWN_MODELS:
            raise SettingError(field_name, m, "unknown model; expected one of " + ", ".join(KNOWN_MODELS))
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

    check_choice("gt_heights", heights, GT_HEIGHTS)
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
            raise SettingError("gt_heights", heights, "needs the mean summit height of both surfaces")
        out["sigma_summits_m"] = math.hypot(liner.sigma_s, piston.sigma_s)
        out["offset_m"] = offset
    else:
        out["sigma_summits_m"] = out["sigma_m"]
        out["offset_m"] = 0.0
    return out


def _gt_curve(g: dict[str, Any], E_star: float, settings: DatabaseSettings) -> ContactCurve:
    from sims import greenwood_tripp as gt

    sigma = g["sigma_m"]
    h = np.linspace(settings.h_min_sigma * sigma, settings.h_max_sigma * sigma, settings.n_separations)
    hs = h - g["offset_m"]
    s, eta = g["sigma_summits_m"], g["eta_per_m2"]
    p = gt.pressure(hs, sigma=s, eta=eta, beta=g["beta_pressure_m"], E_star=E_star)
    try:
        a = gt.area_fraction(hs, sigma=s, eta=eta, beta=g["beta_m"])
    except SettingError as exc:
        raise SettingError(
            "database.h_min_sigma", settings.h_min_sigma, f"Greenwood–Tripp: {exc.allowed}; raise h_min_sigma"
        ) from None
    return ContactCurve("greenwood_tripp", h, p, a, {**g, "E_star_pa": E_star})


def asperity_sums(
    asp_model: Any, heights_m: NDArray[np.float64], h: NDArray[np.float64], area_m2: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Σ force/A0 (Pa) and Σ area/A0 over summits for each separation in ``h`` (the model's R per summit).

    Summits must be sorted by height, highest first (``asp_model.R`` in the same order); at each h only the
    contacting prefix is evaluated.
    """
    n_contact = np.searchsorted(-heights_m, -h, side="left")  # summits with z > h: a prefix of the sorted list
    rows = np.repeat(np.arange(h.size), n_contact)
    starts = np.cumsum(n_contact) - n_contact
    cols = np.arange(rows.size) - np.repeat(starts, n_contact)  # 0 … n_contact[k]−1 for each row k
    delta = heights_m[cols] - h[rows]
    R = np.asarray(asp_model.R, dtype=float)
    sub = _with_radius(asp_model, R[cols] if R.ndim else R)
    f = sub.force(delta)
    a = sub.area(delta)
    p = np.bincount(rows, weights=f, minlength=h.size) / area_m2
    af = np.bincount(rows, weights=a, minlength=h.size) / area_m2
    return p, af


def _with_radius(asp_model: Any, R: Any) -> Any:
    return replace(asp_model, R=R)


def build_database(
    scene: Any,
    models: Sequence[str] | None = None,
    *,
    n_separations: int | None = None,
    gt_heights: str | None = None,
) -> ContactDatabase:
    """Build the curves of ``models`` (default: the scene's ``[database].models``) for ``scene``.

    Only the models asked for are built; surfaces are generated (or loaded) only when an asperity model is asked
    for. ``n_separations`` and ``gt_heights`` (``"summits"`` | ``"seed"``) override the scene's. Raises
    :class:`~contactrig.core.validation.SettingError` (a ValueError) naming the scene key on bad settings.
    """
    from sims import asperity
    from sims.surface import mccool, statistics_of, summit_data, surfaces_from_scene

    t_start = time.perf_counter()
    settings = DatabaseSettings.from_scene(scene)
    if models is not None:
        settings = replace(settings, models=_check_models("models", list(models)))
    if n_separations is not None:
        settings = replace(settings, n_separations=check_int("n_separations", n_separations, 16, 100_000))
    if gt_heights is not None:
        settings = replace(settings, gt_heights=check_choice("gt_heights", gt_heights, GT_HEIGHTS))
    mats: ContactMaterials = materials_from_scene(scene)
    liner, piston = surfaces_from_scene(scene)
    E_star = mats.E_star

    prov: dict[str, Any] = {
        "software": "contactrig",
        "software_version": software_version(),
        "scene_name": getattr(scene, "name", ""),
        "scene_source": getattr(scene, "source", ""),
        "scene_text": getattr(scene, "text", ""),
        "models": list(settings.models),
        "settings": {
            "n_separations": settings.n_separations,
            "h_min_sigma": settings.h_min_sigma,
            "h_max_sigma": settings.h_max_sigma,
            "gt_heights": settings.gt_heights,
        },
        "materials": mats.as_dict(),
        "surfaces": {"liner": liner.as_dict(), "piston": piston.as_dict()},
    }
    curves: dict[str, ContactCurve] = {}

    want_asperity = [m for m in settings.models if m in ASPERITY_MODELS]
    heights = {}
    if want_asperity or liner.kind == "file" or piston.kind == "file":
        heights = {"liner": liner.heights(), "piston": piston.heights()}
    sq = {}
    stats = {}
    for body, spec in (("liner", liner), ("piston", piston)):
        mom = spec.moments() if body not in heights else _moments_of(heights[body], spec)
        st = mccool(mom)
        sq[body] = math.sqrt(mom.m0)
        stats[body] = st
        prov["surfaces"][body]["mccool"] = st.as_dict()
        prov["surfaces"][body]["sq_m"] = sq[body]
    g = greenwood_tripp_parameters(stats["liner"], stats["piston"], sq["liner"], sq["piston"], settings.gt_heights)
    sigma = g["sigma_m"]
    prov["greenwood_tripp"] = g
    # Greenwood & Williamson's plasticity index (E*/H) √(σ/β), σ = √(Sq1² + Sq2²), β = √(β1 β2)
    prov["plasticity_index"] = (E_star / mats.H) * math.sqrt(sigma / g["beta_m"])

    if "greenwood_tripp" in settings.models:
        curves["greenwood_tripp"] = _gt_curve(g, E_star, settings)

    if want_asperity:
        z1, z2 = heights["liner"], heights["piston"]
        if z1.shape != z2.shape or not math.isclose(liner.pixel_m, piston.pixel_m, rel_tol=1e-9):
            raise SettingError(
                "surfaces.piston",
                f"{z2.shape} at {piston.pixel_m:g} m",
                f"the asperity models need both surfaces on one grid: liner is {z1.shape} at {liner.pixel_m:g} m",
            )
        periodic = liner.periodic and piston.periodic
        composite = z1 + z2
        data = summit_data(composite, liner.pixel_m, periodic=periodic)
        if data.height_m.size < 2:
            raise SettingError("surfaces", data.height_m.size, "the composite surface has fewer than 2 summits")
        order = np.argsort(-data.height_m, kind="stable")
        zs = data.height_m[order]
        Rs = data.radius_m[order]
        comp_stats = statistics_of(data)
        prov["composite_surface"] = {
            "sq_m": float(np.std(composite)),
            "summits": comp_stats.as_dict(),
            "highest_summit_m": float(zs[0]),
            "area_m2": data.area_m2,
        }
        h_lo = settings.h_min_sigma * sigma
        h_top = float(zs[0])
        if h_top <= h_lo:
            raise SettingError("database.h_min_sigma", settings.h_min_sigma, "is above the highest summit")
        h = np.linspace(h_lo, h_top, settings.n_separations)
        soft = mats.softer
        for name in want_asperity:
            m = asperity.model(name, E_star=E_star, R=Rs, H=mats.H, yield_strength=soft.yield_strength_pa, nu=soft.nu)
            p, af = asperity_sums(m, zs, h, data.area_m2)
            p[-1] = 0.0
            af[-1] = 0.0
            if af.max() > 1.0:
                raise SettingError(
                    "database.h_min_sigma",
                    settings.h_min_sigma,
                    f"model {name!r}: real-area fraction {af.max():.3g} > 1 at the deepest separation "
                    "(independent-asperity models fail there); raise h_min_sigma",
                )
            params = {"E_star_pa": E_star, "H_pa": mats.H, "n_summits": int(zs.size), "area_m2": data.area_m2}
            if name == "jackson_green":
                params.update(yield_pa=soft.yield_strength_pa, nu=soft.nu)
                # J&G fitted their FEM results up to ω/ω_c ≈ 110; deeper, the fit is an extrapolation
                reach = float(np.max((zs - h[0]) / m.omega_c))
                params["max_interference_over_omega_c"] = reach
                if reach > _JG_FIT_LIMIT:
                    msg = (
                        f"jackson_green: summits reach ω/ω_c = {reach:.3g} at the deepest separation, beyond the "
                        f"range of Jackson & Green's fit (≤ {_JG_FIT_LIMIT:g}): extrapolated there"
                    )
                    prov.setdefault("warnings", []).append(msg)
                    warnings.warn(msg, RuntimeWarning, stacklevel=2)
            try:
                curves[name] = ContactCurve(name, h, p, af, params)
            except SettingError as exc:
                raise RuntimeError(f"model {name!r}: the summed curve is not monotone ({exc})") from None
    prov["build_time_s"] = time.perf_counter() - t_start
    # order the curves as asked
    ordered = {m: curves[m] for m in settings.models}
    return ContactDatabase(ordered, prov)


def _moments_of(z: NDArray[np.float64], spec: Any) -> Any:
    from sims.surface import spectral_moments

    if spec.kind == "file":
        return spectral_moments(z, spec.pixel_m)
    return spec.moments()


# ---------------------------------------------------------------------------------------------------------------
# HDF5.

_UNITS = {"separation_m": "m", "pressure_pa": "Pa", "area_fraction": "1"}


def save_database(db: ContactDatabase, path: str | Path) -> Path:
    """Write ``db`` to HDF5 at ``path`` (see the module docstring for the layout); returns the path."""
    import h5py

    p = Path(path)
    tmp = p.with_name(p.name + ".part")
    with h5py.File(tmp, "w") as f:
        f.attrs["format"] = "contactrig-contact-database"
        f.attrs["format_version"] = 1
        f.attrs["provenance"] = json.dumps(db.provenance, default=json_default)
        for name, curve in db.curves.items():
            g = f.create_group(name)
            for key in ("separation_m", "pressure_pa", "area_fraction"):
                ds = g.create_dataset(key, data=np.asarray(getattr(curve, key)))
                ds.attrs["units"] = _UNITS[key]
            g.attrs["parameters"] = json.dumps(curve.parameters, default=json_default)
    tmp.replace(p)
    return p


def load_database(path: str | Path) -> ContactDatabase:
    """Read a database written by :func:`save_database`."""
    import h5py

    p = Path(path)
    if not p.exists():
        raise SettingError("database", str(p), "file not found")
    try:
        f = h5py.File(p, "r")
    except OSError as exc:
        raise SettingError("database", str(p), f"not a readable HDF5 file ({exc})") from None
    with f:
        if f.attrs.get("format") != "contactrig-contact-database":
            raise SettingError("database", str(p), "not a contactrig contact database")
        prov = json.loads(f.attrs.get("provenance", "{}"))
        curves = {}
        for name in f:
            g = f[name]
            params = json.loads(g.attrs.get("parameters", "{}"))
            curves[name] = ContactCurve(
                name,
                np.asarray(g["separation_m"][()], dtype=float),
                np.asarray(g["pressure_pa"][()], dtype=float),
                np.asarray(g["area_fraction"][()], dtype=float),
                params,
            )
    order = [m for m in prov.get("models", []) if m in curves] + [m for m in curves if m not in prov.get("models", [])]
    return ContactDatabase({m: curves[m] for m in order}, prov)
