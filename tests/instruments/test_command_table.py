"""A protocol test per declared setting (generated from instruments.commands), and the table pinned to the manual.

For every setting of the 6221 and (relayed) 2182A: the ``*RST`` default reads back, MIN/MAX/DEF are accepted, a
value just outside the range is −222 (a keyword that is not allowed −224) and leaves the setting unchanged, and the
``SOURce``/``SENSe`` root may be left out. The literal limits below are the manual's (reference note), written out
independently of the table so that a wrong declaration fails here.
"""

from __future__ import annotations

import math

import pytest

from instruments.commands import K2182A, K2182A_ACTIONS, K6221, K6221_ACTIONS, Action, Setting
from instruments.simulated import GPIB_ADDRESS, SimulatedBench, simulated_resource_manager


def _raw():
    r = simulated_resource_manager(SimulatedBench()).open_resource(
        GPIB_ADDRESS, read_termination="\n", write_termination="\n"
    )
    r.timeout = 300
    return r


class Relay:
    """Talks to the simulated 2182A through the 6221's serial relay."""

    def __init__(self, r) -> None:
        self.r = r

    def write(self, command: str) -> None:
        self.r.write('SYST:COMM:SER:SEND "' + command.replace('"', '""') + '"')

    def query(self, command: str) -> str:
        self.write(command)
        return self.r.query("SYST:COMM:SER:ENT?").strip()


def _error(r, relay) -> str:
    return (relay.query("SYST:ERR?") if relay else r.query("SYST:ERR?")).strip()


ALL = [(s, False) for s in K6221.values() if not s.header.startswith("*")] + [(s, True) for s in K2182A.values()]


def _numbers_equal(a: str, b: str) -> bool:
    try:
        return math.isclose(float(a), float(b), rel_tol=1e-9)
    except ValueError:
        return a == b


@pytest.mark.parametrize(("s", "relayed"), ALL, ids=[s.header for s, _ in ALL])
def test_setting_protocol(s: Setting, relayed: bool):
    r = _raw()
    dev = Relay(r) if relayed else r
    dev.write("*RST")
    assert _numbers_equal(dev.query(s.header + "?"), s.reply(s.default))
    if s.kind in ("float", "int") and s.low is not None and s.high is not None:
        top = 50.0 if s.header == "SENS:VOLT:NPLC" else s.high  # NPLC: at most 50 on the bench's 50 Hz mains
        for word, value in (("MIN", s.low), ("MAX", top), ("DEF", s.default)):
            dev.write(f"{s.header} {word}")
            assert _numbers_equal(dev.query(s.header + "?"), s.reply(value)), word
        before = dev.query(s.header + "?")
        dev.write(f"{s.header} {s.high + max(abs(s.high), 1.0)}")
        assert _error(r, relayed and dev).startswith("-222")
        assert dev.query(s.header + "?") == before  # an out-of-range value changes nothing
    if s.kind == "keyword":
        dev.write(f"{s.header} NOTAWORD")
        assert _error(r, relayed and dev).startswith("-224")
    if s.kind == "bool":
        dev.write(f"{s.header} ON")
        assert dev.query(s.header + "?") == "1"  # ON/OFF set, 1/0 answered
    root = "SOUR:" if not relayed else "SENS:"
    if s.header.startswith(root) and s.header.count(":") >= 2:
        assert dev.query(s.header[len(root) :] + "?") == dev.query(s.header + "?")  # the root is optional
    assert _error(r, relayed and dev).startswith("0,")


@pytest.mark.parametrize(
    ("header", "low", "high"),
    [
        ("SOUR:DELT:HIGH", -0.105, 0.105),
        ("SOUR:DELT:LOW", -0.105, 0.105),
        ("SOUR:DELT:DEL", 1e-3, 9999.999),
        ("SOUR:DELT:COUN", 1, 65536),
        ("SOUR:CURR:COMP", 0.1, 105.0),
        ("TRAC:POIN", 1, 65536),
        ("SOUR:CURR", -0.105, 0.105),
    ],
)
def test_table_holds_the_manuals_limits(header, low, high):
    assert (K6221[header].low, K6221[header].high) == (low, high)


