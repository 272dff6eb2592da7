"""The driver's exact command sequences against scripted transports (no simulator involved)."""

from __future__ import annotations

import numpy as np
import pytest

from instruments.delta import DeltaSettings
from instruments.errors import InstrumentError, InstrumentTimeout, NanovoltmeterMissing, ReplyError, SweepAborted
from instruments.k6221 import Keithley6221

from .conftest import READ, ResponderTransport, ScriptedTransport

NO_ERROR = '0,"No error"'
IDN_6221 = "KEITHLEY INSTRUMENTS INC.,MODEL 6221,4321987,D03  /700x"
IDN_2182 = "KEITHLEY INSTRUMENTS INC.,MODEL 2182A,1234567,C02  /A02"


def head(count=3):
    """Everything up to and including INIT:IMM for DeltaSettings(high_a=1e-3, count=count) with defaults."""
    return [
        ("SOUR:DELT:NVPR?", "1"),
        ("SOUR:SWE:ABOR", None),
        ("SYST:ERR?", NO_ERROR),
        ('SYST:COMM:SER:SEND ":SENS:VOLT:NPLC 1"', None),
        ('SYST:COMM:SER:SEND ":SENS:VOLT:RANG:AUTO ON"', None),
        ('SYST:COMM:SER:SEND ":SENS:VOLT:NPLC?"', None),
        ("SYST:COMM:SER:ENT?", "+1.000000E+00\r"),
        ("*OPC?", "1"),
        ("SOUR:CURR:RANG:AUTO ON", None),
        ("SOUR:CURR:COMP 10", None),
        ("SOUR:DELT:HIGH 0.001", None),
        ("SOUR:DELT:LOW -0.001", None),
        ("SOUR:DELT:DEL 0.002", None),
        (f"SOUR:DELT:COUN {count}", None),
        ("SOUR:DELT:CAB ON", None),
        ("SOUR:SWE:COUN 1", None),
        ("UNIT V", None),
        ("TRAC:CLE", None),
        (f"TRAC:POIN {count}", None),
        ("FORM:ELEM READ,TST", None),
        ("SYST:ERR?", NO_ERROR),
        ("SOUR:DELT:ARM", None),
        ("SOUR:DELT:ARM?", "0"),
        ("SOUR:DELT:ARM?", "1"),
        ("STAT:OPER:EVEN?", "0"),
        ("INIT:IMM", None),
    ]


@pytest.mark.filterwarnings("ignore::instruments.errors.InvalidReadingsWarning")  # expected: overflow injected
def test_delta_block_exact_sequence(clock):
    script = [
        *head(3),
        ("STAT:OPER:EVEN?", "8"),  # sweeping
        ("STAT:OPER:EVEN?", "1026"),  # done + idle
        ("TRAC:POIN:ACT?", "3"),
        ("TRAC:DATA:SEL? 0,2", "+1.000000E-06,+0.000000E+00,+1.100000E-06,+2.300000E-02"),
        ("TRAC:DATA:SEL? 2,1", "+9.900000E+37,+4.600000E-02"),
        ("SYST:ERR?", NO_ERROR),
        ("SOUR:SWE:ABOR", None),
    ]
    t = ScriptedTransport(script)
    k = Keithley6221(t, clock=clock, sleep=clock.sleep, chunk_size=2)
    block = k.run_delta(DeltaSettings(high_a=1e-3, count=3))
    assert t.pairs == []
    np.testing.assert_array_equal(block.readings, [1e-6, 1.1e-6, np.nan])
    np.testing.assert_array_equal(block.timestamps_s, [0.0, 0.023, 0.046])
    assert block.n_invalid == 1 and block.n == 2 and block.unit == "V"
    assert block.mean == pytest.approx(1.05e-6)
    assert len(clock.sleeps) == 2  # one after ARM? 0, one after the "sweeping" poll; no blind sleeps


