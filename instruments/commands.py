"""The SCPI settings of the Keithley 6221 and (relayed) 2182A, each declared once: command, type, range, unit, default.

One :class:`Setting` per setting (the PyMeasure habit, without its silent clamping). From this one table come
the driver's validation (:class:`instruments.delta.DeltaSettings` checks its fields with :meth:`Setting.check`), the
simulated instruments' command handling (:mod:`instruments.simulated` parses, range-checks, stores and answers every
setting through :meth:`Setting.parse` and :meth:`Setting.reply`) and a generated protocol test per setting
(``tests/instruments/test_command_table.py``). Ranges, defaults and parameter spellings are those of the 6220/6221
reference manual and the 2182A manual as collected in the project's reference note (``keithley-delta.md``); where
the note marks a value as not confirmed, the entry's ``doc`` says so.

Errors are SCPI's: a number outside the range is −222 "Data out of range", a keyword that is not allowed is −224
"Illegal parameter value", a word where a number belongs is −104 "Data type error", a missing parameter −109.
This module imports nothing but the standard library and :mod:`contactrig.core.validation`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from contactrig.core.validation import SettingError, check_finite, check_int, check_range

__all__ = [
    "CURRENT_RANGES_A",
    "INFINITY_REPLY",
    "K2182A",
    "K6221",
    "MAX_CURRENT_A",
    "NPLC_MAX_50HZ",
    "OVER_RANGE",
    "VOLTMETER_RANGES_V",
    "ScpiError",
    "Setting",
    "check_nplc",
    "keywords",
    "setting",
]

#: The 6221 sources up to ±105 mA (either polarity).
MAX_CURRENT_A = 0.105
#: 6221 source ranges (A); each allows 5 % over-range (the 100 mA range goes to 105 mA).
CURRENT_RANGES_A = (2e-9, 2e-8, 2e-7, 2e-6, 2e-5, 2e-4, 2e-3, 2e-2, 1e-1)
OVER_RANGE = 1.05
#: 2182A channel-1 voltage ranges (V); a range command names the expected reading and the 2182A picks the range.
VOLTMETER_RANGES_V = (0.01, 0.1, 1.0, 10.0, 100.0)
#: 2182A NPLC limit on 50 Hz mains (60 on 60 Hz: the table's maximum).
NPLC_MAX_50HZ = 50.0
#: What an instrument answers for an infinite count (and for an overflow reading).
INFINITY_REPLY = 9.9e37


class ScpiError(Exception):
    """A command the instrument rejects: ``code`` and ``message`` as its error queue reports them."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(f"{code},{message}")
        self.code = code
        self.message = message


DATA_TYPE = ScpiError(-104, "Data type error")
MISSING = ScpiError(-109, "Missing parameter")
OUT_OF_RANGE = ScpiError(-222, "Data out of range")
ILLEGAL = ScpiError(-224, "Illegal parameter value")


def keywords(*spelled: str) -> dict[str, str]:
    """SCPI keyword parameters written as in the manual (upper case = short form, ``"GUARd"``): every accepted
    spelling (short and long, upper case) → the short form the instrument answers with."""
    out: dict[str, str] = {}
    for word in spelled:
        short = "".join(c for c in word if not c.islower())
        out[short] = short
        out[word.upper()] = short
    return out


