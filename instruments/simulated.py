"""A simulated Keithley 6221 + 2182A bench on pyvisa-sim, with physics behind the readings.

``simulated_resource_manager(bench=...)`` returns a fresh :class:`pyvisa.ResourceManager` whose VISA library is a
:class:`BenchVisaLibrary` (a pyvisa-sim ``SimVisaLibrary`` subclass). The 6221 answers at ``GPIB0::12::INSTR``
and ``TCPIP0::127.0.0.1::1394::SOCKET``. Static replies, settings and their ranges come from the packaged YAML
definition (``k6221_sim.yaml``); a :class:`SimulatedK6221` (a pyvisa-sim ``Device`` subclass) parses SCPI as the
real instrument does (:mod:`instruments.scpi`) and implements the dynamic part in Python: Delta arming and
sweeps, the reading buffer, status event registers, the error queue and the serial relay to the 2182A.

Physics (:class:`ContactVoltageModel`, pluggable): every 2182A conversion is ±I·R + thermal EMF + drift + noise,
and the simulated 6221 forms the 3-point Delta readings from the conversions (:func:`instruments.delta.delta_readings`),
so EMF cancellation is real, not assumed. Instrument time (arming, delay, NPLC) is simulated and scaled by
``time_scale`` (1 = real pace, 0 = instant). Relies on pyvisa-sim 0.7 internals (see :data:`PYVISA_SIM_RANGE`).
"""

from __future__ import annotations

import itertools
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources
from io import StringIO
from typing import Any, ClassVar, Protocol

import numpy as np
import pyvisa
from pyvisa import constants
from pyvisa_sim import parser as sim_parser
from pyvisa_sim.component import NoResponse
from pyvisa_sim.devices import Device, Devices
from pyvisa_sim.highlevel import SimVisaLibrary

from contactrig.core.validation import check_choice, check_range
from instruments.delta import delta_readings
from instruments.scpi import Command, parse_message, split_params, unquote

__all__ = [
    "GPIB_ADDRESS",
    "PYVISA_SIM_RANGE",
    "SOCKET_ADDRESS",
    "BenchVisaLibrary",
    "ContactVoltageModel",
    "ConversionModel",
    "Faults",
    "SimulatedBench",
    "SimulatedK6221",
    "simulated_resource_manager",
]

GPIB_ADDRESS = "GPIB0::12::INSTR"
SOCKET_ADDRESS = "TCPIP0::127.0.0.1::1394::SOCKET"
#: pyvisa-sim versions whose internals this module uses: Device.read returns (byte, end) from 0.7 on (0.6: byte only).
PYVISA_SIM_RANGE = ((0, 7), (0, 8))
DEFINITION = "k6221_sim.yaml"
OVERFLOW = 9.9e37

# SCPI error codes used by the simulator.
E_UNDEFINED = (-113, "Undefined header")
E_CONFLICT = (-221, "Settings conflict")
E_OUT_OF_RANGE = (-222, "Data out of range")
E_ILLEGAL = (-224, "Illegal parameter value")
E_STALE = (-230, "Data corrupt or stale")
E_HW_MISSING = (-241, "Hardware missing")
_ERROR_TEXT = {c: m for c, m in (E_UNDEFINED, E_CONFLICT, E_OUT_OF_RANGE, E_ILLEGAL, E_STALE, E_HW_MISSING)}
_BOOLEAN_HEADERS = {
    "SOUR:DELT:CAB",
    "SOUR:DELT:CSW",
    "SOUR:CURR:RANG:AUTO",
    "SENS:VOLT:RANG:AUTO",
    "OUTP:LTE",
    "SENS:AVER:STAT",
    "CALC1:STAT",
    "SYST:AZER",
    "SENS:VOLT:DFIL:STAT",
    "SENS:VOLT:LPAS",
}
# Keyword parameters: long forms and spellings -> the short form the YAML table holds.
_KEYWORDS = {
    "OHM": "OHMS",
    "VOLT": "V",
    "WATT": "W",
    "WATTS": "W",
    "MOVING": "MOV",
    "REPEAT": "REP",
    "GUAR": "GUARD",
    "ABSOLUTE": "ABS",
    "DELTA": "DELT",
    "SENS": "SENS1",
    "SENSE": "SENS1",
    "SENSE1": "SENS1",
    "CALC": "CALC1",
    "CALCULATE": "CALC1",
    "CALCULATE1": "CALC1",
    "NEVER": "NEV",
}
_ELEMENTS = {
    "READ": "READ",
    "READING": "READ",
    "TST": "TST",
    "TSTAMP": "TST",
    "RNUM": "RNUM",
    "RNUMBER": "RNUM",
    "SOUR": "SOUR",
    "SOURCE": "SOUR",
}
_XOFF = "\x13"


