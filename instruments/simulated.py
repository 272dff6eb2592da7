"""A simulated Keithley 6221 + 2182A bench on pyvisa-sim, with physics behind the readings.

``simulated_resource_manager(bench=...)`` returns a fresh :class:`pyvisa.ResourceManager` whose VISA library is a
:class:`BenchVisaLibrary` (a pyvisa-sim ``SimVisaLibrary`` subclass). The 6221 answers at ``GPIB0::12::INSTR``
and ``TCPIP0::127.0.0.1::1394::SOCKET`` or, with ``SimulatedBench.any_address`` (``acquire --sim``), at any valid
VISA resource name (``ASRL/dev/ttyUSB0::INSTR``, ``TCPIP0::192.168.0.50::1394::SOCKET`` …); nothing is contacted.
Static replies, settings and their ranges come from the packaged YAML definition (``k6221_sim.yaml``); a
:class:`SimulatedK6221` (a pyvisa-sim ``Device`` subclass) parses SCPI as the real instrument does
(:mod:`instruments.scpi`) and implements the dynamic part in Python: Delta arming and sweeps, the reading buffer,
status event registers, the error queue and the serial relay to the 2182A.

Physics (:class:`ContactVoltageModel`, pluggable): every 2182A conversion is ±I·R + thermal EMF + drift + noise,
and the simulated 6221 forms the 3-point Delta readings from the conversions (:func:`instruments.delta.delta_readings`),
so EMF cancellation is real, not assumed. Instrument time (arming, delay, NPLC) is simulated and scaled by
``time_scale`` (1 = real pace, 0 = instant). Relies on pyvisa-sim 0.7 internals (see :data:`PYVISA_SIM_RANGE`).
"""

from __future__ import annotations

import functools
import itertools
import math
import time
from collections import deque
from collections.abc import Callable, Iterable
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
from pyvisa_sim.sessions.serial import SerialInstrumentSession
from pyvisa_sim.sessions.session import Session

from contactrig.core.validation import check_choice, check_range
from instruments.commands import (
    K2182A,
    K2182A_ACTIONS,
    K6221,
    K6221_ACTIONS,
    NPLC_MAX_50HZ,
    Action,
    ScpiError,
    Setting,
)
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

# SCPI error codes used by the simulator (SCPI-99 numbers, as the 6221 and 2182A report them).
E_INVALID_CHARACTER = (-101, "Invalid character")
E_UNDEFINED = (-113, "Undefined header")
E_CONFLICT = (-221, "Settings conflict")
E_OUT_OF_RANGE = (-222, "Data out of range")
E_ILLEGAL = (-224, "Illegal parameter value")
E_STALE = (-230, "Data corrupt or stale")
E_HW_MISSING = (-241, "Hardware missing")
E_INTERRUPTED = (-410, "Query INTERRUPTED")
E_QUEUE_OVERFLOW = (-350, "Queue overflow")
E_INPUT_OVERRUN = (-363, "Input buffer overrun")
#: what the served simulator queues when its own code fails on a message (a bug; logged, the service goes on)
E_INTERNAL = (-300, "Device-specific error")
#: Buffer elements in the instrument's fixed order, whatever the order in FORM:ELEM (RM 6-12).
ELEMENT_ORDER = ("READ", "TST", "SOUR", "AVOL", "COMP", "RNUM")
_ELEMENT_NAMES = {"READ": "READ", "READING": "READ", "TST": "TST", "TSTAMP": "TST", "SOUR": "SOUR", "SOURCE": "SOUR"}
_ELEMENT_NAMES |= {"AVOL": "AVOL", "AVOLTAGE": "AVOL", "COMP": "COMP", "COMPLIANCE": "COMP", "RNUM": "RNUM"}
_ELEMENT_NAMES |= {"RNUMBER": "RNUM", "UNIT": "UNIT", "UNITS": "UNIT"}
_READING_SUFFIX = {"V": "VDC", "OHMS": "OHM", "W": "W", "SIEM": "SIEM"}
_ELEMENT_SUFFIX = {"TST": "SECS", "SOUR": "ADC", "AVOL": "VDC", "COMP": "", "RNUM": "RDNG#"}
#: Standard event status register bit for each class of error (IEEE 488.2): QYE, DDE, EXE, CME.
_ESR_BITS = ((-499, -400, 1 << 2), (-399, -300, 1 << 3), (-299, -200, 1 << 4), (-199, -100, 1 << 5))
_XOFF = "\x13"
#: CALCulate2 statistics of buffer readings (both instruments; SDEV is the sample standard deviation).
_STATISTICS: dict[str, Callable[[np.ndarray], Any]] = {
    "MEAN": np.mean,
    "MAX": np.max,
    "MIN": np.min,
    "SDEV": lambda x: np.std(x, ddof=1) if x.size > 1 else 0.0,
    "PKPK": np.ptp,
}


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
        #: The 6221's RS-232 terminator (its front-panel TX TERM) at an ``ASRL`` address: it ends messages both ways.
        self.serial_terminator = "\n"
        #: True: the 6221 answers at any valid VISA resource name (``acquire --sim``: rehearsed at the address the
        #: real bench will use); False: only at :data:`GPIB_ADDRESS` and :data:`SOCKET_ADDRESS` (an empty address
        #: then looks as it does on hardware).
        self.any_address = False
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


