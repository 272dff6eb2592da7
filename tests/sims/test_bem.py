"""The periodic FFT-BEM contact solver (sims.bem) against closed-form contact mechanics.

References used (independent of the solver): Westergaard's 1-D wavy surface (full-contact pressure, contact width,
pressure profile, mean gap), Hertz (contact radius, peak pressure), Boussinesq's rigid flat punch (stiffness 2aE*)
corrected for the periodic images with the square-lattice constant 4ζ(½)β(½), the Signorini conditions re-checked
with an FFT written here in numpy, and exact trigonometric interpolation for the Fourier refinement.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from contactrig.core.validation import SettingError
from sims import bem


def rough_surface(n: int, seed: int = 0, hurst: float = 0.8, cut: int = 4, slope: float = 0.1) -> np.ndarray:
    """Self-affine periodic heights on the unit box (pixel 1/n), rms slope ``slope``, shortest wavelength cut·pixel."""
    qx = 2 * np.pi * np.fft.fftfreq(n, d=1 / n)
    qy = 2 * np.pi * np.fft.rfftfreq(n, d=1 / n)
    q = np.hypot(qx[:, None], qy[None, :])
    q_roll, q_cut = 2 * 2 * np.pi, n / cut * 2 * np.pi
    psd = np.maximum(q, q_roll) ** (-2 * (1 + hurst))
    psd[(q > q_cut) | (q == 0)] = 0.0
    rng = np.random.default_rng(seed)
    z = np.fft.irfft2(np.sqrt(psd) * np.exp(2j * np.pi * rng.random(q.shape)), s=(n, n))
    zq = np.fft.rfft2(z)
    gx = np.fft.irfft2(1j * qx[:, None] * zq, s=(n, n))
    gy = np.fft.irfft2(1j * qy[None, :] * zq, s=(n, n))
    return z * slope / np.sqrt(np.mean(gx**2 + gy**2))


def numpy_displacement(p: np.ndarray, pixel: float, e_star: float) -> np.ndarray:
    """Zero-mean surface displacement of a periodic half-space under pressure p: u_q = 2 p_q / (E* |q|)."""
    n = p.shape[0]
    q = 2 * np.pi * np.hypot(*np.meshgrid(np.fft.fftfreq(n, pixel), np.fft.fftfreq(n, pixel), indexing="ij"))
    kernel = np.divide(2.0, e_star * q, out=np.zeros_like(q), where=q > 0)
    return np.fft.ifft2(np.fft.fft2(p) * kernel).real


# ---------------------------------------------------------------------------------------------------------------
# Westergaard: z = Δ cos(2πx/λ), one wavelength per box, extruded in y.

N_W, LAM, DELTA, E_W = 128, 1e-3, 1e-6, 1e9
PIX_W = LAM / N_W
X_W = np.arange(N_W) * PIX_W
Z_W = np.tile((DELTA * np.cos(2 * np.pi * X_W / LAM))[:, None], (1, N_W))
P_STAR = math.pi * E_W * DELTA / LAM  # Westergaard (1939); Johnson, Contact Mechanics §13.2


def test_kernel_convention_gives_westergaard_full_contact_pressure():
    # full contact needs p̄ ≥ p* = πE*Δ/λ exactly when the Fourier symbol is E*|q|/2
    assert bem.full_contact_pressure(Z_W, PIX_W, E_W) == pytest.approx(P_STAR, rel=1e-9)
    for factor in (1.0, 1.5):
        res = bem.solve_contact(Z_W, PIX_W, E_W, factor * P_STAR)
        assert res.success and res.area_fraction == 1.0 and res.n_spots == 1
        # full contact: p = p̄ + p* cos(2πx/λ)
        expected = factor * P_STAR + P_STAR * np.cos(2 * np.pi * X_W / LAM)
        np.testing.assert_allclose(res.pressure[:, 7], expected, rtol=0, atol=1e-9 * P_STAR)
        assert res.mean_gap == pytest.approx(0.0, abs=1e-12 * DELTA)
    below = bem.solve_contact(Z_W, PIX_W, E_W, 0.97 * P_STAR)
    assert below.success and below.area_fraction < 1.0


def westergaard_pressure(x: np.ndarray, ratio: float) -> np.ndarray:
    """Westergaard's partial-contact pressure at p̄ = ratio·p* (Johnson, Contact Mechanics §13.2):
    p = 2p̄ cos(πx/λ)/sin²(πa/λ) · √(sin²(πa/λ) − sin²(πx/λ)) for |x| < a, with sin²(πa/λ) = p̄/p*."""
    s2 = ratio
    root = np.sqrt(np.clip(s2 - np.sin(np.pi * x / LAM) ** 2, 0, None))
    return 2 * ratio * P_STAR * np.cos(np.pi * x / LAM) / s2 * root


@pytest.mark.parametrize("ratio", [0.1, 0.4, 0.7, 0.93])
def test_westergaard_partial_contact_width_and_profile(ratio):
    res = bem.solve_contact(Z_W, PIX_W, E_W, ratio * P_STAR)
    assert res.success
    assert res.mean_pressure == pytest.approx(ratio * P_STAR, rel=1e-12)
    a = LAM / math.pi * math.asin(math.sqrt(ratio))  # p̄/p* = sin²(πa/λ), 2a the contact width
    x = np.where(X_W > LAM / 2, X_W - LAM, X_W)
    row = res.pressure[:, 3]
    assert np.all(res.pressure == row[:, None])  # extruded: every column the same
    half_width = np.max(np.abs(x[row > 0]))
    assert abs(half_width - a) <= PIX_W, (half_width / PIX_W, a / PIX_W)
    exact = westergaard_pressure(x, ratio)
    inner = np.abs(x) < a - 3 * PIX_W
    assert np.max(np.abs(row - exact)[inner]) < 0.01 * exact.max()


def westergaard_mean_gap(ratio: float) -> float:
    """ū/Δ for the Westergaard contact at p̄ = ratio·p*: 1 − x + x ln x (x = p̄/p*).

    Checked in the test below by quadrature: in contact the gap is 0, so ū = Δ − u(0) with u(0) the zero-mean
    displacement at the centre of the contact, summed from the cosine series of Westergaard's pressure.
    """
    return 1.0 - ratio + ratio * math.log(ratio)


def test_westergaard_mean_gap_closed_form_by_quadrature():
    m = 2**16
    x = (np.arange(m) - m // 2) * (LAM / m)
    for ratio in (0.05, 0.3, 0.8):
        p = westergaard_pressure(x, ratio)
        pk = np.fft.rfft(np.fft.ifftshift(p)) / m  # one-sided cosine coefficients (times ½)
        k = np.arange(pk.size)
        u0 = sum(2 * pk[i].real * 2 / (E_W * 2 * math.pi * k[i] / LAM) for i in range(1, pk.size - 1))
        assert (DELTA - u0) / DELTA == pytest.approx(westergaard_mean_gap(ratio), abs=2e-4)


def test_westergaard_mean_gap_and_interfacial_stiffness():
    ratios = np.array([0.1, 0.35, 0.7])
    path = bem.solve_load_path(Z_W, PIX_W, E_W, ratios * P_STAR)
    assert path.success and path.stiffness_method == "centred"
    for r, gap in zip(ratios, path.mean_gap, strict=True):
        assert gap / DELTA == pytest.approx(westergaard_mean_gap(r), abs=2e-3)
    # K = −dp̄/dū = p*/(Δ ln(p*/p̄)) from the closed form
    exact = P_STAR / (DELTA * np.log(1.0 / ratios))
    np.testing.assert_allclose(path.stiffness, exact, rtol=0.02)
    forward = bem.solve_load_path(Z_W, PIX_W, E_W, ratios * P_STAR, stiffness="forward")
    np.testing.assert_allclose(forward.stiffness, exact, rtol=0.03)
    dense = np.linspace(0.1, 0.7, 13)
    along = bem.solve_load_path(Z_W, PIX_W, E_W, dense * P_STAR, stiffness="path", keep_fields=False)
    np.testing.assert_allclose(along.stiffness[1:-1], (P_STAR / (DELTA * np.log(1.0 / dense)))[1:-1], rtol=0.03)
    assert not isinstance(along.results[0], bem.ContactResult)


# ---------------------------------------------------------------------------------------------------------------
# Hertz.


def test_hertz_sphere():
    # Box L = 8a (256 points, a = 32 cells). The periodic images add a nearly uniform displacement (absorbed by the
    # mean gap) and a curvature correction of relative order (a/L)³ ≈ 0.2 %, inside the tolerances below.
    n, length, radius, e_star = 256, 1e-3, 10e-3, 1e9
    pix = length / n
    a = length / 8
    force = 4 * e_star * a**3 / (3 * radius)  # from a = (3FR/4E*)^(1/3)
    c = (np.arange(n) - n / 2) * pix
    xx, yy = np.meshgrid(c, c, indexing="ij")
    z = -(xx**2 + yy**2) / (2 * radius)  # the sphere's tip is the highest point
    res = bem.solve_contact(z, pix, e_star, force / length**2)  # mean pressure = F / box area
    assert res.success and res.n_spots == 1
    assert res.mean_pressure * length**2 == pytest.approx(force, rel=1e-12)
    a_num = math.sqrt(res.area_fraction * length**2 / math.pi)
    assert abs(a_num - a) <= pix
    p0 = 3 * force / (2 * math.pi * a**2)
    assert res.pressure.max() == pytest.approx(p0, rel=0.01)
    assert res.pressure[n // 2, n // 2] == res.pressure.max()
    # approach δ = a²/R for one sphere; the images and the zero-mean displacement shift it by F·Z/(πE*L) (see the
    # punch test below), here −21 %
    assert res.approach == pytest.approx(a**2 / radius + force * LATTICE_Z / (math.pi * e_star * length), rel=0.01)


# ---------------------------------------------------------------------------------------------------------------
# Random rough surface: force balance and the Signorini conditions.


def test_force_balance_and_complementarity_on_rough_surface():
    n, e_star = 128, 2.0e9
    pix = 1e-6 / n
    z = rough_surface(n, seed=3) * 1e-6
    h_rms = float(np.std(z))
    target = 0.03 * e_star * 0.1
    tol = 1e-7
    res = bem.solve_contact(z, pix, e_star, target, tol=tol)
    assert res.success and res.status == 0 and res.residual <= tol
    assert 0.01 < res.area_fraction < 0.5
    assert res.pressure.mean() == pytest.approx(target, rel=1e-12)
    # displacement from the returned pressure, recomputed here
    u = numpy_displacement(res.pressure, pix, e_star)
    np.testing.assert_allclose(res.displacement, u, rtol=0, atol=1e-9 * np.abs(u).max())
    h0 = z.max() - z.mean() - res.approach  # separation of the mean planes
    gap = u - (z - z.mean()) + h0
    contact = res.pressure > 0
    assert np.all(np.abs(gap[contact]) <= 10 * tol * h_rms)
    assert np.all(gap >= -10 * tol * h_rms)
    assert np.all(res.pressure[gap > 10 * tol * h_rms] == 0.0)
    # the returned gap field: ≥ 0, zero in contact, and its mean is ū = h₀ for an elastic solid
    assert np.all(res.gap >= 0) and np.all(res.gap[contact] == 0)
    assert res.mean_gap == pytest.approx(float(res.gap.mean()), rel=1e-12)
    assert res.mean_gap == pytest.approx(h0, abs=10 * tol * h_rms)
    # displacement control at that mean gap returns the same contact
    again = bem.solve_contact(z, pix, e_star, mean_gap=res.mean_gap, tol=tol)
    assert again.mean_pressure == pytest.approx(target, rel=1e-4)
    assert abs(again.area_fraction - res.area_fraction) <= 3 / n**2
    assert sum(res.spot_areas) == pytest.approx(res.area_fraction * (n * pix) ** 2, rel=1e-12)
    assert res.n_spots == res.spot_areas.size and np.all(np.diff(res.spot_areas) <= 0)
    assert 0 < res.area_fraction_corrected < res.area_fraction


def test_units_scale_out():
    # the same dimensionless problem in other units gives the same area and scaled fields
    z = rough_surface(64, seed=5)
    res = bem.solve_contact(z, 1 / 64, 1.0, 0.004, tol=1e-9)
    alpha, beta, gamma = 3e-7, 2e-5, 7e10  # heights, pixel, modulus factors
    scaled = bem.solve_contact(z * alpha, beta / 64, gamma, 0.004 * gamma * alpha / beta, tol=1e-9)
    assert scaled.area_fraction == res.area_fraction
    np.testing.assert_allclose(scaled.pressure / (gamma * alpha / beta), res.pressure, rtol=1e-6, atol=1e-9 * 0.004)
    assert scaled.mean_gap / alpha == pytest.approx(res.mean_gap, rel=1e-6)


# ---------------------------------------------------------------------------------------------------------------
# Rigid flat punch.

# Zero-mean periodic 1/r kernel near the origin: 1/r + Z/L with Z = 4ζ(½)β(½) (square-lattice sum, −3.900265…).
LATTICE_Z = -3.900264920001956


def test_lattice_constant():
    mpmath = pytest.importorskip("mpmath")
    value = 4 * mpmath.zeta(0.5) * mpmath.dirichlet(0.5, [0, 1, 0, -1])
    assert float(value) == pytest.approx(LATTICE_Z, rel=1e-12)


def flat_punch(n: int = 256, length: float = 1e-3, cells: int = 24) -> tuple[np.ndarray, float, float]:
    """A flat-topped cylinder of radius ``cells`` pixels raised 1 µm above an n² periodic box of side ``length`` (m):
    (heights, pixel, radius of the discretised face), m."""
    pix = length / n
    c = (np.arange(n) - n / 2) * pix
    xx, yy = np.meshgrid(c, c, indexing="ij")
    z = np.where(np.hypot(xx, yy) <= cells * pix, 1e-6, 0.0)
    return z, pix, math.sqrt(np.count_nonzero(z) / math.pi) * pix


def test_flat_punch_stiffness():
    # A flat-topped cylinder of radius a (24 cells) raised 1 µm above a 256² periodic box, displacement control.
    # Periodic images: each punch also loads its neighbours, so the periodic compliance is
    # 1/k = 1/(2aE*) + Z/(πE*L); removing the image term must leave Boussinesq's 2aE*.
    n, length, e_star = 256, 1e-3, 2e9
    z, pix, a = flat_punch(n, length)
    d1, d2 = 1e-9, 3e-9
    r1 = bem.solve_contact(z, pix, e_star, approach=d1)
    r2 = bem.solve_contact(z, pix, e_star, approach=d2)
    assert r1.success and r2.success and r1.n_spots == 1
    assert r1.area_fraction * n * n == np.count_nonzero(z)
    k_periodic = (r2.mean_pressure - r1.mean_pressure) * length**2 / (d2 - d1)
    k_isolated = 1.0 / (1.0 / k_periodic - LATTICE_Z / (math.pi * e_star * length))
    assert k_isolated == pytest.approx(2 * a * e_star, rel=0.03)
    assert r2.approach == pytest.approx(d2, rel=1e-12)


# ---------------------------------------------------------------------------------------------------------------
# Elastic–perfectly-plastic cap.


def test_plastic_cap():
    n = 128
    z = rough_surface(n, seed=7)
    target = 0.003
    elastic = bem.solve_contact(z, 1 / n, 1.0, target)
    hardness = 0.5 * elastic.pressure.max()
    capped = bem.solve_contact(z, 1 / n, 1.0, target, hardness=hardness)
    assert capped.success
    assert capped.pressure.max() <= hardness
    assert capped.pressure.mean() == pytest.approx(target, rel=1e-12)
    assert 0 < capped.plastic_fraction < capped.area_fraction
    assert capped.plastic_fraction == np.count_nonzero(capped.pressure >= hardness) / n**2
    assert capped.plastic_depth is not None and np.all(capped.plastic_depth >= 0)
    assert np.all(capped.plastic_depth[capped.pressure < hardness] == 0)
    assert capped.area_fraction > elastic.area_fraction  # the cap spreads the load
    # a cap far above every elastic pressure changes nothing
    loose = bem.solve_contact(z, 1 / n, 1.0, target, hardness=1e3 * elastic.pressure.max())
    np.testing.assert_allclose(loose.pressure, elastic.pressure, rtol=0, atol=1e-12 * elastic.pressure.max())
    assert loose.plastic_fraction == 0.0 and elastic.plastic_depth is None
    # plastic area grows with load
    path = bem.solve_load_path(z, 1 / n, 1.0, [0.001, 0.002, 0.004, 0.008], hardness=hardness, stiffness="path")
    plastic = [r.plastic_fraction for r in path.results]
    assert path.success and plastic[0] < plastic[-1] and np.all(np.diff(plastic) >= 0)
    assert all(r.pressure.max() <= hardness for r in path.results if isinstance(r, bem.ContactResult))
    assert np.all(np.diff(path.area_fraction) > 0) and np.all(path.stiffness > 0)
    # displacement control with the cap finds the same state
    again = bem.solve_contact(z, 1 / n, 1.0, approach=capped.approach, hardness=hardness)
    assert again.mean_pressure == pytest.approx(target, rel=1e-4)
    assert again.pressure.max() <= hardness and again.plastic_fraction == pytest.approx(
        capped.plastic_fraction, abs=3 / n**2
    )


# ---------------------------------------------------------------------------------------------------------------
# Fourier refinement and area convergence.


def test_capped_load_control_near_the_hardness_meets_the_signorini_conditions():
    """A load at 0.75 H on a coarse surface: the load-controlled CG cycles (the released points are pushed back to
    H by the load balance); the solver must still meet the contact conditions, checked here from the returned
    pressure by an independent FFT displacement."""
    n, pix, e_star = 16, 1.0 / 16, 1.0
    z = rough_surface(n, seed=7, cut=2)
    hardness = 0.3 * float(np.std(z)) / pix
    target = 0.75 * hardness
    res = bem.solve_contact(z, pix, e_star, target, hardness=hardness, max_iter=3000)
    assert res.success, res.message
    p = res.pressure
    assert p.mean() == pytest.approx(target, rel=1e-12) and p.max() <= hardness
    gap = numpy_displacement(p, pix, e_star) - z
    free = (p > 0) & (p < hardness)
    saturated = p >= hardness
    assert free.any() and saturated.any()
    gap += -gap[free].mean()
    scale = float(np.std(z))
    assert np.abs(gap[free]).max() <= 1e-5 * scale
    assert gap[p == 0].min() >= -1e-5 * scale
    assert gap[saturated].max() <= 1e-5 * scale


def test_refine_is_exact_for_band_limited_surfaces():
    n, factor = 32, 3
    rng = np.random.default_rng(1)
    modes = [(int(rng.integers(-15, 16)), int(rng.integers(-15, 16)), rng.normal(), rng.uniform(0, 2 * np.pi))]
    modes += [(16, 5, 0.7, 0.0), (3, 16, -0.4, 0.0)]  # Nyquist modes: cos is sampled exactly, sin would vanish

    def surface(m: int) -> np.ndarray:
        x = np.arange(m) / m
        xx, yy = np.meshgrid(x, x, indexing="ij")
        return sum(amp * np.cos(2 * np.pi * (kx * xx + ky * yy) + ph) for kx, ky, amp, ph in modes)

    coarse = surface(n)
    fine = bem.refine(coarse, factor)
    assert fine.shape == (n * factor, n * factor)
    np.testing.assert_allclose(fine[::factor, ::factor], coarse, rtol=0, atol=1e-12)
    # away from the Nyquist modes (whose sine part is invisible on the coarse grid) the continuous surface returns
    smooth = [m for m in modes if abs(m[0]) < 16 and abs(m[1]) < 16]
    modes[:] = smooth
    np.testing.assert_allclose(bem.refine(surface(n), factor), surface(n * factor), rtol=0, atol=1e-12)
    # white noise (every mode up to Nyquist) still passes through its samples
    noise = rng.normal(size=(16, 16))
    np.testing.assert_allclose(bem.refine(noise, 2)[::2, ::2], noise, rtol=0, atol=1e-12)


def test_contact_area_converges_under_refinement():
    z = rough_surface(32, seed=3)
    areas, corrected = [], []
    for factor in (1, 2, 4, 8):
        zf = bem.refine(z, factor) if factor > 1 else z
        res = bem.solve_contact(zf, 1 / (32 * factor), 1.0, 0.005)
        areas.append(res.area_fraction)
        corrected.append(res.area_fraction_corrected)
    steps = np.abs(np.diff(areas))
    assert steps[0] > steps[1] > steps[2]  # the counted area converges
    assert np.all(np.abs(np.diff(corrected)) < steps)  # the perimeter correction converges faster
    assert abs(corrected[0] - areas[-1]) < abs(areas[0] - areas[-1])
    check = bem.convergence_check(z, 1 / 32, 1.0, 0.005, factor=2)
    assert check.relative_area_change == pytest.approx((areas[1] - areas[0]) / areas[1], rel=1e-12)
    assert abs(check.relative_corrected_area_change) < abs(check.relative_area_change)
    assert check.fine.n == 64 and check.coarse.n == 32


# ---------------------------------------------------------------------------------------------------------------
# Spots.


def test_spots_merge_across_the_periodic_boundary():
    mask = np.zeros((8, 8), dtype=bool)
    mask[0, 0] = mask[0, 7] = mask[7, 0] = mask[7, 7] = True  # one spot cut into four corners
    mask[3, 3] = mask[4, 4] = True  # diagonal neighbours: two 4-connected spots
    count, areas = bem.contact_spots(mask, pixel_m=2.0)
    assert count == 3
    np.testing.assert_allclose(areas, [16.0, 4.0, 4.0])
    # egg-crate surface, peaks on the grid origin: 2×2 periods → 4 equal spots, one of them cut by both edges
    n = 64
    x = np.arange(n) / n
    z = np.cos(4 * np.pi * x)[:, None] + np.cos(4 * np.pi * x)[None, :]
    res = bem.solve_contact(z, 1 / n, 1.0, 0.05 * bem.full_contact_pressure(z, 1 / n, 1.0))
    assert res.n_spots == 4
    np.testing.assert_allclose(res.spot_areas, res.spot_areas[0])


# ---------------------------------------------------------------------------------------------------------------
# Status, validation and extreme inputs.


def test_iteration_limit_is_reported():
    z = rough_surface(64, seed=2)
    res = bem.solve_contact(z, 1 / 64, 1.0, 0.003, max_iter=2)
    assert res.status == bem.STATUS_MAX_ITERATIONS and not res.success and res.nit == 2
    assert "iteration limit" in res.message
    assert np.all(np.isfinite(res.pressure)) and np.all(res.pressure >= 0)
    assert res.pressure.mean() == pytest.approx(0.003, rel=1e-12)
    with pytest.raises(ValueError):
        res.pressure[0, 0] = 1.0  # fields are read-only


def test_no_contact_and_flat_surfaces():
    z = rough_surface(32, seed=4)
    apart = bem.solve_contact(z, 1 / 32, 1.0, mean_gap=10 * (z.max() - z.mean()))
    assert apart.success and apart.area_fraction == 0 and apart.n_spots == 0 and apart.mean_pressure == 0
    flat = np.full((16, 16), 3e-6)
    res = bem.solve_contact(flat, 1e-6, 1e9, 1e5)
    assert res.success and res.area_fraction == 1.0
    np.testing.assert_allclose(res.pressure, 1e5)
    crushed = bem.solve_contact(flat, 1e-6, 1e9, mean_gap=-1e-9, hardness=2e8)
    assert crushed.success and np.all(crushed.pressure == pytest.approx(2e8)) and crushed.plastic_fraction == 1.0


Z_OK = rough_surface(16, seed=0)


@pytest.mark.parametrize(
    ("args", "kwargs", "field"),
    [
        ((np.zeros((16, 7)), 1.0, 1.0, 1.0), {}, "z"),  # odd: a 16 × 8 rectangle is a valid grid (issue 28)
        ((np.zeros((15, 15)), 1.0, 1.0, 1.0), {}, "z"),
        ((np.zeros(16), 1.0, 1.0, 1.0), {}, "z"),
        ((np.full((16, 16), np.nan), 1.0, 1.0, 1.0), {}, "z"),
        ((Z_OK, 0.0, 1.0, 1.0), {}, "pixel_m"),
        ((Z_OK, 1.0, -1.0, 1.0), {}, "E_star"),
        ((Z_OK, 1.0, 1.0, 0.0), {}, "mean_pressure"),
        ((Z_OK, 1.0, 1.0, math.inf), {}, "mean_pressure"),
        ((Z_OK, 1.0, 1.0, 1.0), {"hardness": 1.0}, "mean_pressure"),
        ((Z_OK, 1.0, 1.0, 1.0), {"hardness": 0.0}, "hardness"),
        ((Z_OK, 1.0, 1.0, 1.0), {"tol": 0.0}, "tol"),
        ((Z_OK, 1.0, 1.0, 1.0), {"max_iter": 0}, "max_iter"),
        ((Z_OK, 1.0, 1.0, 1.0), {"workers": 0}, "workers"),
        ((Z_OK, 1.0, 1.0, 1.0), {"mean_gap": 1.0}, "target"),
        ((Z_OK, 1.0, 1.0), {}, "target"),
        ((Z_OK, 1.0, 1.0), {"mean_gap": 0.0}, "mean_gap"),
        ((Z_OK, 1.0, 1.0), {"approach": -1.0}, "approach"),
        ((Z_OK, 1.0, 1.0), {"approach": 1e3}, "approach"),
        ((Z_OK, 1.0, 1.0, 1.0), {"initial_pressure": -np.ones((16, 16))}, "initial_pressure"),
        ((Z_OK, 1.0, 1.0, 1.0), {"initial_pressure": np.ones((8, 8))}, "initial_pressure"),
    ],
)
def test_invalid_settings_raise(args, kwargs, field):
    with pytest.raises(SettingError) as err:
        bem.solve_contact(*args, **kwargs)
    assert err.value.field == field


def test_invalid_path_and_refine_settings_raise():
    with pytest.raises(SettingError, match="increasing"):
        bem.solve_load_path(Z_OK, 1.0, 1.0, [0.2, 0.1])
    with pytest.raises(SettingError):
        bem.solve_load_path(Z_OK, 1.0, 1.0, [])
    with pytest.raises(SettingError):
        bem.solve_load_path(Z_OK, 1.0, 1.0, [0.1], stiffness="path")
    with pytest.raises(SettingError):
        bem.solve_load_path(Z_OK, 1.0, 1.0, [0.1], stiffness="backward")  # type: ignore[arg-type]
    with pytest.raises(SettingError):
        bem.solve_load_path(Z_OK, 1.0, 1.0, [0.1], step=0.0)
    with pytest.raises(SettingError):
        bem.refine(Z_OK, 0)
    with pytest.raises(SettingError):
        bem.convergence_check(Z_OK, 1.0, 1.0, 0.1, factor=1)


@st.composite
def problems(draw):
    n = draw(st.sampled_from([16, 32]))
    flat = draw(st.booleans()) and draw(st.booleans())
    height = 10.0 ** draw(st.floats(-10, 3))
    seed = draw(st.integers(0, 2**16))
    z = np.full((n, n), height) if flat else rough_surface(n, seed=seed, cut=draw(st.sampled_from([2, 4]))) * height
    pixel = 10.0 ** draw(st.floats(-9, 1))
    e_star = 10.0 ** draw(st.floats(3, 12))
    scale = e_star * max(float(np.std(z)), 1e-300) / pixel
    if flat:
        scale = e_star * 1e-3
    mode = draw(st.sampled_from(["pressure", "pressure", "gap", "approach"]))
    hardness = None
    if draw(st.booleans()):
        hardness = scale * 10.0 ** draw(st.floats(-3, 1))
    kwargs: dict[str, float | None] = {"hardness": hardness}
    if mode == "pressure":
        p = scale * 10.0 ** draw(st.floats(-6, 1))
        if hardness is not None and p >= hardness:
            p = hardness * draw(st.floats(0.01, 0.999))
        kwargs["mean_pressure"] = p
    elif mode == "gap":
        peak = float(z.max() - z.mean())
        kwargs["mean_gap"] = max(peak * draw(st.floats(1e-3, 2.0)), 1e-3 * height)
    else:
        peak = 0.0 if flat else float(z.max() - z.mean())
        kwargs["approach"] = peak * draw(st.floats(0.0, 0.999))
    return z, pixel, e_star, kwargs


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems())
def test_property_extreme_but_valid_inputs(problem):
    z, pixel, e_star, kwargs = problem
    res = bem.solve_contact(z, pixel, e_star, max_iter=3000, **kwargs)
    assert res.status in (bem.STATUS_CONVERGED, bem.STATUS_MAX_ITERATIONS, bem.STATUS_BREAKDOWN)
    assert res.success == (res.status == 0) and res.message
    assert res.success, res.message
    for field in (res.pressure, res.gap, res.displacement):
        assert np.all(np.isfinite(field))
    assert np.all(res.pressure >= 0) and np.all(res.gap >= 0)
    hardness = kwargs["hardness"]
    if hardness is not None:
        assert res.pressure.max() <= hardness
    assert 0.0 <= res.area_fraction_corrected <= res.area_fraction <= 1.0
    assert 0.0 <= res.plastic_fraction <= res.area_fraction
    for value in (res.mean_pressure, res.mean_gap, res.approach, res.residual, res.full_contact_pressure):
        assert math.isfinite(value)
    if kwargs.get("mean_pressure") is not None:
        assert res.mean_pressure == pytest.approx(kwargs["mean_pressure"], rel=1e-9)
