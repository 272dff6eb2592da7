"""Measured curves from a session summary, from Tab. 1 and from arrays."""

import numpy as np
import pandas as pd
import pytest

from analysis.measured import MeasuredCurve, load_tab1
from contactrig.core.validation import SettingError


def _summary():
    rows = []
    for w in (5.0, 10.0, 15.0):
        for rep in (0, 1, 2):
            rows.append(
                {"weight_kg": w, "repeat": rep, "mean_ohm": 1e-3 * (20 - w) + 1e-5 * rep, "sd_ohm": 1e-6,
                 "sem_ohm": 1e-7, "n": 100, "n_invalid": 0}
            )  # fmt: skip
    return pd.DataFrame(rows).sample(frac=1.0, random_state=1)  # order must not matter


def test_from_summary_pivots_weights_by_repeats():
    c = MeasuredCurve.from_summary(_summary())
    assert c.weight_kg.tolist() == [5.0, 10.0, 15.0]
    assert c.values_ohm.shape == (3, 3)
    assert c.values_ohm[1, 2] == pytest.approx(1e-2 + 2e-5)
    assert np.all(c.block_sem_ohm == 1e-7)
    assert c.paired
    assert c.mean_ohm[0] == pytest.approx(1.5e-2 + 1e-5)
    assert c.sd_ohm[0] == pytest.approx(1e-5)


def test_missing_repeat_is_nan_and_unpairs():
    s = _summary()
    s = s[~((s.weight_kg == 10.0) & (s.repeat == 1))]
    c = MeasuredCurve.from_summary(s)
    assert np.isnan(c.values_ohm[1, 1])
    assert c.n.tolist() == [3, 2, 3]
    assert not c.paired


def test_duplicate_block_is_an_error():
    s = pd.concat([_summary(), _summary().iloc[:1]])
    with pytest.raises(SettingError, match="duplicate"):
        MeasuredCurve.from_summary(s)


def test_non_positive_resistance_is_an_error():
    with pytest.raises(SettingError, match="values_ohm"):
        MeasuredCurve([1.0, 2.0], [[1.0, -1.0], [1.0, 1.0]])
    with pytest.raises(SettingError, match="weight_kg"):
        MeasuredCurve([2.0, 1.0], [[1.0], [1.0]])


def test_tab1_ships_in_milliohm_and_matches_the_paper_average():
    try:
        c = load_tab1()
    except FileNotFoundError:
        pytest.skip("daq/data/tab1.csv not installed yet")
    assert c.values_ohm.shape == (8, 6)
    assert c.weight_kg[0] == 5.44 and c.weight_kg[-1] == 25.966
    # the paper's Avg column, to its four decimals (mΩ); the first row's printed 8.0913 rounds 8.09125
    avg_paper = np.array([8.0913, 7.5237, 5.9488, 4.7583, 3.9734, 3.4037, 2.2916, 1.8456])
    assert np.allclose(c.mean_ohm * 1e3, avg_paper, atol=0.6e-4)