def test_fixed_ranges_ohms_and_single_read(clock):
    s = DeltaSettings(
        high_a=2e-3,
        low_a=-1e-3,
        count=2,
        current_range_a=2e-3,
        voltmeter_range_v=0.1,
        unit="OHMS",
        compliance_abort=False,
        nplc=5,
    )
    script = [
        ("SOUR:DELT:NVPR?", "1"),
        ("SOUR:SWE:ABOR", None),
        ("SYST:ERR?", NO_ERROR),
        ('SYST:COMM:SER:SEND ":SENS:VOLT:NPLC 5"', None),
        ('SYST:COMM:SER:SEND ":SENS:VOLT:RANG 0.1"', None),
        ('SYST:COMM:SER:SEND ":SENS:VOLT:NPLC?"', None),
        ("SYST:COMM:SER:ENT?", "+5.000000E+00\r"),
        ("*OPC?", "1"),
        ("SOUR:CURR:RANG 0.002", None),
        ("SOUR:CURR:COMP 10", None),
        ("SOUR:DELT:HIGH 0.002", None),
        ("SOUR:DELT:LOW -0.001", None),
        ("SOUR:DELT:DEL 0.002", None),
        ("SOUR:DELT:COUN 2", None),
        ("SOUR:DELT:CAB OFF", None),
        ("SOUR:SWE:COUN 1", None),
        ("UNIT OHMS", None),
        ("TRAC:CLE", None),
        ("TRAC:POIN 2", None),
        ("FORM:ELEM READ,TST", None),
        ("SYST:ERR?", NO_ERROR),
        ("SOUR:DELT:ARM", None),
        ("SOUR:DELT:ARM?", "1"),
        ("STAT:OPER:EVEN?", "0"),
        ("INIT:IMM", None),
        ("STAT:OPER:EVEN?", "2"),
        ("TRAC:POIN:ACT?", "2"),
        ("TRAC:DATA:SEL? 0,2", "5.0E-03,0,5.1E-03,0.1"),
        ("SYST:ERR?", NO_ERROR),
        ("SOUR:SWE:ABOR", None),
    ]
    t = ScriptedTransport(script)
    block = Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(s)
    assert t.pairs == []
    np.testing.assert_allclose(block.resistance_ohm(), [5.0e-3, 5.1e-3])


def test_missing_nanovoltmeter_names_both_cables(clock):
    t = ScriptedTransport([("SOUR:DELT:NVPR?", "0"), ("SOUR:SWE:ABOR", None)])
    with pytest.raises(NanovoltmeterMissing) as err:
        Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(DeltaSettings(high_a=1e-3))
    assert "RS-232" in str(err.value) and "Trigger Link" in str(err.value)
    assert t.pairs == []


def test_configuration_error_stops_before_arming_and_aborts(clock):
    script = [
        *head(3)[:20],
        ("SYST:ERR?", '-222,"Data out of range"'),
        ("SYST:ERR?", '-113,"Undefined header"'),
        ("SYST:ERR?", NO_ERROR),
        ("SOUR:SWE:ABOR", None),
    ]
    t = ScriptedTransport(script)
    with pytest.raises(InstrumentError) as err:
        Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(DeltaSettings(high_a=1e-3, count=3))
    assert err.value.code == -222 and err.value.message == "Data out of range"
    assert err.value.others == ((-113, "Undefined header"),)
    assert t.pairs == [] and "SOUR:DELT:ARM" not in t.sent


def test_keyboard_interrupt_while_waiting_aborts_and_propagates(clock):
    states = iter(["8"] * 100)
    t = ResponderTransport(
        {
            "SOUR:DELT:NVPR?": "1",
            "SYST:ERR?": NO_ERROR,
            "SOUR:DELT:ARM?": "1",
            "STAT:OPER:EVEN?": lambda: next(states),
        }
    )

    def interrupt(n_sleeps):
        if n_sleeps == 3:
            raise KeyboardInterrupt

    clock.on_sleep = interrupt
    with pytest.raises(KeyboardInterrupt):
        with Keithley6221(t, clock=clock, sleep=clock.sleep) as k:
            k.run_delta(DeltaSettings(high_a=1e-3, count=100))
    assert "INIT:IMM" in t.sent
    assert t.sent[-2:] == ["SOUR:SWE:ABOR", "SOUR:SWE:ABOR"]  # finally, then the context manager
    assert t.closed


def test_keyboard_interrupt_inside_transport_aborts(clock):
    class Interrupting(ResponderTransport):
        def query(self, message):
            if message == "TRAC:POIN:ACT?":
                self.sent.append(message)
                raise KeyboardInterrupt
            return super().query(message)

    t = Interrupting({"SOUR:DELT:NVPR?": "1", "SYST:ERR?": NO_ERROR, "SOUR:DELT:ARM?": "1", "STAT:OPER:EVEN?": "2"})
    with pytest.raises(KeyboardInterrupt):
        Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(DeltaSettings(high_a=1e-3, count=5))
    assert t.sent[-1] == "SOUR:SWE:ABOR"


def test_completion_deadline_names_the_command(clock):
    t = ResponderTransport(
        {
            "SOUR:DELT:NVPR?": "1",
            "SYST:ERR?": NO_ERROR,
            "SOUR:DELT:ARM?": "1",
            "STAT:OPER:EVEN?": "8",
            "TRAC:POIN:ACT?": "4",
        }
    )
    s = DeltaSettings(high_a=1e-3, count=10)
    with pytest.raises(InstrumentTimeout) as err:
        Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(s)
    assert err.value.command == "STAT:OPER:EVEN?" and "4 of 10" in str(err.value)
    assert clock.t >= s.deadline_s()
    assert t.sent[-1] == "SOUR:SWE:ABOR"


