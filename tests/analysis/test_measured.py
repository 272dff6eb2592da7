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


# ---- tables: read by daq.table_import.read_table, the one table reader -------------------------------------------
def test_tab1_curve_and_import_read_the_same_values():
    from daq.table_import import read_table, tab1_path

    c, t = load_tab1(), read_table(tab1_path(), "mohm")
    np.testing.assert_array_equal(c.values_ohm, t.resistance_ohm)
    np.testing.assert_array_equal(c.weight_kg, t.weight_kg)
    assert c.repeat_labels == t.columns and c.paired and c.source == "seed paper Tab. 1"
    assert c.provenance["table"]["unit"] == "mohm"


def test_from_table_sorts_by_weight_and_keeps_series():
    from daq.table_import import parse_table

    c = MeasuredCurve.from_table(parse_table("weight_kg,M1,M2\n10,5,6\n5,7,8\n", "mohm", source="x.csv"))
    assert c.weight_kg.tolist() == [5.0, 10.0] and c.source == "x.csv"
    np.testing.assert_allclose(c.values_ohm * 1e3, [[7, 8], [5, 6]], rtol=1e-12)
    assert c.paired and c.repeat_labels == ("M1", "M2")


def test_load_table_spreadsheet_export_with_missing_repeat_is_unpaired(tmp_path):
    from analysis.measured import load_table

    p = tmp_path / "t.csv"
    p.write_text("weight [kg];M1 [mΩ];M2 [mΩ]\n5,44;7,1;8,2\n7,44;6,5;\n", encoding="utf-8")
    c = load_table(p, allow_missing=True)
    assert c.n.tolist() == [2, 1] and not c.paired
    with pytest.raises(SettingError, match="row 3, column 'M2"):
        load_table(p)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("weight_kg,M1,Avg\n5,7,7\n", "looks like an average"),  # Tab. 1's printed Avg column is not a series
        ("weight_kg,M1\n5,7\n5,8\n", "one row per weight"),
        ("weight_kg,M1\n5,7000\n", "is the unit right"),
        ("weight_kg,M1,M1\n5,7,7\n", "unique column name"),
        ("weight_kg,M1\n5,\n", "empty cell"),
    ],
)
def test_load_tab1_from_a_path_uses_the_same_rules_as_import(tmp_path, text, message):
    p = tmp_path / "t.csv"
    p.write_text(text)
    with pytest.raises(SettingError, match=message) as info:
        load_tab1(p)
    assert str(p) in str(info.value)


def test_any_valid_table_makes_a_curve():
    """Whatever the reader accepts, MeasuredCurve accepts (its checks are no stricter than the reader's)."""
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from daq.table_import import parse_table

    @settings(max_examples=200, deadline=None)
    @given(
        st.lists(st.floats(0, 10_000), min_size=1, max_size=5, unique=True),
        st.integers(1, 3),
        st.data(),
    )
    def check(weights, k, data):
        rows = []
        for w in weights:
            cells = [data.draw(st.one_of(st.just(""), st.floats(1e-5, 1e3).map(repr))) for _ in range(k)]
            if not any(cells):
                cells[0] = "1"
            rows.append(",".join([repr(w), *cells]))
        text = "weight_kg," + ",".join(f"M{i}" for i in range(k)) + "\n" + "\n".join(rows)
        c = MeasuredCurve.from_table(parse_table(text, "mohm", allow_missing=True))
        assert c.weight_kg.size == len(weights) and np.all(np.diff(c.weight_kg) > 0)

    check()


def test_post_init_checks_shapes_labels_and_sem():
    with pytest.raises(SettingError, match="values_ohm"):
        MeasuredCurve([1.0, 2.0], [[1.0, 1.0]])
    with pytest.raises(SettingError, match="repeat_labels"):
        MeasuredCurve([1.0], [[1.0, 1.0]], repeat_labels=("a",))
    with pytest.raises(SettingError, match="block_sem_ohm"):
        MeasuredCurve([1.0], [[1.0, 1.0]], block_sem_ohm=[[1.0]])
    with pytest.raises(SettingError, match="no valid repeat at 2 kg"):
        MeasuredCurve([1.0, 2.0], [[1.0], [np.nan]])
    c = MeasuredCurve([1.0, 2.0], [1.0, 2.0])
    assert c.values_ohm.shape == (2, 1) and c.repeat_labels == ("1",) and not c.values_ohm.flags.writeable


def test_consecutive_blocks_of_one_weight_and_repeat_are_one_seating():
    """An adaptive session's repeat at the present seating (same weight and repeat as the block before): one repeat,
    the mean of the blocks' means, SEM √(Σ sem²)/n; a block in compliance (NaN) among them counts for nothing."""
    s = pd.DataFrame(
        {
            "weight_kg": [5.0, 5.0, 5.0, 5.0, 10.0, 10.0],
            "repeat": [1, 2, 2, 2, 1, 2],
            "mean_ohm": [1.0, 2.0, 4.0, np.nan, 0.5, 0.7],
            "sem_ohm": [0.1, 0.3, 0.4, np.nan, 0.1, 0.1],
        }
    )
    c = MeasuredCurve.from_summary(s, seatings=True)
    assert c.values_ohm.tolist() == [[1.0, 3.0], [0.5, 0.7]]
    assert c.block_sem_ohm[0, 1] == pytest.approx(0.5 / 2)
    assert c.n.tolist() == [2, 2]


def test_consecutive_duplicates_outside_an_adaptive_session_are_still_an_error():
    """A fixed plan or an imported table never repeats (weight, repeat) on purpose: two such rows, consecutive or
    not, are a mix-up and refused, never averaged into one repeat."""
    s = _summary()
    s = pd.concat([s.iloc[:1], s.iloc[:1], s.iloc[1:]])  # the first block twice in a row
    with pytest.raises(SettingError, match="duplicate"):
        MeasuredCurve.from_summary(s)