def _resolve(header: str, table: dict[str, Setting], known: Iterable[str], root: str) -> str:
    """The header the instrument implements: as given, or with its optional root node (``SOUR:``, ``SENS:``)."""
    base = header.rstrip("?")
    if base.startswith(root.rstrip(":") + "1:"):  # SOUR1 = SOUR
        base = root + base[len(root) + 1 :]
        header = base + ("?" if header.endswith("?") else "")
    if base in table or header in known or base.startswith("*"):
        return header
    rooted = root + header
    return rooted if rooted.rstrip("?") in table or rooted in known else header


def _static_reply(reply: str | None) -> Callable[[Command], str | None]:
    """A handler that answers ``reply`` (None: an event accepted with no effect on the simulated bench)."""

    def handler(cmd: Command) -> str | None:
        return reply

    return handler


class _ScpiDevice(Device):
    """A pyvisa-sim Device that receives canonical SCPI commands. Settings are those of one command table
    (:mod:`instruments.commands`): parsed, range-checked, stored and answered from their declarations; static
    replies (``*IDN?``) come from the YAML dialogues; anything else is handled in Python (``handlers``)."""

    # set by pyvisa-sim's Device (untyped): the bytes received so far and the message terminators
    _input_buffer: bytearray
    _query_eom: bytes
    _response_eom: bytes
    root = ""
    #: headers that are another header on this instrument (``UNIT:VOLT:DC`` is ``UNIT`` on the 6221)
    aliases: ClassVar[dict[str, str]] = {}

    def __init__(
        self, name: str, definition: dict[str, Any], table: dict[str, Setting], actions: dict[str, Action]
    ) -> None:
        super().__init__(name, b"")
        for itype, eom in definition.get("eom", {}).items():
            self.add_eom(itype, *sim_parser._get_pair(eom))
        sim_parser.update_component(name, self, definition)
        self.table = table
        self.actions = actions
        self.values: dict[str, Any] = {h: s.default for h, s in table.items()}
        self._by_key = {s.key: h for h, s in table.items()}
        self.errors: deque[tuple[int, str]] = deque()
        self.esr = 0
        self.handlers: dict[str, Callable[[Command], str | None]] = {}

    def bind_actions(self) -> None:
        """Complete ``handlers`` from the action table: a static reply answers, an event without a handler is accepted
        with no effect. Every handler must be declared (in the action or the setting table) and every computed
        query must have a handler: the table is the whole command surface."""
        for header, action in self.actions.items():
            if header in self.handlers:
                continue
            assert action.reply is not None or not action.is_query, f"{header}: a computed query needs a handler"
            self.handlers[header] = _static_reply(action.reply)
        undeclared = [h for h in self.handlers if h not in self.actions and h.rstrip("?") not in self.table]
        assert not undeclared, f"handlers without a declaration: {undeclared}"

    _calc2: float

    def _calc2_readings(self) -> np.ndarray:
        """The buffer's valid readings (overflows left out), which ``CALC2`` works on."""
        raise NotImplementedError

    def _calc2_immediate(self, cmd: Command) -> None:
        """``CALC2:IMM``: the statistic ``CALC2:FORM`` of the buffer's valid readings (−230 when there are none)."""
        r = self._calc2_readings()
        if not r.size:
            self.push_error(E_STALE)
            return None
        self._calc2 = float(_STATISTICS[str(self.prop("calc2_format"))](r))
        return None

    def _calc2_query(self, cmd: Command) -> str | None:
        before = len(self.errors)
        self._calc2_immediate(cmd)
        return f"{self._calc2:+.8E}" if len(self.errors) == before else None

    def reset_settings(self) -> None:
        """``*RST``: every setting the manual resets goes back to its default."""
        for header, s in self.table.items():
            if s.reset:
                self.values[header] = s.default

    def prop(self, key: str) -> Any:
        """The current value of the setting with Python name ``key``."""
        return self.values[self._by_key[key]]

    def set_prop(self, key: str, value: Any) -> None:
        self.values[self._by_key[key]] = value

    def push_error(self, err: tuple[int, str]) -> None:
        for lo, hi, bit in _ESR_BITS:
            if lo <= err[0] <= hi:
                self.esr |= bit
        if len(self.errors) < 32:
            self.errors.append(err)
        else:  # the queue is full: the last entry becomes "Queue overflow", as on SCPI instruments
            self.errors[-1] = E_QUEUE_OVERFLOW

    def pop_error(self, cmd: Command | None = None) -> str:
        if not self.errors:
            return '0,"No error"'
        code, msg = self.errors.popleft()
        return f'{code:d},"{msg}"'

    def error_handlers(self) -> dict[str, Callable[[Command], str | None]]:
        """The error queue's commands (SYSTem:ERRor, STATus:QUEue, SYSTem:CLEar) the instrument declares."""
        every: dict[str, Callable[[Command], str | None]] = {
            "SYST:ERR?": self.pop_error,
            "STAT:QUE?": self.pop_error,
            "SYST:ERR:ALL?": lambda c: ",".join(self._drain()) if self.errors else '0,"No error"',
            "SYST:ERR:COUN?": lambda c: str(len(self.errors)),
            "SYST:ERR:CODE?": lambda c: self.pop_error().split(",", 1)[0],
            "SYST:ERR:CODE:ALL?": lambda c: ",".join(e.split(",", 1)[0] for e in self._drain()) or "0",
            "SYST:CLE": lambda c: self.errors.clear(),
            "STAT:QUE:CLE": lambda c: self.errors.clear(),
        }
        return {h: f for h, f in every.items() if h in self.actions}

    def _drain(self) -> list[str]:
        out = []
        while self.errors:
            out.append(self.pop_error())
        return out

    def execute(self, cmd: Command) -> str | None:
        """One command: a handler, a declared setting, a static dialogue, or −113 (−101 for a non-ASCII byte)."""
        if cmd.invalid_character:
            self.push_error(E_INVALID_CHARACTER)
            return None
        if not cmd.header:
            self.push_error(E_UNDEFINED)
            return None
        base = cmd.header.rstrip("?")
        header = _resolve(
            self.aliases.get(base, base) + cmd.header[len(base) :], self.table, self.handlers, self.root
        )
        if header != cmd.header:
            cmd = Command(header, cmd.params, cmd.raw)
        handler = self.handlers.get(header)
        if handler is not None:
            return handler(cmd)
        if header.rstrip("?") in self.table:
            return self.setting(cmd)
        return self.static(cmd)

    def setting(self, cmd: Command) -> str | None:
        """Set or query a declared setting (``MIN``/``MAX``/``DEF`` after a query give the limits)."""
        header = cmd.header.rstrip("?")
        s = self.table[header]
        if cmd.is_query:
            if not cmd.params:
                return s.reply(self.values[header])
            reply = s.limit_reply(cmd.params)
            if reply is None:
                self.push_error(E_ILLEGAL)
            return reply
        try:
            self.values[header] = s.parse(cmd.params)
        except ScpiError as err:
            self.push_error((err.code, err.message))
        return None

    def set_ok(self, cmd: Command) -> bool:
        """Apply a setting command; True if the instrument took it."""
        before = len(self.errors), self.esr
        self.setting(cmd)
        return (len(self.errors), self.esr) == before

    def static(self, cmd: Command) -> str | None:
        """Answer ``cmd`` from the YAML dialogues; queue −113 if it is unknown; None = no reply.

        Only ASCII reaches pyvisa-sim's matcher (it decodes as UTF-8 and raises on anything else); the dialogues are
        ASCII, so a text that is not cannot match."""
        text = cmd.text
        if not text.isascii():
            self.push_error(E_UNDEFINED)
            return None
        response = self._match(text.encode("ascii"))
        if response is None:
            self.push_error(E_UNDEFINED)
            return None
        if response is NoResponse:
            return None
        return response.decode("latin-1")

    def run(self, message: str) -> list[str]:
        """Execute one program message; the replies of its queries, in order."""
        replies = []
        for cmd in parse_message(message):
            reply = self.execute(cmd)
            if reply is not None:
                replies.append(reply)
        return replies