def test_trace_settings_survive_rst_and_others_do_not():
    r = _raw()
    r.write("TRAC:POIN 10;:TRAC:TST:FORM DELT;:SOUR:DELT:HIGH 0.01;:UNIT OHMS")
    r.write("*RST")  # RM table 6-4, note 1: *RST does not touch the TRACe settings
    assert r.query("TRAC:POIN?;:TRAC:TST:FORM?;:SOUR:DELT:HIGH?;:UNIT?") == "10;DELT;+1.00000000E-03;V"


def test_message_split_on_lf_and_query_interrupted():
    r = _raw()
    r.write("SOUR:DELT:HIGH 0.002\nSOUR:DELT:DEL 0.005")  # an LF inside one write ends a message
    assert r.query("SOUR:DELT:HIGH?;DEL?") == "+2.00000000E-03;+5.00000000E-03"
    r.write("*IDN?")
    r.write("SOUR:DELT:HIGH?")  # the *IDN? reply was never read: discarded, −410
    assert r.read() == "+2.00000000E-03"
    assert r.query("SYST:ERR?") == '-410,"Query INTERRUPTED"'
    assert int(r.query("*ESR?")) & 4  # query error bit


def test_sense_data_idle_is_settings_conflict():
    r = _raw()
    r.write("SENS:DATA?")
    assert r.query("SYST:ERR?").startswith("-221")  # UM 5-41


# ---- kinds added for the manuals' full summaries: text and list settings ------------------------------------------
TEXTS = [(s, r) for s, r in ALL if s.kind == "text"]
LISTS = [(s, r) for s, r in ALL if s.kind == "list"]


@pytest.mark.parametrize(("s", "relayed"), TEXTS, ids=[s.header for s, _ in TEXTS])
def test_text_setting_protocol(s: Setting, relayed: bool):
    r = _raw()
    dev = Relay(r) if relayed else r
    dev.write(f"{s.header} 'AB'")
    assert dev.query(s.header + "?") == '"AB"'
    dev.write(f'{s.header} "{"x" * (s.max_items + 1)}"')  # longer than the instrument holds
    assert _error(r, relayed and dev).startswith("-222")
    dev.write(f"{s.header} AB")  # not a string
    assert _error(r, relayed and dev).startswith("-104")
    assert dev.query(s.header + "?") == '"AB"'


@pytest.mark.parametrize(("s", "relayed"), LISTS, ids=[s.header for s, _ in LISTS])
def test_list_setting_protocol(s: Setting, relayed: bool):
    r = _raw()
    dev = Relay(r) if relayed else r
    dev.write(f"{s.header} {s.low},{s.high}")
    assert [float(x) for x in dev.query(s.header + "?").split(",")] == [s.low, s.high]
    dev.write(f"{s.header} {s.low},{s.high + max(abs(s.high), 1.0)}")
    assert _error(r, relayed and dev).startswith("-222")
    dev.write(f"{s.header} " + ",".join([str(s.low)] * (s.max_items + 1)))
    assert _error(r, relayed and dev).startswith("-222")
    assert len(dev.query(s.header + "?").split(",")) == 2  # refused lists change nothing


# ---- a protocol test per declared action (events and computed queries) --------------------------------------------
ACTIONS = [(a, False) for a in K6221_ACTIONS.values()] + [(a, True) for a in K2182A_ACTIONS.values()]


@pytest.mark.parametrize(("a", "relayed"), ACTIONS, ids=[("2182A " if r else "") + a.header for a, r in ACTIONS])
def test_action_protocol(a: Action, relayed: bool):
    """Every declared command is known on a freshly reset instrument: a query answers (its static reply when it has
    one), an event is taken; the only error is the one the manual gives for an idle instrument."""
    r = _raw()
    dev = Relay(r) if relayed else r
    dev.write("*RST;*CLS")
    text = f"{a.header} {a.example}".strip()
    if a.is_query:
        dev.write(text)
        if relayed:
            reply = dev.r.query("SYST:COMM:SER:ENT?").strip()
        else:
            reply = r.read() if not a.idle_error else None
        if a.reply is not None:
            assert reply == a.reply
        elif not a.idle_error:
            assert reply is not None, a.header  # answered (SYST:COMM:SER:ENT? with nothing relayed: an empty line)
    else:
        dev.write(text)
    err = _error(r, relayed and dev)
    expected = f"{a.idle_error}," if a.idle_error else "0,"
    assert err.startswith(expected), (a.header, err)