# ---------------------------------------------------------------------------------------------------- physics
class ConversionModel(Protocol):
    """What the bench needs from a physical model: a settable resistance and the 2182A conversion voltages."""

    resistance_ohm: float

    def conversion_voltages(
        self, t_s: np.ndarray, current_a: np.ndarray, nplc: float, rng: np.random.Generator
    ) -> np.ndarray: ...


@dataclass
class ContactVoltageModel:
    """Voltage across the sample at each 2182A conversion (V):

        V(t, I) = I·R + E_th + d·t + noise,   noise ~ N(0, σ₁/√NPLC)

    resistance_ohm R (sample), thermal_emf_v E_th (constant thermoelectric offset), drift_v_per_s d (slow
    linear drift), noise_v_1plc σ₁ (rms conversion noise at 1 PLC; it falls as 1/√NPLC with integration time).
    """

    resistance_ohm: float = 5e-3
    thermal_emf_v: float = 3e-6
    drift_v_per_s: float = 2e-8
    noise_v_1plc: float = 8e-9

    def conversion_voltages(
        self, t_s: np.ndarray, current_a: np.ndarray, nplc: float, rng: np.random.Generator
    ) -> np.ndarray:
        t = np.asarray(t_s, dtype=float)
        i = np.asarray(current_a, dtype=float)
        noise = rng.normal(0.0, self.noise_v_1plc / math.sqrt(nplc), size=t.shape) if self.noise_v_1plc else 0.0
        return i * self.resistance_ohm + self.thermal_emf_v + self.drift_v_per_s * t + noise


@dataclass
class Faults:
    """Faults to inject (all off by default). Headers are canonical short forms, e.g. ``"TRAC:DATA:SEL?"``.

    voltmeter_absent: no 2182A on the serial link (``NVPR?`` 0, relay silent, ARM fails).
    silent: queries that are processed but never answered (the driver sees a VISA timeout).
    garbage: header → text that replaces the real reply.
    overflow_readings: indices of Delta readings that come back as +9.9E37.
    relay_xoff: relayed replies lead with XOFF (0x13) bytes.
    relay_pieces: relayed replies arrive split over this many ``ENT?`` reads, the first one empty (0 = whole).
    relay_terminator: the 2182A's own terminator inside relayed replies ("\\r" or "\\n"; "\\n" leaves a stray
    empty line after the 6221's own LF, as seen in the field).
    """

    voltmeter_absent: bool = False
    silent: set[str] = field(default_factory=set)
    garbage: dict[str, str] = field(default_factory=dict)
    overflow_readings: set[int] = field(default_factory=set)
    relay_xoff: bool = False
    relay_pieces: int = 0
    relay_terminator: str = "\r"