@dataclass(frozen=True)
class Setting:
    """One SCPI setting.

    key: Python name. header: canonical short-form header (``SOUR:DELT:HIGH``; its query is ``header + "?"``).
    kind: ``float``, ``int``, ``bool``, ``keyword`` (``choices``: accepted spelling → short form) or ``range``
    (a number within [low, high] selects the smallest of ``ranges`` that holds it; the query answers the range).
    unit, doc: for readers and error messages. low/high: limits (inclusive). default: the value after ``*RST``
    (``reset=False``: ``*RST`` leaves it alone, as for the TRACe settings, RM table 6-4 note 1).
    step: the instrument's resolution (the driver refuses values off the grid; the instrument rounds).
    infinite: ``INF`` is accepted (queried back as 9.9E37). instrument: ``"6221"`` or ``"2182A"``.
    """

    key: str
    header: str
    kind: str
    default: Any
    unit: str = ""
    doc: str = ""
    low: float | None = None
    high: float | None = None
    choices: dict[str, str] = field(default_factory=dict)
    ranges: tuple[float, ...] = ()
    step: float | None = None
    infinite: bool = False
    reset: bool = True
    instrument: str = "6221"

    # ------------------------------------------------------------------ driver side
    def check(self, name: str, value: Any) -> Any:
        """The driver's validation: ``value`` if the instrument would take it unchanged, else a
        :class:`SettingError` naming ``name``, the value and what is allowed (nothing is clamped or rounded)."""
        unit = self.unit
        if self.kind == "int":
            return check_int(name, value, int(self.low or 0), int(self.high or 0))
        if self.kind == "bool":
            if not isinstance(value, bool):
                raise SettingError(name, value, "expected True or False")
            return value
        if self.kind == "keyword":
            if not isinstance(value, str) or value.upper() not in self.choices:
                raise SettingError(name, value, "expected one of " + ", ".join(sorted(set(self.choices.values()))))
            return self.choices[value.upper()]
        if self.kind == "range":
            x = check_range(name, value, unit=unit)
            if not any(math.isclose(x, r, rel_tol=1e-9) for r in self.ranges):
                allowed = ", ".join(f"{r:g}" for r in self.ranges)
                raise SettingError(name, value, "expected None (auto) or one of " + allowed)
            return x
        x = check_range(name, value, self.low, self.high, unit=unit)
        if self.step is not None and abs(round(x / self.step) * self.step - x) > 1e-9 * max(1.0, abs(x)):
            step = f"{self.step * 1e3:g} m{unit}" if self.step < 1 and unit else f"{self.step:g} {unit}"
            raise SettingError(name, value, f"the {self.instrument} sets {self.header} in steps of {step}")
        return x

    # ------------------------------------------------------------------ instrument side
    def parse(self, param: str) -> Any:
        """The value an instrument stores for the parameter text ``param``; raises :class:`ScpiError`."""
        p = param.strip()
        if not p:
            raise MISSING
        word = p.upper()
        if self.kind == "keyword":
            short = self.choices.get(word) or self.choices.get(_unquote(p).upper())
            if short is None:
                raise ILLEGAL
            return short
        if self.kind == "bool":
            if word in ("ON", "1", "OFF", "0"):
                return word in ("ON", "1")
            if _is_number(word):
                return round(float(word)) != 0
            raise ILLEGAL
        x = self._number(word)
        if self.kind == "range":
            return min((r for r in self.ranges if abs(x) <= r * (1 + 1e-9)), default=self.ranges[-1])
        if self.kind == "int" and math.isfinite(x):
            return round(x)
        if self.step is not None:
            x = round(x / self.step) * self.step
        return x

    def _number(self, word: str) -> float:
        named = {"MIN": self.low, "MINIMUM": self.low, "MAX": self.high, "MAXIMUM": self.high}
        if word in ("DEF", "DEFAULT"):
            return float(self.default)
        if word in named and named[word] is not None:
            return float(named[word])  # type: ignore[arg-type]
        if word in ("INF", "INFINITY"):
            if self.infinite:
                return math.inf
            raise ILLEGAL
        try:
            x = float(word)
        except ValueError:
            raise DATA_TYPE from None
        if not math.isfinite(x):
            raise DATA_TYPE
        lo, hi = self.low, self.high
        if (lo is not None and x < lo - 1e-12 * abs(lo)) or (hi is not None and x > hi + 1e-12 * abs(hi)):
            raise OUT_OF_RANGE
        return x

    def reply(self, value: Any) -> str:
        """The instrument's answer to the query: numbers with 9 significant digits, booleans 1/0, keywords in
        short form."""
        if self.kind == "bool":
            return "1" if value else "0"
        if self.kind == "keyword":
            return str(value)
        if isinstance(value, float) and math.isinf(value):
            return f"{INFINITY_REPLY:+.8E}"
        if self.kind == "int":
            return f"{int(value):d}"
        return f"{float(value):+.8E}"

    def limit_reply(self, which: str) -> str | None:
        """Answer to ``<header>? MIN|MAX|DEF`` (None when the setting has no such limit)."""
        w = which.strip().upper()[:3]
        value = {"MIN": self.low, "MAX": self.high, "DEF": self.default}.get(w)
        return None if value is None else self.reply(value)


