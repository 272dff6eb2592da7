"""The driver's exact command sequences against scripted transports (no simulator involved)."""

from __future__ import annotations

import numpy as np
import pytest

from instruments.delta import DeltaSettings
from instruments.errors import (
    InstrumentError,
    InstrumentTimeout,
    NanovoltmeterMissing,
    ReplyError,
    SweepAborted,
    SweepStalled,
)
from instruments.k6221 import Keithley6221

from .conftest import (
    READ,
    SOURCE_READBACK,
    SOURCE_STATE_QUERY,
    VOLTMETER_READBACK,
    VOLTMETER_STATE_QUERY,
    ResponderTransport,
    ScriptedTransport,
)

NO_ERROR = '0,"No error"'
IDN_6221 = "KEITHLEY INSTRUMENTS INC.,MODEL 6221,4321987,D03  /700x"
IDN_2182 = "KEITHLEY INSTRUMENTS INC.,MODEL 2182A,1234567,C02  /A02"


START = "SOUR:SWE:ABOR;:SOUR:DELT:NVPR?;:SYST:ERR?"  # stop, 2182A present?, error queue empty?
ARM = "SOUR:DELT:ARM;:SOUR:DELT:ARM?;:STAT:OPER:EVEN?;:STAT:MEAS:EVEN?"
ARM_POLL = "SOUR:DELT:ARM?;:STAT:OPER:EVEN?;:STAT:MEAS:EVEN?"
POLL = "STAT:OPER:EVEN?;:TRAC:POIN:ACT?;:STAT:MEAS:EVEN?"


def voltmeter_setup(nplc="1", rng=":SENS:VOLT:RANG:AUTO ON", readback=VOLTMETER_READBACK):
    """The relayed 2182A part: pinned state, NPLC, range and one compound read-back in one relayed message (its
    first ENT? in the same 6221 message), then *OPC? to resynchronise."""
    relayed = f":SENS:CHAN 1;:SENS:VOLT:DFIL:STAT OFF;:SENS:VOLT:LPAS OFF;:SYST:AZER ON;:SENS:VOLT:NPLC {nplc};{rng}"
    return [
        (f'SYST:COMM:SER:SEND "{relayed};{VOLTMETER_STATE_QUERY}";:SYST:COMM:SER:ENT?', readback + "\r"),
        ("*OPC?", "1"),
    ]


SOURCE_PINS = ["SOUR:DELT:CSW OFF", "SENS:AVER:STAT OFF", "CALC1:STAT OFF", "TRAC:FEED SENS1", "TRAC:TST:FORM ABS"]


def configure(count=3, rng="SOUR:CURR:RANG:AUTO ON", high="0.001", low="-0.001", cab="ON", unit="V"):
    """The one 6221 configuration message: settings, pinned state, buffer, format, read-back, SYST:ERR?."""
    return ";:".join(
        [
            rng,
            "SOUR:CURR:COMP 10",
            f"SOUR:DELT:HIGH {high}",
            f"SOUR:DELT:LOW {low}",
            "SOUR:DELT:DEL 0.002",
            f"SOUR:DELT:COUN {count}",
            f"SOUR:DELT:CAB {cab}",
            "SOUR:SWE:COUN 1",
            f"UNIT {unit}",
            *SOURCE_PINS,
            "TRAC:CLE",
            f"TRAC:POIN {count}",
            "FORM:ELEM READ,TST",
            SOURCE_STATE_QUERY,
            "SYST:ERR?",
        ]
    )


def head(count=3):
    """Everything up to and including INIT:IMM for DeltaSettings(high_a=1e-3, count=count) with defaults."""
    return [
        (START, "1;" + NO_ERROR),
        *voltmeter_setup(),
        (configure(count), SOURCE_READBACK + ";" + NO_ERROR),
        (ARM, "0;0;0"),
        (ARM_POLL, "1;0;8"),  # a compliance bit left latched by an earlier block: read (cleared), not used
        ("INIT:IMM", None),
    ]