def test_the_tables_are_the_whole_command_surface():
    """The simulator refuses to start with a handler that is not declared or a computed query without a handler
    (instruments.simulated._ScpiDevice.bind_actions); every declared header is unique across both tables."""
    from instruments.simulated import SimulatedK6221, _load_definition

    data = _load_definition()
    dev = SimulatedK6221("k6221", data["devices"]["k6221"], data["devices"]["k2182a"], SimulatedBench())
    assert set(K6221_ACTIONS) <= set(dev.handlers)
    assert set(K2182A_ACTIONS) <= set(dev.voltmeter.handlers)
    assert not set(K6221) & set(K6221_ACTIONS) and not set(K2182A) & set(K2182A_ACTIONS)


# ---- the manuals' side effects -------------------------------------------------------------------------------------
def test_source_clear_turns_the_output_off():
    r = _raw()
    r.write("OUTP ON")
    r.write("SOUR:CLE:IMM")  # SOURce:CLEar[:IMMediate]
    assert r.query("OUTP?") == "0"


def test_staircase_sweep_settings_are_coupled_as_the_manual_lists():
    r = _raw()
    r.write("SOUR:SWE:POIN 11;:SOUR:CURR:STAR 1e-3;STOP 2e-3")  # RM 4-22: START/STOP set CENTer, SPAN and STEP
    assert [float(x) for x in r.query("SOUR:CURR:CENT?;SPAN?;STEP?").split(";")] == pytest.approx([1.5e-3, 1e-3, 1e-4])
    r.write("SOUR:CURR:STEP 2.5e-4")  # STEP sets POINts = SPAN/STEP + 1
    assert r.query("SOUR:SWE:POIN?") == "5"
    r.write("SOUR:CURR:CENT 0;SPAN 4e-3")  # CENTer/SPAN set STARt and STOP
    assert [float(x) for x in r.query("SOUR:CURR:STAR?;STOP?").split(";")] == pytest.approx([-2e-3, 2e-3])


def test_list_sweep_append_and_points():
    r = _raw()
    r.write("SOUR:LIST:CURR 1e-3;:SOUR:LIST:CURR:APP 2e-3,3e-3")
    assert r.query("SOUR:LIST:CURR:POIN?") == "3"
    r.write("SOUR:LIST:CURR:APP " + ",".join(["1e-3"] * 98))  # at most 100 points
    assert r.query("SYST:ERR?").startswith("-222") and r.query("SOUR:LIST:CURR:POIN?") == "3"


def test_trace_notify_must_be_below_the_buffer_size():
    r = _raw()
    r.write("TRAC:POIN 100;:TRAC:NOT 99")
    assert r.query("TRAC:NOT?") == "99"
    r.write("TRAC:NOT 100")  # RM 6-17: at most TRAC:POIN − 1, else ignored with −222
    assert r.query("SYST:ERR?").startswith("-222") and r.query("TRAC:NOT?") == "99"


def test_status_register_format_and_error_queue_commands():
    r = _raw()
    r.write("*CLS;:FORM:SREG HEX")
    assert r.query("STAT:OPER:COND?") == "#H400"  # idle: bit 10
    r.write("FORM:SREG BIN")
    assert r.query("STAT:OPER:COND?") == "#B10000000000"
    r.write("NOTACOMMAND;:NOTONE")
    assert r.query("SYST:ERR:COUN?") == "2"
    assert r.query("SYST:ERR:ALL?") == '-113,"Undefined header",-113,"Undefined header"'
    assert r.query("SYST:ERR:CODE:ALL?") == "0"