class Simulated2182A(_ScpiDevice):
    """The 2182A behind the 6221's RS-232 port (reached only through the relay); ``SENSe`` is optional."""

    root = "SENS:"
    aliases: ClassVar[dict[str, str]] = {"UNIT:VOLT:DC": "UNIT:VOLT"}

    def __init__(self, name: str, definition: dict[str, Any], bench: SimulatedBench | None = None) -> None:
        super().__init__(name, definition, K2182A, K2182A_ACTIONS)
        self.bench = bench if bench is not None else SimulatedBench()
        self.source_current_a: Callable[[], float] = lambda: 0.0
        self._last = OVERFLOW
        self._fresh = False
        self._buffer: list[float] = []
        self._calc2 = math.nan
        self.handlers.update(self.error_handlers())
        self.handlers.update(
            {
                "*RST": lambda c: self.reset_settings(),
                "SYST:PRES": lambda c: self.reset_settings(),
                "*CLS": lambda c: self._clear_status(),
                "*ESR?": self._read_esr,
                "*STB?": lambda c: str(4 if self.errors else 0),
                "*OPC": self._opc,
                "STAT:PRES": lambda c: self._preset_enables(),
                "SYST:LFR?": lambda c: f"{self.bench.line_frequency_hz:g}",
                "SENS:VOLT:RANG": self._set_range,
                "SENS:VOLT:NPLC": self._set_nplc,
                "SENS:VOLT:APER": self._aperture,
                "SENS:VOLT:APER?": self._aperture,
                "SENS:VOLT:REF:ACQ": lambda c: self.set_prop("reference", self._last if self._last < OVERFLOW else 0.0),
                "READ?": self._read,
                "FETC?": lambda c: f"{self._last:+.8E}",
                "SENS:DATA?": lambda c: f"{self._last:+.8E}",
                "SENS:DATA:FRES?": self._fresh_reading,
                "CALC1:DATA?": lambda c: f"{self._last:+.8E}",
                "TRAC:CLE": lambda c: self._buffer.clear(),
                "TRAC:DATA?": self._trace_data,
                "TRAC:FREE?": self._trace_free,
                "TRAC:POIN:ACT?": lambda c: str(len(self._buffer)),
                "CALC2:IMM": self._calc2_immediate,
                "CALC2:IMM?": self._calc2_query,
                "CALC2:DATA?": lambda c: f"{self._calc2:+.8E}",
            }
        )
        self.bind_actions()

    def _clear_status(self) -> None:
        self.errors.clear()
        self.esr = 0

    def _preset_enables(self) -> None:
        for key in ("meas_enable", "oper_enable", "ques_enable"):
            self.set_prop(key, 0)

    def _read_esr(self, cmd: Command) -> str:
        value, self.esr = self.esr, 0
        return str(value)

    def _opc(self, cmd: Command) -> None:
        self.esr |= 1
        return None

    def _aperture(self, cmd: Command) -> str | None:
        """``SENS:VOLT:APER``: the integration time in seconds, coupled to NPLC (aperture = NPLC / mains Hz)."""
        lfr = self.bench.line_frequency_hz
        if cmd.is_query:
            self.set_prop("aperture", float(self.prop("nplc")) / lfr)
            return self.setting(cmd)
        if self.set_ok(cmd):
            nplc = Command("SENS:VOLT:NPLC", f"{float(self.prop('aperture')) * lfr:.12g}", cmd.raw)
            self._set_nplc(nplc)
        return None

    def _fresh_reading(self, cmd: Command) -> str | None:
        if not self._fresh:
            self.push_error(E_STALE)
            return None
        self._fresh = False
        return f"{self._last:+.8E}"

    def _trace_free(self, cmd: Command) -> str:
        """Bytes free and in use; 16 bytes per reading (the instrument's own figure is unverified)."""
        used = len(self._buffer) * 16
        return f"{int(self.prop('trace_points')) * 16 - used},{used}"

    def _trace_data(self, cmd: Command) -> str | None:
        if not self._buffer:
            self.push_error(E_STALE)
            return None
        return ",".join(f"{x:+.8E}" for x in self._buffer)

    def _calc2_readings(self) -> np.ndarray:
        return np.array([x for x in self._buffer if abs(x) < OVERFLOW])

    def _set_range(self, cmd: Command) -> str | None:
        if cmd.is_query:
            return self.setting(cmd)
        if self.set_ok(cmd):
            self.set_prop("range_auto", False)  # a fixed range turns auto range off
        return None

    def _set_nplc(self, cmd: Command) -> str | None:
        if cmd.is_query:
            return self.setting(cmd)
        old = self.prop("nplc")
        if cmd.params.strip().upper().startswith("MAX") and self.bench.line_frequency_hz == 50.0:
            cmd = Command(cmd.header, f"{NPLC_MAX_50HZ:g}", cmd.raw)  # MAX is 50 PLC on 50 Hz mains
        if self.set_ok(cmd) and self.bench.line_frequency_hz == 50.0 and self.prop("nplc") > NPLC_MAX_50HZ:
            self.set_prop("nplc", old)
            self.push_error(E_OUT_OF_RANGE)
        return None

    def _read(self, cmd: Command) -> str:
        """One conversion at the 6221's DC output current (0 when its output is off), less the rel value, through
        the math (mX+b, or percent of b), stored in the buffer while its control is NEXT."""
        t = np.array([self.bench.instrument_time_s])
        current = np.array([self.source_current_a()])
        x = float(self.convert(self.bench, t, current, float(self.prop("nplc")))[0])
        if x < OVERFLOW:
            x -= float(self.prop("reference")) if self.prop("reference_on") else 0.0
            x = self._math(x)
        self._last, self._fresh = x, True
        if self.prop("trace_control") == "NEXT" and len(self._buffer) < int(self.prop("trace_points")):
            self._buffer.append(x)
            if len(self._buffer) == int(self.prop("trace_points")):
                self.set_prop("trace_control", "NEV")  # the buffer is full: storage stops
        return f"{x:+.8E}"

    def _math(self, x: float) -> float:
        if not self.prop("calc_state"):
            return x
        m, b = float(self.prop("calc_mmf")), float(self.prop("calc_mbf"))
        if self.prop("calc_format") == "PERC":  # percent of the reference b (unverified: b as the reference)
            return (x - b) / b * 100.0 if b else OVERFLOW
        return m * x + b

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
        replies = self.run(message)
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
    avol: np.ndarray = field(default_factory=lambda: np.empty(0))
    finished: bool = False
    stopped_n: int | None = None
    endless: bool = False  # SOUR:DELT:COUN INF: fills the buffer and keeps running until aborted


