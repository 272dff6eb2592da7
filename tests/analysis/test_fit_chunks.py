"""The bootstrap made block by block (analysis/fit.py ``BOOT_CHUNK``): the same result bit for bit whatever the block
size (the same random stream consumed in the same order), each block checked against an independent definition, and
memory that no longer grows with resamples × weights."""

import math
import tracemalloc

import numpy as np
import pytest

from analysis import fit
from analysis.fit import compare_models
from analysis.measured import MeasuredCurve
from contactrig.core.validation import SettingError

W = np.linspace(5.0, 26.0, 40)
H = 5e-3
AREAS = {"a": 1e-7 * (W / W[0]) ** 0.8, "b": 1e-7 * (W / W[0]) ** 0.7, "c": 1e-7 * (W / W[0]) ** 0.9}


def _curve(seed, r=6, bend=0.0, paired=True, m=W.size):
    """Paired series about R_s + s·h/A; ``bend`` a lack of fit common to every series (over-dispersion)."""
    rng = np.random.default_rng(seed)
    w = np.linspace(5.0, 26.0, m)
    truth = 2e-4 + 1e-7 * H / (1e-7 * (w / w[0]) ** 0.8) * (1 + bend * np.sin(w))
    return MeasuredCurve(w, truth[:, None] * (1 + 0.05 * rng.normal(size=(m, r))), paired=paired)


def _run(curve, chunk, monkeypatch, **kw):
    monkeypatch.setattr(fit, "BOOT_CHUNK", chunk)
    return compare_models(curve, AREAS, height_m=H, n_boot=301, seed=3, **kw)


def _same(a, b):
    assert a.as_dict() == b.as_dict()  # every figure, interval, share and statement
    for n in a.fits:
        assert np.array_equal(a.fits[n].boot_params, b.fits[n].boot_params)


@pytest.mark.parametrize(
    ("bend", "kw"),
    [
        (0.0, {}),  # resampled series, χ² ranking from the resamples
        (0.2, {}),  # over-dispersed: wild bootstrap ranking (random signs drawn block by block)
        (0.0, {"bootstrap": "within"}),  # resampled within each weight
        (0.0, {"boot_interval": "percentile", "offset_terms": {n: {"k": 1e-5 * W / W[0]} for n in AREAS}}),
    ],
)
def test_blocks_give_the_unblocked_result_bit_for_bit(bend, kw, monkeypatch):
    curve = _curve(1, r=11, bend=bend)  # 11 series: BLAS would round a 7-row block differently
    whole = _run(curve, 10_000, monkeypatch, **kw)  # one block: everything at once
    assert (whole.criterion == "QAIC") == (bend > 0)  # the branch meant is the branch run
    assert len(whole.first_fraction) >= 2  # a ranking from the resamples is made
    for chunk in (1, 7, 64):
        _same(_run(curve, chunk, monkeypatch, **kw), whole)


def test_blocks_match_independent_definitions():
    curve = _curve(2, r=5)
    v = curve.values_ohm
    res = fit._resample(curve, "series", 50, np.random.default_rng(0), chunk=8)
    ref = np.random.default_rng(0).integers(0, 5, size=(50, 5))  # the draws: one call, as before blocks
    assert np.array_equal(res.cols, ref)
    means = np.vstack([b for _, b in res.blocks()])
    assert np.allclose(means, v[:, ref].mean(axis=2).T, rtol=1e-13, atol=0)  # mean of the series drawn
    x, sigma = H / AREAS["b"], curve.sem_ohm
    design = np.column_stack((np.ones_like(x), x)) / sigma[:, None]
    coef, *_ = np.linalg.lstsq(design, (means / sigma).T, rcond=None)
    chi2 = np.sum(((means / sigma).T - design @ coef) ** 2, axis=0)
    assert np.allclose(fit._refit_chi2(x, means, sigma), chi2, rtol=1e-9, atol=0)
    p = coef.T
    direct = np.sum(((means - p[:, :1] - p[:, 1:] * x) / sigma) ** 2, axis=1)
    assert np.allclose(fit._chi2_rows(means, p, x, sigma, np.zeros_like(x)), direct, rtol=1e-12, atol=0)


def _peak(curve, areas, n_boot):
    tracemalloc.start()
    try:
        ranked = compare_models(curve, areas, height_m=H, n_boot=n_boot, seed=0)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(ranked.first_fraction) == 2  # the ranking ran through the resamples
    return peak


def test_memory_does_not_grow_with_resamples_times_weights():
    curve = _curve(4, m=4000)
    areas = {n: 1e-7 * (curve.weight_kg / 5.0) ** e for n, e in (("a", 0.8), ("b", 0.79))}
    _peak(curve, areas, 10)  # imports and caches out of the way
    grown = _peak(curve, areas, 1000) - _peak(curve, areas, 250)
    assert grown < 0.1 * 750 * 4000 * 8, f"{grown / 1e6:.1f} MB more"  # before: 32.6 MB more, the (B, m) means


def test_each_row_is_computed_on_its_own():
    """The figures behind the ranking (resampled means, χ² of each row) are the same bit for bit in any block: a
    sensitive check, as the ranking's shares themselves rarely move by one rounding."""
    curve = _curve(5, r=11)
    whole = fit._resample(curve, "series", 301, np.random.default_rng(0), chunk=10_000)
    means = next(whole.blocks())[1]
    for chunk in (1, 7, 64):
        part = fit._resample(curve, "series", 301, np.random.default_rng(0), chunk=chunk)
        assert np.array_equal(np.vstack([b for _, b in part.blocks()]), means)
    x, sigma = H / AREAS["a"], curve.sem_ohm
    p = np.random.default_rng(1).normal(size=(301, 2)) * [1e-5, 1e-7] + [2e-4, 1e-7]
    chi2, refit = fit._chi2_rows(means, p, x, sigma, x * 1e-6), fit._refit_chi2(x, means, sigma)
    for rows in (slice(0, 1), slice(3, 10), slice(64, 128), slice(300, 301)):
        assert np.array_equal(fit._chi2_rows(means[rows], p[rows], x, sigma, x * 1e-6), chi2[rows])
        assert np.array_equal(fit._refit_chi2(x, means[rows], sigma), refit[rows])


def test_areas_at_many_weights_in_one_call_match_one_weight_at_a_time():
    """area_at_weights evaluates one PCHIP at every weight at once: the same bits as a call per weight (the former
    loop, written out here with SciPy), exact simulated values where the weights coincide, a bad weight named."""
    from scipy.interpolate import PchipInterpolator

    rng = np.random.default_rng(7)
    ws = np.sort(rng.uniform(2.0, 30.0, 60))
    a = 1e-7 * ws**0.8 * (1 + 0.01 * rng.random(60))
    w = np.concatenate([rng.uniform(ws[0], ws[-1], 500), ws[::7], ws[::9] * (1 + 1e-10)])
    rng.shuffle(w)
    pchip = PchipInterpolator(np.log(ws), np.log(a))
    one_by_one = [
        a[np.flatnonzero(np.abs(ws - x) <= 1e-9 * x)[0]] if np.any(np.abs(ws - x) <= 1e-9 * x)
        else math.exp(float(pchip(math.log(x))))
        for x in w
    ]  # fmt: skip
    assert np.array_equal(fit.area_at_weights(ws, a, w), one_by_one)
    with pytest.raises(SettingError, match="31"):
        fit.area_at_weights(ws, a, np.array([10.0, 31.0, 1.0]))
