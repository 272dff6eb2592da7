"""Shared validation: messages name field, value and what is allowed; nothing is clamped."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from contactrig.core.validation import SettingError, check_choice, check_int, check_keys, check_range


def test_range_error_names_field_value_and_range():
    with pytest.raises(SettingError) as err:
        check_range("delta.high_a", 0.5, -0.105, 0.105, unit="A")
    msg = str(err.value)
    assert "[delta] high_a" in msg and "0.5" in msg and "[-0.105, 0.105] A" in msg


@given(st.floats(allow_nan=True, allow_infinity=True))
def test_range_accepts_exactly_the_closed_interval(x):
    inside = math.isfinite(x) and -1.0 <= x <= 2.0
    if inside:
        assert check_range("f", x, -1.0, 2.0) == x
    else:
        with pytest.raises(SettingError):
            check_range("f", x, -1.0, 2.0)


def test_open_bounds_and_types():
    with pytest.raises(SettingError):
        check_range("f", 0.0, 0.0, None, lo_open=True)
    with pytest.raises(SettingError):
        check_range("f", "1", 0.0, 2.0)
    with pytest.raises(SettingError):
        check_range("f", True, 0.0, 2.0)


@given(st.integers(min_value=-10, max_value=70000))
def test_int_range(n):
    if 1 <= n <= 65536:
        assert check_int("count", n, 1, 65536) == n
    else:
        with pytest.raises(SettingError, match="count"):
            check_int("count", n, 1, 65536)


def test_int_rejects_fractions_and_bools():
    for bad in (2.5, True, "3"):
        with pytest.raises(SettingError):
            check_int("count", bad, 1, 10)
    assert check_int("count", 3.0, 1, 10) == 3


def test_choice_and_keys():
    assert check_choice("unit", "V", ("V", "OHMS")) == "V"
    with pytest.raises(SettingError, match="'OHMS'"):
        check_choice("unit", "W", ("V", "OHMS"))
    with pytest.raises(SettingError, match=r"\[rig\] radius"):
        check_keys("rig", {"radius": 1}, ("radius_m",))


def test_unit_slips_name_the_scene_key_the_user_typed():
    """A value in the wrong unit is reported on the key the user typed, never on an internal quantity (H, h_min)."""
    from sims.materials import Material
    from sims.surface import SurfaceSpec

    steel = {"E_pa": 210e9, "nu": 0.3, "H_pa": 2e9}
    assert Material.from_table("materials.liner", steel).E_pa == 210e9
    with pytest.raises(SettingError, match=r"^\[materials\.liner\] E_pa = 210000\.0 .*H_pa = 2e\+09 Pa.*in Pa\?"):
        Material.from_table("materials.liner", {**steel, "E_pa": 210e3})  # MPa typed for Pa
    gaussian = {"kind": "gaussian", "n": 512, "pixel_m": 10e-6, "sq_m": 0.4e-6, "correlation_m": 80e-6}
    with pytest.raises(SettingError, match=r"^\[surfaces\.piston\] sq_m = 0\.0004 .*in metres\?"):
        SurfaceSpec.from_table("surfaces.piston", {**gaussian, "sq_m": 0.4e-3})  # 0.4 µm typed in mm