class SimulatedBench:
    """The physical world behind the simulated instruments: sample, cabling, noise, time and faults.

    resistance_ohm: sample resistance (settable between blocks: ``bench.resistance_ohm = …``).
    seed: seeds the noise generator; the same seed and the same sequence of blocks give the same readings.
    time_scale: real seconds per instrument second (1 = real pace, 0 = instant).
    model: a :class:`ConversionModel` (default :class:`ContactVoltageModel` with ``resistance_ohm``).
    lead_resistance_ohm: resistance of leads and bodies in the current loop, added to R for the compliance check.
    line_frequency_hz: mains frequency for NPLC timing. arm_time_s: time the 6221 needs to arm a Delta test.
    conversion_overhead_s: per-conversion time on top of delay + NPLC/line frequency.
    """

    def __init__(
        self,
        resistance_ohm: float = 5e-3,
        *,
        seed: int | None = 0,
        time_scale: float = 0.0,
        model: ConversionModel | None = None,
        lead_resistance_ohm: float = 0.2,
        line_frequency_hz: float = 50.0,
        arm_time_s: float = 0.2,
        conversion_overhead_s: float = 1e-3,
        clock: Callable[[], float] = time.monotonic,
        faults: Faults | None = None,
    ) -> None:
        self.model: ConversionModel = model if model is not None else ContactVoltageModel()
        self.resistance_ohm = resistance_ohm  # validated by the setter
        self.rng = np.random.default_rng(seed)
        self.time_scale = check_range("time_scale", time_scale, 0.0)
        self.lead_resistance_ohm = check_range("lead_resistance_ohm", lead_resistance_ohm, 0.0, unit="Ω")
        self.line_frequency_hz = float(check_choice("line_frequency_hz", line_frequency_hz, (50, 60)))
        self.arm_time_s = check_range("arm_time_s", arm_time_s, 0.0, unit="s")
        self.conversion_overhead_s = check_range("conversion_overhead_s", conversion_overhead_s, 0.0, unit="s")
        self.clock = clock
        self.faults = faults if faults is not None else Faults()
        #: Instrument time elapsed in simulated sweeps (s): the drift term keeps running from block to block.
        self.instrument_time_s = 0.0
        self._injected_errors: deque[tuple[int, str]] = deque()

    @property
    def resistance_ohm(self) -> float:
        return float(self.model.resistance_ohm)

    @resistance_ohm.setter
    def resistance_ohm(self, value: float) -> None:
        self.model.resistance_ohm = check_range("resistance_ohm", value, 0.0, unit="Ω")

    def queue_error(self, code: int, message: str) -> None:
        """Put an error into the 6221's error queue (delivered with the next command it receives)."""
        self._injected_errors.append((int(code), str(message)))


# ---------------------------------------------------------------------------------------------------- devices
def _moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Mean of the last ``n`` values at each position (fewer at the start), as an instrument's moving filter."""
    if n <= 1 or x.size == 0:
        return x
    c = np.cumsum(np.concatenate(([0.0], x)))
    idx = np.arange(1, x.size + 1)
    lo = np.maximum(idx - n, 0)
    return (c[idx] - c[lo]) / (idx - lo)


def _load_definition() -> dict[str, Any]:
    text = resources.files("instruments").joinpath(DEFINITION).read_text(encoding="utf-8")
    return sim_parser._load(StringIO(text))


class _ScpiDevice(Device):
    """A pyvisa-sim Device that receives canonical SCPI commands; settings and static replies come from YAML."""

    # set by pyvisa-sim's Device (untyped): the bytes received so far and the message terminators
    _input_buffer: bytearray
    _query_eom: bytes
    _response_eom: bytes

    def __init__(self, name: str, definition: dict[str, Any]) -> None:
        super().__init__(name, b"")
        self._definition = definition
        for itype, eom in definition.get("eom", {}).items():
            self.add_eom(itype, *sim_parser._get_pair(eom))
        sim_parser.update_component(name, self, definition)
        self.errors: deque[tuple[int, str]] = deque()

    def reset_properties(self) -> None:
        for name, prop in self._definition.get("properties", {}).items():
            self._properties[name].set_value(prop.get("default", ""))

    def prop(self, name: str) -> Any:
        return self._properties[name].get_value()

    def push_error(self, err: tuple[int, str]) -> None:
        if len(self.errors) < 32:
            self.errors.append(err)
        else:  # the queue is full: the last entry becomes "Queue overflow", as on SCPI instruments
            self.errors[-1] = (-350, "Queue overflow")

    def static(self, cmd: Command) -> str | None:
        """Answer ``cmd`` from the YAML table; queue an error if it is unknown or rejected; None = no reply."""
        text = cmd.text
        if cmd.header.split("?")[0] in _BOOLEAN_HEADERS and cmd.params:
            p = cmd.params.strip().upper()
            text = f"{cmd.header} {dict(ON='1', OFF='0').get(p, p)}"
        response = self._match(text.encode("latin-1"))
        if response is None:
            self.push_error(E_UNDEFINED)
            return None
        if response is NoResponse:
            return None
        if response.startswith(b"ERR:"):
            code = int(response[4:])
            self.push_error((code, _ERROR_TEXT.get(code, "Error")))
            return None
        return response.decode("latin-1")