def test_binary_byte_order_and_reciprocal_math():
    import numpy as np

    from instruments.simulated import SimulatedBench, simulated_resource_manager

    r = simulated_resource_manager(SimulatedBench(seed=2)).open_resource(
        GPIB_ADDRESS, read_termination="\n", write_termination="\n"
    )
    r.timeout = 2000
    r.write("FORM:ELEM READ;:SOUR:DELT:HIGH 1e-3;COUN 4;:SOUR:DELT:ARM;:INIT")
    ascii_ = [float(x) for x in r.query("TRAC:DATA?").split(",")]
    for order, dtype in (("NORM", ">f8"), ("SWAP", "<f8")):
        r.write(f"FORM:DATA DRE;:FORM:BORD {order}")
        r.write("TRAC:DATA?")
        raw = r.read_raw()
        n = int(raw[1:2])
        np.testing.assert_allclose(np.frombuffer(raw[2 + n : -1], dtype=dtype), ascii_, rtol=1e-8)  # ASCII: 9 digits
    r.write("FORM:DATA ASC;:TRAC:FEED CALC1;:CALC1:FORM REC;KMAT:MA1F 2;MA0F 1;:CALC1:STAT ON")
    r.write("SOUR:DELT:ARM;:INIT")
    recip = [float(x) for x in r.query("TRAC:DATA?").split(",")]
    assert all(abs(y - 1) > 1 for y in recip)  # m/X + b with X of a few mV: far from b


def test_2182a_aperture_is_nplc_over_mains_and_rel_math_and_buffer():
    r = _raw()
    v = Relay(r)
    v.write("*RST;:SENS:VOLT:NPLC 1")
    assert float(v.query("SENS:VOLT:APER?")) == pytest.approx(1 / 50)  # the bench's 50 Hz mains
    v.write("SENS:VOLT:APER 0.2")
    assert float(v.query("SENS:VOLT:NPLC?")) == pytest.approx(10.0)
    first = float(v.query("READ?"))
    v.write("SENS:VOLT:REF:ACQ;:SENS:VOLT:REF:STAT ON")
    assert abs(float(v.query("READ?"))) < abs(first) + 1e-6  # rel subtracts the acquired reading
    v.write("SENS:VOLT:REF:STAT OFF;:CALC:KMAT:MMF 2;MBF 1;:CALC:STAT ON")
    assert float(v.query("READ?")) == pytest.approx(1.0, abs=1e-3)  # 2·(µV) + 1
    v.write("CALC:STAT OFF;:TRAC:CLE;:TRAC:POIN 3;:TRAC:FEED:CONT NEXT")
    readings = [float(v.query("READ?")) for _ in range(4)]
    assert v.query("TRAC:POIN:ACT?") == "3"  # full: storage stopped
    assert v.query("TRAC:FEED:CONT?") == "NEV"
    v.write("CALC2:FORM MAX")
    assert float(v.query("CALC2:IMM?")) == pytest.approx(max(readings[:3]))


def test_system_preset_resets_like_rst():
    r = _raw()
    r.write("SOUR:DELT:HIGH 0.01;:SYST:PRES")
    assert r.query("SOUR:DELT:HIGH?") == "+1.00000000E-03"


@pytest.mark.parametrize(
    "message",
    [  # commands PyMeasure's keithley6221.py / keithley2182.py send (cross-check): none is −113 any more
        ":ARM:SOUR TIM;:ARM:TIM 0.5",
        ":ARM:ILIN 2;:TRIG:ILIN 2;",
        ":ARM:SOUR TLIN;:TRIG:SOUR TLIN;",
        ":TRIG:OUTP SOUR;:TRIG:OLIN 3;",
        ":SYST:BEEP 1000, 0.5",
        ":UNIT:VOLT:DC OHMS",
        "*TRG",
    ],
)
def test_commands_other_drivers_send_are_known(message):
    r = _raw()
    r.write(message)
    assert r.query("SYST:ERR?") == '0,"No error"'
