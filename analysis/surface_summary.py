"""What a measured surface file holds and its roughness before and after form removal and filtering.

:func:`summarise` reads a height-map file the way a scene does (:func:`contactrig.core.scene.read_measured_map`:
bounded; any SurfaceTopography format or a plain-text grid), conditions it twice with :mod:`sims.surface` — mean
plane only, and the given form removal and ISO 16610-61 filters — and returns a :class:`SurfaceSummary`: the file's
metadata, ISO 25178-2 parameters of both (Sq, Sp, Sv, Sz, Ssk, Sku, Sdq) and McCool's summit statistics η, β, σ_s.
Used by ``contactrig surface``; the figure is :mod:`analysis.surface_figure`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["SurfaceSummary", "roughness", "summarise"]


def roughness(z: NDArray[np.float64], pixel_m: float) -> dict[str, float]:
    """ISO 25178-2 height and hybrid parameters of a conditioned map or profile (m; NaN where no point was measured)
    and McCool's summit statistics from its finite-difference moments, all of the measured points only: heights
    from the measured points about their mean, Sdq and the moments from pairs (triples) of measured neighbours.
    Sdq is √(2 m2) for a map (both directions), √m2 for a profile."""
    from sims.surface import finite_difference_moments, kurtosis, mccool, rms_roughness, rms_slope, skewness

    m = finite_difference_moments(z, pixel_m)
    sdq = rms_slope(z, pixel_m, periodic=False) if z.ndim == 2 else math.sqrt(m.m2)
    h = z[np.isfinite(z)]
    h = h - h.mean()
    out = {
        "Sq_m": rms_roughness(h),
        "Sp_m": float(np.max(h)),
        "Sv_m": float(-np.min(h)),
        "Ssk": skewness(h),
        "Sku": kurtosis(h),
        "Sdq": sdq,
    }
    out["Sz_m"] = out["Sp_m"] + out["Sv_m"]
    st = mccool(m)
    out.update(eta_per_m2=st.eta, beta_m=st.beta, sigma_s_m=st.sigma_s)
    return out


@dataclass(frozen=True)
class SurfaceSummary:
    """``info``: file, format, instrument, points, pixel, unit, size, missing points; ``before``/``after``:
    :func:`roughness` of the map with the mean plane only removed and after form removal and filtering;
    ``conditioning``: what was done (provenance); ``levelled``/``filtered``: the two surfaces, m."""

    info: dict[str, Any]
    before: dict[str, float]
    after: dict[str, float]
    conditioning: dict[str, Any]
    levelled: NDArray[np.float64] = field(repr=False)
    filtered: NDArray[np.float64] = field(repr=False)

    def as_dict(self) -> dict[str, Any]:
        return {"info": self.info, "before": self.before, "after": self.after, "conditioning": self.conditioning}

    def text(self) -> str:
        """A short human-readable account."""
        i = self.info
        shape = " × ".join(str(n) for n in i["points"][::-1])  # x × y, as the size
        size = " × ".join(f"{1e3 * s:.4g}" for s in i["size_m"])
        lines = [
            f"file:        {i['path']}",
            f"format:      {i['file_format']}   instrument: {i['instrument'] or 'not given'}",
            f"points:      {shape} ({'line profile' if i['profile'] else 'areal map, x × y'}), {size} mm",
            f"pixel:       {1e6 * i['pixel_m']:.6g} µm (from the {i['pixel_m_from']})   height unit: "
            f"{i['height_unit_m']:g} m (from the {i['height_unit_m_from']})",
            *([f"resampled:   {i['resampled']}"] if i.get("resampled") else []),
            f"missing:     {i['missing_points']} points ({100 * i['missing_fraction']:.3g} %); every statistic is "
            "of the measured points only",
            f"conditioning: {_describe(self.conditioning)}",
            "",
            f"{'':12s}{'mean plane only':>18s}{'form + filters':>18s}",
        ]
        for key, label, scale in _ROWS:
            lines.append(f"{label:12s}{self.before[key] * scale:18.4g}{self.after[key] * scale:18.4g}")
        return "\n".join(lines)


_ROWS = (
    ("Sq_m", "Sq (µm)", 1e6),
    ("Sp_m", "Sp (µm)", 1e6),
    ("Sv_m", "Sv (µm)", 1e6),
    ("Sz_m", "Sz (µm)", 1e6),
    ("Ssk", "Ssk", 1.0),
    ("Sku", "Sku", 1.0),
    ("Sdq", "Sdq", 1.0),
    ("eta_per_m2", "η (1/mm²)", 1e-6),
    ("beta_m", "β (µm)", 1e6),
    ("sigma_s_m", "σ_s (µm)", 1e6),
)


def _describe(c: dict[str, Any]) -> str:
    radius = (
        f" (radius {1e3 * c['cylinder_radius_m']:.4g} mm, sagitta {1e6 * c['cylinder_sagitta_m']:.3g} µm over "
        f"{1e3 * c['cylinder_chord_m']:.4g} mm)"
        if "cylinder_radius_m" in c
        else ""
    )
    parts = [f"form {c['form']}{radius}"]
    for key, name in (("lambda_s_m", "λs"), ("lambda_c_m", "λc")):
        if c.get(key) is not None:
            parts.append(f"{name} = {1e6 * c[key]:.4g} µm")
    return ", ".join(parts) + " (ISO 16610-61 Gaussian)"


def summarise(path: str, table: dict[str, Any] | None = None) -> SurfaceSummary:
    """Read ``path`` and condition it with the scene keys of ``table`` (``pixel_m``, ``height_unit_m``, ``form``,
    ``lambda_s_m``, ``lambda_c_m``, … as in ``[surfaces.liner]``; unknown keys are errors naming them)."""
    from contactrig.core.scene import read_measured_map
    from sims.surface import SurfaceSpec

    keys = {"kind": "file", "path": str(path), **(table or {})}
    hm = read_measured_map(path, key="FILE")
    plane_keys = {
        k: v for k, v in keys.items() if k in ("kind", "path", "pixel_m", "height_unit_m", "max_missing_fraction")
    }
    plane = SurfaceSpec.from_table("surface", plane_keys, hm.heights, path=hm.path, metadata=hm.metadata())
    spec = SurfaceSpec.from_table("surface", keys, hm.heights, path=hm.path, metadata=hm.metadata())
    assert spec.measured is not None and plane.measured is not None
    rec = dict(spec.conditioning or {})
    pts = tuple(int(n) for n in hm.heights.shape)
    info = {
        "path": hm.path,
        "file_format": hm.file_format,
        "instrument": hm.instrument,
        "points": pts,
        "profile": hm.heights.ndim == 1,
        "pixel_m": spec.pixel_m,
        "pixel_m_from": rec.get("pixel_m_from"),
        "height_unit_m": spec.height_unit_m,
        "height_unit_m_from": rec.get("height_unit_m_from"),
        "size_m": [n * spec.pixel_m for n in spec.measured.shape[::-1]],
        "missing_points": int(rec.get("missing_points", 0)),
        "missing_fraction": float(rec.get("missing_points", 0)) / spec.measured.size,
        "resampled": rec.get("resampled"),
    }
    return SurfaceSummary(
        info,
        roughness(plane.measured_points(), plane.pixel_m),
        roughness(spec.measured_points(), spec.pixel_m),
        rec,
        plane.measured,
        spec.measured,
    )
