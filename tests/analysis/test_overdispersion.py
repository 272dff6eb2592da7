"""Over-dispersion (issue 21 §1): copies of other series counted once, errors by one rule, ranking by QAIC."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from analysis.fit import compare_models, fit_model, series_dependence
from analysis.measured import MeasuredCurve, load_tab1
from analysis.series_dependence import find_dependence, print_quantum

W = np.array([5.44, 7.44, 10.526, 13.616, 16.708, 19.795, 22.882, 25.966])
H = 5e-3
RS, S = 2e-4, 1e-7
AREAS = {"a": 1e-7 * (W / W[0]) ** 0.8, "b": 1e-7 * (W / W[0]) ** 0.9}


def test_tab1_copies_are_found_from_the_printed_numbers():
    curve = load_tab1()
    assert print_quantum(curve.values_ohm) == 1e-7  # mΩ printed to 4 decimals
    dep = find_dependence(curve.values_ohm, curve.repeat_labels)
    assert dep.keep == (0, 1, 2) and dep.dropped == (3, 4, 5)
    assert any("M4 is the mean of M1, M2, M3" in n for n in dep.notes)


def test_a_built_table_mean_and_offset_columns_are_dropped_and_fitting_counts_them_once():
    rng = np.random.default_rng(5)
    base = np.round(5 + rng.normal(size=(8, 4)), 4)
    mean = np.round(base[:, :2].mean(axis=1), 4)
    shifted = base[:, 3] + np.round(rng.normal(size=8), 3)  # a column = another + offsets with 3 decimals
    v = np.column_stack((base, mean, shifted)) * 1e-3
    dep = find_dependence(v, ("A", "B", "C", "D", "E", "F"))
    assert dep.dropped == (4, 5) and dep.keep == (0, 1, 2, 3)
    area = AREAS["a"]
    full = MeasuredCurve(W, v, repeat_labels=("A", "B", "C", "D", "E", "F"), paired=True)
    indep = MeasuredCurve(W, v[:, :4], repeat_labels=("A", "B", "C", "D"), paired=True)
    cmp = compare_models(full, {"m": area}, height_m=H, n_boot=99)
    ref = fit_model(indep, area, height_m=H, n_boot=99)
    assert cmp.n_repeats == 4 and cmp.series_notes
    assert cmp.fits["m"].estimate.scale == ref.estimate.scale
    assert cmp.fits["m"].intervals.t.dof == ref.intervals.t.dof


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(3, 8), st.sampled_from([None, 2, 4, 6]))
def test_independent_series_are_never_dropped(seed, r, decimals):
    rng = np.random.default_rng(seed)
    v = np.exp(rng.normal(size=(8, r)))
    if decimals is not None:
        v = np.round(v, decimals)
    dep = find_dependence(v)
    # by chance: a mean within one print quantum at 7 of 8 weights, or 8 round differences (10^-8 per pair)
    assert dep.dropped == () and dep.keep == tuple(range(r))


def _overdispersed(seed, lack_of_fit=0.025, repeat=0.02, r=6):
    """Truth: model "a"; a lack of fit common to every series (per-weight factor, SD ``lack_of_fit``) plus
    re-seating scatter ``repeat``: χ²/ν ≈ 1 + 6 (0.025/0.02)² ≈ 10, Tab. 1's over-dispersion."""
    rng = np.random.default_rng(seed)
    truth = RS + S * H / AREAS["a"]
    common = 1 + lack_of_fit * rng.normal(size=(W.size, 1))
    return MeasuredCurve(W, truth[:, None] * common * (1 + repeat * rng.normal(size=(W.size, r))), paired=True)


