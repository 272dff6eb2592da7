"""What would it take (analysis.what_would_it_take, ``design --what-would-it-take``, issue 27): limits, monotonicity,
a closed-form detection probability, the command's files, JSON and errors."""

from __future__ import annotations

import json
import math
from importlib import resources

import numpy as np
import pytest

from analysis.design import ModelCurves, Plan, design
from analysis.noise_model import NoiseModel
from analysis.what_would_it_take import ALL, FACTORS, LoadRange, summary, table, what_would_it_take
from contactrig.cli.main import main

W = np.geomspace(1.0, 100.0, 6)


def _curves(**exponents: float) -> ModelCurves:
    """Models with A ∝ W^b (b per model) and one tiny clean term."""
    return ModelCurves(
        weight_kg=W,
        area_m2={k: 1e-8 * W**b for k, b in exponents.items()},
        clean_ohm={k: 1e-9 / W for k in exponents},
        geometry="test",
    )


def _range(curves: ModelCurves, loads: int = 8, repeats: int = 6) -> LoadRange:
    return LoadRange(1.0, 100.0, curves, (Plan(tuple(np.geomspace(1.0, 100.0, loads)), repeats, 1.0),))


TAB1_LIKE = NoiseModel(0.096, 0.132, 0.145, "test")


def test_zero_noise_tells_distinct_curves_apart_and_identical_ones_never() -> None:
    """The limits: every component removed, A ∝ W and A ∝ W^0.3 are told apart (only the instrument noise is left);
    identical curves give Δχ² = 0 exactly, never ≥ 10, whatever the noise."""
    res = what_would_it_take([_range(_curves(a=1.0, b=0.3, c=1.0))], TAB1_LIKE, n_sessions=60)
    assert res.pair("a", "b").largest[ALL][0] is not None
    assert res.pair("b", "c").largest[ALL][0] is not None
    same = res.pair("a", "c")
    assert same.now == (0.0,) and all(v == (None,) for v in same.largest.values())
    assert "no noise reduction" in summary(res, ("a", "c"))


def test_noise_scaled_up_tells_nothing_apart() -> None:
    """Tab. 1's scatter × 3: no pair reaches the target as things are."""
    big = NoiseModel(3 * 0.096, 3 * 0.132, 3 * 0.145, "×3")
    res = what_would_it_take([_range(_curves(a=1.0, b=0.6, c=0.3))], big, n_sessions=60)
    assert all(p.now[0] < res.target for p in res.pairs)
    assert all(p.largest[ALL][0] is None or p.largest[ALL][0] < 1.0 for p in res.pairs)


def test_more_reduction_never_tells_less_beyond_the_monte_carlo_error() -> None:
    """Monotonicity, on seeds apart from the search's: at every grid factor below the one found, the pair reaches the
    target within 3 Monte-Carlo SE (the search's bisection assumes it)."""
    curves = _curves(a=1.0, b=0.75)
    rng = _range(curves)
    res = what_would_it_take([rng], TAB1_LIKE, n_sessions=100, seed=1)
    need = res.pair("a", "b")
    checked = 0
    for comp in ("lack_sd", "lack_sd|alone", ALL):
        found = need.largest[comp][0]
        assert found is not None, comp
        for f in [x for x in FACTORS if x < found][:4]:
            from analysis.what_would_it_take import _scaled

            score = design(curves, list(rng.plans), n_sessions=200, seed=7, noise=_scaled(TAB1_LIKE, comp, f))
            p = float(score.pair_score[("a", "b")][0])
            assert p >= res.target - 3 * math.sqrt(res.target * (1 - res.target) / 200), (comp, f, p)
            checked += 1
    assert checked >= 6


