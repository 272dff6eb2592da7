"""Session plan: validated scene tables, unknown keys named, steps as pure data."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contactrig.core.scene import load_scene, parse_scene
from contactrig.core.validation import SettingError
from daq.plan import InstrumentSettings, Measure, PlaceWeight, SessionPlan, SessionSettings, session_steps

from .conftest import SMALL_SCENE, small_scene


def test_default_scene_plan_matches_tab1_layout():
    plan = SessionPlan.from_scene(load_scene(None))
    # Tab. 1: eight weights from 5.44 to 25.966 kg, six repeats M1…M6
    assert plan.session.weights_kg[0] == 5.44 and plan.session.weights_kg[-1] == 25.966
    assert len(plan.session.weights_kg) == 8 and plan.session.repeats == 6
    assert plan.blocks_planned == 48
    assert plan.block_settings.low_a == -plan.block_settings.high_a


@pytest.mark.parametrize("table", ["instrument", "delta", "session"])
def test_unknown_key_is_an_error_naming_it(table):
    text = SMALL_SCENE.replace(f"[{table}]\n", f"[{table}]\nbogus_key = 1\n")
    with pytest.raises(SettingError) as err:
        SessionPlan.from_scene(parse_scene(text))
    assert f"[{table}] bogus_key" in str(err.value)


@pytest.mark.parametrize(
    ("key", "line", "field"),
    [
        ("repeats", "repeats = 0", "session.repeats"),
        ("repeats", "repeats = 2.5", "session.repeats"),
        ("operator", "operator = 3", "session.operator"),
        ("sim_model", 'sim_model = "nonexistent"', "session.sim_model"),
        ("timeout_ms", "timeout_ms = 10", "instrument.timeout_ms"),
        ("address", 'address = "nonsense"', "instrument.address"),
        ("high_a", "high_a = 0.2", "high_a"),
        ("count", "count = 0", "count"),
        ("unit", 'unit = "W"', "unit"),
    ],
)
def test_bad_values_name_field_and_value(key, line, field):
    with pytest.raises(SettingError) as err:
        SessionPlan.from_scene(small_scene(**{key: line}))
    assert err.value.field.endswith(field)
    assert "not allowed" in str(err.value)


def test_delta_errors_are_prefixed_with_the_table():
    with pytest.raises(SettingError) as err:
        SessionPlan.from_scene(small_scene(high_a="high_a = 0.2"))
    assert err.value.field == "delta.high_a"


def test_weights_fall_back_to_rig_and_session_overrides():
    plan = SessionPlan.from_scene(small_scene())
    assert plan.session.weights_kg == (5.44, 10.526, 25.966)
    text = SMALL_SCENE.replace("[session]\n", "[session]\nweights_kg = [1.0, 2.0]\n")
    assert SessionPlan.from_scene(parse_scene(text)).session.weights_kg == (1.0, 2.0)


@pytest.mark.parametrize("weights", ["[]", "[-1.0]", "[0.0]", "[1e9]", '["a"]', "3.0"])
def test_bad_weights(weights):
    text = SMALL_SCENE.replace("[session]\n", f"[session]\nweights_kg = {weights}\n")
    with pytest.raises(SettingError) as err:
        SessionPlan.from_scene(parse_scene(text))
    assert "[session] weights_kg" in str(err.value)


def test_instrument_settings_defaults_are_valid():
    assert InstrumentSettings().address == "GPIB0::12::INSTR"


@settings(max_examples=40, deadline=None)
@given(
    weights=st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=1, max_size=4),
    repeats=st.integers(-5, 2000),
)
def test_session_settings_accept_only_valid(weights, repeats):
    ok = all(0 < w <= 1000 for w in weights) and 1 <= repeats <= 1000
    if ok:
        s = SessionSettings(weights_kg=weights, repeats=repeats)
        assert s.weights_kg == tuple(weights)
    else:
        with pytest.raises(SettingError):
            SessionSettings(weights_kg=weights, repeats=repeats)


def test_steps_prompt_once_per_weight_then_measure_each_repeat():
    plan = SessionPlan.from_scene(small_scene())
    steps = list(session_steps(plan))
    assert [type(s) for s in steps] == [PlaceWeight, Measure, Measure] * 3
    assert [s.block for s in steps if isinstance(s, Measure)] == list(range(6))
    assert [(s.weight_kg, s.repeat) for s in steps if isinstance(s, Measure)][:2] == [(5.44, 1), (5.44, 2)]


def test_steps_skip_done_blocks_for_resume():
    plan = SessionPlan.from_scene(small_scene())
    steps = list(session_steps(plan, {0, 1, 2}))
    # weight 1 is done, weight 2 has repeat 2 left, weight 3 untouched
    assert isinstance(steps[0], PlaceWeight) and steps[0].weight_kg == 10.526 and steps[0].repeats_left == 1
    assert [s.block for s in steps if isinstance(s, Measure)] == [3, 4, 5]


@pytest.mark.parametrize("value", ["-0.1", "1.5", '"0.1"', "nan"])
def test_sim_repeat_sd_is_checked(value):
    text = SMALL_SCENE.replace("[session]\n", f"[session]\nsim_repeat_sd = {value}\n")
    with pytest.raises(SettingError) as err:
        SessionPlan.from_scene(parse_scene(text))
    assert err.value.field == "session.sim_repeat_sd" and "not allowed" in str(err.value)
    text = SMALL_SCENE.replace("[session]\n", "[session]\nsim_repeat_sd = 0.0\n")
    assert SessionPlan.from_scene(parse_scene(text)).session.sim_repeat_sd == 0.0
