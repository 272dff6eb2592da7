"""Experiment design (analysis.design): the Monte Carlo's limits and the written plan scene."""

from __future__ import annotations

import numpy as np

from analysis.design import ModelCurves, Plan, design, plan_scene_text
from contactrig.core.scene import default_scene_text, parse_scene


def _curves(exponent_b: float) -> ModelCurves:
    w = np.geomspace(1.0, 100.0, 6)
    return ModelCurves(
        weight_kg=w,
        area_m2={"a": 1e-8 * w, "b": 1e-8 * w**exponent_b},
        clean_ohm={"a": 1e-6 / w, "b": 1e-6 / w},
        geometry="test",
    )


def test_identical_models_are_never_told_apart_and_distinct_ones_always() -> None:
    """Same A(W): Δχ² = 0 exactly (never ≥ 10). A ∝ W against A ∝ W^0.3 over two decades: told apart in ≥ 95 % of
    sessions — not every one: with the true R_s = 0 the true model's 95 % upper limit of R_s falls below zero by
    chance in 2.5 % of sessions, and the fit then ranks it last as unphysical (as `fit` does)."""
    plan = Plan(tuple(np.geomspace(1.0, 100.0, 8)), 6, 1.0)
    same = design(_curves(1.0), [plan], n_sessions=200, film_ohm_m2=2e-9)
    assert same.pair_score[("a", "b")][0] == 0.0 and same.cheapest[("a", "b")] is None
    far = design(_curves(0.3), [plan], n_sessions=200, film_ohm_m2=2e-9)
    assert far.pair_score[("a", "b")][0] >= 0.95 and far.cheapest[("a", "b")] == 0


def test_plan_scene_is_a_valid_scene_with_the_plan() -> None:
    plan = Plan((2.0, 10.0, 26.0), 12, 1.0)
    scene = parse_scene(plan_scene_text(default_scene_text(), plan))
    session = scene.table("session")
    assert session["repeats"] == 12 and session["weights_kg"] == [2.0, 10.0, 26.0]


def test_no_plan_reaching_the_target_is_said_first_and_marks_the_plan() -> None:
    plan = Plan(tuple(np.geomspace(1.0, 100.0, 8)), 6, 1.0)
    result = design(_curves(1.0), [plan], n_sessions=50, film_ohm_m2=2e-9)
    assert not result.discriminating
    assert result.statement().startswith("NO PLAN REACHES THE TARGET")
    text = plan_scene_text(default_scene_text(), plan, discriminating=False)
    assert text.startswith("# NOT A DISCRIMINATING PLAN")
    assert parse_scene(text).table("session")["repeats"] == 6
    far = design(_curves(0.3), [plan], n_sessions=50, film_ohm_m2=2e-9)
    assert far.discriminating and not far.statement().startswith("NO PLAN")


def test_a_scene_without_resistivities_is_a_setting_error() -> None:
    import re

    import pytest

    from analysis.design import model_curves
    from contactrig.core.validation import SettingError

    text = re.sub(r"^resistivity_ohm_m\s*=.*$", "", default_scene_text(), flags=re.M)
    with pytest.raises(SettingError, match="resistivit"):
        model_curves(parse_scene(text), [5.0, 10.0, 20.0])


def test_noise_model_is_recovered_from_a_simulated_table() -> None:
    """Many series with known offset, re-seating and lack of fit about a log-log line: the two-way estimates hold."""
    from analysis.design import NoiseModel, estimate_noise
    from analysis.measured import MeasuredCurve

    w = np.geomspace(5.0, 26.0, 40)
    truth = NoiseModel(series_sd=0.08, reseat_sd=0.12, lack_sd=0.10)
    f = truth.factors(np.random.default_rng(3), (1, w.size, 60))[0]
    curve = MeasuredCurve(w, 1e-2 * ((w / 5.0) ** -0.9)[:, None] * f, paired=True)
    est = estimate_noise(curve)
    assert abs(est.reseat_sd - 0.12) < 0.01 and abs(est.series_sd - 0.08) < 0.025 and abs(est.lack_sd - 0.10) < 0.03