def _closed_form(curves: ModelCurves, plan: Plan, truth: str, other: str, sd: float, film: float,
                 series: float) -> float:  # fmt: skip
    """P(χ²_other − χ²_truth ≥ 10) for iid log-normal re-seating of SD ``sd``: Δ = (μ'+e)ᵀQ_o(μ'+e) − eᵀQ_t e with
    Q = V − VX(XᵀVX)⁻¹XᵀV the weighted residual form of each model (X = [1, 1/A], V the fit's "relative" weights
    in expectation), e ~ N(0, Σ) the noise of the means; mean λ + tr((Q_o − Q_t)Σ), variance 4μ'ᵀQ_oΣQ_oμ' +
    2 tr(((Q_o − Q_t)Σ)²) (Gaussian quadratic forms), normal approximation."""
    w = np.asarray(plan.weights_kg)
    a_t, c_t = curves.at(truth, w)
    a_o, _ = curves.at(other, w)
    contact = film / a_t + c_t
    mu = series + contact
    var_f = math.expm1(sd**2)  # Var f of a mean-one log-normal
    sigma = np.diag(var_f * contact**2 / plan.repeats)
    c2 = float(np.mean(var_f * contact**2 / mu**2))  # pooled relative variance: the fit's weights
    v = np.diag(plan.repeats / (c2 * mu**2))

    def q(area: np.ndarray) -> np.ndarray:
        x = np.column_stack([np.ones_like(w), 1.0 / area])
        vx = v @ x
        return v - vx @ np.linalg.solve(x.T @ vx, vx.T)

    qt, qo = q(a_t), q(a_o)
    shifted = mu - c_t  # y − R_clean (the clean terms of both models are equal here)
    d = (qo - qt) @ sigma
    mean = float(shifted @ qo @ shifted + np.trace(d))
    var = float(4 * shifted @ qo @ sigma @ qo @ shifted + 2 * np.trace(d @ d))
    return 0.5 * math.erfc((10.0 - mean) / math.sqrt(2 * var))


def test_detection_probability_matches_the_closed_form_of_a_linear_case() -> None:
    """Many loads (ν = 98: ĉ stays below 1.5, so AIC), R_s clearly positive (no unphysical flag), small iid scatter:
    the simulated P(Δχ² ≥ 10) is the Gaussian quadratic form's, within 4 Monte-Carlo SE + 0.03 (the normal
    approximation and the estimated weights)."""
    curves = _curves(a=1.0, b=0.97)
    film, series = 2e-9, 0.01
    plan = Plan(tuple(np.geomspace(1.0, 100.0, 100)), 8, 1.0)
    n = 1500
    for sd in (0.08, 0.1, 0.13):
        expected = _closed_form(curves, plan, "a", "b", sd, film, series)
        sim = design(curves, [plan], n_sessions=n, film_ohm_m2=film, series_ohm=series, noise=NoiseModel.iid(sd))
        got = float(sim.probability[("a", "b")][0])
        assert 0.15 < expected < 0.995, expected  # a point where the probability is informative
        assert abs(got - expected) <= 4 * math.sqrt(expected * (1 - expected) / n) + 0.03, (sd, got, expected)


def test_the_search_lands_where_the_closed_form_puts_the_target() -> None:
    """The study's factor for the pair is, within one grid step, the largest grid factor at which the closed form
    gives ≥ 90 % both ways."""
    curves = _curves(a=1.0, b=0.97)
    film, series = 2e-9, 0.01
    plan = Plan(tuple(np.geomspace(1.0, 100.0, 100)), 8, 1.0)
    sd = 0.25
    res = what_would_it_take([LoadRange(1.0, 100.0, curves, (plan,))], NoiseModel.iid(sd), n_sessions=200,
                             film_ohm_m2=film, series_ohm=series)  # fmt: skip
    closed = [
        k for k, f in enumerate(FACTORS)
        if f > 0 and min(_closed_form(curves, plan, t, o, f * sd, film, series)
                         for t, o in (("a", "b"), ("b", "a"))) >= 0.9
    ]  # fmt: skip
    found = res.pair("a", "b").largest["reseat_sd"][0]
    assert closed and 0.0 < closed[0] and found is not None  # the target lies inside the grid
    assert abs(FACTORS.index(found) - closed[0]) <= 1, (found, FACTORS[closed[0]])


