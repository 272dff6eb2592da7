"""Drivers written by others against the simulated bench: PyMeasure's ``Keithley6221`` (every property it
declares) and the command sequence of Tektronix's official Delta example.

PyMeasure talks to the bench through pyvisa's ResourceManager on the simulated bench's VISA library (a
:class:`~instruments.simulated.BenchVisaLibrary` instance handed to PyMeasure's VISA adapter). Each property is read;
each control is set to a value inside the range the 6221 manual documents and read back; afterwards the error queue
must be empty. Skipped when pymeasure is not installed (``pip install -e .[peers]``).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from instruments.simulated import GPIB_ADDRESS, BenchVisaLibrary, SimulatedBench

pymeasure_keithley = pytest.importorskip("pymeasure.instruments.keithley")

#: A value inside the manual's range for every PyMeasure control (PyMeasure's own names and value spellings).
SET_VALUES = {
    "source_enabled": True,
    "shield_to_guard_enabled": True,
    "source_delay": 0.5,
    "output_low_grounded": True,
    "source_current": 1e-3,
    "source_compliance": 20.0,
    "source_range": 2e-3,
    "source_auto_range": True,
    "delta_unit": "Ohms",
    "delta_high_source": 2e-3,
    "delta_low_source": -1e-3,
    "delta_delay": 0.01,
    "delta_cycles": 100,
    "delta_measurement_sets": 2,
    "delta_compliance_abort_enabled": True,
    "delta_cold_switch_enabled": True,
    "delta_buffer_points": 100,
    "waveform_function": "square",
    "waveform_frequency": 10.0,
    "waveform_amplitude": 1e-3,
    "waveform_offset": 1e-4,
    "waveform_dutycycle": 25.0,
    "waveform_duration_time": 10.0,
    "waveform_duration_cycles": 100.0,
    "waveform_ranging": "fixed",
    "waveform_use_phasemarker": True,
    "waveform_phasemarker_phase": 90.0,
    "waveform_phasemarker_line": 3,
    "display_enabled": False,
    "measurement_event_enabled": 8,
    "operation_event_enabled": 4,
    "questionable_event_enabled": 2,
    "standard_event_enabled": 1,
    "srq_event_enabled": 16,
    "buffer_points": 200,
}
#: Properties whose commands are not the 6221's, so a faithful bench must refuse them (−113, Undefined header):
#: ``standard_event_enabled`` sends ``ESE``/``ESE?`` without the ``*`` of IEEE 488.2's ``*ESE``; ``options`` sends
#: ``*OPT?``, which is not among the 6221's common commands in the material we have.
NOT_THE_MANUALS = {"standard_event_enabled", "options"}


def property_names() -> list[str]:
    names: list[str] = []
    for klass in pymeasure_keithley.Keithley6221.__mro__:
        names += [n for n, v in vars(klass).items() if isinstance(v, property) and n not in names]
    return names


def open_pymeasure(bench: SimulatedBench):
    return pymeasure_keithley.Keithley6221(
        GPIB_ADDRESS,
        visa_library=BenchVisaLibrary.create(bench),
        timeout=300,  # an unanswered query costs the whole VISA timeout: keep it short
        read_termination="\n",
        write_termination="\n",
    )


def _prepare(k, name: str) -> None:
    """State a property needs: a filled buffer for the buffer reads, a running sweep for the latest reading."""
    if name in ("delta_values", "buffer_data"):
        k.write("SOUR:DELT:COUN 10;ARM")
        k.write("INIT:IMM")
    elif name == "delta_sense":  # SENS:DATA? answers only while a Delta run is going (UM 5-41)
        k.write("SOUR:DELT:COUN INF;ARM")
        k.write("INIT:IMM")


def _same(got, want) -> bool:
    if isinstance(want, float) and isinstance(got, (int, float)):
        return math.isclose(got, want, rel_tol=1e-9)
    return got == want


def probe(name: str) -> tuple[bool, str]:
    """Read (and for a control, set and read back) one PyMeasure property; (works, what happened)."""
    bench = SimulatedBench(seed=1, time_scale=1e-4 if name == "delta_sense" else 0.0, arm_time_s=0.0)
    k = open_pymeasure(bench)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)  # ``error`` is deprecated in favour of ``next_error``
            _prepare(k, name)
            value = getattr(k, name)
            if name in SET_VALUES:
                setattr(k, name, SET_VALUES[name])
                value = getattr(k, name)
                if not _same(value, SET_VALUES[name]):
                    return False, f"read back {value!r} after setting {SET_VALUES[name]!r}"
        error = k.ask("SYST:ERR?").strip()
        return error.startswith("0,"), error if not error.startswith("0,") else repr(value)[:60]
    except Exception as exc:  # a timeout (unanswered query) or a reply PyMeasure cannot map
        return False, f"{type(exc).__name__}: {str(exc)[:80]}; error queue: {k.ask('SYST:ERR?').strip()}"
    finally:
        k.adapter.close()


@pytest.mark.parametrize("name", property_names())
def test_pymeasure_property(name):
    works, detail = probe(name)
    if name in NOT_THE_MANUALS:
        assert not works and "-113" in detail, detail
    else:
        assert works, detail


def test_pymeasure_counts():
    names = property_names()
    assert len(names) >= 49  # PyMeasure 0.16: 42 of the 6221's own, 2 of its buffer mixin, 5 SCPI ones
    assert set(SET_VALUES) <= set(names) and NOT_THE_MANUALS <= set(names)


def test_pymeasure_delta_values_are_the_bench_physics():
    bench = SimulatedBench(resistance_ohm=4e-3, seed=2)
    k = open_pymeasure(bench)
    try:
        k.delta_high_source = 1e-3
        k.delta_cycles = 20
        k.delta_buffer_points = 20
        k.delta_arm()
        k.delta_start()
        assert int(k.operation_events) & 2
        values = np.array(k.delta_values)
    finally:
        k.adapter.close()
    readings, stamps = values[0::2], values[1::2]
    assert readings.size == 20 and stamps[0] == 0.0
    assert np.mean(readings) == pytest.approx(4e-3 * 1e-3, rel=1e-2)


# ---------------------------------------------------------------------------------------------- Tektronix
#: The command sequence of Tektronix's Delta_Measurement_Example.py (tektronix/keithley,
#: Instrument_Examples/Model_622x_2182A), written out here with its parameters: high 1 mA, low −1 mA, 100 readings,
#: no filter, 2182A range 0.1 V, delay 0.5 s, 5 NPLC, compliance 10 V, no guard, low floating.
TEKTRONIX_SETUP = [
    "SOUR:SWE:ABOR",
    "SOUR:WAVE:ABOR",
    "*RST",
    "OUTP:ISH OLOW",
    "OUTP:LTE OFF",
    "FORM:ELEM READ,TST,RNUM,SOUR",
    "SOUR:DELT:HIGH 0.001",
    "SOUR:DELT:LOW -0.001",
    "SOUR:DELT:COUNT 100",
    "SOUR:DELT:DEL 0.5",
    "SOUR:CURR:COMP 10.0",
    "SOUR:CURR:RANG -0.001",
    'SYST:COMM:SERIAL:SEND "*RST"',
    'SYST:COMM:SERIAL:SEND ":SENS:VOLT:NPLC 5.0"',
    'SYST:COMM:SERIAL:SEND ":SENS:VOLT:RANG 0.1"',
    "SENS:AVER:WIND 0",
    "SENS:AVER:TCON MOV",
    "SENS:AVER:STAT 0",
    "UNIT V",
    "SOUR:DELT:ARM",
    "INIT:IMM",
]
#: The example's CSV header: the columns it writes, in this order, four values per reading.
TEKTRONIX_CSV = ("Voltage Reading", "Timestamp", "Source Current", "Reading Number")


def test_tektronix_example_sequence_csv_columns_in_the_fixed_order():
    bench = SimulatedBench(resistance_ohm=6e-3, seed=4)
    from instruments.simulated import simulated_resource_manager

    r = simulated_resource_manager(bench).open_resource(GPIB_ADDRESS, read_termination="\n", write_termination="\n")
    r.timeout = 2000
    for command in TEKTRONIX_SETUP:
        r.write(command)
    assert int(r.query("STAT:OPER:EVEN?")) & 2  # the example's completion test: bit 1, sweep done
    data = []
    for i in range(1):  # the example reads 1000 at a time with TRAC:DATA:SEL?
        data += r.query(f"TRAC:DATA:SEL? {i * 1000},100").split(",")
    assert r.query("SYST:ERR?") == '0,"No error"'
    r.write(":SOUR:SWE:ABORT")
    table = np.array(data, dtype=float).reshape(-1, len(TEKTRONIX_CSV))
    columns = dict(zip(TEKTRONIX_CSV, table.T, strict=True))
    # Fixed order (RM 6-12): reading, timestamp, source, reading number — not the order FORM:ELEM named them in.
    np.testing.assert_array_equal(columns["Reading Number"], np.arange(100))
    assert set(np.abs(columns["Source Current"])) == {1e-3}
    assert columns["Timestamp"][0] == 0.0 and np.all(np.diff(columns["Timestamp"]) > 0.5)
    resistance = columns["Voltage Reading"] / 1e-3  # the example's R = V / ((high − low)/2)
    assert np.mean(resistance) == pytest.approx(6e-3, rel=1e-3)
    # 9 significant digits, as the 6221 prints readings
    assert all(len(x.strip().lstrip("+-").split("E")[0].replace(".", "")) == 9 for x in data)