def test_overdispersed_coin_toss_is_no_longer_called_decisive():
    n = 40
    wrong = raw_decisive = discriminates = qaic = 0
    for seed in range(n):
        cmp = compare_models(_overdispersed(seed), AREAS, height_m=H, n_boot=300, seed=seed)
        raw = cmp.fits["b"].goodness.chi2 - cmp.fits["a"].goodness.chi2
        wrong += cmp.ranking[0] == "b"
        raw_decisive += abs(raw) >= 2  # what ΔAIC on the raw χ² claims
        if cmp.criterion == "QAIC":
            qaic += 1
            assert "QAIC" in cmp.statement and "over-dispersed" in cmp.statement
            if all(f.physical for f in cmp.fits.values()):
                assert math.isclose(cmp.delta_aic[cmp.ranking[1]], abs(raw) / cmp.c_hat, rel_tol=1e-9)
            discriminates += cmp.discriminates
    assert 0.3 * n < wrong < 0.7 * n  # the truth is a coin toss with these data
    assert raw_decisive > 0.8 * n  # raw ΔAIC would call nearly every one of them
    assert qaic > 0.9 * n and discriminates <= 1


def test_overdispersed_errors_are_the_chi2_scaled_ones_when_larger():
    from scipy.optimize import curve_fit

    curve = _overdispersed(3, r=6)
    f = fit_model(curve, AREAS["a"], height_m=H, n_boot=0)
    assert f.goodness.reduced_chi2 > 1.5
    x, y, sigma = f.points.regressor_per_m, f.points.measured_ohm, f.points.sigma_ohm
    _, pcov = curve_fit(lambda xx, a, b: a + b * xx, x, y, p0=[RS, S * H], sigma=sigma, absolute_sigma=False)
    q = np.array([np.polyfit(x, curve.values_ohm[:, k], 1, w=1 / sigma)[::-1] for k in range(6)])
    se_series = q.std(axis=0, ddof=1) / math.sqrt(6)
    scaled = np.sqrt(np.diag(pcov))
    expected = np.maximum(scaled, se_series)  # per parameter (issue 26 item 12)
    assert np.allclose([f.estimate.R_series_se, f.estimate.scale_se], expected, rtol=1e-5)
    assert f.estimate.chi2_scaled == tuple(bool(b) for b in scaled > se_series)
    if np.all(scaled > se_series) or np.all(scaled <= se_series):
        assert f.estimate.error_rule.startswith("χ²-scaled" if scaled[1] > se_series[1] else "paired-series")


def test_fit_figure_of_tab1_uses_the_fits_series_and_criterion():
    """Fig. fit of Tab. 1: the legend names the fit's criterion (QAIC: ĉ ≈ 3 > 1.5) and the error bars are the SEM of
    the independent series M1–M3 the fit counts (not of all six columns, three of them copies)."""
    from analysis.figures import get_figure
    from analysis.pipeline import analyse_tab1

    a = analyse_tab1(n_boot=0, models=["greenwood_tripp", "hertz"])
    assert a.comparison.criterion == "QAIC"
    top = get_figure("fit_residuals").draw(a).axes[0]
    labels = [t.get_text() for t in top.get_legend().get_texts()]
    assert any("ΔQAIC" in t for t in labels) and not any("ΔAIC" in t for t in labels)
    (bars,) = top.containers[0].lines[2]
    half = np.array([abs(seg[1, 1] - seg[0, 1]) / 2 for seg in bars.get_segments()])
    m13 = load_tab1().values_ohm[:, :3]
    np.testing.assert_allclose(half, 1e3 * m13.std(axis=1, ddof=1) / math.sqrt(3), rtol=1e-9)


def test_tab1_integrity_notes_are_the_series_detectors():
    """One implementation: the report's Tab. 1 notes are the detector's findings and name what the fit counts."""
    from analysis.pipeline import tab1_integrity_notes

    curve = load_tab1()
    notes = tab1_integrity_notes(curve)
    dep = series_dependence(curve)  # the detector with the curve's weights and unit, as the fit calls it
    assert [n.rstrip(".") for n in notes[: len(dep.notes)]] == list(dep.notes)
    assert dep.keep == find_dependence(curve.values_ohm, curve.repeat_labels).keep
    assert "M4, M5, M6 are not independent repeats" in notes[-1] and "3 independent series (M1, M2, M3)" in notes[-1]