# ---- the command ---------------------------------------------------------------------------------------------
def test_wwit_sessions_without_the_study_is_refused(tmp_path, capsys) -> None:
    assert main(["design", "--wwit-sessions", "50", "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "--wwit-sessions" in err and "--what-would-it-take" in err and "Traceback" not in err
    assert not (tmp_path / "o" / "design.md").exists()


def test_wwit_sessions_out_of_range_is_refused(tmp_path, capsys) -> None:
    assert main(["design", "--what-would-it-take", "--wwit-sessions", "5", "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "--wwit-sessions" in err and "5" in err and "20" in err and len(err.strip().splitlines()) == 1


def test_an_existing_figure_is_refused_before_any_work(tmp_path, capsys) -> None:
    out = tmp_path / "o"
    out.mkdir()
    (out / "what-would-it-take.png").write_bytes(b"mine")
    assert main(["design", "--what-would-it-take", "-o", str(out)]) == 2
    assert "what-would-it-take.png" in capsys.readouterr().err
    assert (out / "what-would-it-take.png").read_bytes() == b"mine" and not (out / "design.md").exists()


@pytest.mark.slow
def test_design_what_would_it_take_writes_its_section_figure_and_json(tmp_path, capsys) -> None:
    jsonschema = pytest.importorskip("jsonschema")
    out = tmp_path / "o"
    code = main(["design", "--sessions", "20", "--what-would-it-take", "--wwit-sessions", "20", "--seed", "3",
                 "-o", str(out), "--json", "--quiet"])  # fmt: skip
    assert code == 0
    data = json.loads(capsys.readouterr().out)
    schema = json.loads(resources.files("contactrig").joinpath("schemas", "design.json").read_text("utf-8"))
    jsonschema.validate(data, schema)
    study = data["what_would_it_take"]
    assert study["seed"] == 3 and study["sessions_per_point"] == 20 and len(study["pairs"]) == 10
    assert (out / "what-would-it-take.png").read_bytes()[:4] == b"\x89PNG"
    text = (out / "design.md").read_text("utf-8")
    assert "## What would it take" in text and "what-would-it-take.png" in text
    assert main(["design", "--what-would-it-take", "-o", str(out)]) == 2  # no overwrite without --force


def test_table_has_a_row_per_component_and_pair() -> None:
    res = what_would_it_take([_range(_curves(a=1.0, b=0.3))], TAB1_LIKE, n_sessions=40)
    rows = [line for line in table(res).splitlines()[2:]]
    assert len(rows) == len(res.components) == 7


def test_a_futile_adaptive_session_says_what_would_from_the_simulated_study() -> None:
    """The futility message of an adaptive session ends with the study's one line for its leading pair (A ∝ W vs
    A ∝ W^0.98 under a 20 % lack of fit, 20 min: futile), the same line as the study on that bench gives."""
    import time

    from analysis.sequential import CostModel, SequentialDesign, simulate_loop
    from analysis.what_would_it_take import futility_summary

    curves = ModelCurves(W, {"a": 1e-8 * W, "b": 1e-8 * W**0.98}, {"a": 1e-6 / W, "b": 1e-6 / W}, "test")
    noise = NoiseModel(0.0, 0.1, 0.2, "test")
    d = SequentialDesign(curves, W, CostModel(block_s=3.0), budget_s=1200, noise=noise, film_ohm_m2=2e-9,
                         n_forward=60)  # fmt: skip
    status, _, _, _ = simulate_loop(d, "a", np.random.default_rng(5), film_ohm_m2=2e-9, series_ohm=0.0, noise=noise)
    assert status == "futile"
    start = time.perf_counter()
    stop = d.stop()
    assert stop is not None and stop[0] == "futile"
    line = futility_summary(d)
    assert time.perf_counter() - start < 30.0  # fast enough for the live line (cached after the first)
    assert stop[1].endswith("simulated: " + line)
    assert "to tell" in line and "lack of fit" in line


def test_a_negative_seed_is_refused_in_one_line_naming_the_option(tmp_path, capsys) -> None:
    """Before the slow work, as --sessions: numpy's generator takes no negative seed (it used to fail after the
    model curves were built, with a message naming neither the option nor the value)."""
    assert main(["design", "--what-would-it-take", "--seed", "-1", "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "--seed" in err and "-1" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o" / "design.md").exists()


def test_the_study_refuses_bad_arguments_naming_them() -> None:
    from contactrig.core.validation import SettingError

    rng = _range(_curves(a=1.0, b=0.3))
    with pytest.raises(SettingError, match="n_sessions"):
        what_would_it_take([rng], TAB1_LIKE, n_sessions=1)
    with pytest.raises(SettingError, match="target"):
        what_would_it_take([rng], TAB1_LIKE, target=1.0)
    with pytest.raises(SettingError, match="ranges"):
        what_would_it_take([], TAB1_LIKE)