class Simulated2182A(_ScpiDevice):
    """The 2182A behind the 6221's RS-232 port (reached only through the relay)."""

    def convert(self, bench: SimulatedBench, t_s: np.ndarray, currents: np.ndarray, nplc: float) -> np.ndarray:
        """The conversions of one Delta run (V; +9.9E37 over range): channel 2 sees no sample current, a digital
        filter left on averages consecutive conversions (across polarities, which wrecks the Delta readings)."""
        if int(self.prop("channel")) != 1:
            currents = np.zeros_like(currents)
        volts = bench.model.conversion_voltages(t_s, currents, nplc, bench.rng)
        if self.prop("digital_filter"):
            volts = _moving_mean(volts, int(self.prop("digital_filter_count")))
        if not self.prop("range_auto"):
            volts = np.where(np.abs(volts) > 1.2 * float(self.prop("range")), OVERFLOW, volts)
        return volts

    def handle(self, message: str) -> str | None:
        replies = []
        for cmd in parse_message(message):
            if cmd.header == "SENS:VOLT:RANG" and cmd.params:
                r = self.static(cmd)
                if not self.errors:
                    self._properties["range_auto"].set_value("0")
            elif cmd.header == "*RST":
                self.reset_properties()
                r = None
            else:
                r = self.static(cmd)
            if r is not None:
                replies.append(r)
        return ";".join(replies) if replies else None


@dataclass
class _Sweep:
    """A Delta run: every reading precomputed with the instrument time (s after INIT) when it is stored."""

    started_real: float
    readings: np.ndarray
    stamps: np.ndarray
    ready_s: np.ndarray
    end_s: float
    aborted_at_s: float | None
    source_a: np.ndarray = field(default_factory=lambda: np.empty(0))
    finished: bool = False
    stopped_n: int | None = None


