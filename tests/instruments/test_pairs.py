"""The instrument-pair registry and the one block-statistics function."""

from __future__ import annotations

import math
import statistics

import numpy as np
import pytest

from contactrig.core.validation import SettingError
from instruments.block import block_statistics
from instruments.delta import DeltaSettings
from instruments.pairs import (
    DEFAULT_PAIR,
    InstrumentPair,
    delta_settings_from_table,
    get_pair,
    pair_names,
    register,
    unregister,
)


def test_block_statistics_against_the_statistics_module():
    """Mean, sample SD and SEM over the valid readings, checked against Python's own statistics module."""
    values = np.array([5.0e-3, np.nan, 5.2e-3, 4.9e-3, 5.05e-3, np.inf])
    valid = np.isfinite(values)
    st = block_statistics(values, valid)
    good = [5.0e-3, 5.2e-3, 4.9e-3, 5.05e-3]
    assert st.n == 4 and st.n_invalid == 2
    assert st.mean == pytest.approx(statistics.fmean(good), rel=1e-15)
    assert st.sd == pytest.approx(statistics.stdev(good), rel=1e-12)
    assert st.sem == pytest.approx(statistics.stdev(good) / 2.0, rel=1e-12)


def test_block_statistics_with_too_few_valid_readings():
    one = block_statistics(np.array([2.0, np.nan]), np.array([True, False]))
    assert one.mean == 2.0 and math.isnan(one.sd) and math.isnan(one.sem) and (one.n, one.n_invalid) == (1, 1)
    none = block_statistics(np.array([np.nan]), np.array([False]))
    assert math.isnan(none.mean) and none.n == 0 and none.n_invalid == 1


def test_the_keithley_pair_is_the_default():
    pair = get_pair()
    assert pair.key == DEFAULT_PAIR in pair_names() and pair.settings_table == "delta"
    settings = pair.parse_settings({"high_a": 1e-3, "unit": "OHMS"})
    assert settings == DeltaSettings(high_a=1e-3, unit="OHMS") and pair.reading_unit(settings) == "OHMS"


def test_unknown_pair_names_the_scene_key_and_the_choices():
    with pytest.raises(SettingError) as err:
        get_pair("four_wire_smu")
    assert err.value.field == "instrument.pair"
    assert "[instrument] pair = 'four_wire_smu'" in str(err.value) and repr(DEFAULT_PAIR) in str(err.value)


@pytest.mark.parametrize(
    ("table", "field"),
    [({"high_a": 0.2}, "delta.high_a"), ({"high_a": 1e-3, "bogus": 1}, "delta.bogus"), ({}, "delta.high_a")],
)
def test_delta_table_errors_name_the_delta_key(table, field):
    with pytest.raises(SettingError) as err:
        delta_settings_from_table(table)
    assert err.value.field == field and f"[delta] {field.split('.')[1]}" in str(err.value)


def test_register_refuses_a_taken_key_and_bad_names():
    pair = get_pair()
    with pytest.raises(ValueError, match="registered already"):
        register(pair)
    other = InstrumentPair(**{**pair.__dict__, "key": "copy_of_k6221"})
    try:
        register(other)
        assert get_pair("copy_of_k6221") is other and pair_names()[-1] == "copy_of_k6221"
        register(other, replace=True)
    finally:
        unregister("copy_of_k6221")
    assert "copy_of_k6221" not in pair_names()
    with pytest.raises(ValueError, match="expected a name"):
        register(InstrumentPair(**{**pair.__dict__, "key": "not a name"}))


def test_the_simulated_keithley_pair_identifies_through_the_registry():
    pair = get_pair()
    sim = pair.simulate(resistance_ohm=7e-3, seed=3)
    assert sim.bench.resistance_ohm == 7e-3
    from instruments.transport import VisaTransport

    with pair.open_driver(
        VisaTransport.open("GPIB0::12::INSTR", sim.resource_manager, 2000), clock=lambda: 0.0, sleep=lambda s: None
    ) as driver:
        ident = driver.identify()
        block = driver.run_block(DeltaSettings(high_a=1e-3, count=6, unit="OHMS"))
    assert "6221" in ident.source and "2182A" in ident.voltmeter
    # the block's own summary is block_statistics over its readings, bit for bit
    st = block_statistics(block.readings, block.valid)
    assert (block.mean, block.n) == (st.mean, st.n) and block.mean == pytest.approx(7e-3, rel=1e-3)
