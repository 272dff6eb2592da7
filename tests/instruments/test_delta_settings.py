"""DeltaSettings validation (property-based), the Delta formula, buffer parsing and block statistics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contactrig.core.validation import SettingError
from instruments.delta import DeltaBlock, DeltaSettings, delta_readings, parse_buffer

finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=150, deadline=None)
@given(high=st.one_of(finite, st.floats(-0.2, 0.2)))
def test_high_current_accepted_exactly_or_rejected_by_name(high):
    if -0.105 <= high <= 0.105 and high != 0.0:
        s = DeltaSettings(high_a=high)
        assert s.high_a == high and s.low_a == -high  # nothing clamped
    else:
        with pytest.raises(SettingError) as err:
            DeltaSettings(high_a=high)
        # 0 A: high = low = 0, refused as low_a; otherwise high_a itself, its value shown as given
        if high == 0.0:
            assert err.value.field == "low_a" and "must differ from high_a" in str(err.value)
        else:
            assert err.value.field == "high_a" and repr(high) in str(err.value)


@settings(max_examples=150, deadline=None)
@given(count=st.integers(-100, 100_000))
def test_count_range(count):
    if 1 <= count <= 65536:
        assert DeltaSettings(high_a=1e-3, count=count).count == count
    else:
        with pytest.raises(SettingError, match="count"):
            DeltaSettings(high_a=1e-3, count=count)


@settings(max_examples=150, deadline=None)
@given(delay=st.one_of(finite, st.floats(0, 2e-3), st.floats(9999, 10001)))
def test_delay_range(delay):
    if 1e-3 <= delay <= 9999.999:
        assert DeltaSettings(high_a=1e-3, delay_s=delay).delay_s == delay
    else:
        with pytest.raises(SettingError, match="delay_s"):
            DeltaSettings(high_a=1e-3, delay_s=delay)


@settings(max_examples=100, deadline=None)
@given(nplc=st.one_of(finite, st.floats(0, 0.02), st.floats(49, 61)), line=st.sampled_from([50, 60]))
def test_nplc_range_depends_on_line_frequency(nplc, line):
    limit = 50.0 if line == 50 else 60.0
    if 0.01 <= nplc <= limit:
        assert DeltaSettings(high_a=1e-3, nplc=nplc, line_frequency_hz=line).nplc == nplc
    else:
        with pytest.raises(SettingError, match="nplc"):
            DeltaSettings(high_a=1e-3, nplc=nplc, line_frequency_hz=line)


@settings(max_examples=100, deadline=None)
@given(cents=st.integers(-1000, 12000))
def test_compliance_range_in_10_mV_steps(cents):
    v = cents / 100
    if 0.1 <= v <= 105:
        assert DeltaSettings(high_a=1e-3, compliance_v=v).compliance_v == v
    else:
        with pytest.raises(SettingError, match="compliance_v"):
            DeltaSettings(high_a=1e-3, compliance_v=v)


def test_compliance_off_step_rejected():
    with pytest.raises(SettingError, match="10 mV"):
        DeltaSettings(high_a=1e-3, compliance_v=1.005)


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(high_a=1e-3, low_a=1e-3), "low_a"),
        (dict(high_a=1e-3, low_a=0.2), "low_a"),
        (dict(high_a=float("nan")), "high_a"),
        (dict(high_a="1e-3"), "high_a"),
        (dict(high_a=1e-3, count=10.5), "count"),
        (dict(high_a=1e-3, count=True), "count"),
        (dict(high_a=1e-3, unit="W"), "unit"),
        (dict(high_a=1e-3, compliance_abort="yes"), "compliance_abort"),
        (dict(high_a=1e-3, current_range_a=3e-3), "current_range_a"),
        (dict(high_a=3e-3, current_range_a=2e-3), "high_a"),
        (dict(high_a=1e-3, voltmeter_range_v=0.5), "voltmeter_range_v"),
        (dict(high_a=1e-3, line_frequency_hz=55), "line_frequency_hz"),
    ],
)
def test_invalid_settings_name_the_field(kwargs, field):
    with pytest.raises(SettingError) as err:
        DeltaSettings(**kwargs)
    assert err.value.field == field
    assert field in str(err.value)


def test_range_over_range_allowed_and_settings_frozen():
    s = DeltaSettings(high_a=2.1e-3, low_a=0.0, current_range_a=2e-3)  # 5 % over-range
    assert s.delta_current_a == pytest.approx(1.05e-3)
    with pytest.raises(AttributeError):
        s.high_a = 1.0  # type: ignore[misc]


def test_delta_formula_cancels_emf_and_linear_drift():
    # Reference example: 10.01 mV, -9.99 mV, 10.01 mV -> 10 mV (10 µV EMF removed).
    assert delta_readings(np.array([10.01e-3, -9.99e-3, 10.01e-3])) == pytest.approx([10e-3], abs=1e-15)
    # Closed form: V_k = ±I R + E + d·k (alternating, + first) gives Δ = I R exactly for every reading.
    k = np.arange(12)
    ir, emf, drift = 2.5e-6, 7e-5, 3e-7
    v = np.where(k % 2 == 0, ir, -ir) + emf + drift * k
    assert delta_readings(v) == pytest.approx(np.full(10, ir), rel=1e-9)
    assert delta_readings(np.array([1.0, 2.0])).size == 0


def test_parse_buffer_marks_overflow_invalid():
    r, t = parse_buffer("+1.0E-06,+0.0E+00,+9.9E37,+1.0E-01,-9.91E+37,+2.0E-01,1e-6,3e-1")
    assert np.isnan(r[1]) and np.isnan(r[2])
    assert r[0] == 1e-6 and r[3] == 1e-6
    assert t.tolist() == [0.0, 0.1, 0.2, 0.3]
    with pytest.raises(ValueError):
        parse_buffer("1,2,3")
    with pytest.raises(ValueError):
        parse_buffer("1,abc")


def test_block_statistics_ignore_invalid():
    s = DeltaSettings(high_a=2e-3, low_a=0.0, count=4)
    b = DeltaBlock(s, np.array([1.0, np.nan, 3.0, 5.0]), np.arange(4.0), 1, "V")
    assert b.n == 3 and b.mean == 3.0
    assert b.sd == pytest.approx(2.0) and b.sem == pytest.approx(2.0 / math.sqrt(3))
    assert b.resistance_ohm()[0] == pytest.approx(1.0 / 1e-3)
    with pytest.raises(ValueError):
        b.readings[0] = 0.0
    empty = DeltaBlock(s, np.array([np.nan]), np.zeros(1), 1, "V")
    assert math.isnan(empty.mean) and math.isnan(empty.sd)


@pytest.mark.parametrize(("high", "low"), [(2e-3, 0.0), (2e-3, -1e-3), (1e-3, 1e-4)])
def test_ohms_with_asymmetric_currents_is_refused_naming_unit(high, low):
    with pytest.raises(SettingError) as err:
        DeltaSettings(high_a=high, low_a=low, unit="OHMS")
    assert err.value.field == "unit" and err.value.value == "OHMS" and "'V'" in err.value.allowed
    # the same levels in V are fine, and symmetric levels in OHMS too
    assert DeltaSettings(high_a=high, low_a=low, unit="V").unit == "V"
    assert DeltaSettings(high_a=high, low_a=-high, unit="OHMS").unit == "OHMS"
