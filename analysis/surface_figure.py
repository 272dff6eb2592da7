"""The figure of ``contactrig surface``: height map, a profile and the power spectrum, before and after conditioning.

matplotlib is imported only when drawing. The power spectrum is SurfaceTopography's (``power_spectrum_from_area``
or ``_from_profile`` of a non-periodic topography); without the library that panel says so.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from analysis.surface_summary import SurfaceSummary

__all__ = ["draw_surface", "power_spectrum"]


def power_spectrum(z: NDArray[np.float64], pixel_m: float) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """(q in rad/m, C in m⁴ for a map or m³ for a profile) from SurfaceTopography, or None without the library."""
    try:
        import SurfaceTopography as st
    except ImportError:
        return None
    if z.ndim == 1:
        q, c = st.UniformLineScan(z, physical_sizes=z.size * pixel_m, periodic=False).power_spectrum_from_profile()
    else:
        ny, nx = z.shape
        t = st.Topography(z.T, physical_sizes=(nx * pixel_m, ny * pixel_m), periodic=False)
        q, c = t.power_spectrum_from_area()
    ok = np.isfinite(c) & (c > 0)
    return np.asarray(q[ok], dtype=float), np.asarray(c[ok], dtype=float)


def _profile_panel(ax: Any, s: SurfaceSummary, pixel_m: float) -> None:
    mid = s.levelled.shape[0] // 2 if s.levelled.ndim == 2 else None
    before = s.levelled[mid] if mid is not None else s.levelled
    after = s.filtered[mid] if mid is not None else s.filtered
    x_mm = np.arange(before.size) * pixel_m * 1e3
    ax.plot(x_mm, before * 1e6, lw=0.7, label="mean plane only")
    ax.plot(x_mm, after * 1e6, lw=0.7, label="form removed, filtered")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("height (µm)")
    ax.set_title("profile" + (f" (row {mid})" if mid is not None else ""))
    ax.legend(fontsize=7)


def _psd_panel(ax: Any, s: SurfaceSummary, pixel_m: float) -> None:
    for z, label in ((s.levelled, "mean plane only"), (s.filtered, "form removed, filtered")):
        spec = power_spectrum(z, pixel_m)
        if spec is None:
            ax.text(0.5, 0.5, "power spectrum: pip install 'contactrig[surfaces]'", ha="center", transform=ax.transAxes)
            return
        ax.loglog(spec[0], spec[1], lw=0.8, label=label)
    ax.set_xlabel("wavenumber q (rad/m)")
    ax.set_ylabel("PSD C(q) (m⁴; profile: m³)")
    ax.set_title("power spectrum (SurfaceTopography)")
    ax.legend(fontsize=7)


def draw_surface(s: SurfaceSummary, path: str, *, force: bool = False) -> None:
    """Height map (after conditioning), the middle profile and the power spectra; saved atomically to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from analysis.figures import save_figure_file

    pixel_m = float(s.info["pixel_m"])
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    if s.filtered.ndim == 2:
        ny, nx = s.filtered.shape
        im = axes[0].imshow(
            s.filtered * 1e6, extent=(0, nx * pixel_m * 1e3, ny * pixel_m * 1e3, 0), cmap="viridis", aspect="equal"
        )
        fig.colorbar(im, ax=axes[0], label="height (µm)")
        axes[0].set_xlabel("x (mm)")
        axes[0].set_ylabel("y (mm)")
        axes[0].set_title("height map, form removed and filtered")
    else:
        axes[0].set_axis_off()
        axes[0].text(0.5, 0.5, "line profile: no map", ha="center", transform=axes[0].transAxes)
    _profile_panel(axes[1], s, pixel_m)
    _psd_panel(axes[2], s, pixel_m)
    fig.suptitle(f"{s.info['path']}  (Sq {s.before['Sq_m'] * 1e6:.3g} → {s.after['Sq_m'] * 1e6:.3g} µm)", fontsize=9)
    fig.tight_layout()
    save_figure_file(fig, path, force=force)
    plt.close(fig)