def test_lack_of_fit_lowers_the_discrimination_as_qaic_does_in_fit() -> None:
    from analysis.design import NoiseModel

    plan = Plan(tuple(np.geomspace(1.0, 100.0, 8)), 12, 1.0)
    iid = design(_curves(0.8), [plan], n_sessions=300, film_ohm_m2=2e-9, noise=NoiseModel.iid(0.15))
    lack = design(_curves(0.8), [plan], n_sessions=300, film_ohm_m2=2e-9, noise=NoiseModel(0.1, 0.13, 0.15))
    assert lack.pair_score[("a", "b")][0] < iid.pair_score[("a", "b")][0] - 0.2


def test_design_prediction_holds_when_its_sessions_are_replayed_through_fit() -> None:
    """Calibration: 150 sessions per direction, replayed in-process from the design's own random factors through
    `fit` (compare_models, physical conversion). The design judges every session as the fit does — ĉ/QAIC, and an
    unphysical or load-independent fit ranked last by the fit's own t-intervals — so the session decisions agree
    (all but a rounding case at an interval's edge) and the observed rate lies in the binomial 95 % interval of the
    prediction, in both directions. (Before the design modelled the unphysical flag: 0.947 observed against 0.993
    predicted in one direction.)"""
    from analysis.design import DELTA_AIC, NoiseModel, simulate_plan, told_apart
    from analysis.fit import compare_models
    from analysis.measured import MeasuredCurve
    from analysis.resistance_model import bench_resistance_ohm

    curves = _curves(0.75)
    plan = Plan(tuple(np.geomspace(1.0, 100.0, 8)), 6, 1.0)
    noise = NoiseModel(0.05, 0.10, 0.04)
    film, series, block_sd, n = 2e-9, 1e-5, 1e-7, 150
    w = np.asarray(plan.weights_kg)
    unphysical_seen = 0
    for truth, other in (("a", "b"), ("b", "a")):
        fits = simulate_plan(curves, plan, truth, film, series, np.random.default_rng(7), n, 0.15, block_sd, noise)
        decided = told_apart(fits, truth, other, w.size - 2)
        predicted = float(decided.mean())
        unphysical_seen += int(fits[other].unphysical.sum() + fits[truth].unphysical.sum())
        rng = np.random.default_rng(7)  # the same factors, drawn again in the same order
        a_t, c_t = curves.at(truth, w)
        f = noise.factors(rng, (n, w.size, plan.repeats))
        values = bench_resistance_ohm(series, film, a_t, c_t, f) + block_sd * rng.standard_normal(f.shape)
        told = np.zeros(n, dtype=bool)
        for k in range(n):
            cmp = compare_models(
                MeasuredCurve(w, values[k], paired=True),
                {m: curves.at(m, w)[0] for m in ("a", "b")}, height_m=1.0, conversion="physical", n_boot=0,
                offset_terms={m: {"clean": curves.at(m, w)[1]} for m in ("a", "b")},
            )  # fmt: skip
            told[k] = cmp.ranking[0] == truth and cmp.delta_aic[other] >= DELTA_AIC
            assert cmp.fits[other].physical == (not fits[other].unphysical[k]), (truth, k)
        assert np.sum(told != decided) <= 1, (truth, np.flatnonzero(told != decided))
        half = 1.96 * np.sqrt(max(predicted * (1 - predicted), 1e-4) / n)
        assert abs(told.mean() - predicted) <= half, (truth, told.mean(), predicted)
    assert unphysical_seen > 0  # the unphysical rule is exercised, not vacuous


def test_design_refuses_a_missing_noise_session_in_one_line(tmp_path, capsys) -> None:
    from contactrig.cli.main import main

    assert main(["design", "--noise-from", str(tmp_path / "none.h5"), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--noise-from" in err[0] and "Traceback" not in err[0]
