"""Form removal and the ISO 16610-61 Gaussian filter against closed forms (numpy only; no file library)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contactrig.core.validation import SettingError
from sims import surface_filter as sf
from sims.surface import Conditioning, condition_height_map, gaussian, self_affine
from tests import surface_maker as mk


def test_alpha_is_the_standards_constant():
    assert sf.ALPHA == pytest.approx(0.4697, abs=1e-4)
    assert sf.gaussian_transmission(1.0, 1.0) == pytest.approx(0.5, abs=1e-15)


@pytest.mark.parametrize("ratio", [0.5, 1.0, 2.0])
def test_transmission_of_a_sinusoid_matches_the_closed_form(ratio):
    """Mean surface of a sinusoid of wavelength λ = ratio·λc: amplitude × exp(−π(αλc/λ)²) (50 % at λ = λc),
    measured away from the edges (a full λc margin)."""
    pixel, lc = 1e-6, 80e-6
    lam = ratio * lc
    n = 800
    z = mk.sinusoid(4, n, pixel, lam, 1.0)
    mean = sf.gaussian_mean_surface(z, pixel, lc)[:, 100:-100]
    ref = np.sin(2 * np.pi * np.arange(n)[100:-100] * pixel / lam)
    gain = float(np.sum(mean[0] * ref) / np.sum(ref * ref))
    expected = math.exp(-math.pi * (sf.ALPHA * lc / lam) ** 2)
    assert gain == pytest.approx(expected, abs=2e-3)
    if ratio == 1.0:
        assert gain == pytest.approx(0.5, abs=2e-3)


@pytest.mark.parametrize("axis", ["x", "y"])
def test_cylinder_radius_is_recovered(axis):
    """A 42.5 mm bore, 2 mm × 2 mm at 8 µm (sagitta 12 µm), with 0.3 µm Gaussian roughness: radius within 1 %."""
    pixel, radius = 8e-6, 0.0425
    rough = gaussian(256, pixel_m=pixel, sq_m=0.3e-6, correlation_m=40e-6, seed=1)
    z = mk.bore(256, 256, pixel, radius, axis) + rough
    _, fit = sf.fit_cylinder(z, pixel, axis)
    assert fit.radius_m == pytest.approx(radius, rel=0.01)
    assert fit.concave
    assert fit.rms_m == pytest.approx(0.3e-6, rel=0.05)


def test_sq_after_the_l_filter_matches_the_spectrum():
    """A Gaussian-correlated map (λ = 10 µm, Sq = 1 µm, periodic, deterministic amplitudes) after the L-filter at
    λc = 40 µm: Sq² = Σ P(q) (1 − T(q))² / Σ P(q) · Sq0², T = exp(−π(αλc q/2π)²), over the interior (3 %)."""
    n, pixel, lam, lc = 256, 1e-6, 10e-6, 40e-6
    z = gaussian(n, pixel_m=pixel, sq_m=1e-6, correlation_m=lam, seed=4)
    out = sf.s_l_surface(z, pixel, form="plane", lambda_c_m=lc)
    q = 2 * np.pi * np.fft.fftfreq(n, d=pixel)
    q2 = q[:, None] ** 2 + q[None, :] ** 2
    p = np.exp(-q2 * lam**2 / 4)
    p[0, 0] = 0
    t = np.exp(-math.pi * (sf.ALPHA * lc * np.sqrt(q2) / (2 * np.pi)) ** 2)
    expected = 1e-6 * math.sqrt(float(np.sum(p * (1 - t) ** 2) / np.sum(p)))
    m = int(lc / pixel)
    inner = out.z[m:-m, m:-m]
    assert float(np.std(inner)) == pytest.approx(expected, rel=0.03)
    assert out.record["lambda_c_m"] == lc and out.record["filter"].startswith("ISO 16610-61")


def test_missing_points_are_counted_filled_from_neighbours_and_too_many_refused():
    z = mk.liner(n=128)
    missing = np.isnan(z)
    assert 0 < missing.sum() < 0.05 * z.size
    c = Conditioning(form="cylinder", lambda_s_m=16e-6, lambda_c_m=250e-6)
    out, record = condition_height_map(z, pixel_m=8e-6, height_unit_m=1.0, conditioning=c)
    assert record["missing_points"] == int(missing.sum())
    assert np.isfinite(out).all()
    # a filled point is the mean of its neighbours, not zero: compare with the 3×3 neighbourhood mean
    i, j = np.argwhere(missing & ~np.roll(missing, 1, 0) & ~np.roll(missing, -1, 0))[5]
    neighbours = out[i - 1 : i + 2, j - 1 : j + 2]
    assert abs(out[i, j] - neighbours.mean()) < 0.5 * np.std(out)
    with pytest.raises(SettingError, match=r"points missing.*max_missing_fraction = 0\.001"):
        condition_height_map(
            z, pixel_m=8e-6, height_unit_m=1.0, conditioning=Conditioning(max_missing_fraction=0.001), key="path"
        )


def test_form_and_filters_change_the_roughness_as_they_should():
    """Mean plane only leaves the bore's sagitta in Sq; the cylinder removes it (Sq back near the roughness's)."""
    z = mk.liner(n=128)
    plane, _ = condition_height_map(z, pixel_m=8e-6, height_unit_m=1.0)
    cyl, rec = condition_height_map(z, pixel_m=8e-6, height_unit_m=1.0, conditioning=Conditioning(form="cylinder"))
    assert rec["cylinder_radius_m"] == pytest.approx(0.0425, rel=0.05)
    assert np.std(cyl) < np.std(plane)
    assert np.std(cyl) == pytest.approx(0.4e-6, rel=0.1)


def test_nesting_indices_are_checked():
    with pytest.raises(SettingError, match="lambda_s_m"):
        Conditioning.from_table({"lambda_s_m": 1e-4, "lambda_c_m": 1e-5})
    with pytest.raises(SettingError, match="form"):
        Conditioning.from_table({"form": "sphere"})


@pytest.mark.parametrize("how", sf.EDGES)
def test_edges_are_never_wrapped_into_a_cliff(how):
    """A measured map's edge step (a window of a larger self-affine surface, mean plane removed) wraps into a cliff
    in a periodic solver: the RMS jump across the periodic boundary is several times the RMS step between
    neighbours inside the map;
    after ``treat_edges`` it is no larger than that."""

    def rms(a):
        return float(np.sqrt(np.mean(np.square(a))))

    def wrap_jump(a):
        return max(rms(a[0] - a[-1]), rms(a[:, 0] - a[:, -1]))

    measured = self_affine(512, pixel_m=8e-6, sq_m=1e-6, hurst=0.8, seed=2)[:100, :100]  # a window of a larger one
    z = condition_height_map(measured, pixel_m=8e-6, height_unit_m=1.0)[0]
    inner = max(rms(np.diff(z, axis=0)), rms(np.diff(z, axis=1)))
    assert wrap_jump(z) > 3 * inner  # the untreated map would have a cliff
    t = sf.treat_edges(z, how)
    assert wrap_jump(t) <= inner
    if how == "mirror":
        assert t.shape == (200, 200) and np.std(t) == pytest.approx(np.std(z), rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(
    shape=st.tuples(st.integers(8, 40), st.integers(8, 40)),
    fraction=st.floats(0.0, 0.05),
    form=st.sampled_from(sf.FORMS),
    lambda_c=st.one_of(st.none(), st.floats(3e-6, 200e-6)),
    seed=st.integers(0, 2**16),
)
def test_any_map_within_the_dropout_limit_comes_out_complete(shape, fraction, form, lambda_c, seed):
    """Whatever the grid, dropout pattern (≤ the limit), form and cut-off: a finite surface, the dropouts counted.
    (The bore, R = 100 µm, rises ≥ 6× the roughness over the narrowest field: a cylinder the field resolves.)"""
    rng = np.random.default_rng(seed)
    z = rng.normal(0, 1e-8, shape) + mk.bore(*shape, 1e-6, 1e-4)
    holes = np.zeros(shape, dtype=bool)
    holes.flat[rng.permutation(holes.size)[: int(fraction * holes.size)]] = True
    z[holes] = np.nan
    out = sf.s_l_surface(z, 1e-6, form=form, lambda_c_m=lambda_c)
    assert np.isfinite(out.z).all() and out.z.shape == shape
    assert out.record["missing_points"] == int(holes.sum())
