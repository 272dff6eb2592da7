"""RS-232: serial parameters from the scene's [instrument] table, validated, set on the VISA resource, and buffer
chunks and timeouts sized to the baud rate."""

from __future__ import annotations

import pytest

from contactrig.core.validation import SettingError
from instruments.transport import SerialSettings, VisaTransport


class FakeSerialResource:
    """Records the attributes a transport sets (as a pyvisa SerialInstrument would hold them)."""

    def __init__(self, name, **kw):
        self.resource_name = name
        self.opened_with = kw
        self.closed = False

    def close(self):
        self.closed = True


class FakeRM:
    def __init__(self):
        self.resources = []

    def open_resource(self, address, **kw):
        r = FakeSerialResource(address, **kw)
        self.resources.append(r)
        return r


def test_serial_parameters_are_set_on_the_resource():
    from pyvisa import constants

    rm = FakeRM()
    serial = SerialSettings(baud_rate=9600, flow_control="xon_xoff", terminator="CR", data_bits=7, parity="even")
    t = VisaTransport.open("ASRL1::INSTR", rm, 5000, serial=serial)
    r = rm.resources[0]
    assert r.baud_rate == 9600 and r.data_bits == 7 and r.parity == constants.Parity.even
    assert r.flow_control == constants.ControlFlow.xon_xoff and r.stop_bits == constants.StopBits.one
    assert r.read_termination == "\r" and r.write_termination == "\r"
    assert t.serial == serial and t.nodelay == ""


def test_chunks_and_timeout_scale_with_the_baud_rate():
    # 19 200 baud, 8N1: 1920 characters/s; 32 characters per reading
    slow = SerialSettings(baud_rate=19200)
    assert slow.bytes_per_s == pytest.approx(1920.0)
    chunk = slow.chunk_size(5000)
    assert chunk * 32 / 1920.0 <= 5.0 / 4  # one reply within a quarter of the 5 s timeout
    assert chunk < 1000  # a 1000-reading chunk (~17 s) would time out
    assert SerialSettings(baud_rate=115200).chunk_size(5000) > chunk
    assert SerialSettings(baud_rate=115200).chunk_size(60_000) == 1000  # capped
    # 300 baud with a 100 ms timeout: the smallest chunk (10 readings, 320 characters at 30/s) needs ~43 s
    tiny = SerialSettings(baud_rate=300)
    assert tiny.chunk_size(100) == 10
    assert tiny.timeout_ms(100, 10) >= 4 * 10 * 32 / 30 * 1000


def test_open_raises_a_too_short_timeout_for_the_baud_rate():
    rm = FakeRM()
    t = VisaTransport.open("ASRL3::INSTR", rm, 100, serial=SerialSettings(baud_rate=300))
    assert rm.resources[0].timeout >= 40_000 and t.timeout_s >= 40


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("baud_rate", 14400),
        ("baud_rate", "fast"),
        ("flow_control", "rts_cts"),
        ("terminator", "NUL"),
        ("data_bits", 9),
        ("parity", "mark"),
    ],
)
def test_bad_serial_keys_name_key_value_and_what_is_allowed(key, value):
    from daq.plan import InstrumentSettings

    with pytest.raises(SettingError) as err:
        InstrumentSettings.from_table({"address": "ASRL1::INSTR", key: value})
    assert err.value.field == f"instrument.{key}" and err.value.value == value
    assert str(err.value).startswith(f"[instrument] {key} = ") and ("expected" in err.value.allowed)


def test_driver_over_serial_reads_in_baud_sized_chunks():
    """Keithley6221.open on a serial address takes its chunk size from the baud rate."""
    from instruments.k6221 import Keithley6221

    rm = FakeRM()
    k = Keithley6221.open("ASRL1::INSTR", rm, 5000, serial=SerialSettings(baud_rate=19200))
    assert k.chunk_size == SerialSettings(baud_rate=19200).chunk_size(5000) < 1000
    k._closed = True  # nothing to abort on a fake resource