def _unquote(text: str) -> str:
    t = text.strip()
    return t[1:-1] if len(t) >= 2 and t[0] == t[-1] and t[0] in "'\"" else t


def _is_number(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def _table(*settings: Setting) -> dict[str, Setting]:
    out = {s.header: s for s in settings}
    assert len(out) == len(settings), "a header is declared twice"
    return out


_ON_OFF = {"kind": "bool"}
_FEED = {"SENS": "SENS1", "SENS1": "SENS1", "SENSE": "SENS1", "SENSE1": "SENS1", "CALC": "CALC1", "CALC1": "CALC1"}
_FEED.update({"CALCULATE": "CALC1", "CALCULATE1": "CALC1", "CALC2": "CALC2", "CALCULATE2": "CALC2"})
_ARB = {f"ARB{i}": f"ARB{i}" for i in range(5)} | {f"ARBITRARY{i}": f"ARB{i}" for i in range(5)}

#: The 6221's settings (header → setting). Each line is the manual's command, type, range, unit and default.
K6221: dict[str, Setting] = _table(
    # ---- source (RM SOURce subsystem)
    Setting("source_current", "SOUR:CURR", "float", 0.0, "A", "DC output current", -MAX_CURRENT_A, MAX_CURRENT_A),
    Setting(
        "compliance", "SOUR:CURR:COMP", "float", 10.0, "V", "voltage compliance, 10 mV steps", 0.1, 105.0, step=0.01
    ),
    Setting(
        "current_range",
        "SOUR:CURR:RANG",
        "range",
        0.1,
        "A",
        "source range: the smallest that holds the value",
        -MAX_CURRENT_A,
        MAX_CURRENT_A,
        ranges=CURRENT_RANGES_A,
    ),
    Setting("current_range_auto", "SOUR:CURR:RANG:AUTO", "bool", False, "", "auto source range"),
    Setting("source_delay", "SOUR:DEL", "float", 1e-3, "s", "source delay", 1e-3, 999999.999),
    Setting("output", "OUTP", "bool", False, "", "output on/off"),
    Setting(
        "output_shield",
        "OUTP:ISH",
        "keyword",
        "OLOW",
        "",
        "inner shield: output low or guard",
        choices=keywords("OLOW", "GUARd"),
    ),
    Setting("output_low_to_earth", "OUTP:LTE", "bool", False, "", "output low connected to earth"),
    # ---- Delta (RM 6-12)
    Setting(
        "delta_high",
        "SOUR:DELT:HIGH",
        "float",
        1e-3,
        "A",
        "Delta high level; setting it sets LOW to -HIGH",
        -MAX_CURRENT_A,
        MAX_CURRENT_A,
    ),
    Setting("delta_low", "SOUR:DELT:LOW", "float", -1e-3, "A", "Delta low level", -MAX_CURRENT_A, MAX_CURRENT_A),
    Setting("delta_delay", "SOUR:DELT:DEL", "float", 2e-3, "s", "delay before each conversion", 1e-3, 9999.999),
    Setting(
        "delta_count",
        "SOUR:DELT:COUN",
        "int",
        65536,
        "",
        "Delta readings; INF fills 65536 and keeps running",
        1,
        65536,
        infinite=True,
    ),
    Setting("sweep_count", "SOUR:SWE:COUN", "int", 1, "", "repeated measurement sets", 1, 9999, infinite=True),
    Setting("delta_cab", "SOUR:DELT:CAB", "bool", False, "", "compliance abort"),
    Setting("delta_csw", "SOUR:DELT:CSW", "bool", False, "", "cold switching"),
    Setting(
        "unit",
        "UNIT",
        "keyword",
        "V",
        "",
        "reading unit (Ω = V/I, S = I/V, W = V·I)",
        choices=keywords("V", "OHMS", "W", "SIEMens") | {"OHM": "OHMS", "VOLT": "V", "WATT": "W"},
    ),
    # ---- 6221 filter acting on Delta readings (SENSe:AVERage)
    Setting("filter_state", "SENS:AVER:STAT", "bool", False, "", "averaging filter on Delta readings"),
    Setting("filter_count", "SENS:AVER:COUN", "int", 10, "", "averaging filter count", 2, 300),
    Setting(
        "filter_type",
        "SENS:AVER:TCON",
        "keyword",
        "MOV",
        "",
        "moving or repeating filter",
        choices=keywords("MOVing", "REPeat"),
    ),
    Setting("filter_window", "SENS:AVER:WIND", "float", 0.0, "%", "filter window", 0.0, 10.0),
    # ---- buffer (TRACe: *RST leaves these alone) and format
    Setting(
        "trace_points",
        "TRAC:POIN",
        "int",
        65536,
        "",
        "buffer size; arming sizes it to the Delta count",
        1,
        65536,
        reset=False,
    ),
    Setting("trace_feed", "TRAC:FEED", "keyword", "SENS1", "", "what feeds the buffer", choices=_FEED, reset=False),
    Setting(
        "trace_feed_control",
        "TRAC:FEED:CONT",
        "keyword",
        "NEXT",
        "",
        "buffer control",
        choices=keywords("NEXT", "NEVer"),
        reset=False,
    ),
    Setting(
        "trace_tst_format",
        "TRAC:TST:FORM",
        "keyword",
        "ABS",
        "",
        "timestamps absolute or relative",
        choices=keywords("ABSolute", "DELTa"),
        reset=False,
    ),
    Setting(
        "format_data",
        "FORM:DATA",
        "keyword",
        "ASC",
        "",
        "data format (ASCII or IEEE-754 single/double)",
        choices=keywords("ASCii", "SREal", "DREal"),
    ),
    # ---- math
    Setting("calc1_state", "CALC1:STAT", "bool", False, "", "mX+b math on readings fed from CALC1"),
    Setting("calc1_mmf", "CALC1:KMAT:MMF", "float", 1.0, "", "math factor m", -1e12, 1e12),
    Setting("calc1_mbf", "CALC1:KMAT:MBF", "float", 0.0, "", "math offset b", -1e12, 1e12),
    Setting(
        "calc2_format",
        "CALC2:FORM",
        "keyword",
        "MEAN",
        "",
        "buffer statistic",
        choices=keywords("MEAN", "SDEViation", "MAXimum", "MINimum", "PKPK"),
    ),
    Setting("calc2_state", "CALC2:STAT", "bool", False, "", "buffer statistics on"),
    # ---- status enables (read-only registers are in the simulator)
    Setting("meas_enable", "STAT:MEAS:ENAB", "int", 0, "", "measurement event enable", 0, 65535),
    Setting("oper_enable", "STAT:OPER:ENAB", "int", 0, "", "operation event enable", 0, 65535),
    Setting("ques_enable", "STAT:QUES:ENAB", "int", 0, "", "questionable event enable", 0, 65535),
    Setting("standard_event_enable", "*ESE", "int", 0, "", "standard event enable", 0, 255),
    Setting("service_request_enable", "*SRE", "int", 0, "", "service request enable", 0, 255),
    # ---- waveform (6221 only; defaults not confirmed in the note)
    Setting(
        "wave_function",
        "SOUR:WAVE:FUNC",
        "keyword",
        "SIN",
        "",
        "waveform",
        choices=keywords("SINe", "SQUare", "RAMP") | _ARB,
    ),
    Setting("wave_frequency", "SOUR:WAVE:FREQ", "float", 1e3, "Hz", "waveform frequency", 1e-3, 1e5),
    Setting("wave_amplitude", "SOUR:WAVE:AMPL", "float", 2e-12, "A", "peak amplitude", 2e-12, MAX_CURRENT_A),
    Setting("wave_offset", "SOUR:WAVE:OFFS", "float", 0.0, "A", "offset", -MAX_CURRENT_A, MAX_CURRENT_A),
    Setting("wave_duty", "SOUR:WAVE:DCYC", "float", 50.0, "%", "duty cycle", 0.0, 100.0),
    Setting("wave_time", "SOUR:WAVE:DUR:TIME", "float", math.inf, "s", "duration", 1e-7, 999999.999, infinite=True),
    Setting(
        "wave_cycles",
        "SOUR:WAVE:DUR:CYCL",
        "float",
        math.inf,
        "",
        "duration in cycles",
        1e-3,
        99999999900.0,
        infinite=True,
    ),
    Setting(
        "wave_ranging", "SOUR:WAVE:RANG", "keyword", "BEST", "", "waveform ranging", choices=keywords("BEST", "FIXed")
    ),
    Setting("wave_marker", "SOUR:WAVE:PMAR:STAT", "bool", False, "", "phase marker on"),
    Setting("wave_marker_phase", "SOUR:WAVE:PMAR", "float", 0.0, "°", "phase marker phase", -180.0, 180.0),
    Setting("wave_marker_line", "SOUR:WAVE:PMAR:OLIN", "int", 3, "", "phase marker trigger line", 1, 6),
    Setting("display", "DISP:ENAB", "bool", True, "", "front-panel display on"),
)

#: The 2182A's settings, reached through the 6221's serial relay.
K2182A: dict[str, Setting] = _table(
    Setting(
        "nplc",
        "SENS:VOLT:NPLC",
        "float",
        5.0,
        "PLC",
        "integration time (50 Hz mains: at most 50)",
        0.01,
        60.0,
        instrument="2182A",
    ),
    Setting(
        "range",
        "SENS:VOLT:RANG",
        "range",
        100.0,
        "V",
        "channel-1 range: the smallest that holds the value",
        0.0,
        120.0,
        ranges=VOLTMETER_RANGES_V,
        instrument="2182A",
    ),
    Setting("range_auto", "SENS:VOLT:RANG:AUTO", "bool", True, "", "auto range", instrument="2182A"),
    Setting("channel", "SENS:CHAN", "int", 1, "", "channel (0 = internal temperature)", 0, 2, instrument="2182A"),
    Setting(
        "function",
        "SENS:FUNC",
        "keyword",
        '"VOLT"',
        "",
        "function",
        choices={"VOLT": '"VOLT"', "VOLTAGE": '"VOLT"', "VOLT:DC": '"VOLT"', "TEMP": '"TEMP"', "TEMPERATURE": '"TEMP"'},
        instrument="2182A",
    ),
    Setting("digital_filter", "SENS:VOLT:DFIL:STAT", "bool", False, "", "digital filter", instrument="2182A"),
    Setting(
        "digital_filter_count", "SENS:VOLT:DFIL:COUN", "int", 10, "", "digital filter count", 1, 100, instrument="2182A"
    ),
    Setting(
        "digital_filter_type",
        "SENS:VOLT:DFIL:TCON",
        "keyword",
        "MOV",
        "",
        "digital filter type",
        choices=keywords("MOVing", "REPeat"),
        instrument="2182A",
    ),
    Setting("analog_filter", "SENS:VOLT:LPAS", "bool", False, "", "analog low-pass filter", instrument="2182A"),
    Setting("autozero", "SYST:AZER", "bool", True, "", "autozero", instrument="2182A"),
    Setting("line_sync", "SYST:LSYN", "bool", False, "", "line synchronisation", instrument="2182A"),
)


def setting(key: str) -> Setting:
    """The setting with Python name ``key`` (either instrument)."""
    for table in (K6221, K2182A):
        for s in table.values():
            if s.key == key:
                return s
    raise KeyError(key)


def check_nplc(name: str, value: Any, line_frequency_hz: float) -> float:
    """NPLC for the given mains frequency: 0.01 … 50 on 50 Hz, 0.01 … 60 on 60 Hz."""
    nplc = K2182A["SENS:VOLT:NPLC"]
    hi = NPLC_MAX_50HZ if line_frequency_hz == 50.0 else float(nplc.high or 0)
    return check_range(name, check_finite(name, value), nplc.low, hi)
