"""Single-asperity models against Johnson's closed forms, regime continuity and extreme inputs."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

from contactrig.core.validation import SettingError
from sims import asperity

E_STAR, R, H = 49e9, 2e-3, 1.2e9


def johnson_force(delta: np.ndarray) -> np.ndarray:
    return 4.0 / 3.0 * E_STAR * math.sqrt(R) * np.asarray(delta) ** 1.5


def test_hertz_stachowiak_form_equals_johnson_to_its_rounded_constant() -> None:
    m = asperity.model("hertz", E_star=E_STAR, R=R)
    d = np.geomspace(1e-10, 1e-5, 20)
    # 1.0397 stands for (9/8)^(1/3) = 1.040042: 0.05 % in load
    np.testing.assert_allclose(m.force(d), johnson_force(d) * (1.040042 / 1.0397) ** 1.5, rtol=1e-5)
    np.testing.assert_allclose(m.force(d) / johnson_force(d), 1.0, rtol=6e-4)
    np.testing.assert_allclose(m.contact_radius(d), np.sqrt(R * d), rtol=2e-4)
    p0_johnson = 2 * E_STAR / math.pi * np.sqrt(d / R)
    np.testing.assert_allclose(m.peak_pressure(d), p0_johnson, rtol=1e-3)
    np.testing.assert_allclose(m.mean_pressure(d), 2 / 3 * p0_johnson, rtol=1e-3)


def test_lagemann_corrected_is_johnson_exactly() -> None:
    m = asperity.model("lagemann", E_star=E_STAR, R=R)
    d = np.geomspace(1e-10, 1e-5, 20)
    np.testing.assert_allclose(m.force(d), johnson_force(d), rtol=1e-12)
    np.testing.assert_allclose(m.contact_radius(d), np.sqrt(R * d), rtol=1e-12)
    p0 = 2 * E_STAR / math.pi * np.sqrt(d / R)
    np.testing.assert_allclose(m.peak_pressure(d), p0, rtol=1e-12)
    np.testing.assert_allclose(m.mean_pressure(d), 2 / 3 * p0, rtol=1e-12)
    # the corrected eq. 12 profile integrates to the load
    delta = 1e-7
    a = float(m.contact_radius(delta))
    load, _ = integrate.quad(lambda r: 2 * math.pi * r * float(m.pressure_profile([r], delta)[0]), 0, a)
    assert load == pytest.approx(float(m.force(delta)), rel=1e-7)


def test_pasaribu_schipper_regimes_and_continuity() -> None:
    m = asperity.model("pasaribu_schipper", E_star=E_STAR, R=R, H=H)
    w1, w2 = float(m.omega_c1), float(m.omega_c2)
    assert w1 == pytest.approx(0.89 * R * (H / E_STAR) ** 2, rel=1e-12)
    assert w2 == pytest.approx(54 * w1, rel=1e-12)
    # yield onset at a mean pressure of 0.4 H (what 0.89 encodes)
    assert float(m.force(w1 * (1 - 1e-12)) / m.area(w1 * (1 - 1e-12))) == pytest.approx(0.4 * H, rel=2e-3)
    # elastic = Hertz; plastic = H × 2πRδ
    d_el = np.array([0.1, 0.5, 0.9]) * w1
    np.testing.assert_allclose(m.force(d_el), johnson_force(d_el), rtol=1e-12)
    d_pl = np.array([1.5, 10.0]) * w2
    np.testing.assert_allclose(m.force(d_pl), H * 2 * math.pi * R * d_pl, rtol=1e-12)
    eps = 1e-9
    for w, tol in ((w1, 1.1e-3), (w2, 1e-6)):
        below, above = w * (1 - eps), w * (1 + eps)
        assert float(m.force(below)) == pytest.approx(float(m.force(above)), rel=tol)
        assert float(m.area(below)) == pytest.approx(float(m.area(above)), rel=1e-6)
        # area slope continuous too (the cubic smoothing)
        h = w * 1e-4
        s_below = float((m.area(w - h) - m.area(w - 2 * h)) / h)
        s_above = float((m.area(w + 2 * h) - m.area(w + h)) / h)
        assert s_below == pytest.approx(s_above, rel=1e-2)


def test_jackson_green_elastic_below_and_continuous_at_1_9_omega_c() -> None:
    m = asperity.model("jackson_green", E_star=E_STAR, R=R, H=H, nu=0.33)
    wc = float(m.omega_c)
    c = 1.295 * math.exp(0.736 * 0.33)
    sy = H / 2.84
    assert wc == pytest.approx((math.pi * c * sy / (2 * E_STAR)) ** 2 * R, rel=1e-12)
    d = np.array([0.2, 1.0, 1.8]) * wc
    np.testing.assert_allclose(m.force(d), johnson_force(d), rtol=1e-12)
    np.testing.assert_allclose(m.area(d), math.pi * R * d, rtol=1e-12)
    # Hertz load at ω_c equals the critical load P_c
    assert float(johnson_force(wc)) == pytest.approx(float(m.critical_force), rel=1e-12)
    b = 1.9 * wc
    assert float(m.area(b * (1 + 1e-9))) == pytest.approx(float(m.area(b * (1 - 1e-9))), rel=1e-6)
    assert float(m.force(b * (1 + 1e-9))) == pytest.approx(float(m.force(b * (1 - 1e-9))), rel=6e-3)


def jg2005(omega: np.ndarray, e_star: float, radius: float, sy: float, nu: float) -> tuple[np.ndarray, np.ndarray]:
    """Jackson & Green (2005), J. Tribol. 127:343, transcribed here from the paper's equations (not from the module):
    ω_c = (πCS_y/(2E′))² R, C = 1.295 e^(0.736ν), P_c = (4/3)(R/E′)²(CπS_y/2)³; for ω* = ω/ω_c ≥ 1.9
    P/P_c = e^(−¼ ω*^(5/12)) ω*^(3/2) + (4H_G/(C S_y))(1 − e^(−ω*^(5/9)/25)) ω*,
    H_G/S_y = 2.84(1 − e^(−0.82(a/R)^−0.7)), a = √(Rω)(ω*/1.9)^(B/2), A = πRω(ω*/1.9)^B, B = 0.14 e^(23 S_y/E′)
    (E′ there is Johnson's E*)."""
    c = 1.295 * math.exp(0.736 * nu)
    wc = (math.pi * c * sy / (2 * e_star)) ** 2 * radius
    pc = 4 / 3 * (radius / e_star) ** 2 * (c * math.pi * sy / 2) ** 3
    b = 0.14 * math.exp(23 * sy / e_star)
    w = omega / wc
    a = np.sqrt(radius * omega) * (w / 1.9) ** (b / 2)
    hg = 2.84 * sy * (1 - np.exp(-0.82 * (a / radius) ** -0.7))
    p = pc * (np.exp(-0.25 * w ** (5 / 12)) * w**1.5 + 4 * hg / (c * sy) * (1 - np.exp(-(w ** (5 / 9)) / 25)) * w)
    return p, math.pi * radius * omega * (w / 1.9) ** b


@pytest.mark.parametrize(("sy", "nu"), [(H / 2.84, 0.33), (250e6, 0.3), (2e9, 0.25)])
def test_jackson_green_plastic_branch_matches_the_published_equations(sy: float, nu: float) -> None:
    m = asperity.model("jackson_green", E_star=E_STAR, R=R, H=H, yield_strength=sy, nu=nu)
    w = np.array([1.9001, 2.5, 5.0, 20.0, 100.0]) * float(m.omega_c)
    p_ref, a_ref = jg2005(w, E_STAR, R, sy, nu)
    np.testing.assert_allclose(m.force(w), p_ref, rtol=1e-12)
    np.testing.assert_allclose(m.area(w), a_ref, rtol=1e-12)
    # Johnson: first yield of a Hertz sphere when p0 = 1.60 Y (ν = 0.3); J&G's C encodes it: p0(ω_c) = C S_y
    p0 = 2 * E_STAR / math.pi * math.sqrt(float(m.omega_c) / R)
    assert p0 / sy == pytest.approx(m.C, rel=1e-12)
    if nu == 0.3:
        assert m.C == pytest.approx(1.60, rel=0.01)


@pytest.mark.parametrize("name", asperity.MODELS)
def test_zero_and_negative_interference_give_exactly_zero(name: str) -> None:
    m = asperity.model(name, E_star=E_STAR, R=R, H=H)
    d = np.array([-1.0, -1e-12, 0.0])
    assert m.force(d).tolist() == [0.0, 0.0, 0.0]
    assert m.area(d).tolist() == [0.0, 0.0, 0.0]


@settings(max_examples=50, deadline=None)
@given(
    st.sampled_from(asperity.MODELS),
    st.floats(min_value=1e3, max_value=1e12),
    st.floats(min_value=1e-9, max_value=1.0),
    st.floats(min_value=1e-4, max_value=0.09),
    st.lists(st.floats(min_value=0.0, max_value=10.0), min_size=2, max_size=30),
)
def test_models_finite_nonnegative_monotone_over_extremes(
    name: str, e_star: float, radius: float, h_ratio: float, deltas: list[float]
) -> None:
    m = asperity.model(name, E_star=e_star, R=radius, H=h_ratio * e_star)
    d = np.sort(np.asarray(deltas))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f, a = m.force(d), m.area(d)
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(a)) and f.min() >= 0 and a.min() >= 0
    # Pasaribu–Schipper's force dips by 0.1 % at ω_c1 (documented); all else is monotone
    assert np.all(np.diff(f) >= -1.1e-3 * f[1:])
    assert np.all(np.diff(a) >= 0)


def test_vectorised_radius_broadcasts() -> None:
    radii = np.array([1e-4, 1e-3, 1e-2])
    m = asperity.model("pasaribu_schipper", E_star=E_STAR, R=radii, H=H)
    f = m.force(np.full(3, 1e-7))
    single = [float(asperity.model("pasaribu_schipper", E_star=E_STAR, R=r, H=H).force(1e-7)) for r in radii]
    np.testing.assert_allclose(f, single, rtol=1e-12)


def test_bad_inputs_are_errors() -> None:
    with pytest.raises(SettingError, match="model"):
        asperity.model("greenwood", E_star=E_STAR, R=R)
    with pytest.raises(SettingError, match="H"):
        asperity.model("pasaribu_schipper", E_star=E_STAR, R=R)
    with pytest.raises(SettingError, match="R"):
        asperity.model("hertz", E_star=E_STAR, R=-1.0)
    with pytest.raises(SettingError, match="E_star"):
        asperity.model("hertz", E_star=0.0, R=R)
    with pytest.raises(SettingError, match="delta"):
        asperity.model("hertz", E_star=E_STAR, R=R).force([np.nan])
