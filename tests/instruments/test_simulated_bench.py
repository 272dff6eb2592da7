"""Whole Delta blocks and SCPI behaviour on the simulated bench (pyvisa-sim), and each injected fault."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from instruments.delta import DeltaSettings
from instruments.errors import (
    ComplianceWarning,
    InstrumentError,
    InstrumentTimeout,
    NanovoltmeterMissing,
    ReplyError,
    SweepAborted,
)
from instruments.k6221 import Keithley6221
from instruments.simulated import (
    GPIB_ADDRESS,
    PYVISA_SIM_RANGE,
    SOCKET_ADDRESS,
    ContactVoltageModel,
    SimulatedBench,
    simulated_resource_manager,
)
from instruments.transport import RecordingTransport, VisaTransport

from .conftest import FakeClock


def open_k(bench, address=GPIB_ADDRESS, timeout_ms=2000, **kw):
    return Keithley6221.open(address, resource_manager=simulated_resource_manager(bench), timeout_ms=timeout_ms, **kw)


def recorded(bench, timeout_ms=2000, **kw):
    rm = simulated_resource_manager(bench)
    rec = RecordingTransport(VisaTransport.open(GPIB_ADDRESS, rm, timeout_ms))
    return Keithley6221(rec, **kw), rec


def raw(bench, address=GPIB_ADDRESS):
    res = simulated_resource_manager(bench).open_resource(address, read_termination="\n", write_termination="\n")
    res.timeout = 500
    return res


# ---------------------------------------------------------------------------------------------- pyvisa-sim pin
def test_pyvisa_sim_version_in_pinned_range():
    import pyvisa_sim
    from pyvisa_sim import parser
    from pyvisa_sim.devices import Device
    from pyvisa_sim.highlevel import SimVisaLibrary

    version = tuple(int(p) for p in pyvisa_sim.__version__.split(".")[:2])
    lo, hi = PYVISA_SIM_RANGE
    assert lo <= version < hi, f"pyvisa-sim {pyvisa_sim.__version__} outside the range the bench was written for"
    for name in ("_load", "_get_pair", "update_component"):
        assert callable(getattr(parser, name))
    assert callable(Device._match) and callable(SimVisaLibrary._init)


def test_importing_instruments_does_not_import_pyvisa():
    code = (
        "import sys, instruments, instruments.delta, contactrig.cli.instruments, instruments.k6221;"
        "sys.exit(1 if 'pyvisa' in sys.modules else 0)"
    )
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


# ---------------------------------------------------------------------------------------------- whole blocks
def test_block_counts_units_and_value_gpib_and_socket():
    for address in (GPIB_ADDRESS, SOCKET_ADDRESS):
        bench = SimulatedBench(resistance_ohm=5e-3, seed=1)
        with open_k(bench, address) as k:
            ident = k.identify()
            block = k.run_delta(DeltaSettings(high_a=1e-3, count=50, nplc=1))
        assert "6221" in ident.source and "2182A" in ident.voltmeter
        assert block.readings.shape == (50,) and block.n == 50 and block.n_invalid == 0 and block.unit == "V"
        assert block.mean == pytest.approx(1e-3 * 5e-3, rel=1e-3)
        period = 2e-3 + 1 / 50 + bench.conversion_overhead_s
        np.testing.assert_allclose(block.timestamps_s, period * np.arange(50), atol=1e-6)


def test_emf_and_drift_cancel_to_within_the_noise():
    """Huge EMF and drift; the Delta mean must still be I·R within the noise of the mean.

    Noise expectation, computed from the Delta formula: each Delta reading has SD σ·√6/4 (weights 1, −2, 1 over 4),
    and in the mean of N readings every interior conversion has net weight ±1/N, so SEM(mean) ≈ σ/√N.
    """
    sigma, n, current, r = 5e-9, 400, 1e-3, 5e-3
    model = ContactVoltageModel(resistance_ohm=r, thermal_emf_v=1e-4, drift_v_per_s=1e-6, noise_v_1plc=sigma)
    bench = SimulatedBench(r, seed=7, model=model)
    with open_k(bench) as k:
        block = k.run_delta(DeltaSettings(high_a=current, count=n, nplc=1))
    assert abs(block.mean - current * r) < 5 * sigma / math.sqrt(n)
    assert block.sd == pytest.approx(sigma * math.sqrt(6) / 4, rel=0.15)
    # Without the Delta technique a single conversion at +I would be off by the EMF, 20× the signal.
    assert model.thermal_emf_v > 10 * current * r


def test_ohms_unit_and_asymmetric_currents_and_resistance_change():
    bench = SimulatedBench(resistance_ohm=8e-3, seed=2)
    with open_k(bench) as k:
        ohms = k.run_delta(DeltaSettings(high_a=2e-3, count=30, unit="OHMS"))
        volts = k.run_delta(DeltaSettings(high_a=2e-3, low_a=0.0, count=30))
        bench.resistance_ohm = 2e-3  # between blocks, as the rig simulation will do
        later = k.run_delta(DeltaSettings(high_a=2e-3, low_a=0.0, count=30))
    assert ohms.unit == "OHMS" and ohms.mean == pytest.approx(8e-3, rel=2e-3)
    assert volts.mean == pytest.approx(8e-3 * 1e-3, rel=2e-3)  # R·(high − low)/2
    assert np.nanmean(volts.resistance_ohm()) == pytest.approx(8e-3, rel=2e-3)
    assert later.mean == pytest.approx(2e-3 * 1e-3, rel=1e-2)


def test_seeded_and_reproducible():
    def run(seed):
        with open_k(SimulatedBench(seed=seed)) as k:
            return k.run_delta(DeltaSettings(high_a=1e-3, count=20)).readings

    np.testing.assert_array_equal(run(3), run(3))
    assert not np.array_equal(run(3), run(4))


def test_fresh_library_each_call_no_state_leak():
    bench = SimulatedBench()
    r1 = raw(bench)
    r1.write("SOUR:DELT:HIGH 0.05")
    r1.write("*IDN?")  # reply left unread
    r2 = raw(bench)
    assert r1.visalib is not r2.visalib
    assert float(r2.query("SOUR:DELT:HIGH?")) == pytest.approx(1e-3)
    assert r1.read().startswith("KEITHLEY")  # r1 keeps its own unread reply and settings
    assert float(r1.query("SOUR:DELT:HIGH?")) == pytest.approx(0.05)


def test_time_is_simulated_and_scaled():
    clock = FakeClock()
    bench = SimulatedBench(seed=1, time_scale=1.0, clock=clock)
    s = DeltaSettings(high_a=1e-3, count=10)
    with open_k(bench, clock=clock, sleep=clock.sleep) as k:
        block = k.run_delta(s)
    period = s.conversion_period_s + bench.conversion_overhead_s
    assert block.n == 10
    # arming plus the 12 conversions of the sweep took (fake) time, observed through status polling
    assert bench.arm_time_s + 12 * period <= clock.t < bench.arm_time_s + 12 * period + 1.0
    fast = SimulatedBench(seed=1, time_scale=0.0, clock=clock)
    t0 = clock.t
    with open_k(fast, clock=clock, sleep=clock.sleep) as k:
        np.testing.assert_array_equal(k.run_delta(s).readings, block.readings)
    assert clock.t == t0


def test_sweep_in_progress_partial_buffer_and_abort():
    clock = FakeClock()
    r = raw(SimulatedBench(seed=1, time_scale=1.0, clock=clock))
    for cmd in (
        "SOUR:DELT:COUN 100",
        "TRAC:POIN 100",
        "SOUR:DELT:DEL 0.009",
        'SYST:COMM:SER:SEND "SENS:VOLT:NPLC 1"',
        "SOUR:DELT:ARM",
    ):
        r.write(cmd)
    assert r.query("SOUR:DELT:ARM?") == "0"  # arming takes instrument time
    clock.sleep(0.5)
    assert r.query("SOUR:DELT:ARM?") == "1"
    r.write("INIT:IMM")
    clock.sleep(0.2 + 1e-9)  # period 0.009 + 1/50 + 0.001 = 0.03 s: readings appear from the 3rd conversion on
    assert r.query("TRAC:POIN:ACT?") == str(int(0.2 / 0.03) - 2)
    assert r.query("STAT:OPER:EVEN?") == "8"  # sweeping, not done
    r.write("SOUR:DELT:ARM")  # re-arming while running is refused
    assert r.query("SYST:ERR?").startswith("-221")
    r.write("SOUR:SWE:ABOR")
    assert int(r.query("STAT:OPER:EVEN?")) & 4
    clock.sleep(10)
    assert r.query("TRAC:POIN:ACT?") == "4"  # nothing more after the abort


def test_real_pace_scaled_down_completes():
    bench = SimulatedBench(seed=1, time_scale=0.01)
    with open_k(bench, poll_interval_s=0.005) as k:
        assert k.run_delta(DeltaSettings(high_a=1e-3, count=20)).n == 20


# ---------------------------------------------------------------------------------------------- SCPI spelling
def test_scpi_spelling_long_short_case_colon_compound_and_quotes():
    r = raw(SimulatedBench())
    r.write(":sour:delt:high 2e-3;low -1E-3;:SOURce:DELTa:DELay 5e-3")
    # 9 significant digits, as the 6221 prints them (e.g. +1.01194701E-05)
    assert r.query("SOURce:DELTa:HIGH?;LOW?;DEL?") == "+2.00000000E-03;-1.00000000E-03;+5.00000000E-03"
    r.write("SOUR:DELT:CAB ON")
    assert r.query("SOUR:DELT:CAB?") == "1"  # ON/OFF set, 1/0 answered, as on the instrument
    r.write("source:delta:high 3e-3")  # HIGH also sets LOW to −HIGH
    assert float(r.query("SOUR:DELT:LOW?")) == pytest.approx(-3e-3)
    r.write('SYST:COMM:SER:SEND ":SENS:VOLT:NPLC 5;:sense:voltage:range 0.1"')  # ';' inside quotes is relayed
    r.write('SYSTem:COMMunicate:SERial:SEND "SENS:VOLT:NPLC?"')
    assert r.query("SYST:COMM:SER:ENT?") == "+5.00000000E+00\r"
    assert r.query("SYST:ERR?") == '0,"No error"'
    r.write("SOUR:DELT:BOGUS 1")
    r.write("SOUR:DELT:DEL 1e6")
    assert r.query("SYSTem:ERRor:NEXT?") == '-113,"Undefined header"'
    assert r.query("SYST:ERR?") == '-222,"Data out of range"'
    assert r.query("*idn?").startswith("KEITHLEY INSTRUMENTS INC.,MODEL 6221")


def test_status_buffer_and_arm_protocol_raw():
    r = raw(SimulatedBench(seed=5))
    for cmd in ("SOUR:DELT:COUN 4", "TRAC:POIN 4", "SOUR:DELT:ARM"):
        r.write(cmd)
    assert r.query("SOUR:DELT:ARM?") == "1"
    r.write("INIT")
    assert int(r.query("STAT:OPER:EVEN?")) & 2
    assert r.query("STAT:OPER?") == "0"  # reading cleared the event register
    assert r.query("TRAC:POIN:ACT?") == "4"
    full = r.query("TRAC:DATA?").split(",")
    assert len(full) == 8
    assert r.query("TRAC:DATA:SEL? 1,2").split(",") == full[2:6]
    r.write("SOUR:SWE:ABOR")
    assert r.query("SOUR:DELT:ARM?") == "0"
    r.write("TRAC:POIN 2")
    r.write("SOUR:DELT:ARM")  # arming sizes the buffer to the Delta count (RM 6-12)
    assert r.query("SOUR:DELT:ARM?;:TRAC:POIN?;:SYST:ERR?") == '1;4;0,"No error"'


# ---------------------------------------------------------------------------------------------- faults
def test_fault_nanovoltmeter_absent():
    bench = SimulatedBench()
    bench.faults.voltmeter_absent = True
    with open_k(bench) as k:
        with pytest.raises(NanovoltmeterMissing, match="Trigger Link"):
            k.identify()
        with pytest.raises(NanovoltmeterMissing, match="RS-232"):
            k.run_delta(DeltaSettings(high_a=1e-3))


def test_fault_query_never_answers_times_out_naming_it_and_aborts():
    bench = SimulatedBench()
    bench.faults.silent.add("TRAC:POIN:ACT?")
    k, rec = recorded(bench, timeout_ms=50)
    with k, pytest.raises(InstrumentTimeout) as err:
        k.run_delta(DeltaSettings(high_a=1e-3, count=5))
    assert "TRAC:POIN:ACT?" in err.value.command  # asked in the completion poll, with the status registers
    assert rec.exchanges[-1].message == "SOUR:SWE:ABOR"


def test_fault_garbage_reply():
    bench = SimulatedBench()
    bench.faults.garbage["TRAC:DATA:SEL?"] = "+1.0E-06,+0.0E+00,#!garbage"
    k, rec = recorded(bench)
    with k, pytest.raises(ReplyError, match="TRAC:DATA:SEL"):
        k.run_delta(DeltaSettings(high_a=1e-3, count=5))
    assert rec.exchanges[-1].message == "SOUR:SWE:ABOR"


def test_fault_error_queued():
    bench = SimulatedBench()
    bench.queue_error(-350, "Queue overflow")
    with open_k(bench) as k, pytest.raises(InstrumentError) as err:
        k.run_delta(DeltaSettings(high_a=1e-3, count=5))
    assert err.value.code == -350 and "Queue overflow" in str(err.value)


@pytest.mark.filterwarnings("ignore::instruments.errors.InvalidReadingsWarning")  # expected: overflow injected
def test_fault_overflow_readings_are_nan_and_not_averaged():
    bench = SimulatedBench(resistance_ohm=5e-3, seed=1)
    bench.faults.overflow_readings.update({2, 5})
    with open_k(bench) as k:
        block = k.run_delta(DeltaSettings(high_a=1e-3, count=10))
    assert block.n_invalid == 2 and block.n == 8
    assert np.isnan(block.readings[[2, 5]]).all()
    assert block.mean == pytest.approx(np.nanmean(block.readings)) and math.isfinite(block.mean)


@pytest.mark.filterwarnings("ignore::instruments.errors.InvalidReadingsWarning")  # expected: overflow injected
def test_range_overflow_from_physics():
    bench = SimulatedBench(resistance_ohm=20.0, seed=1, lead_resistance_ohm=0.0)  # 20 mV on the 10 mV range
    with open_k(bench) as k:
        block = k.run_delta(DeltaSettings(high_a=1e-3, count=5, voltmeter_range_v=0.01))
    assert block.n_invalid == 5


def test_relay_quirks_xoff_pieces_and_stray_terminator_keep_link_in_step():
    bench = SimulatedBench(seed=1)
    bench.faults.relay_xoff = True
    bench.faults.relay_pieces = 3
    bench.faults.relay_terminator = "\n"
    with open_k(bench) as k:
        ident = k.identify()
        assert ident.voltmeter == "KEITHLEY INSTRUMENTS INC.,MODEL 2182A,1234567,C02  /A02"
        assert k.query("SOUR:DELT:NVPR?") == "1"  # no stray empty line left behind
        assert k.run_delta(DeltaSettings(high_a=1e-3, count=5)).n == 5


def test_compliance_abort_and_compliance_limit():
    bench = SimulatedBench(resistance_ohm=200.0, seed=1, lead_resistance_ohm=0.0)
    with open_k(bench) as k:
        with pytest.raises(SweepAborted, match="compliance"):
            k.run_delta(DeltaSettings(high_a=1e-3, count=5, compliance_v=0.1))
        with pytest.warns(ComplianceWarning):
            block = k.run_delta(DeltaSettings(high_a=1e-3, count=5, compliance_v=0.1, compliance_abort=False))
    # The source can only drive compliance/R: the sample then shows exactly the compliance voltage — wrong, and
    # flagged: no reading counts, the block has no mean.
    assert np.nanmean(block.readings) == pytest.approx(0.1, rel=1e-4)
    assert block.compliance and block.n == 0 and math.isnan(block.mean)


def test_compliance_with_abort_off_is_flagged_not_averaged_the_issue_case():
    """200 Ω at 0.1 A with a 1 V compliance: I·R = 20 V, the readings say ≈ 1 V; the block must say so."""
    bench = SimulatedBench(resistance_ohm=200.0, seed=1)
    s = DeltaSettings(high_a=0.1, count=20, compliance_v=1.0, compliance_abort=False)
    with open_k(bench) as k, pytest.warns(ComplianceWarning, match="compliance"):
        block = k.run_delta(s)
    assert np.nanmean(block.readings) < 0.1 * 200.0 / 10  # the readings are far below I·R = 20 V
    assert block.compliance and not block.valid.any() and math.isnan(block.mean) and block.n == 0


def test_stale_compliance_bit_does_not_leak_into_the_next_block():
    """The bench latches the compliance bit until STAT:MEAS:EVEN? reads it. A bit latched before the block (a
    previous user, or an earlier block read by someone else) must not flag a clean block."""
    bench = SimulatedBench(resistance_ohm=200.0, seed=1, lead_resistance_ohm=0.0)
    rm = simulated_resource_manager(bench)
    r = rm.open_resource(GPIB_ADDRESS, read_termination="\n", write_termination="\n", timeout=500)
    for cmd in ("SOUR:DELT:HIGH 0.01", "SOUR:CURR:COMP 1", "SOUR:DELT:CAB OFF", "SOUR:DELT:COUN 3", "TRAC:POIN 3"):
        r.write(cmd)
    r.write("SOUR:DELT:ARM")
    r.write("INIT:IMM")  # 0.01 A × 200 Ω = 2 V > 1 V: compliance, latched and left unread
    r.write("SOUR:SWE:ABOR")
    bench.resistance_ohm = 5e-3
    with Keithley6221.open(GPIB_ADDRESS, resource_manager=rm, timeout_ms=2000) as k:
        block = k.run_delta(DeltaSettings(high_a=1e-3, count=10))
    assert not block.compliance and block.n == 10 and block.mean == pytest.approx(5e-6, rel=1e-2)
    # the latch itself: set by a sweep in compliance, cleared by reading
    bench.resistance_ohm = 200.0
    r.write("SOUR:DELT:CAB OFF;:SOUR:CURR:COMP 0.1;:SOUR:DELT:HIGH 0.1;:SOUR:DELT:COUN 3;:TRAC:POIN 3;:SOUR:DELT:ARM")
    r.write("INIT:IMM")
    assert int(r.query("STAT:MEAS:EVEN?")) & 8
    assert not int(r.query("STAT:MEAS:EVEN?")) & 8


def _previous_user(r):
    """Leave the 6221 and the 2182A as a previous user might have: filters on, math on the buffer feed, relative
    timestamps, channel 2, cold switching."""
    for cmd in (
        "SENS:AVER:STAT ON",
        "SENS:AVER:COUN 5",
        "CALC1:KMAT:MMF 2",
        "CALC1:STAT ON",
        "TRAC:FEED CALC1",
        "TRAC:TST:FORM DELT",
        "SOUR:DELT:CSW ON",
        'SYST:COMM:SER:SEND ":SENS:VOLT:DFIL:STAT ON;:SENS:VOLT:DFIL:COUN 4"',
        'SYST:COMM:SER:SEND ":SYST:AZER OFF"',
    ):
        r.write(cmd)
    assert r.query("SYST:ERR?") == '0,"No error"'


def test_previous_users_state_changes_the_readings_on_the_bench():
    """The bench honours the state a session must pin (else the pinning test below could not fail)."""

    def block(previous):
        r = raw(SimulatedBench(resistance_ohm=5e-3, seed=4))
        if previous:
            _previous_user(r)
        for cmd in ("SOUR:DELT:HIGH 0.001", "SOUR:DELT:COUN 20", "TRAC:POIN 20", "SOUR:DELT:ARM", "INIT:IMM"):
            r.write(cmd)
        v = np.array([float(x) for x in r.query("TRAC:DATA:SEL? 0,20").split(",")]).reshape(-1, 2)
        return v[:, 0], v[:, 1]

    clean, t_clean = block(False)
    dirty, t_dirty = block(True)
    assert np.mean(clean) == pytest.approx(5e-6, rel=1e-2)
    assert abs(np.mean(dirty) / 5e-6 - 1) > 0.5  # filters across polarities and ×2 math: far off
    assert np.all(np.diff(t_clean) > 0) and np.allclose(t_dirty[1:], t_dirty[1])  # relative stamps


def test_session_pins_the_previous_users_state_and_reads_it_back():
    bench = SimulatedBench(resistance_ohm=5e-3, seed=4)
    rm = simulated_resource_manager(bench)
    r = rm.open_resource(GPIB_ADDRESS, read_termination="\n", write_termination="\n", timeout=500)
    _previous_user(r)
    with Keithley6221.open(GPIB_ADDRESS, resource_manager=rm, timeout_ms=2000) as k:
        block = k.run_delta(DeltaSettings(high_a=1e-3, count=20))
        state = k.state_read
    assert block.mean == pytest.approx(5e-6, rel=1e-2) and np.all(np.diff(block.timestamps_s) > 0)
    assert state["6221"] == {
        "SOUR:DELT:CSW OFF": "0",
        "SENS:AVER:STAT OFF": "0",
        "CALC1:STAT OFF": "0",
        "TRAC:FEED SENS1": "SENS1",
        "TRAC:TST:FORM ABS": "ABS",
    }
    assert state["2182A"][":SENS:VOLT:DFIL:STAT OFF"] == "0" and state["2182A"][":SYST:AZER ON"] == "1"
    assert r.query("SENS:AVER:STAT?;:TRAC:FEED?;:CALC1:STAT?") == "0;SENS1;0"  # as the instrument holds it now
    r.write('SYST:COMM:SER:SEND ":SENS:VOLT:DFIL:STAT?;:SENS:CHAN?"')
    assert r.query("SYST:COMM:SER:ENT?") == "0;1\r"


def test_third_party_style_sequence_long_forms_and_extra_elements():
    """A driver written by someone else (long forms, *RST, guard/LTE/filter commands, four buffer elements)."""
    r = raw(SimulatedBench(resistance_ohm=7e-3, seed=9))
    for cmd in (
        ":SOURce:SWEep:ABORt",
        "SOUR:WAVE:ABOR",
        "*RST",
        "OUTPut:ISHield OLOW",
        "OUTP:LTEarth OFF",
        "FORMat:ELEMents READing,TSTamp,RNUMber,SOURce",
        "SOUR:DELT:HIGH 0.002",
        "SOUR:DELT:LOW -0.002",
        "SOURce:DELTa:COUNt 10",
        "SOUR:DELT:DEL 0.01",
        "SOUR:CURR:COMP 10",
        "SOUR:CURR:RANG -0.002",
        'SYST:COMM:SERIAL:SEND "*RST"',
        'SYSTem:COMMunicate:SERial:SEND ":SENS:VOLT:NPLC 5"',
        'SYST:COMM:SER:SEND ":SENSe:VOLTage:CHANnel1:RANGe 0.1"',
        "SENS:AVER:WIND 0",
        "SENSe:AVERage:TCONtrol MOVing",
        "SENS:AVER:STATe 0",
        "UNIT V",
        "SOUR:DELT:ARM",
        "INIT:IMM",
    ):
        r.write(cmd)
    assert r.query("SYST:ERR?") == '0,"No error"'
    assert int(r.query("STAT:OPER:EVEN?")) & 2
    values = [float(x) for x in r.query("TRAC:DATA:SEL? 0,10").split(",")]
    assert len(values) == 40
    # The buffer comes in the instrument's fixed element order — reading, timestamp, source, reading number
    # (RM 6-12) — whatever the order in FORM:ELEM; Tektronix's CSV writer labels its columns in that order.
    volts, stamps, source, numbers = (np.array(values[i::4]) for i in range(4))
    np.testing.assert_array_equal(numbers, np.arange(10))
    assert stamps[0] == 0.0 and np.all(np.diff(stamps) > 0.01)
    assert set(np.abs(source)) == {0.002}
    assert np.mean(volts) / 0.002 == pytest.approx(7e-3, rel=1e-3)  # R = V / ((high − low)/2)
    r.write(":SOUR:SWE:ABORT")
    r.write("FORM:ELEM READ,BOGUS")
    assert r.query("SYST:ERR?") == '-224,"Illegal parameter value"'


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"time_scale": -1.0}, "time_scale"),
        ({"time_scale": float("inf")}, "time_scale"),
        ({"resistance_ohm": -1e-3}, "resistance_ohm"),
        ({"resistance_ohm": float("nan")}, "resistance_ohm"),
        ({"lead_resistance_ohm": -0.1}, "lead_resistance_ohm"),
        ({"line_frequency_hz": 55}, "line_frequency_hz"),
        ({"arm_time_s": -1}, "arm_time_s"),
    ],
)
def test_bench_settings_are_validated(kwargs, field):
    from contactrig.core.validation import SettingError

    with pytest.raises(SettingError) as err:
        SimulatedBench(**kwargs)
    assert err.value.field == field and "not allowed" in str(err.value)
    bench = SimulatedBench()
    with pytest.raises(SettingError, match="resistance_ohm"):
        bench.resistance_ohm = -1.0
    assert bench.resistance_ohm == 5e-3  # unchanged, nothing clamped


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"poll_interval_s": 0.0}, "poll_interval_s"),
        ({"arm_timeout_s": -1.0}, "arm_timeout_s"),
        ({"relay_timeout_s": float("nan")}, "relay_timeout_s"),
        ({"chunk_size": 0}, "chunk_size"),
        ({"chunk_size": 70000}, "chunk_size"),
        ({"chunk_size": 2.5}, "chunk_size"),
    ],
)
def test_driver_options_are_validated(kwargs, field):
    from contactrig.core.validation import SettingError

    with pytest.raises(SettingError) as err:
        Keithley6221(object(), **kwargs)
    assert err.value.field == field


def test_invalid_readings_are_announced_with_a_warning_naming_the_count():
    import warnings

    from instruments.errors import InvalidReadingsWarning
    from instruments.simulated import Faults

    bench = SimulatedBench(resistance_ohm=5e-3, seed=3, faults=Faults(overflow_readings={0, 4}))
    rm = simulated_resource_manager(bench=bench)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with Keithley6221.open("GPIB0::12::INSTR", resource_manager=rm, timeout_ms=2000) as k:
            block = k.run_delta(DeltaSettings(high_a=1e-3, count=10))
    msgs = [str(w.message) for w in caught if issubclass(w.category, InvalidReadingsWarning)]
    assert block.n_invalid == 2 and block.n == 8
    assert len(msgs) == 1 and msgs[0].startswith("2 of 10 Delta readings invalid")
