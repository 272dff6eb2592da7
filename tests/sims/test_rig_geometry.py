"""Gap of the piston in its liner and the skirt mesh: exact circle-in-circle geometry, limits, mesh bookkeeping."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sims.rig.geometry import (
    contact_edge_angle_rad,
    dgap_dh0,
    effective_radius_m,
    gap_m,
)
from sims.rig.mesh import graded_edges, uniform_mesh, variable_mesh

R_L, C = 0.042, 40e-6


def _gap_by_intersection(theta: float, h0: float, r_l: float, c: float) -> float:
    """Independent construction: intersect the ray from the liner centre with the offset piston circle."""
    e = c - h0
    r_p = r_l - c
    d = np.array([math.sin(theta), -math.cos(theta)])  # unit ray, θ from the downward vertical
    centre = np.array([0.0, -e])
    # |t d − centre| = r_p → t² − 2 t (d·centre) + |centre|² − r_p² = 0, take the positive root.
    b = d @ centre
    t = b + math.sqrt(b * b - (centre @ centre - r_p * r_p))
    return r_l - t


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, math.pi), st.floats(-5e-6, 5e-6), st.floats(0.0, 200e-6))
def test_exact_gap_is_the_offset_circle(theta, h0, c):
    assert float(gap_m(theta, h0, R_L, c)) == pytest.approx(_gap_by_intersection(theta, h0, R_L, c), abs=1e-15)


def test_gap_limits_and_small_clearance_form():
    theta = np.linspace(0, math.pi, 7)
    for exact in (True, False):
        assert float(gap_m(0.0, 1e-6, R_L, C, exact)) == pytest.approx(1e-6, abs=1e-20)
    # Near θ = 0 the gap is h0 + x²/(2 R_eff), x = R θ (conformal contact).
    r_eff = effective_radius_m(R_L, C)
    t = 1e-3
    rise = float(gap_m(t, 0.0, R_L, C)) - 0.0
    assert rise == pytest.approx((R_L * t) ** 2 / (2 * r_eff), rel=2e-3)
    # The two forms differ by O(e²/R).
    diff = np.abs(gap_m(theta, 0.0, R_L, C, True) - gap_m(theta, 0.0, R_L, C, False))
    assert diff.max() <= C**2 / (R_L - C) and diff.max() > 0


def test_the_h0_plus_c_form_fails_at_zero_clearance():
    # Reference-note form h0 + c(1 − cos θ): with c = 0 it is uniform (no load capacity). The eccentricity form
    # h0 + e(1 − cos θ), e = c − h0, is right: with c = 0 and h0 < 0 the bottom is compressed and the top opens.
    # Reference: the ray/circle intersection construction at zero clearance (the piston pushed 1 µm into the liner).
    theta = np.array([0.0, math.pi / 2, math.pi])
    h0 = -1e-6
    exact = [_gap_by_intersection(t, h0, R_L, 0.0) for t in theta]
    second_order = h0**2 / R_L  # the small-clearance form drops terms of order e²/R
    assert exact == pytest.approx([-1e-6, 0.0, 1e-6], abs=second_order)  # not uniform: the note's form fails
    assert gap_m(theta, h0, R_L, 0.0, exact=False).tolist() == pytest.approx(exact, abs=second_order)
    assert gap_m(theta, h0, R_L, 0.0).tolist() == pytest.approx(exact, abs=1e-16)


def test_slope_of_the_gap():
    for exact in (True, False):
        for theta in (0.1, 1.0, 2.5):
            fd = (gap_m(theta, 1e-7, R_L, C, exact) - gap_m(theta, -1e-7, R_L, C, exact)) / 2e-7
            assert float(dgap_dh0(theta, 0.0, R_L, C, exact)) == pytest.approx(float(fd), rel=1e-7)


def test_contact_edge_angle_inverts_the_gap():
    for h0 in (-1e-6, 0.0, 2e-6):
        for exact in (True, False):
            t = contact_edge_angle_rad(3e-6, h0, R_L, C, exact)
            assert float(gap_m(t, h0, R_L, C, exact)) == pytest.approx(3e-6, rel=1e-12)
    assert contact_edge_angle_rad(1e-6, 2e-6, R_L, C) == 0.0
    assert contact_edge_angle_rad(1.0, 0.0, R_L, C) == math.pi


def test_meshes_cover_the_skirt_once():
    r_p, length = R_L - C, 0.045
    whole = 2 * math.pi * r_p * length
    for mesh in (
        uniform_mesh(r_p, length, 37, 5),
        variable_mesh(r_p, length, 0.3, 16),
        variable_mesh(r_p, length, 0.3, 16, y_zone_m=0.01, n_axial=4),
        variable_mesh(r_p, length, math.pi, 8),
        variable_mesh(r_p, length, 0.0, 8),
    ):
        assert mesh.area_m2.sum() == pytest.approx(whole, rel=1e-12)
        assert np.all(mesh.area_m2 > 0)
        assert np.all(np.diff(mesh.theta_edges_rad) > 0) and np.all(np.diff(mesh.y_edges_m) > 0)
        assert mesh.n_nodes == mesh.area_m2.size
    # Without the tail the mesh is the contact zone only: its nodes stand for the zone's nominal area.
    zone_only = variable_mesh(r_p, length, 0.3, 16, tail=False)
    assert zone_only.theta_edges_rad[-1] == pytest.approx(0.3) and zone_only.n_nodes == 16
    assert zone_only.area_m2.sum() == pytest.approx(2 * 0.3 / math.pi * whole / 2, rel=1e-12)
    m = variable_mesh(r_p, length, 0.3, 16)
    fine = np.diff(m.theta_edges_rad)[:16]
    assert np.allclose(fine, 0.3 / 16) and m.theta_edges_rad[16] == pytest.approx(0.3)
    assert m.shape[1] == 1  # straight skirt: one axial cell is exact


def test_graded_edges():
    e = graded_edges(0.0, 1.0, 0.1, 2.0)
    assert e[0] == 0.0 and e[-1] == 1.0 and np.all(np.diff(e) > 0)
    assert np.diff(e)[0] == pytest.approx(0.1)
    assert graded_edges(1.0, 1.0, 0.1).tolist() == [1.0]


# ---- states outside the geometry are named where they occur, never NaN (issue #11) -----------------------------


def _gap_by_ray(theta: float, h0: float, R_l: float, c: float) -> float:
    """Independent gap: along the ray from the liner's centre at angle θ from the downward vertical, the distance
    from the piston circle (centre e below, radius R_p) to the liner circle, found by bisection on the ray."""
    from scipy.optimize import brentq

    e, rp = c - h0, R_l - c
    d = np.array([math.sin(theta), -math.cos(theta)])  # unit ray; the piston centre is at (0, −e)
    inside = lambda r: float(np.hypot(*(r * d - np.array([0.0, -e]))) - rp)  # noqa: E731
    return R_l - brentq(inside, 0.0, R_l + abs(e), xtol=1e-16, rtol=1e-15)


@pytest.mark.parametrize("theta", [0.0, 0.3, math.pi / 2, 2.5, math.pi])
def test_exact_gap_is_the_ray_distance_up_to_the_geometry_bound(theta):
    from sims.rig.geometry import gap_m

    R_l, c = 0.042, 40e-6
    h0 = 2 * c - R_l + 1e-6  # 1 µm inside the deepest minimum gap the geometry allows
    assert float(gap_m(theta, h0, R_l, c)) == pytest.approx(_gap_by_ray(theta, h0, R_l, c), abs=1e-12)


def test_a_minimum_gap_beyond_the_liner_wall_is_a_named_error_not_nan():
    from sims.rig.geometry import OutOfGeometryError, contact_edge_angle_rad, dgap_dh0, gap_m

    R_l, c = 0.042, 40e-6
    h0 = np.array([-1e-6, 2 * c - R_l - 1e-4])  # one good, one through the wall
    theta = np.linspace(0, math.pi, 9)
    for f in (gap_m, dgap_dh0):
        with pytest.raises(OutOfGeometryError, match="outside the piston/liner geometry") as err:
            f(theta, h0[:, None], R_l, c)
        assert err.value.h0_m == pytest.approx(h0[1])
        assert np.all(np.isfinite(f(theta, h0[0], R_l, c)))
    with pytest.raises(OutOfGeometryError):
        contact_edge_angle_rad(1e-6, float(h0[1]), R_l, c)