class SimulatedK6221(_ScpiDevice):
    """The simulated 6221 at one VISA address (a pyvisa-sim Device with SCPI parsing and Delta physics)."""

    def __init__(
        self, name: str, definition: dict[str, Any], voltmeter_def: dict[str, Any], bench: SimulatedBench
    ) -> None:
        super().__init__(name, definition)
        self.bench = bench
        self.voltmeter = Simulated2182A("k2182a", voltmeter_def)
        self._out: deque[bytes] = deque()
        self._out_pos = 0
        self._armed_at: float | None = None
        self._sweep: _Sweep | None = None
        self._oper_event = 0
        self._meas_event = 0
        self._relay_out = ""
        self._relay_pending: deque[str] = deque()
        self._handlers: dict[str, Callable[[Command], str | None]] = {
            "*RST": self._rst,
            "*CLS": self._cls,
            "SYST:ERR?": lambda c: self._pop_error(),
            "SOUR:DELT:NVPR?": lambda c: "0" if self.bench.faults.voltmeter_absent else "1",
            "SOUR:DELT:ARM": self._arm,
            "SOUR:DELT:ARM?": lambda c: "1" if self._is_armed() else "0",
            "INIT:IMM": self._init,
            "SOUR:SWE:ABOR": self._abort,
            "STAT:OPER:EVEN?": self._read_oper,
            "STAT:MEAS:EVEN?": self._read_meas,
            "TRAC:CLE": self._trace_clear,
            "TRAC:POIN:ACT?": lambda c: str(self._stored()),
            "TRAC:DATA?": self._trace_data,
            "TRAC:DATA:SEL?": self._trace_data_sel,
            "SENS:DATA?": self._latest,
            "SENS:DATA:FRES?": self._latest,
            "SYST:COMM:SER:SEND": self._relay_send,
            "SYST:COMM:SER:ENT?": self._relay_enter,
            "SOUR:DELT:HIGH": self._set_high,
            "SOUR:CURR:RANG": self._set_range,
            "UNIT": self._keyword,
            "OUTP:ISH": self._keyword,
            "SENS:AVER:TCON": self._keyword,
            "TRAC:TST:FORM": self._keyword,
            "TRAC:FEED": self._keyword,
            "TRAC:FEED:CONT": self._keyword,
            "FORM:ELEM": self._form_elem,
        }

    # ---------------------------------------------------------------- VISA side: buffers
    def write(self, data: bytes) -> None:
        if not isinstance(data, bytes):
            raise TypeError("data must be an instance of bytes")
        self._input_buffer.extend(data)
        if not self._input_buffer.endswith(self._query_eom):
            return
        message = bytes(self._input_buffer[: -len(self._query_eom)]).decode("latin-1")
        self._input_buffer = bytearray()
        reply = self.handle(message)
        if reply is not None:
            self._out.append(reply.encode("latin-1") + self._response_eom)

    def read(self) -> tuple[bytes, bool]:
        """One byte, as pyvisa-sim's sessions expect (O(1): no bytearray.pop(0))."""
        chunk, end = self.read_chunk(1, None)
        return chunk, end

    def read_chunk(self, count: int, termchar: bytes | None) -> tuple[bytes, bool]:
        """Up to ``count`` bytes of the current reply, stopping after ``termchar``; end = reply exhausted."""
        if not self._out:
            return b"", False
        buf = self._out[0]
        stop = min(len(buf), self._out_pos + count)
        if termchar is not None:
            k = buf.find(termchar, self._out_pos, stop)
            if k >= 0:
                stop = k + 1
        chunk = buf[self._out_pos : stop]
        if stop >= len(buf):
            self._out.popleft()
            self._out_pos = 0
            return chunk, True
        self._out_pos = stop
        return chunk, False

    # ---------------------------------------------------------------- message handling
    def handle(self, message: str) -> str | None:
        """Execute one program message; return the response message (``;``-joined query replies) or None."""
        while self.bench._injected_errors:
            self.push_error(self.bench._injected_errors.popleft())
        self._advance()
        replies = []
        faults = self.bench.faults
        for cmd in parse_message(message):
            if not cmd.header:
                self.push_error(E_UNDEFINED)
                continue
            handler = self._handlers.get(cmd.header)
            reply = handler(cmd) if handler is not None else self.static(cmd)
            if cmd.header in faults.garbage:
                reply = faults.garbage[cmd.header]
            if cmd.header in faults.silent:
                reply = None
            if reply is not None:
                replies.append(reply)
        return ";".join(replies) if replies else None

    def _pop_error(self) -> str:
        if not self.errors:
            return '0,"No error"'
        code, msg = self.errors.popleft()
        return f'{code:d},"{msg}"'

    def _rst(self, cmd: Command) -> None:
        self._abort(cmd)
        self.reset_properties()
        self._sweep = None
        return None

    def _cls(self, cmd: Command) -> None:
        self.errors.clear()
        self._oper_event = 0
        self._meas_event = 0
        return None

    def _set_high(self, cmd: Command) -> None:
        before = len(self.errors)
        self.static(cmd)
        if len(self.errors) == before:  # setting HIGH also sets LOW to -HIGH
            self._properties["delta_low"].set_value(str(-self.prop("delta_high")))
        return None

    def _set_range(self, cmd: Command) -> None:
        before = len(self.errors)
        self.static(cmd)
        if len(self.errors) == before:
            self._properties["current_range_auto"].set_value("0")
        return None

    def _keyword(self, cmd: Command) -> str | None:
        p = cmd.params.strip().upper()
        return self.static(Command(cmd.header, _KEYWORDS.get(p, p), cmd.raw))

    def _form_elem(self, cmd: Command) -> str | None:
        if cmd.is_query:
            return self.static(cmd)
        given = split_params(cmd.params)
        elems = [_ELEMENTS[p.upper()] for p in given if p.upper() in _ELEMENTS]
        if not elems or len(elems) != len(given) or len(set(elems)) != len(elems):
            self.push_error(E_ILLEGAL)
            return None
        return self.static(Command(cmd.header, ",".join(elems), cmd.raw))

    # ---------------------------------------------------------------- time
    def _now_s(self, since_real: float) -> float:
        """Instrument seconds elapsed since ``since_real`` (infinite when time_scale is 0)."""
        if self.bench.time_scale == 0:
            return math.inf
        return (self.bench.clock() - since_real) / self.bench.time_scale

    def _is_armed(self) -> bool:
        return self._armed_at is not None and self._now_s(self._armed_at) >= self.bench.arm_time_s

    def _advance(self) -> None:
        """Bring the sweep up to the current time: latch done / aborted into the operation event register."""
        sw = self._sweep
        if sw is None or sw.finished:
            return
        now = self._now_s(sw.started_real)
        if sw.aborted_at_s is not None and now >= sw.aborted_at_s:
            sw.finished = True
            self._oper_event |= 1 << 2
        elif sw.aborted_at_s is None and now >= sw.end_s:
            sw.finished = True
            self._oper_event |= (1 << 1) | (1 << 10)

    def _stored(self) -> int:
        sw = self._sweep
        if sw is None:
            return 0
        if sw.stopped_n is not None:
            return sw.stopped_n
        return int(np.searchsorted(sw.ready_s, self._now_s(sw.started_real), side="right"))

    # ---------------------------------------------------------------- Delta
    def _arm(self, cmd: Command) -> None:
        if self.bench.faults.voltmeter_absent:
            self.push_error(E_HW_MISSING)
            return None
        running = self._sweep is not None and not self._sweep.finished
        if running or self.prop("trace_points") < self.prop("delta_count"):
            self.push_error(E_CONFLICT)
            return None
        self._armed_at = self.bench.clock()
        return None

    def _abort(self, cmd: Command) -> None:
        sw = self._sweep
        if sw is not None and not sw.finished:
            sw.stopped_n = self._stored()
            sw.finished = True
            self._oper_event |= 1 << 2  # the running sweep was aborted
        self._armed_at = None
        return None

    def _trace_clear(self, cmd: Command) -> None:
        if self._sweep is not None and not self._sweep.finished:
            self.push_error(E_CONFLICT)
            return None
        self._sweep = None
        return None

    def _init(self, cmd: Command) -> None:
        if not self._is_armed():
            self.push_error(E_CONFLICT)
            return None
        self._armed_at = None
        self._sweep = self._simulate_sweep()
        self._oper_event |= 1 << 3
        self._advance()
        return None

    def _simulate_sweep(self) -> _Sweep:
        b = self.bench
        count = int(self.prop("delta_count"))
        high, low = float(self.prop("delta_high")), float(self.prop("delta_low"))
        nplc = float(self.voltmeter.prop("nplc"))
        period = float(self.prop("delta_delay")) + nplc / b.line_frequency_hz + b.conversion_overhead_s
        n_conv = count + 2
        t_inst = b.instrument_time_s + period * np.arange(1, n_conv + 1)
        currents = np.where(np.arange(n_conv) % 2 == 0, high, low)
        loop_ohm = b.resistance_ohm + b.lead_resistance_ohm
        compliance = float(self.prop("compliance"))
        if max(abs(high), abs(low)) * loop_ohm > compliance:
            self._meas_event |= 1 << 3  # latched until STAT:MEAS:EVEN? reads it
            if self.prop("delta_cab"):
                b.instrument_time_s += period
                return _Sweep(b.clock(), np.empty(0), np.empty(0), np.empty(0), period, period)
            # the source cannot drive more than compliance / loop resistance
            limit = compliance / loop_ohm if loop_ohm > 0 else math.inf
            currents = np.clip(currents, -limit, limit)
        volts = self.voltmeter.convert(b, t_inst, currents, nplc)
        deltas = delta_readings(np.where(volts >= OVERFLOW, 0.0, volts))
        over = volts >= OVERFLOW
        bad = over[:-2] | over[1:-1] | over[2:]
        if self.prop("unit") == "OHMS":
            deltas = deltas / ((high - low) / 2.0)
        deltas = self._filtered(deltas)
        for i in b.faults.overflow_readings:
            if 0 <= i < count:
                bad[i] = True
        if bad.any():
            self._meas_event |= 1
        deltas = np.where(bad, OVERFLOW, deltas)
        ready = period * np.arange(3, n_conv + 1)
        b.instrument_time_s += period * n_conv
        # SOUR element: the source value at the last conversion of each reading (which value the 6221 reports is
        # not documented in the material we have; unverified).
        return _Sweep(b.clock(), deltas, ready - ready[0], ready, float(ready[-1]), None, currents[2:])

    def _filtered(self, deltas: np.ndarray) -> np.ndarray:
        """What the 6221 does to Delta readings before they reach the buffer: its averaging filter
        (``SENS:AVER``, moving or repeating over ``SENS:AVER:COUN``) and, with the buffer fed from ``CALC1``, the
        mX+b math. Off in a pinned session; a previous user may have left either on."""
        out = deltas
        if self.prop("filter_state"):
            n = int(self.prop("filter_count"))
            if self.prop("filter_type") == "REP":  # each reading replaced by the mean of its group of n
                groups = np.arange(out.size) // n
                sums = np.bincount(groups, weights=out)
                out = (sums / np.bincount(groups))[groups]
            else:
                out = _moving_mean(out, n)
        if self.prop("trace_feed") == "CALC1" and self.prop("calc1_state"):
            out = float(self.prop("calc1_mmf")) * out + float(self.prop("calc1_mbf"))
        return out

    def _read_oper(self, cmd: Command) -> str:
        value, self._oper_event = self._oper_event, 0
        return str(value)

    def _read_meas(self, cmd: Command) -> str:
        value, self._meas_event = self._meas_event, 0
        return str(value)

    def _format(self, start: int, stop: int) -> str:
        sw = self._sweep
        assert sw is not None
        elems = str(self.prop("format_elements")).split(",")
        stamps = sw.stamps
        if self.prop("trace_tst_format") == "DELT":  # time since the previous reading
            stamps = np.diff(sw.stamps, prepend=sw.stamps[:1])
        cols = {
            "READ": lambda: sw.readings[start:stop],
            "TST": lambda: stamps[start:stop],
            "RNUM": lambda: np.arange(start, stop, dtype=float),
            "SOUR": lambda: sw.source_a[start:stop],
        }
        arrays = [cols[e]() for e in elems]
        flat = np.column_stack(arrays).ravel()
        return ",".join(f"{x:+.6E}" for x in flat.tolist())

    def _trace_data(self, cmd: Command) -> str | None:
        n = self._stored()
        if n == 0:
            self.push_error(E_STALE)
            return None
        return self._format(0, n)

    def _trace_data_sel(self, cmd: Command) -> str | None:
        params = split_params(cmd.params)
        try:
            start, count = (int(p) for p in params)
        except ValueError:
            self.push_error(E_ILLEGAL)
            return None
        if start < 0 or count < 1 or start + count > self._stored():
            self.push_error(E_OUT_OF_RANGE)
            return None
        return self._format(start, start + count)

    def _latest(self, cmd: Command) -> str | None:
        n = self._stored()
        if self._sweep is None or self._sweep.finished or n == 0:
            self.push_error(E_STALE)
            return None
        return f"{self._sweep.readings[n - 1]:+.6E}"

    # ---------------------------------------------------------------- serial relay
    def _relay_send(self, cmd: Command) -> None:
        params = split_params(cmd.params)
        if len(params) != 1:
            self.push_error(E_ILLEGAL)
            return None
        if self.bench.faults.voltmeter_absent:
            return None
        reply = self.voltmeter.handle(unquote(params[0]))
        if reply is not None:
            f = self.bench.faults
            line = reply + f.relay_terminator
            pieces = max(int(f.relay_pieces), 0)
            if pieces:
                cut = np.linspace(0, len(line), pieces + 1).astype(int)
                self._relay_pending.append("")
                self._relay_pending.extend(line[a:c] for a, c in itertools.pairwise(cut.tolist()))
            else:
                self._relay_pending.append(line)
        return None

    def _relay_enter(self, cmd: Command) -> str:
        text = self._relay_pending.popleft() if self._relay_pending else ""
        if text and self.bench.faults.relay_xoff:
            text = _XOFF + _XOFF + text
        return text


