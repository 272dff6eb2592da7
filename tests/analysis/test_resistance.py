"""Eq. 23 and constriction resistance against hand values, limits and an independent linear solve."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from analysis.resistance import (
    area_to_resistance_ohm,
    bulk_resistance_ohm,
    greenwood_cluster_resistance_ohm,
    holm_resistance_ohm,
    holm_single_spot_resistance_ohm,
)
from contactrig.core.validation import SettingError


def test_bulk_hand_value_and_shape():
    # 1e-7 Ω·m × 5 mm / 1 mm² = 0.5 mΩ
    assert bulk_resistance_ohm(1e-6, 1e-7, 5e-3) == pytest.approx(5e-4, rel=1e-15)
    out = bulk_resistance_ohm(np.array([[1e-6, 2e-6]]), 1e-7, 5e-3)
    assert out.shape == (1, 2)
    assert out[0, 1] == pytest.approx(2.5e-4)


@settings(max_examples=60, deadline=None)
@given(
    area=st.floats(1e-30, 1e6, allow_nan=False),
    zeta=st.floats(1e-12, 1e3),
    height=st.floats(1e-12, 1e2),
)
def test_bulk_is_finite_positive_and_inverse_in_area(area, zeta, height):
    r = float(bulk_resistance_ohm(area, zeta, height))
    assert math.isfinite(r) and r > 0
    assert r * area / (zeta * height) == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("bad", [0.0, -1e-6, np.nan, np.inf])
def test_bulk_rejects_non_positive_area_by_name(bad):
    with pytest.raises(SettingError, match="area_m2"):
        bulk_resistance_ohm(np.array([1e-6, bad]), 1e-7, 5e-3)


def test_bulk_rejects_bad_resistivity_and_height():
    with pytest.raises(SettingError, match="resistivity_ohm_m"):
        bulk_resistance_ohm(1e-6, 0.0, 5e-3)
    with pytest.raises(SettingError, match="height_m"):
        bulk_resistance_ohm(1e-6, 1e-7, -1.0)


def test_holm_single_spot_both_bodies():
    a = 10e-6
    assert float(holm_resistance_ohm(a, 1e-7)) == pytest.approx(1e-7 / (2 * a))
    assert float(holm_resistance_ohm(a, 1e-7, 3e-7)) == pytest.approx(1e-7 / (4 * a) + 3e-7 / (4 * a))
    # one spot of area A: a = sqrt(A/π)
    area = math.pi * a**2
    assert float(holm_single_spot_resistance_ohm(area, 1e-7)) == pytest.approx(1e-7 / (2 * a))
    assert float(area_to_resistance_ohm(area, 1e-7, 5e-3, "holm")) == pytest.approx(1e-7 / (2 * a))
    with pytest.raises(SettingError, match="conversion"):
        area_to_resistance_ohm(area, 1e-7, 5e-3, "film")


def test_greenwood_one_spot_is_holm():
    r = greenwood_cluster_resistance_ohm(np.array([7e-6]), np.array([[0.3, -0.2]]), 2e-7, 1e-7)
    assert r == pytest.approx(float(holm_resistance_ohm(7e-6, 2e-7, 1e-7)), rel=1e-14)


def test_greenwood_far_apart_spots_are_parallel_holm():
    a = np.array([1e-6, 3e-6, 5e-6, 2e-6])
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])  # s/a ~ 1e6
    parallel = 1.0 / np.sum(1.0 / holm_resistance_ohm(a, 1e-7))
    assert greenwood_cluster_resistance_ohm(a, xy, 1e-7) == pytest.approx(parallel, rel=1e-5)


def test_greenwood_two_equal_spots_hand_formula():
    # Σa = 2a, Σ_{i≠j} a_i a_j / s = 2a²/s  →  R = ζ/(4a) + ζ/(2π s)
    a, s, zeta = 1e-5, 2e-4, 1e-7
    r = greenwood_cluster_resistance_ohm(np.array([a, a]), np.array([[0.0, 0.0], [s, 0.0]]), zeta)
    assert r == pytest.approx(zeta / (4 * a) + zeta / (2 * math.pi * s), rel=1e-13)


def _point_source_solve(a, xy, zeta):
    d = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
    np.fill_diagonal(d, np.inf)
    g = zeta / (math.pi * d)
    np.fill_diagonal(g, zeta / (2 * a))
    return 1.0 / np.sum(np.linalg.solve(g, np.ones(a.size)))


def test_greenwood_agrees_with_point_source_linear_solve_to_second_order():
    # Independent reference: equal potential on every spot, Holm self-resistance ζ/(2a_i) and the point-source
    # interaction ζ/(π s_ij) (both bodies); R = 1 / Σ I_i for V = 1. Greenwood's closed form is its first-order
    # expansion in a/s: the mismatch, relative to the interaction term, falls ~10× when the spots are 10× apart.
    rng = np.random.default_rng(3)
    n, zeta = 40, 1e-7
    xy = rng.uniform(0, 1e-3, size=(n, 2))
    a = rng.uniform(0.5e-6, 2e-6, size=n)
    rel = []
    for spread in (1.0, 10.0):
        r_exact = _point_source_solve(a, xy * spread, zeta)
        r_green = greenwood_cluster_resistance_ohm(a, xy * spread, zeta)
        interaction = r_green - zeta / (2 * a.sum())
        assert interaction > 0
        rel.append(abs(r_green - r_exact) / interaction)
    assert rel[0] < 0.05
    assert 5 < rel[0] / rel[1] < 20


def test_greenwood_dense_cluster_tends_to_uniform_disc_term():
    # Many tiny spots spread uniformly over a disc of radius α: the interaction term → (ζ/π)⟨1/s⟩, with ⟨1/s⟩
    # from the distance density of two uniform points in a disc (numerical quadrature).
    alpha, zeta, n = 1.0, 1.0, 2000
    rng = np.random.default_rng(11)
    rad = alpha * np.sqrt(rng.uniform(size=n))
    th = rng.uniform(0, 2 * math.pi, size=n)
    xy = np.column_stack((rad * np.cos(th), rad * np.sin(th)))
    a = np.full(n, 1e-9)

    def density(s):
        u = s / (2 * alpha)
        return 4 * s / (math.pi * alpha**2) * (math.acos(u) - u * math.sqrt(1 - u * u))

    inv_mean = quad(lambda s: density(s) / s, 0, 2 * alpha)[0]
    assert inv_mean == pytest.approx(16 / (3 * math.pi * alpha), rel=1e-8)
    r = greenwood_cluster_resistance_ohm(a, xy, zeta)
    interaction = r - zeta / (2 * a.sum())
    expected = zeta / math.pi * inv_mean * (n - 1) / n
    assert interaction == pytest.approx(expected, rel=0.03)
    # ... which is within 8 % of Holm's single spot of the cluster radius, ζ/(2α)
    assert interaction == pytest.approx(zeta / (2 * alpha), rel=0.09)


def test_greenwood_rejects_overlapping_spots_and_bad_shapes():
    with pytest.raises(SettingError, match="centres_m"):
        greenwood_cluster_resistance_ohm(np.array([1.0, 1.0]), np.array([[0.0, 0.0], [1.5, 0.0]]), 1e-7)
    with pytest.raises(SettingError, match="centres_m"):
        greenwood_cluster_resistance_ohm(np.array([1.0, 1.0]), np.zeros((3, 2)), 1e-7)
    with pytest.raises(SettingError, match="radii_m"):
        greenwood_cluster_resistance_ohm(np.array([0.0]), np.zeros((1, 2)), 1e-7)


def test_mean_inverse_distance_unit_square_closed_form_and_scaling():
    from analysis.resistance import mean_inverse_distance_rectangle_per_m as inv

    assert inv(1.0, 1.0) == pytest.approx(4 * (1 - math.sqrt(2)) / 3 + 4 * math.asinh(1.0), rel=1e-12)
    assert inv(2e-3, 2e-3) == pytest.approx(inv(1.0, 1.0) / 2e-3, rel=1e-12)  # ⟨1/s⟩ scales as 1/size
    assert inv(3.0, 0.5) == pytest.approx(inv(0.5, 3.0), rel=1e-12)


def test_greenwood_patch_limits_and_random_spots():
    from analysis.resistance import greenwood_patch_resistance_ohm as patch

    zeta, w, length = 1e-7, 2e-3, 40e-3
    area = 1e-7
    # one spot: Holm of a single spot of area A
    assert float(patch(area, 1, w, length, zeta)) == pytest.approx(
        float(holm_single_spot_resistance_ohm(area, zeta)), rel=1e-14
    )
    # many equal spots scattered uniformly: the closed form matches the pairwise cluster sum of actual spots
    n = 1500
    rng = np.random.default_rng(4)
    xy = rng.uniform(size=(n, 2)) * [w, length]
    small = 1e-9  # small spots (0.46 µm), so that random placement leaves them apart
    a = np.full(n, math.sqrt(small / (n * math.pi)))
    r_pairs = greenwood_cluster_resistance_ohm(a, xy, zeta)
    assert float(patch(small, n, w, length, zeta)) == pytest.approx(r_pairs, rel=0.01)
    # with many spots, quadrupling the real area changes R by far less than eq. 23's factor 4
    r1, r4 = patch(np.array([area, 4 * area]), n, w, length, zeta)
    assert 1.0 < r1 / r4 < 1.5
    with pytest.raises(SettingError, match="area_m2"):
        patch(w * length, 10, w, length, zeta)
    with pytest.raises(SettingError, match="n_spots"):
        patch(area, 0, w, length, zeta)