def test_arm_deadline(clock):
    t = ResponderTransport({"SOUR:DELT:NVPR?": "1", "SYST:ERR?": NO_ERROR, "SOUR:DELT:ARM?": "0"})
    with pytest.raises(InstrumentTimeout) as err:
        Keithley6221(t, clock=clock, sleep=clock.sleep, arm_timeout_s=2.0).run_delta(DeltaSettings(high_a=1e-3))
    assert err.value.command == "SOUR:DELT:ARM?"
    assert 2.0 <= clock.t < 2.5
    assert t.sent[-1] == "SOUR:SWE:ABOR" and "INIT:IMM" not in t.sent


def test_aborted_sweep_reports_compliance(clock):
    t = ResponderTransport(
        {
            "SOUR:DELT:NVPR?": "1",
            "SYST:ERR?": NO_ERROR,
            "SOUR:DELT:ARM?": "1",
            "STAT:OPER:EVEN?": "4",
            "TRAC:POIN:ACT?": "0",
            "STAT:MEAS:EVEN?": "8",
        }
    )
    with pytest.raises(SweepAborted, match="compliance"):
        Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(DeltaSettings(high_a=1e-3))
    assert t.sent[-1] == "SOUR:SWE:ABOR"


def test_garbage_buffer_reply(clock):
    t = ResponderTransport(
        {
            "SOUR:DELT:NVPR?": "1",
            "SYST:ERR?": NO_ERROR,
            "SOUR:DELT:ARM?": "1",
            "STAT:OPER:EVEN?": "2",
            "TRAC:POIN:ACT?": "2",
            "TRAC:DATA:SEL? 0,2": "1.0E-6,0,#%!",
        }
    )
    with pytest.raises(ReplyError, match="TRAC:DATA:SEL"):
        Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(DeltaSettings(high_a=1e-3, count=2))
    assert t.sent[-1] == "SOUR:SWE:ABOR"


def test_identify_relay_retries_strips_xoff_and_stray_terminator(clock):
    script = [
        ("*IDN?", IDN_6221),
        ("SOUR:DELT:NVPR?", "1"),
        ('SYST:COMM:SER:SEND "*IDN?"', None),
        ("SYST:COMM:SER:ENT?", ""),  # nothing yet
        ("SYST:COMM:SER:ENT?", "\x13\x13KEITHLEY INSTRUMENTS INC.,MODEL 2182A,"),  # partial, XOFF in front
        ("SYST:COMM:SER:ENT?", "1234567,C02  /A02"),  # rest; the 2182A's LF was eaten as the VISA terminator
        ("*OPC?", ""),  # ...so a stray empty line comes first
        (READ, "1"),
    ]
    t = ScriptedTransport(script)
    ident = Keithley6221(t, clock=clock, sleep=clock.sleep).identify()
    assert ident.voltmeter == IDN_2182 and ident.source == IDN_6221
    assert t.pairs == []


def test_relay_line_ended_by_cr_and_quotes_doubled(clock):
    script = [
        ('SYST:COMM:SER:SEND "SENS:FUNC ""VOLT"";:SENS:VOLT:NPLC?"', None),
        ("SYST:COMM:SER:ENT?", "+5.000000E+00\r"),
        ("*OPC?", "1"),
    ]
    t = ScriptedTransport(script)
    assert (
        Keithley6221(t, clock=clock, sleep=clock.sleep).relay_query('SENS:FUNC "VOLT";:SENS:VOLT:NPLC?')
        == "+5.000000E+00"
    )


def test_relay_skips_leading_stray_terminator(clock):
    script = [
        ('SYST:COMM:SER:SEND "*IDN?"', None),
        ("SYST:COMM:SER:ENT?", "\r"),
        ("SYST:COMM:SER:ENT?", IDN_2182 + "\r"),
        ("*OPC?", "1"),
    ]
    t = ScriptedTransport(script)
    assert Keithley6221(t, clock=clock, sleep=clock.sleep).relay_query("*IDN?") == IDN_2182


def test_voltmeter_setting_readback_mismatch(clock):
    script = [
        *head(3)[:5],
        ('SYST:COMM:SER:SEND ":SENS:VOLT:NPLC?"', None),
        ("SYST:COMM:SER:ENT?", "+2.000000E+00\r"),
        ("*OPC?", "1"),
        ("SOUR:SWE:ABOR", None),
    ]
    t = ScriptedTransport(script)
    with pytest.raises(ReplyError, match="NPLC"):
        Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(DeltaSettings(high_a=1e-3, count=3))
    assert t.pairs == []


def test_relay_timeout_names_relayed_command(clock):
    t = ResponderTransport({"SYST:COMM:SER:ENT?": "", "*OPC?": "1"})
    with pytest.raises(InstrumentTimeout, match="relaying"):
        Keithley6221(t, clock=clock, sleep=clock.sleep, relay_timeout_s=1.0).relay_query("*IDN?")
