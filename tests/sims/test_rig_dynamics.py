"""Damped release-to-rest dynamics (seed eq. 22): settles to the static solution, stiff and non-stiff."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sims.rig.dynamics import explicit_cost_estimate, settle, stiffness_ratio
from sims.rig.equilibrium import RigLoadError, equilibrium
from sims.rig.loads import SkirtLoads
from sims.rig.settings import RigSettings
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
    with pytest.warns(RuntimeWarning, match="implicit method"):
        explicit = settle(LAW, SETTINGS, 25.966, damping_n_s_per_m=3e6, static=static, method="RK45")
    implicit = settle(LAW, SETTINGS, 25.966, damping_n_s_per_m=3e6, static=static, method="BDF")
    assert explicit.stiff and explicit.settled and implicit.settled
    assert explicit.nfev > 10 * implicit.nfev
    assert any("stiff" in w for w in explicit.warnings) and not implicit.warnings
    # The stability-limited estimate is a lower bound of the explicit cost.
    assert explicit.nfev >= explicit_cost_estimate(static.stiffness_n_per_m, 25.966, 3e6, 1e-6)


def test_explicit_method_on_a_stiff_case_stops_at_the_evaluation_budget(static):
    with pytest.warns(RuntimeWarning) as caught:
        run = settle(LAW, SETTINGS, 25.966, damping_n_s_per_m=2e6, static=static, method="RK45", max_evaluations=3000)
    messages = [str(w.message) for w in caught]
    assert any("implicit method" in m for m in messages)
    assert any("Maximum number of function evaluations" in m for m in messages)
    assert run.status == -2 and not run.settled
    assert "Maximum number of function evaluations" in run.message and "3000" in run.message
    assert 3000 <= run.nfev < 3000 + 20  # stopped after the step that crossed the budget
    assert math.isfinite(run.final_separation_m) and 0 < run.settle_time_s < run.t_s.max() + 1e-12
    assert len(run.warnings) == 2
    with pytest.raises(ValueError, match="max_evaluations"):
        settle(LAW, SETTINGS, 25.966, static=static, max_evaluations=0)


@pytest.mark.parametrize("method", ["RK45", "Radau", "BDF", "LSODA"])
def test_light_damping_first_overshoot_is_the_linear_oscillators(static, method):
    # Released δ above rest (linear regime), a lightly damped oscillator overshoots by δ·exp(−πζ/√(1−ζ²)) half a
    # period later: the analytic reference for numerical damping. Error control keeps every method on it.
    m, k, damping = 25.966, static.stiffness_n_per_m, 2e4
    zeta = damping / (2 * math.sqrt(k * m))
    period = 2 * math.pi / (math.sqrt(k / m) * math.sqrt(1 - zeta**2))
    delta = 1e-3 * static.load_n / k
    t = np.linspace(0.0, period, 2001)
    run = settle(
        LAW,
        SETTINGS,
        25.966,
        method=method,
        damping_n_s_per_m=damping,
        static=static,
        start_m=static.min_separation_m + delta,
        t_eval_s=t,
        t_max_s=period,
        rtol=1e-6,
    )
    assert run.status == 0 and np.array_equal(run.t_s, t)
    overshoot = static.min_separation_m - run.min_separation_m.min()
    assert overshoot == pytest.approx(delta * math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2)), rel=2e-3)


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
    from contactrig.core.scene import load_scene
    from sims.config import SimConfig
    from sims.database import build_database

    config = SimConfig.from_scene(load_scene())
    curve = build_database(config, models=["greenwood_tripp"])["greenwood_tripp"]
    s = config.rig
    run = settle(curve, s, 13.616, damping_n_s_per_m=1e7)
    assert run.stiff and run.method == "BDF" and run.settled
    assert abs(run.separation_error_m) <= 2e-6 * run.static.load_n / run.static.stiffness_n_per_m
    assert run.area_relative_error < 1e-5


class _Saturating:
    """A contact law whose pressure saturates at ``p_sat`` [Pa] (1 − e^(−(h_max − h)/λ)): carried near saturation,
    an undamped release overshoots far below rest — here through the liner wall."""

    h_min, h_max = -0.02, 1e-5

    def __init__(self, p_sat: float, lam: float = 1e-3) -> None:
        self.p, self.lam = p_sat, lam

    def _x(self, h):
        return np.clip(self.h_max - np.asarray(h, float), 0, None)

    def pressure(self, h):
        return self.p * (1 - np.exp(-self._x(h) / self.lam))

    def dpressure_dh(self, h):
        h = np.asarray(h, float)
        return np.where(h < self.h_max, -self.p / self.lam * np.exp(-self._x(h) / self.lam), 0.0)

    def area_fraction_at(self, h):
        return np.clip(self._x(h) / 0.1, 0, 1)


def test_a_state_outside_the_geometry_ends_the_run_with_a_named_status():
    """Issue #11: an integrator step that takes the piston through the liner wall is status −3 with a message at
    the point it happens, not a NaN that surfaces later as an error about an input the user never gave."""
    import warnings

    from contactrig.core.scene import load_scene
    from sims.config import SimConfig

    rig = SimConfig.from_scene(load_scene()).rig
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        run = settle(_Saturating(7e4), rig, 25.0, method="RK45", damping_n_s_per_m=0.0, max_evaluations=50_000)
    assert run.status == -3 and not run.settled
    assert "left the piston/liner geometry" in run.message and "liner wall" in run.message
    assert np.all(np.isfinite(run.min_separation_m)) and np.all(np.isfinite(run.velocity_m_per_s))
    # it really went deep: the last recorded state is past half the piston radius, with the bound 2c − R_l beyond
    assert run.min_separation_m.min() < -0.5 * rig.piston_radius_m