# ---------------------------------------------------------------------------------------------------- library
class BenchVisaLibrary(SimVisaLibrary):
    """pyvisa-sim's SimVisaLibrary with the simulated bench's devices and chunked reads.

    Construct through :meth:`create` (or :func:`simulated_resource_manager`): every instance is new (PyVISA
    otherwise caches one library per path for the whole process, which leaks state between tests).
    """

    _pending: ClassVar[dict[str, SimulatedBench]] = {}
    _serial: ClassVar[int] = 0

    @classmethod
    def create(cls, bench: SimulatedBench) -> BenchVisaLibrary:
        cls._serial += 1
        key = f"contactrig-bench-{cls._serial}-{id(bench):x}"
        cls._pending[key] = bench
        try:
            lib = cls(key)
        finally:
            cls._pending.pop(key, None)
        # Drop PyVISA's process-wide cache entry so the next call builds a new library.
        pyvisa.highlevel.VisaLibraryBase._registry.pop((cls, lib.library_path), None)
        return lib

    def _init(self) -> None:
        self.sessions: dict[Any, Any] = {}
        bench = self._pending.get(str(self.library_path))
        if bench is None:
            raise OSError("BenchVisaLibrary must be created with BenchVisaLibrary.create(bench)")
        self.bench = bench
        data = _load_definition()
        self.devices = Devices()
        for address, res in data["resources"].items():
            device = SimulatedK6221(res["device"], data["devices"][res["device"]], data["devices"]["k2182a"], bench)
            self.devices.add_device(pyvisa.rname.to_canonical_name(address), device)

    def open(self, session: Any, resource_name: str, *args: Any, **kwargs: Any) -> tuple[Any, constants.StatusCode]:
        """As pyvisa-sim's, but an unknown address raises (pyvisa-sim 0.7 returns session 0 and the error status,
        which PyVISA does not check here, so the "open" resource silently answers nothing)."""
        handle, status = super().open(session, resource_name, *args, **kwargs)
        if status < 0:
            raise pyvisa.errors.VisaIOError(int(status))
        return handle, status

    def read(self, session: Any, count: int) -> tuple[bytes, constants.StatusCode]:
        """Read up to ``count`` bytes at once (pyvisa-sim reads byte by byte, quadratic in the reply size)."""
        sess = self.sessions.get(session)
        device = getattr(sess, "device", None)
        if sess is None or not isinstance(device, SimulatedK6221):
            return super().read(session, count)
        attr = constants.ResourceAttribute
        timeout_ms, _ = sess.get_attribute(attr.timeout_value)
        termchar_on, _ = sess.get_attribute(attr.termchar_enabled)
        termchar, _ = sess.get_attribute(attr.termchar)
        suppress_end, _ = sess.get_attribute(attr.suppress_end_enabled)
        stop = bytes([termchar]) if termchar_on else None
        timeout_s = math.inf if timeout_ms in (None, constants.VI_TMO_INFINITE) else timeout_ms / 1000.0
        start = time.monotonic()
        while True:
            chunk, end = device.read_chunk(count, stop)
            if chunk:
                if end and not suppress_end:
                    return chunk, constants.StatusCode.success
                if stop is not None and chunk.endswith(stop):
                    return chunk, constants.StatusCode.success_termination_character_read
                return chunk, constants.StatusCode.success_max_count_read
            if time.monotonic() - start > timeout_s:
                raise pyvisa.errors.VisaIOError(constants.VI_ERROR_TMO)
            time.sleep(0.002)


def simulated_resource_manager(bench: SimulatedBench | None = None) -> pyvisa.ResourceManager:
    """A new :class:`pyvisa.ResourceManager` on a new simulated bench library (default bench if None)."""
    return pyvisa.ResourceManager(BenchVisaLibrary.create(bench if bench is not None else SimulatedBench()))
