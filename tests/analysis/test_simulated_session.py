"""The simulated session (``--sim``): re-seating factors mean-one log-normal, seeded, indexed by block number;
the bench's speed setting. The whole simulated session (R = R_s + f·ζh/A from the rig) is checked end to end
through the CLI in tests/daq/test_commands.py."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from analysis.simulated_session import SimulatedRigBench, repeat_factors
from contactrig.core.validation import SettingError
from daq.plan import DEFAULT_SIM_REPEAT_SD
from daq.table_import import tab1_path


@pytest.mark.parametrize("sd", [0.05, 0.15, 0.5])
def test_factors_are_mean_one_lognormal_with_the_given_log_sd(sd):
    n = 40_000
    f = repeat_factors(n, sd, seed=3)
    assert np.all(f > 0)
    log = np.log(f)
    # sampling errors of a normal sample's mean and SD: σ/√n and σ/√(2n); 5 of them is a generous bound
    assert abs(log.mean() + sd**2 / 2) < 5 * sd / math.sqrt(n)
    assert abs(log.std(ddof=1) - sd) < 5 * sd / math.sqrt(2 * n)
    # E[f] = 1 exactly for the log-normal with μ = −σ²/2; SD of f is sqrt(exp(σ²) − 1)
    assert abs(f.mean() - 1) < 5 * math.sqrt(math.expm1(sd**2) / n)


def test_factors_are_seeded_and_depend_only_on_the_block_number():
    a = repeat_factors(48, 0.15, seed=1)
    np.testing.assert_array_equal(a, repeat_factors(48, 0.15, seed=1))
    np.testing.assert_array_equal(a[:10], repeat_factors(10, 0.15, seed=1))  # a resumed plan gets the same f_b
    assert not np.array_equal(a, repeat_factors(48, 0.15, seed=2))
    np.testing.assert_array_equal(repeat_factors(5, 0.0, seed=1), np.ones(5))


def test_default_scatter_is_that_of_tab1_independent_repeats():
    """Tab. 1: M4 is the mean of M1–M3 and M5, M6 are offset copies, so M1–M3 are the independent repeats; their
    relative SD per weight (pooled over the weights) is the default ``sim_repeat_sd`` to within 0.02."""
    t = pd.read_csv(tab1_path())
    v = t[["M1", "M2", "M3"]].to_numpy()
    assert np.sum(np.abs(t["M4"] - v.mean(axis=1)) < 1e-4) >= 7  # M4 = mean(M1–M3) at 7 of 8 weights
    rel = v.std(axis=1, ddof=1) / v.mean(axis=1)
    log_sd = math.sqrt(np.mean(np.log(v).var(axis=1, ddof=1)))
    assert abs(np.median(rel) - DEFAULT_SIM_REPEAT_SD) < 0.02 and abs(log_sd - DEFAULT_SIM_REPEAT_SD) < 0.02


@pytest.mark.parametrize("speed", [0.0, -1.0, float("nan")])
def test_sim_speed_must_be_positive(speed):
    with pytest.raises(SettingError, match="--sim-speed"):
        SimulatedRigBench(speed)


def test_sim_speed_sets_the_time_scale():
    assert SimulatedRigBench(4.0).time_scale == 0.25
    assert SimulatedRigBench(math.inf).time_scale == 0.0
    assert SimulatedRigBench().simulated


# ---- the simulated bench's noise and resistance model (issue 21 §1–§3) ------------------------------------------


def _bench_sessions(noise: str, n: int, series_ohm: float = 2e-4, text: str | None = None):
    """``n`` simulated sessions of the default scene (or of the scene ``text``; seeds 1 … n) as the bench makes them
    (:func:`simulated_resistances`; the instrument noise, ~1e-5 of R, left out), each fitted as ``fit --conversion
    physical`` fits a session (the clean terms of :func:`analysis.pipeline.physical_terms`). Returns the truth
    (σ_f, R_s), the t-interval hits of both per session, ĉ per session and the noise model used."""
    import dataclasses
    import re

    from analysis.fit import compare_models
    from analysis.measured import MeasuredCurve
    from analysis.pipeline import physical_terms
    from analysis.resistance_model import specimen_resistance_terms
    from analysis.simulated_session import simulated_resistances
    from contactrig.core.scene import default_scene_text, parse_scene
    from daq.plan import SessionPlan
    from sims.config import SimConfig

    text = re.sub(r"^series_resistance_ohm\s*=.*$", f"series_resistance_ohm = {series_ohm}",
                  default_scene_text() if text is None else text, flags=re.M)  # fmt: skip
    scene = parse_scene(text)
    plan = SessionPlan.from_scene(scene)
    model, w = plan.session.sim_model, np.asarray(plan.session.weights_kg)
    terms = specimen_resistance_terms(SimConfig.from_scene(scene), [model], list(w))[model]
    fit_terms = physical_terms(scene, [model], w)[model]  # what `fit --conversion physical` subtracts
    hits, c_hat = np.zeros((n, 2), dtype=bool), np.zeros(n)
    for k in range(n):
        session = dataclasses.replace(plan.session, sim_noise=noise, sim_seed=k + 1)
        info = simulated_resistances(dataclasses.replace(plan, session=session), terms)
        values = np.asarray(info["block_resistance_ohm"]).reshape(w.size, plan.session.repeats)
        fit = compare_models(
            MeasuredCurve(w, values, paired=True), {model: terms.area_m2}, height_m=1.0, conversion="physical",
            n_boot=0, offset_terms={model: fit_terms},
        ).fits[model]  # fmt: skip
        film, r_s = info["circuit"]["film_ohm_m2"], info["circuit"]["series_resistance_ohm"]
        t = fit.intervals.t
        hits[k] = [t.scale[0] <= film <= t.scale[1], t.R_series_ohm[0] <= r_s <= t.R_series_ohm[1]]
        c_hat[k] = fit.goodness.reduced_chi2
    return hits, c_hat, info, plan.session.repeats, w.size


def test_tab1_noise_makes_simulated_sessions_over_dispersed_like_tab1():
    """With ``sim_noise = "tab1"`` a fit's ĉ = χ²/ν is ≫ 1. Expected from the noise parameters alone
    (analysis.noise_model): E[ĉ] ≈ (σ_e² + r·σ_b²)/(σ_a² + σ_e²) = 5.4 for r = 6 repeats, times ν₂/(ν₂ − 2) = 40/38
    for the pooled relative scatter estimated on ν₂ = m(r − 1) = 40 dof (mean of an F ratio): 5.66. The mean over
    500 sessions (SE ≈ 0.12) lies within ±15 % of it (the formula neglects the fitted parameters' share of the
    lack of fit and the log-normal's skew). iid re-seating: E[ĉ] = 40/38, also within ±15 %."""
    from analysis.noise_model import tab1_noise

    _, c_hat, info, r, m = _bench_sessions("tab1", 500)
    noise = tab1_noise()
    assert info["noise"]["name"] == "tab1" and info["noise"]["lack_sd"] == noise.lack_sd
    nu2 = m * (r - 1)
    expected = noise.expected_c_hat(r) * nu2 / (nu2 - 2)
    assert 5.0 < expected < 6.2  # the Tab. 1 estimates (σ_a 9.6 %, σ_e 13.2 %, σ_b 14.5 %) give 5.66
    assert abs(c_hat.mean() / expected - 1) < 0.15, (c_hat.mean(), expected)
    _, c_iid, _, _, _ = _bench_sessions("iid", 200)
    assert abs(c_iid.mean() / (nu2 / (nu2 - 2)) - 1) < 0.15, c_iid.mean()


def test_physical_fit_of_simulated_sessions_recovers_film_and_series():
    """The bench's resistance is the physical model's (R_s + f·(σ_f/A + R_Barber + R_macro), the clean terms from
    the function `fit --conversion physical` subtracts): over 1000 simulated sessions with Tab. 1's noise the 95 %
    t-intervals of σ_f and R_s contain the simulated values in ≥ 90 % (issue 21 acceptance: ≥ 90 % of 200; measured
    0.915 / 0.965 for seeds 1–200, 0.935 / 0.945 over 4000), and with iid re-seating near 95 %."""
    hits, _, _, _, _ = _bench_sessions("tab1", 1000)
    assert np.all(hits[:200].mean(axis=0) >= 0.90), hits[:200].mean(axis=0)
    assert np.all(hits.mean(axis=0) >= 0.90), hits.mean(axis=0)
    hits_iid, _, _, _, _ = _bench_sessions("iid", 300)
    assert np.all(hits_iid.mean(axis=0) >= 0.92), hits_iid.mean(axis=0)


def test_physical_fit_of_simulated_press_sessions_recovers_film_and_series():
    """The press (issue 27): `fit --conversion physical` subtracts the press's clean-metal terms (Barber's from the
    press stiffness, Holm's spot of the contact radius), the simulated bench's; over 300 simulated press sessions
    (iid re-seating 15 %, R_s = 0.2 mΩ) the 95 % t-intervals of σ_f and R_s contain the simulated values in ≥ 92 %
    (measured 0.94 / 0.94 over 400). With Tab. 1's noise the σ_f interval covers less on the press than on the rig
    (measured 0.89 / 0.95 over 400 press sessions, against 0.935 / 0.945 over 4000 on the rig: the lack of fit common
    to every seating, 14.5 %, weighs most at the press's smallest loads, where σ_f/A is 150 times larger than at its
    largest); the test holds it at ≥ 0.85."""
    from pathlib import Path

    press = (Path(__file__).resolve().parents[2] / "contactrig" / "scenes" / "press.toml").read_text()
    hits, _, info, _, _ = _bench_sessions("iid", 300, text=press)
    assert info["weights_kg"][0] == 0.5  # the press's loads
    assert np.all(hits.mean(axis=0) >= 0.92), hits.mean(axis=0)
    hits, _, _, _, _ = _bench_sessions("tab1", 300, text=press)
    assert np.all(hits.mean(axis=0) >= 0.85), hits.mean(axis=0)


def test_sim_noise_is_a_checked_scene_key_matching_the_noise_models():
    from analysis.noise_model import NOISE_MODELS
    from daq.plan import SIM_NOISE_KINDS, SessionSettings

    assert tuple(NOISE_MODELS) == SIM_NOISE_KINDS
    assert SessionSettings(weights_kg=(5.0,)).sim_noise == "tab1"
    with pytest.raises(SettingError, match=r"\[session\] sim_noise"):
        SessionSettings(weights_kg=(5.0,), sim_noise="gaussian")


def test_tab1_factors_are_seeded_and_recorded_per_block():
    from analysis.noise_model import tab1_noise
    from analysis.simulated_session import session_factors

    a = session_factors(tab1_noise(), 8, 6, seed=3)
    np.testing.assert_array_equal(a, session_factors(tab1_noise(), 8, 6, seed=3))
    assert a.shape == (48,) and not np.array_equal(a, session_factors(tab1_noise(), 8, 6, seed=4))
    # one series' offset is common to its blocks at every weight: the series means of ln f differ far more than
    # independent blocks would allow (σ_a = 9.6 % against σ_e/√8 = 4.7 %) — checked on many sessions
    logs = np.log(np.array([session_factors(tab1_noise(), 8, 6, seed=s).reshape(8, 6) for s in range(400)]))
    series_means = logs.mean(axis=1)  # (sessions, repeats)
    var = series_means.var(axis=1, ddof=1).mean()
    expected = tab1_noise().series_sd ** 2 + tab1_noise().reseat_sd ** 2 / 8  # the lack term is common to all
    assert abs(var / expected - 1) < 0.1, (var, expected)
