"""Damped release-to-rest dynamics (seed eq. 22): settles to the static solution, stiff and non-stiff."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sims.rig_dynamics import settle, stiffness_ratio
from sims.rig_loads import SkirtLoads
from sims.rig_settings import RigSettings
from sims.rig_statics import RigLoadError, equilibrium
from tests.sims.test_rig_laws import ExponentialLaw, GreenwoodTrippLaw

LAW = ExponentialLaw()
SETTINGS = RigSettings(n_theta=16)


@pytest.fixture(scope="module")
def static():
    return equilibrium(LAW, SETTINGS, 25.966)


def test_analytic_slope_matches_finite_difference(static):
    for law in (LAW, GreenwoodTrippLaw()):
        for gap in ("exact", "small_clearance"):
            s = RigSettings(gap=gap)
            loads = SkirtLoads(law, s, static.mesh)
            h0 = 0.5e-6
            step = 1e-12
            fd = (loads.force_n(h0 + step) - loads.force_n(h0 - step)) / (2 * step)
            assert loads.force_and_slope(h0)[1] == pytest.approx(fd, rel=1e-5)


def test_light_damping_is_not_stiff_and_settles_explicitly(static):
    run = settle(LAW, SETTINGS, 25.966, damping_n_s_per_m=2e5, static=static)
    assert run.damping_ratio < 1 and not run.stiff and run.method == "RK45" and run.njev == 0
    assert run.settled and run.status == 1
    # At rest: the static solution (same mesh), to the rest tolerance h_tol = 1e-6·W/k.
    h_tol = 1e-6 * static.load_n / static.stiffness_n_per_m
    assert abs(run.separation_error_m) <= 2 * h_tol
    assert run.area_relative_error < 1e-5
    # It really fell and oscillated: started above the rest position and overshot below it.
    assert run.min_separation_m[0] > static.min_separation_m
    assert run.min_separation_m.min() < static.min_separation_m - 10 * h_tol


@pytest.mark.parametrize("method", ["auto", "Radau", "BDF", "LSODA"])
def test_heavy_damping_is_stiff_and_implicit_methods_settle(static, method):
    run = settle(LAW, SETTINGS, 25.966, damping_n_s_per_m=2e7, static=static, method=method)
    assert run.stiff and run.stiffness_ratio > 1e3
    assert run.method == ("BDF" if method == "auto" else method)
    assert run.settled
    assert abs(run.separation_error_m) <= 2e-6 * static.load_n / static.stiffness_n_per_m
    if method != "LSODA":  # LSODA may run non-stiff (no Jacobian) phases
        assert run.njev > 0
    assert run.nfev < 5000
    # Overdamped: no overshoot below the rest position (beyond the tolerance).
    assert run.min_separation_m.min() > static.min_separation_m - 1e-3 * (LAW.h_max - LAW.h_min)


def test_explicit_method_pays_for_stiffness_in_evaluations(static):
    explicit = settle(LAW, SETTINGS, 25.966, damping_n_s_per_m=6e6, static=static, method="RK45")
    implicit = settle(LAW, SETTINGS, 25.966, damping_n_s_per_m=6e6, static=static, method="BDF")
    assert explicit.stiff and explicit.settled and implicit.settled
    assert explicit.nfev > 10 * implicit.nfev


def test_stiffness_ratio_of_the_linear_oscillator():
    k, m = 1e8, 25.0
    b_crit = 2 * math.sqrt(k * m)
    zeta, ratio = stiffness_ratio(k, m, 10 * b_crit)
    lam = np.roots([m, 10 * b_crit, k])  # m λ² + B λ + k = 0
    assert zeta == pytest.approx(10)
    assert ratio == pytest.approx(max(abs(lam)) / min(abs(lam)), rel=1e-9)
    assert stiffness_ratio(k, m, 0.5 * b_crit) == (pytest.approx(0.5), 1.0)


def test_massless_piston_is_an_error():
    with pytest.raises(RigLoadError, match="moving mass"):
        settle(LAW, SETTINGS, 0.0)
    with pytest.raises(ValueError, match="method"):
        settle(LAW, SETTINGS, 1.0, method="Euler")


def test_settles_on_the_database_curve():
    from sims.database import build_database
    from sims.scene import load_scene

    scene = load_scene()
    curve = build_database(scene, models=["greenwood_tripp"])["greenwood_tripp"]
    s = RigSettings.from_scene(scene)
    run = settle(curve, s, 13.616, damping_n_s_per_m=1e7)
    assert run.stiff and run.method == "BDF" and run.settled
    assert abs(run.separation_error_m) <= 2e-6 * run.static.load_n / run.static.stiffness_n_per_m
    assert run.area_relative_error < 1e-5
