"""contactrig's surface statistics against SurfaceTopography's on the same maps (tolerances stated per quantity).

Definitions, and where they differ (README "Measured surfaces"):

* Sq: identical (RMS about the mean) — 1e-12.
* Sdq, periodic map: ours forward differences with wrap (``rms_slope``), the library's ``rms_gradient`` on a periodic
  topography — identical, 1e-12. Non-periodic: the library averages z_x² and z_y² over the common (n−1)×(m−1)
  points, ours (``rms_slope(periodic=False)``) each over its own differences — 0.2 %.
* Profile slope and curvature (m2, m4 for McCool's η, β, σ_s): ours average x and y profiles
  (``finite_difference_moments``); the library's ``rms_slope_from_profile`` / ``rms_curvature_from_profile`` along
  its x only — the same estimator on an isotropic map within 1 %; η, β, σ_s from either within 2 %.
* Ssk, Sku: the library has none; checked against SciPy's ``stats.skew``/``kurtosis(fisher=False)`` — 1e-12.
* Power spectrum: we use the library's (``power_spectrum_from_area``, C(q) with Sq² = ∫ C d²q/(2π)²) for figures
  and have none of our own; its slope on a generated self-affine map is the prescribed −2(1+H) within 0.05 (its
  logarithmic bins sample the few modes near q_box coarsely: integrating it back to Sq is not a fair test).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from sims import surface as s

st = pytest.importorskip("SurfaceTopography", reason="SurfaceTopography (extra 'surfaces') is the reference")

N, PIXEL = 128, 1e-6


@pytest.fixture(scope="module")
def z():
    return s.self_affine(N, pixel_m=PIXEL, sq_m=1e-6, hurst=0.8, cutoff_m=8 * PIXEL, seed=5)


def _topo(z, periodic):
    return st.Topography(z.T, physical_sizes=(N * PIXEL, N * PIXEL), periodic=periodic)  # library: [x, y]


def test_sq_and_sdq(z):
    assert s.rms_roughness(z) == pytest.approx(_topo(z, False).rms_height_from_area(), rel=1e-12)
    assert s.rms_slope(z, PIXEL) == pytest.approx(_topo(z, True).rms_gradient(), rel=1e-12)
    assert s.rms_slope(z, PIXEL, periodic=False) == pytest.approx(_topo(z, False).rms_gradient(), rel=2e-3)


def test_skewness_and_kurtosis_against_scipy(z):
    w = z + 0.3 * z**2 / 1e-6  # a skewed map
    assert s.skewness(w) == pytest.approx(stats.skew(w.ravel()), rel=1e-12)
    assert s.kurtosis(w) == pytest.approx(stats.kurtosis(w.ravel(), fisher=False), rel=1e-12)


def test_profile_moments_and_mccool(z):
    t = _topo(z, False)
    ours = s.finite_difference_moments(z, PIXEL)
    assert math.sqrt(ours.m2) == pytest.approx(t.rms_slope_from_profile(), rel=0.01)
    assert math.sqrt(ours.m4) == pytest.approx(t.rms_curvature_from_profile(), rel=0.01)
    lib = s.SpectralMoments(
        t.rms_height_from_area() ** 2, t.rms_slope_from_profile() ** 2, t.rms_curvature_from_profile() ** 2
    )
    a, b = s.mccool(ours), s.mccool(lib)
    for key in ("eta", "beta", "sigma_s"):
        assert getattr(a, key) == pytest.approx(getattr(b, key), rel=0.02), key


def test_the_librarys_power_spectrum_has_the_generated_slope():
    """A self-affine map made with C(q) ∝ q^−2(1+H): the library's radially averaged spectrum has that log-log slope
    between 3 q_box and half the cut-off (±0.05 for H = 0.8, i.e. −3.6)."""
    n = 256
    z = s.self_affine(n, pixel_m=PIXEL, sq_m=1e-6, hurst=0.8, cutoff_m=4 * PIXEL, seed=5)
    q, c = st.Topography(z.T, physical_sizes=(n * PIXEL, n * PIXEL), periodic=True).power_spectrum_from_area()
    q_box, q_cut = 2 * math.pi / (n * PIXEL), 2 * math.pi / (4 * PIXEL)
    band = (q > 3 * q_box) & (q < q_cut / 2) & np.isfinite(c)
    assert band.sum() >= 10
    assert np.polyfit(np.log(q[band]), np.log(c[band]), 1)[0] == pytest.approx(-3.6, abs=0.05)