class SimulatedK6221(_ScpiDevice):
    """The simulated 6221 at one VISA address (a pyvisa-sim Device with SCPI parsing and Delta physics).

    IEEE 488.2 message exchange: a LF ends a program message (at an ``ASRL`` address the bench's
    ``serial_terminator``; one write may hold several); a reply left unread when the next message arrives is
    discarded and −410 queued. ``SOURce`` is an optional root (``CURR:COMP`` =
    ``SOUR:CURR:COMP``, ``SOUR1`` = ``SOUR``).
    """

    root = "SOUR:"
    aliases: ClassVar[dict[str, str]] = {"UNIT:VOLT": "UNIT", "UNIT:VOLT:DC": "UNIT"}  # RM 10-14

    def __init__(
        self, name: str, definition: dict[str, Any], voltmeter_def: dict[str, Any], bench: SimulatedBench
    ) -> None:
        super().__init__(name, definition, K6221, K6221_ACTIONS)
        self.bench = bench
        self.voltmeter = Simulated2182A("k2182a", voltmeter_def, bench)
        self.voltmeter.source_current_a = lambda: float(self.prop("source_current")) if self.prop("output") else 0.0
        self._out: deque[bytes] = deque()
        self._out_pos = 0
        self._armed_at: float | None = None
        self._sweep: _Sweep | None = None
        self._oper_event = 0
        self._meas_event = 0
        self._ques_event = 0
        self._calc2 = math.nan
        self._relay_pending: deque[str] = deque()
        self.handlers.update(self.error_handlers())
        self.handlers.update(self._status_handlers())
        self.handlers.update(self._delta_handlers())
        self.handlers.update(self._source_handlers())
        self.bind_actions()

    def _status_handlers(self) -> dict[str, Callable[[Command], str | None]]:
        return {
            "*RST": self._rst,
            "*CLS": self._cls,
            "*ESR?": self._read_esr,
            "*STB?": lambda c: str(self._stb()),
            "*OPC": self._opc,
            "SYST:PRES": self._rst,
            "STAT:PRES": self._preset,
            "STAT:OPER:EVEN?": self._read_oper,
            "STAT:MEAS:EVEN?": self._read_meas,
            "STAT:QUES:EVEN?": self._read_ques,
            "STAT:OPER:COND?": lambda c: self._register(self._oper_condition()),
            "STAT:MEAS:COND?": lambda c: self._register(0),
            "STAT:QUES:COND?": lambda c: self._register(0),
        }

    def _delta_handlers(self) -> dict[str, Callable[[Command], str | None]]:
        return {
            "SOUR:DELT:NVPR?": self._nvpresent,
            "SOUR:PDEL:NVPR?": self._nvpresent,
            "SOUR:DCON:NVPR?": self._nvpresent,
            "SOUR:DELT:ARM": self._arm,
            "SOUR:DELT:ARM?": lambda c: "1" if self._is_armed() else "0",
            "INIT:IMM": self._init,
            "SOUR:SWE:ABOR": self._abort,
            "ABOR": self._abort,  # whether ABORt also stops a Delta run is unverified: the simulation stops it
            "TRAC:CLE": self._trace_clear,
            "TRAC:POIN:ACT?": lambda c: str(self._stored()),
            "TRAC:DATA?": self._trace_data,
            "TRAC:DATA:SEL?": self._trace_data_sel,
            "TRAC:DATA:TYPE?": lambda c: "DELT" if self._stored() else "NONE",
            "SENS:DATA?": self._latest,
            "SENS:DATA:FRES?": self._latest,
            "CALC1:DATA?": self._latest_math,
            "CALC1:DATA:FRES?": self._latest_math,
            "TRAC:FREE?": self._trace_free,
            "CALC2:IMM": self._calc2_immediate,
            "CALC2:IMM?": self._calc2_query,
            "CALC2:DATA?": lambda c: f"{self._calc2:+.8E}",
            "SYST:COMM:SER:SEND": self._relay_send,
            "SYST:COMM:SER:ENT?": self._relay_enter,
            "SOUR:DELT:HIGH": self._set_high,
            "SOUR:CURR:RANG": self._set_range,
            "FORM:ELEM": self._form_elem,
            "FORM:ELEM?": lambda c: ",".join(e for e in (*ELEMENT_ORDER, "UNIT") if e in self._elements),
        }

    def _source_handlers(self) -> dict[str, Callable[[Command], str | None]]:
        """Commands whose manual side effects touch other settings: the source, sweep coupling, lists, buffer."""
        out: dict[str, Callable[[Command], str | None]] = {
            "SOUR:CLE": lambda c: self.set_prop("output", False),
            "TRAC:NOT": self._set_notify,
        }
        for h in ("SOUR:CURR:STAR", "SOUR:CURR:STOP", "SOUR:CURR:STEP", "SOUR:CURR:CENT", "SOUR:CURR:SPAN"):
            out[h] = self._set_sweep
        out["SOUR:SWE:POIN"] = self._set_sweep
        for name, key in (("CURR", "list_current"), ("DEL", "list_delay"), ("COMP", "list_compliance")):
            out[f"SOUR:LIST:{name}:APP"] = functools.partial(self._list_append, key)
            out[f"SOUR:LIST:{name}:POIN?"] = functools.partial(self._list_points, key)
        return out

    def _nvpresent(self, cmd: Command) -> str:
        return "0" if self.bench.faults.voltmeter_absent else "1"

    def _set_sweep(self, cmd: Command) -> str | None:
        """Staircase sweep settings are coupled (RM 4-22): START/STOP set CENT and SPAN, CENT/SPAN set START and
        STOP, and STEP = SPAN / (POIN − 1) except that setting STEP sets POIN = SPAN / STEP + 1."""
        if cmd.is_query:
            return self.setting(cmd)
        if not self.set_ok(cmd):
            return None
        key = self.table[cmd.header].key
        start, stop = float(self.prop("sweep_start")), float(self.prop("sweep_stop"))
        if key in ("sweep_center", "sweep_span"):
            center, span = float(self.prop("sweep_center")), float(self.prop("sweep_span"))
            start, stop = center - span / 2, center + span / 2
            self.set_prop("sweep_start", start)
            self.set_prop("sweep_stop", stop)
        span = stop - start
        self.set_prop("sweep_center", (start + stop) / 2)
        self.set_prop("sweep_span", abs(span))
        if key == "sweep_step":
            step = float(self.prop("sweep_step"))
            self.set_prop("sweep_points", round(abs(span) / step) + 1 if step > 0 else 1)
        else:
            points = int(self.prop("sweep_points"))
            self.set_prop("sweep_step", abs(span) / (points - 1) if points > 1 else 0.0)
        return None

    def _list_points(self, key: str, cmd: Command) -> str:
        return str(len(self.prop(key)))

    def _list_append(self, key: str, cmd: Command) -> None:
        s = self.table[self._by_key[key]]
        try:
            added = s.parse(cmd.params)
        except ScpiError as err:
            self.push_error((err.code, err.message))
            return None
        if len(self.prop(key)) + len(added) > s.max_items:
            self.push_error(E_OUT_OF_RANGE)
            return None
        self.set_prop(key, (*self.prop(key), *added))
        return None

    def _set_notify(self, cmd: Command) -> str | None:
        """``TRAC:NOT``: 1 … TRAC:POIN − 1; a larger value is ignored with −222 (RM 6-17)."""
        if cmd.is_query:
            return self.setting(cmd)
        old = self.prop("trace_notify")
        if self.set_ok(cmd) and int(self.prop("trace_notify")) > int(self.prop("trace_points")) - 1:
            self.set_prop("trace_notify", old)
            self.push_error(E_OUT_OF_RANGE)
        return None

    def _trace_free(self, cmd: Command) -> str:
        """Bytes free and in use; 16 bytes per stored reading (the instrument's own figure is unverified)."""
        used = self._stored() * 16
        return f"{65536 * 16 - used},{used}"

    def _register(self, value: int) -> str:
        """A status register as ``FORM:SREG`` asks: decimal, or ``#H``/``#Q``/``#B`` hexadecimal, octal, binary."""
        fmt = str(self.prop("format_sreg"))
        if fmt == "HEX":
            return f"#H{value:X}"
        if fmt == "OCT":
            return f"#Q{value:o}"
        if fmt == "BIN":
            return f"#B{value:b}"
        return str(value)

    # ---------------------------------------------------------------- VISA side: buffers
    def write(self, data: bytes) -> None:
        """Bytes from the controller: every LF ends one program message (IEEE 488.2)."""
        if not isinstance(data, bytes):
            raise TypeError("data must be an instance of bytes")
        self._input_buffer.extend(data)
        eom = self._query_eom
        while (k := self._input_buffer.find(eom)) >= 0:
            message = bytes(self._input_buffer[:k]).decode("latin-1").rstrip("\r")
            del self._input_buffer[: k + len(eom)]
            self._interrupt_unread()
            reply = self.handle(message)
            if reply is not None:
                self._out.append(reply.encode("latin-1") + self._response_eom)

    def _interrupt_unread(self) -> None:
        """A new message while a reply is unread: the reply is discarded and −410 queued. A remnant of bare
        terminators (the relay's stray LF, as seen in the field) stays for the controller to read."""
        unread = b"".join(self._out)[self._out_pos :]
        if unread.strip(b"\r\n"):
            self._out.clear()
            self._out_pos = 0
            self.push_error(E_INTERRUPTED)

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
        """Execute one program message; return the response message (``;``-joined query replies) or None.

        Faults: a ``silent`` header withholds the whole response message (the instrument never answers it), a
        ``garbage`` header replaces its own reply."""
        while self.bench._injected_errors:
            self.push_error(self.bench._injected_errors.popleft())
        self._advance()
        replies, silent = [], False
        faults = self.bench.faults
        for cmd in parse_message(message):
            reply = self.execute(cmd)
            base = _resolve(cmd.header, self.table, self.handlers, self.root)
            reply = faults.garbage.get(base, reply)
            silent = silent or base in faults.silent
            if reply is not None:
                replies.append(reply)
        return ";".join(replies) if replies and not silent else None

    # ---------------------------------------------------------------- status (IEEE 488.2 and SCPI registers)
    def _rst(self, cmd: Command) -> None:
        self._abort(cmd)
        self.reset_settings()
        return None

    def _cls(self, cmd: Command) -> None:
        self.errors.clear()
        self.esr = self._oper_event = self._meas_event = self._ques_event = 0
        return None

    def _preset(self, cmd: Command) -> None:
        for key in ("meas_enable", "oper_enable", "ques_enable"):
            self.set_prop(key, 0)
        return None

    def _opc(self, cmd: Command) -> None:
        self.esr |= 1  # operation complete: nothing is pending in the simulation
        return None

    def _read_esr(self, cmd: Command) -> str:
        value, self.esr = self.esr, 0
        return str(value)

    def _stb(self) -> int:
        """Status byte: MSB (0), EAV (2), QSB (3), ESB (5), OSB (7) and MSS (6) from the enabled summaries."""
        stb = 1 if self._meas_event & int(self.prop("meas_enable")) else 0
        stb |= 4 if self.errors else 0
        stb |= 8 if self._ques_event & int(self.prop("ques_enable")) else 0
        stb |= 32 if self.esr & int(self.prop("standard_event_enable")) else 0
        stb |= 128 if self._oper_event & int(self.prop("oper_enable")) else 0
        return stb | (64 if stb & int(self.prop("service_request_enable")) & ~64 else 0)

    def _oper_condition(self) -> int:
        running = self._sweep is not None and not self._sweep.finished
        return 1 << 3 if running else 1 << 10

    def _read_oper(self, cmd: Command) -> str:
        value, self._oper_event = self._oper_event, 0
        return self._register(value)

    def _read_meas(self, cmd: Command) -> str:
        value, self._meas_event = self._meas_event, 0
        return self._register(value)

    def _read_ques(self, cmd: Command) -> str:
        value, self._ques_event = self._ques_event, 0
        return self._register(value)

    # ---------------------------------------------------------------- settings with side effects
    def _set_high(self, cmd: Command) -> str | None:
        if cmd.is_query:
            return self.setting(cmd)
        if self.set_ok(cmd):  # setting HIGH also sets LOW to -HIGH
            self.set_prop("delta_low", -float(self.prop("delta_high")))
        return None

    def _set_range(self, cmd: Command) -> str | None:
        if cmd.is_query:
            return self.setting(cmd)
        if self.set_ok(cmd):
            self.set_prop("current_range_auto", False)
        return None

    @property
    def _elements(self) -> tuple[str, ...]:
        return tuple(self._form_elements)

    _form_elements: tuple[str, ...] = ("READ", "TST")

    def _form_elem(self, cmd: Command) -> None:
        """``FORM:ELEM``: any of READ, TST, SOUR, AVOL, COMP, RNUM, UNIT, or ALL / DEF; the order given does not
        matter (the buffer comes in the fixed order)."""
        given = [p.upper() for p in split_params(cmd.params)]
        if given == ["ALL"]:
            self._form_elements = (*ELEMENT_ORDER, "UNIT")
            return None
        if given == ["DEF"] or given == ["DEFAULT"]:
            self._form_elements = ("READ", "TST")
            return None
        elems = [_ELEMENT_NAMES.get(p) for p in given]
        if not elems or None in elems or len(set(elems)) != len(elems):
            self.push_error(E_ILLEGAL)
            return None
        self._form_elements = tuple(e for e in (*ELEMENT_ORDER, "UNIT") if e in elems)
        return None

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
        elif sw.aborted_at_s is None and now >= sw.end_s and not sw.endless:
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
    def _count(self) -> tuple[int, bool]:
        """Readings of the next run and whether it keeps running (``SOUR:DELT:COUN INF``: 65536, RM 6-12)."""
        count = float(self.prop("delta_count"))
        return (65536, True) if math.isinf(count) else (int(count), False)

    def _arm(self, cmd: Command) -> None:
        if self.bench.faults.voltmeter_absent:
            self.push_error(E_HW_MISSING)
            return None
        if self._sweep is not None and not self._sweep.finished:
            self.push_error(E_CONFLICT)
            return None
        self.set_prop("trace_points", self._count()[0])  # arming sizes the buffer to the Delta count (RM 6-12)
        self.set_prop("trace_feed_control", "NEXT")  # and enables it (unverified)
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
        count, endless = self._count()
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
        clean = np.where(volts >= OVERFLOW, 0.0, volts)
        deltas = delta_readings(clean)
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
        # SOUR element: the source value at the last conversion of each reading; AVOL: the mean of its three
        # conversions with the Delta weights unsigned (what the EMF and drift add). Which values the 6221 reports
        # in these two elements is not documented in the material we have (unverified).
        avol = (clean[:-2] + 2.0 * clean[1:-1] + clean[2:]) / 4.0
        return _Sweep(
            b.clock(), deltas, ready - ready[0], ready, float(ready[-1]), None, currents[2:], avol, endless=endless
        )

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
            out = self._math(out)
        return out

    def _math(self, x: np.ndarray) -> np.ndarray:
        """CALC1 (RM table 6-3): mX+b, or m/X+b (``CALC1:FORM REC``), or nothing (``NONE``)."""
        m, b = float(self.prop("calc1_mmf")), float(self.prop("calc1_mbf"))
        fmt = self.prop("calc1_format")
        if fmt == "REC":
            with np.errstate(divide="ignore"):
                return np.where(x != 0, m / np.where(x != 0, x, 1.0) + b, OVERFLOW)
        return m * x + b if fmt == "MXB" else x

    # ---------------------------------------------------------------- buffer
    def _columns(self, start: int, stop: int) -> list[tuple[np.ndarray, str]]:
        """The selected elements of readings ``start … stop − 1``, in the fixed order, with their unit suffixes."""
        sw = self._sweep
        assert sw is not None
        stamps = sw.stamps
        if self.prop("trace_tst_format") == "DELT":  # time since the previous reading
            stamps = np.diff(sw.stamps, prepend=sw.stamps[:1])
        data = {
            "READ": sw.readings,
            "TST": stamps,
            "SOUR": sw.source_a,
            "AVOL": sw.avol,
            "COMP": np.zeros(sw.readings.size),
            "RNUM": np.arange(sw.readings.size, dtype=float),
        }
        units = "UNIT" in self._elements
        suffix = {**_ELEMENT_SUFFIX, "READ": _READING_SUFFIX[str(self.prop("unit"))]}
        return [(data[e][start:stop], suffix[e] if units else "") for e in ELEMENT_ORDER if e in self._elements]

    def _format(self, start: int, stop: int) -> str:
        """Readings ``start … stop − 1`` as the 6221 sends them: ASCII with 9 significant digits, or an IEEE 488.2
        definite-length block of 4- or 8-byte floats (``FORM:DATA SRE|DRE``; ``FORM:BORD NORM`` big-endian, ``SWAP``
        little-endian)."""
        cols = self._columns(start, stop)
        flat = np.column_stack([c for c, _ in cols]).ravel()
        fmt = str(self.prop("format_data"))
        if fmt != "ASC":
            order = "<" if self.prop("format_border") == "SWAP" else ">"  # SWAPped: little-endian
            raw_bytes = flat.astype(f"{order}f4" if fmt == "SRE" else f"{order}f8").tobytes()
            n = str(len(raw_bytes))
            return f"#{len(n)}{n}" + raw_bytes.decode("latin-1")
        texts = [f"{x:+.8E}" for x in flat.tolist()]
        if any(u for _, u in cols):
            k = len(cols)
            texts = [t + cols[i % k][1] for i, t in enumerate(texts)]
        return ",".join(texts)

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
        """``SENS:DATA?``: the latest reading while running; −221 when idle (UM 5-41), −230 before the first."""
        sw = self._sweep
        if sw is None or sw.finished:
            self.push_error(E_CONFLICT)
            return None
        n = self._stored()
        if n == 0:
            self.push_error(E_STALE)
            return None
        return f"{sw.readings[n - 1]:+.8E}"

    def _latest_math(self, cmd: Command) -> str | None:
        """``CALC1:DATA?``: the latest reading after the CALC1 math (when it is on)."""
        reply = self._latest(cmd)
        if reply is None or not self.prop("calc1_state") or self.prop("trace_feed") == "CALC1":
            return reply  # math off, or already applied to what the buffer holds
        return f"{float(self._math(np.array([float(reply)]))[0]):+.8E}"

    def _calc2_readings(self) -> np.ndarray:
        n = self._stored()
        r = self._sweep.readings[:n] if self._sweep is not None else np.empty(0)
        return r[np.abs(r) < OVERFLOW]

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
class _SerialSession(SerialInstrumentSession):
    """pyvisa-sim's ASRL session, also for a port named by its device path (``ASRL/dev/ttyUSB0::INSTR``, which
    pyvisa-sim 0.7 refuses: it reads the board as a number)."""

    def after_parsing(self) -> None:
        if str(self.parsed.board).isdigit():
            super().after_parsing()


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
        self.devices = Devices()
        for address in _load_definition()["resources"]:  # listed by list_resources(); any other opens on demand
            self._add_device(pyvisa.rname.to_canonical_name(address))

    def open(self, session: Any, resource_name: str, *args: Any, **kwargs: Any) -> tuple[Any, constants.StatusCode]:
        """Open ``resource_name``: the simulated 6221 answers at its listed addresses or, with the bench's
        ``any_address``, at any valid VISA resource name of an interface pyvisa-sim simulates (GPIB, ASRL —
        ``ASRL/dev/ttyUSB0::INSTR`` too —, TCPIP INSTR and SOCKET, USB), as the operator's bench will be addressed;
        nothing is contacted. An invalid or unknown name raises (pyvisa-sim 0.7 returns session 0 and an error
        status, which PyVISA does not check here, so the "open" resource silently answers nothing)."""
        try:
            parsed = pyvisa.rname.parse_resource_name(resource_name)
        except pyvisa.rname.InvalidResourceName as exc:
            raise ValueError(f"not a VISA resource name: {exc}") from None
        try:
            cls = Session.get_session_class(parsed.interface_type_const, parsed.resource_class)
        except ValueError:
            raise ValueError(
                f"the simulated bench has no {parsed.interface_type} {parsed.resource_class} interface; it answers at "
                f"{', '.join(f'{t.name.upper()} {c}' for t, c in sorted(Session._session_classes, key=str))}"
            ) from None
        if cls is SerialInstrumentSession:
            cls = _SerialSession
        sess = cls(session, resource_name, parsed)
        name = str(sess.attrs[constants.ResourceAttribute.resource_name])
        if name not in self.devices.list_resources():
            if not self.bench.any_address:
                raise pyvisa.errors.VisaIOError(constants.StatusCode.error_resource_not_found)
            self._add_device(name)
        sess.device = self.devices[name]
        return self._register(sess), constants.StatusCode.success

    def _add_device(self, name: str) -> None:
        """The simulated 6221 (with its 2182A) at the canonical resource ``name``, on this library's bench."""
        data = _load_definition()
        device = SimulatedK6221("k6221", data["devices"]["k6221"], data["devices"]["k2182a"], self.bench)
        if name.upper().startswith("ASRL"):
            term = self.bench.serial_terminator
            device.add_eom("ASRL INSTR", term, term)
        self.devices.add_device(name, device)

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
