"""A protocol test per declared setting (generated from instruments.commands), and the table pinned to the manual.

For every setting of the 6221 and (relayed) 2182A: the ``*RST`` default reads back, MIN/MAX/DEF are accepted, a
value just outside the range is −222 (a keyword that is not allowed −224) and leaves the setting unchanged, and the
``SOURce``/``SENSe`` root may be left out. The literal limits below are the manual's (reference note), written out
independently of the table so that a wrong declaration fails here.
"""

from __future__ import annotations

import math

import pytest

from instruments.commands import K2182A, K6221, Setting
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