@pytest.mark.filterwarnings("ignore::instruments.errors.InvalidReadingsWarning")  # expected: overflow injected
def test_delta_block_exact_sequence(clock):
    script = [
        *head(3),
        (POLL, "8;1;0"),  # sweeping
        (POLL, "1026;3;0"),  # done + idle; no compliance during the block
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
    assert block.n_invalid == 1 and block.n == 2 and block.unit == "V" and not block.compliance
    assert block.mean == pytest.approx(1.05e-6)
    assert len(clock.sleeps) == 2  # one after ARM? 0, one after the "sweeping" poll; no blind sleeps


def test_fixed_ranges_ohms_and_single_read(clock):
    s = DeltaSettings(
        high_a=2e-3,
        low_a=-2e-3,
        count=2,
        current_range_a=2e-3,
        voltmeter_range_v=0.1,
        unit="OHMS",
        compliance_abort=False,
        nplc=5,
    )
    script = [
        (START, "1;" + NO_ERROR),
        *voltmeter_setup("5", ":SENS:VOLT:RANG 0.1", "+5.000000E+00;1;0;0;1"),
        # a 6221 that answers the keyword without its suffix (SENS for SENS1)
        (configure(2, "SOUR:CURR:RANG 0.002", "0.002", "-0.002", "OFF", "OHMS"), "0;0;0;SENS;ABS;" + NO_ERROR),
        (ARM, "1;0;0"),
        ("INIT:IMM", None),
        (POLL, "2;2;0"),
        ("TRAC:DATA:SEL? 0,2", "5.0E-03,0,5.1E-03,0.1"),
        ("SYST:ERR?", NO_ERROR),
        ("SOUR:SWE:ABOR", None),
    ]
    t = ScriptedTransport(script)
    block = Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(s)
    assert t.pairs == []
    np.testing.assert_allclose(block.resistance_ohm(), [5.0e-3, 5.1e-3])


def test_missing_nanovoltmeter_names_both_cables(clock):
    t = ScriptedTransport([(START, "0;" + NO_ERROR), ("SOUR:SWE:ABOR", None)])
    with pytest.raises(NanovoltmeterMissing) as err:
        Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(DeltaSettings(high_a=1e-3))
    assert "RS-232" in str(err.value) and "Trigger Link" in str(err.value)
    assert t.pairs == []


def test_configuration_error_stops_before_arming_and_aborts(clock):
    script = [
        *head(3)[:3],
        (configure(3), SOURCE_READBACK + ';-222,"Data out of range"'),
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
            "TRAC:POIN:ACT?": "0",
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
            if "TRAC:POIN:ACT?" in message:  # the completion poll
                self.sent.append(message)
                raise KeyboardInterrupt
            return super().query(message)

    t = Interrupting({"SOUR:DELT:NVPR?": "1", "SYST:ERR?": NO_ERROR, "SOUR:DELT:ARM?": "1", "STAT:OPER:EVEN?": "2"})
    with pytest.raises(KeyboardInterrupt):
        Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(DeltaSettings(high_a=1e-3, count=5))
    assert t.sent[-1] == "SOUR:SWE:ABOR"


def test_stalled_sweep_is_a_clear_error_after_the_stall_window(clock):
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
    k = Keithley6221(t, clock=clock, sleep=clock.sleep, stall_timeout_s=5.0)
    with pytest.raises(SweepStalled) as err:
        k.run_delta(s)
    assert isinstance(err.value, InstrumentTimeout) and isinstance(err.value, InstrumentError)
    assert err.value.command == "TRAC:POIN:ACT?" and "4 of 10" in str(err.value) and "stalled" in str(err.value)
    # 4 readings came at once, then none: stalled one window (2 conversions + 5 s) after the progress was seen
    window = 2 * s.conversion_period_s + 5.0
    assert window < clock.t <= window + 0.1
    assert t.sent[-1] == "SOUR:SWE:ABOR" and k.source_state == "idle"
    assert any("left idle" in note for note in err.value.__notes__)


def test_deadline_follows_progress_long_block_does_not_time_out(clock):
    """10 000 readings arriving at 1 per 0.5 s of (fake) time take 5000 s: far beyond any fixed deadline computed
    from the nominal conversion period (22 ms here), and never stalled, since the count keeps growing."""
    s = DeltaSettings(high_a=1e-3, count=10_000)
    slow = 0.5  # s per reading, 20× the nominal period

    def stored():
        return str(min(int(clock.t / slow), s.count))

    def oper():
        return "2" if int(stored()) >= s.count else "8"

    t = ResponderTransport(
        {
            "SOUR:DELT:NVPR?": "1",
            "SYST:ERR?": NO_ERROR,
            "SOUR:DELT:ARM?": "1",
            "STAT:OPER:EVEN?": oper,
            "TRAC:POIN:ACT?": stored,
            "TRAC:DATA:SEL? 0,10000": ",".join(["1.0E-06,0"] * 10_000),
        }
    )
    k = Keithley6221(t, clock=clock, sleep=clock.sleep, poll_interval_s=5.0, stall_timeout_s=1.0, chunk_size=10_000)
    block = k.run_delta(s)
    assert block.n == 10_000 and clock.t >= 5000 > 10 * s.deadline_s()


def test_arm_deadline(clock):
    t = ResponderTransport(
        {"SOUR:DELT:NVPR?": "1", "SYST:ERR?": NO_ERROR, "SOUR:DELT:ARM?": "0", "STAT:OPER:EVEN?": "0"}
    )
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
        ('SYST:COMM:SER:SEND "*IDN?";:SYST:COMM:SER:ENT?', ""),  # nothing yet
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
        ('SYST:COMM:SER:SEND "SENS:FUNC ""VOLT"";:SENS:VOLT:NPLC?";:SYST:COMM:SER:ENT?', "+5.000000E+00\r"),
        ("*OPC?", "1"),
    ]
    t = ScriptedTransport(script)
    assert (
        Keithley6221(t, clock=clock, sleep=clock.sleep).relay_query('SENS:FUNC "VOLT";:SENS:VOLT:NPLC?')
        == "+5.000000E+00"
    )


def test_relay_skips_leading_stray_terminator(clock):
    script = [
        ('SYST:COMM:SER:SEND "*IDN?";:SYST:COMM:SER:ENT?', "\r"),
        ("SYST:COMM:SER:ENT?", IDN_2182 + "\r"),
        ("*OPC?", "1"),
    ]
    t = ScriptedTransport(script)
    assert Keithley6221(t, clock=clock, sleep=clock.sleep).relay_query("*IDN?") == IDN_2182


def test_voltmeter_setting_readback_mismatch(clock):
    setup = voltmeter_setup(readback="+2.000000E+00;1;0;0;1")
    script = [*head(3)[:1], *setup, ("SOUR:SWE:ABOR", None)]
    t = ScriptedTransport(script)
    with pytest.raises(ReplyError, match="NPLC"):
        Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(DeltaSettings(high_a=1e-3, count=3))
    assert t.pairs == []


@pytest.mark.parametrize(
    ("who", "readback", "name"),
    [
        ("2182A", "+1.000000E+00;1;1;0;1", "DFIL"),  # the digital filter stayed on
        ("2182A", "+1.000000E+00;2;0;0;1", "CHAN"),
        ("6221", "0;1;0;SENS1;ABS", "SENS:AVER"),  # the 6221's filter stayed on
        ("6221", "0;0;0;CALC1;ABS", "TRAC:FEED"),
        ("6221", "0;0;0;SENS1;DELT", "TRAC:TST:FORM"),
    ],
)
def test_pinned_state_that_did_not_take_stops_before_arming(clock, who, readback, name):
    replies = {"SOUR:DELT:NVPR?": "1", "SYST:ERR?": NO_ERROR, "SOUR:DELT:ARM?": "1"}
    if who == "2182A":
        replies["SYST:COMM:SER:ENT?"] = readback + "\r"
    else:
        replies[SOURCE_STATE_QUERY] = readback
    t = ResponderTransport(replies)
    with pytest.raises(ReplyError, match=name):
        Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(DeltaSettings(high_a=1e-3, count=3))
    assert "SOUR:DELT:ARM" not in t.sent and t.sent[-1] == "SOUR:SWE:ABOR"


def test_compliance_bit_after_the_sweep_flags_the_block(clock):
    meas = iter(["8", "8"])  # stale bit before INIT (cleared by reading), and set again during this block
    t = ResponderTransport(
        {
            "SOUR:DELT:NVPR?": "1",
            "SYST:ERR?": NO_ERROR,
            "SOUR:DELT:ARM?": "1",
            "STAT:OPER:EVEN?": "2",
            "TRAC:POIN:ACT?": "2",
            "STAT:MEAS:EVEN?": lambda: next(meas),
            "TRAC:DATA:SEL? 0,2": "1.0E+00,0,1.0E+00,0.1",
        }
    )
    from instruments.errors import ComplianceWarning

    with pytest.warns(ComplianceWarning, match="compliance"):
        block = Keithley6221(t, clock=clock, sleep=clock.sleep).run_delta(
            DeltaSettings(high_a=1e-3, count=2, compliance_abort=False)
        )
    assert block.compliance and block.n == 0 and not block.valid.any() and np.isnan(block.mean)
    assert t.sent.index("STAT:MEAS:EVEN?") < t.sent.index("INIT:IMM")  # cleared before INIT
    assert t.sent.count("STAT:MEAS:EVEN?") == 2


def test_relay_timeout_names_relayed_command(clock):
    t = ResponderTransport({"SYST:COMM:SER:ENT?": "", "*OPC?": "1"})
    with pytest.raises(InstrumentTimeout, match="relaying"):
        Keithley6221(t, clock=clock, sleep=clock.sleep, relay_timeout_s=1.0).relay_query("*IDN?")
