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
    "K2182A_ACTIONS",
    "K6221",
    "K6221_ACTIONS",
    "MAX_CURRENT_A",
    "NPLC_MAX_50HZ",
    "OVER_RANGE",
    "VOLTMETER_RANGES_V",
    "Action",
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
    kind: ``float``, ``int``, ``bool``, ``keyword`` (``choices``: accepted spelling → short form), ``range``
    (a number within [low, high] selects the smallest of ``ranges`` that holds it; the query answers the range),
    ``text`` (a quoted string of at most ``max_items`` characters, answered quoted) or ``list`` (comma-separated
    numbers within [low, high], at most ``max_items`` of them).
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
    max_items: int = 0

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
        if self.kind in ("text", "list"):
            return self._check_items(name, value)
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

    def _check_items(self, name: str, value: Any) -> Any:
        if self.kind == "text":
            if not isinstance(value, str) or len(value) > self.max_items or not value.isascii():
                raise SettingError(name, value, f"an ASCII text of at most {self.max_items} characters")
            return value
        if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or not 1 <= len(value) <= self.max_items:
            raise SettingError(name, value, f"a list of 1 to {self.max_items} numbers")
        return tuple(check_range(name, x, self.low, self.high, unit=self.unit) for x in value)

    # ------------------------------------------------------------------ instrument side
    def parse(self, param: str) -> Any:
        """The value an instrument stores for the parameter text ``param``; raises :class:`ScpiError`."""
        p = param.strip()
        if not p:
            raise MISSING
        if self.kind in ("text", "list"):
            return self._parse_items(p)
        if self.kind in ("keyword", "bool"):
            return self._parse_word(p)
        x = self._number(p.upper())
        if self.kind == "range":
            return min((r for r in self.ranges if abs(x) <= r * (1 + 1e-9)), default=self.ranges[-1])
        if self.kind == "int" and math.isfinite(x):
            return round(x)
        if self.step is not None:
            x = round(x / self.step) * self.step
        return x

    def _parse_word(self, p: str) -> Any:
        """A ``keyword`` (its short form) or ``bool`` parameter (ON/OFF/1/0, or a number rounded: 0 is off)."""
        word = p.upper()
        if self.kind == "keyword":
            short = self.choices.get(word) or self.choices.get(_unquote(p).upper())
            if short is None:
                raise ILLEGAL
            return short
        if word in ("ON", "1", "OFF", "0"):
            return word in ("ON", "1")
        if _is_number(word):
            return round(float(word)) != 0
        raise ILLEGAL

    def _parse_items(self, p: str) -> Any:
        """A ``text`` (quoted string) or ``list`` (comma-separated numbers) parameter."""
        if self.kind == "text":
            text = _unquote(p)
            if text == p or len(text) > self.max_items:  # not a string, or longer than the instrument holds
                raise DATA_TYPE if text == p else OUT_OF_RANGE
            return text
        items = [x.strip().upper() for x in p.split(",")]
        if len(items) > self.max_items:
            raise OUT_OF_RANGE
        return tuple(self._number(x) for x in items)

    def _number(self, word: str) -> float:
        named = {"MIN": self.low, "MINIMUM": self.low, "MAX": self.high, "MAXIMUM": self.high}
        if word in ("DEF", "DEFAULT"):
            return float(self.default[0] if self.kind == "list" else self.default)
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
        if self.kind == "text":
            return '"' + str(value).replace('"', '""') + '"'
        if self.kind == "list":
            return ",".join(f"{float(x):+.8E}" for x in value)
        if isinstance(value, float) and math.isinf(value):
            return f"{INFINITY_REPLY:+.8E}"
        if self.kind == "int":
            return f"{int(value):d}"
        return f"{float(value):+.8E}"

    def limit_reply(self, which: str) -> str | None:
        """Answer to ``<header>? MIN|MAX|DEF`` (None when the setting has no such limit)."""
        w = which.strip().upper()[:3]
        if self.kind in ("text", "list"):
            return None
        value = {"MIN": self.low, "MAX": self.high, "DEF": self.default}.get(w)
        return None if value is None else self.reply(value)


@dataclass(frozen=True)
class Action:
    """A command that is not a stored setting: an event (``SOUR:CLE``: the output goes off), or a query whose
    answer is not a setting's value (``TRAC:FREE?``).

    header: canonical short form (a query ends with ``?``). doc: what it does on the instrument (its side effects).
    reply: the static answer of a query (None: computed by the simulator, which then has a handler for this header;
    an event without a handler is accepted and has no effect on a simulated bench, e.g. ``SYST:BEEP``).
    idle_error: the SCPI error code the command gives on a freshly reset, idle instrument (0: none), e.g. −221
    for ``SENS:DATA?`` when no test runs (UM 5-41). example: a parameter to send with it in the protocol test.
    instrument: ``"6221"`` or ``"2182A"``.
    """

    header: str
    doc: str
    reply: str | None = None
    idle_error: int = 0
    example: str = ""
    instrument: str = "6221"

    @property
    def is_query(self) -> bool:
        return self.header.endswith("?")


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


def _actions(*actions: Action) -> dict[str, Action]:
    out = {a.header: a for a in actions}
    assert len(out) == len(actions), "a header is declared twice"
    return out


_ON_OFF = {"kind": "bool"}
_FEED = {"SENS": "SENS1", "SENS1": "SENS1", "SENSE": "SENS1", "SENSE1": "SENS1", "CALC": "CALC1", "CALC1": "CALC1"}
_FEED.update({"CALCULATE": "CALC1", "CALCULATE1": "CALC1", "NONE": "NONE"})
_CALC1_FORMATS = keywords("NONE", "MXB", "RECiprocal")
#: Largest |m| and |b| of the mX+b math (RM table 6-3).
MATH_LIMIT = 9.99999e20
_LINES = (1, 6)  # Trigger Link lines
_ARB = {f"ARB{i}": f"ARB{i}" for i in range(5)} | {f"ARBITRARY{i}": f"ARB{i}" for i in range(5)}

_I = (-MAX_CURRENT_A, MAX_CURRENT_A)
_RESP = keywords("FAST", "SLOW")
_SPACING = keywords("LINear", "LOGarithmic", "LIST")
_SWEEP_RANGING = keywords("BEST", "AUTO", "FIXed")
_PDEL_RANGING = keywords("BEST", "FIXed")
_BORDER = keywords("NORMal", "SWAPped")
_SREG = keywords("ASCii", "HEXadecimal", "OCTal", "BINary")
_POS = keywords("RST", "PRESet") | {f"SAV{i}": f"SAV{i}" for i in range(5)}
_BAUD = {str(b): str(b) for b in (300, 600, 1200, 2400, 4800, 9600, 19200)}
_TRIG_SOURCE = keywords("IMMediate", "TLINk")
_ARM_SOURCE = keywords("IMMediate", "TIMer", "BUS", "TLINk", "BSTest", "PSTest", "NSTest", "MANual")
_DIRECTION = keywords("ACCeptor", "SOURce")
_TRIG_OUTPUT = keywords("SOURce", "DELay", "NONE")
_ARM_OUTPUT = keywords("TEXit", "TENTer", "NONE")

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
    Setting(
        "trace_feed",
        "TRAC:FEED",
        "keyword",
        "CALC1",
        "",
        "what feeds the buffer: pre-math, post-math readings or nothing (power-on CALC1, RM table 6-4)",
        choices=_FEED,
        reset=False,
    ),
    Setting(
        "trace_feed_control",
        "TRAC:FEED:CONT",
        "keyword",
        "NEV",
        "",
        "buffer control (power-on NEVer, RM table 6-4; arming a Delta test enables the buffer: unverified)",
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
    Setting("calc1_format", "CALC1:FORM", "keyword", "MXB", "", "math: mX+b, m/X+b or none", choices=_CALC1_FORMATS),
    Setting("calc1_mmf", "CALC1:KMAT:MMF", "float", 1.0, "", "math factor m (= MA1Factor)", -MATH_LIMIT, MATH_LIMIT),
    Setting("calc1_mbf", "CALC1:KMAT:MBF", "float", 0.0, "", "math offset b (= MA0Factor)", -MATH_LIMIT, MATH_LIMIT),
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
    # ---- the rest of the 6221's SCPI summary (RM section 14); "unverified": a *RST default the note could not confirm
    Setting("source_filter", "SOUR:CURR:FILT", "bool", False, "", "analog output filter"),
    Setting("output_response", "OUTP:RESP", "keyword", "FAST", "", "output response (unverified)", choices=_RESP),
    Setting("sweep_start", "SOUR:CURR:STAR", "float", 0.0, "A", "staircase sweep start; couples", *_I),
    Setting("sweep_stop", "SOUR:CURR:STOP", "float", 0.0, "A", "staircase sweep stop; couples", *_I),
    Setting("sweep_step", "SOUR:CURR:STEP", "float", 0.0, "A", "sweep step; sets POIN (RM 4-22)", 0.0, 0.21),
    Setting("sweep_center", "SOUR:CURR:CENT", "float", 0.0, "A", "sweep centre; couples", *_I),
    Setting("sweep_span", "SOUR:CURR:SPAN", "float", 0.0, "A", "sweep span; couples", 0.0, 0.21),
    Setting("sweep_spacing", "SOUR:SWE:SPAC", "keyword", "LIN", "", "sweep type", choices=_SPACING),
    Setting("sweep_points", "SOUR:SWE:POIN", "int", 11, "", "sweep points (unverified default)", 1, 65535),
    Setting("sweep_ranging", "SOUR:SWE:RANG", "keyword", "BEST", "", "sweep ranging", choices=_SWEEP_RANGING),
    Setting("sweep_cab", "SOUR:SWE:CAB", "bool", False, "", "sweep compliance abort"),
    Setting("list_current", "SOUR:LIST:CURR", "list", (0.0,), "A", "list sweep currents", *_I, max_items=100),
    Setting("list_delay", "SOUR:LIST:DEL", "list", (1e-3,), "s", "list sweep delays", 1e-3, 999999.999, max_items=100),
    Setting("list_compliance", "SOUR:LIST:COMP", "list", (10.0,), "V", "list compliances", 0.1, 105.0, max_items=100),
    Setting("pdelta_high", "SOUR:PDEL:HIGH", "float", 1e-3, "A", "pulse Delta high level", *_I),
    Setting("pdelta_low", "SOUR:PDEL:LOW", "float", 0.0, "A", "pulse Delta low level", *_I),
    Setting("pdelta_width", "SOUR:PDEL:WIDT", "float", 110e-6, "s", "pulse width", 50e-6, 12e-3),
    Setting("pdelta_sdelay", "SOUR:PDEL:SDEL", "float", 16e-6, "s", "pulse source delay", 16e-6, 11.966e-3),
    Setting("pdelta_count", "SOUR:PDEL:COUN", "int", 65536, "", "pulse Delta readings", 1, 65536, infinite=True),
    Setting("pdelta_ranging", "SOUR:PDEL:RANG", "keyword", "BEST", "", "pulse ranging", choices=_PDEL_RANGING),
    Setting("pdelta_interval", "SOUR:PDEL:INT", "int", 5, "PLC", "pulse interval", 5, 999999),
    Setting("pdelta_sweep", "SOUR:PDEL:SWE", "bool", False, "", "pulse Delta sweep output"),
    Setting("pdelta_low_meas", "SOUR:PDEL:LME", "int", 2, "", "low measurements per pulse", 1, 2),
    Setting("dcon_start", "SOUR:DCON:STAR", "float", -10e-6, "A", "diff. conductance start (unverified)", *_I),
    Setting("dcon_step", "SOUR:DCON:STEP", "float", 1e-6, "A", "diff. conductance step (unverified)", 0.0, 0.21),
    Setting("dcon_stop", "SOUR:DCON:STOP", "float", 10e-6, "A", "diff. conductance stop (unverified)", *_I),
    Setting("dcon_delta", "SOUR:DCON:DELT", "float", 1e-6, "A", "diff. conductance delta (unverified)", 0.0, 0.105),
    Setting("dcon_delay", "SOUR:DCON:DEL", "float", 2e-3, "s", "diff. conductance delay", 1e-3, 9999.999),
    Setting("dcon_cab", "SOUR:DCON:CAB", "bool", False, "", "diff. conductance compliance abort"),
    Setting("trace_notify", "TRAC:NOT", "int", 1, "", "readings that set bit 6; < TRAC:POIN", 1, 65535, reset=False),
    Setting("format_border", "FORM:BORD", "keyword", "NORM", "", "binary byte order (unverified)", choices=_BORDER),
    Setting("format_sreg", "FORM:SREG", "keyword", "ASC", "", "status register reply format", choices=_SREG),
    Setting("display_text", "DISP:TEXT:DATA", "text", "", "", "top display message", max_items=20),
    Setting("display_text_on", "DISP:TEXT:STAT", "bool", False, "", "top display message shown"),
    Setting("display2_text", "DISP:WIND2:TEXT:DATA", "text", "", "", "bottom display message", max_items=32),
    Setting("display2_text_on", "DISP:WIND2:TEXT:STAT", "bool", False, "", "bottom display message shown"),
    Setting("queue_enable", "STAT:QUE:ENAB", "text", "", "", "error queue enabled codes (unverified)", max_items=200),
    Setting("power_on_setup", "SYST:POS", "keyword", "PRES", "", "power-on setup", choices=_POS, reset=False),
    Setting("key_click", "SYST:KCL", "bool", True, "", "key click"),
    Setting("beeper", "SYST:BEEP:STAT", "bool", True, "", "beeper"),
    Setting("last_key", "SYST:KEY", "int", 1, "", "simulate a key press; query: last key (unverified)", 1, 31),
    Setting("timestamp_auto_reset", "SYST:TIME:RES:AUTO", "bool", False, "", "timestamp reset at INIT (unverified)"),
    Setting("baud", "SYST:COMM:SER:BAUD", "keyword", "19200", "", "RS-232 baud rate", choices=_BAUD, reset=False),
    Setting("trig_source", "TRIG:SOUR", "keyword", "IMM", "", "trigger layer event", choices=_TRIG_SOURCE),
    Setting("trig_direction", "TRIG:DIR", "keyword", "ACC", "", "trigger layer bypass", choices=_DIRECTION),
    Setting("trig_in_line", "TRIG:ILIN", "int", 1, "", "trigger input line (unverified default)", *_LINES),
    Setting("trig_out_line", "TRIG:OLIN", "int", 2, "", "trigger output line (unverified default)", *_LINES),
    Setting("trig_output", "TRIG:OUTP", "keyword", "NONE", "", "trigger output event", choices=_TRIG_OUTPUT),
    Setting("arm_source", "ARM:SOUR", "keyword", "IMM", "", "arm layer event", choices=_ARM_SOURCE),
    Setting("arm_direction", "ARM:DIR", "keyword", "ACC", "", "arm layer bypass", choices=_DIRECTION),
    Setting("arm_in_line", "ARM:ILIN", "int", 1, "", "arm input line (unverified default)", *_LINES),
    Setting("arm_out_line", "ARM:OLIN", "int", 2, "", "arm output line (unverified default)", *_LINES),
    Setting("arm_output", "ARM:OUTP", "keyword", "NONE", "", "arm output event", choices=_ARM_OUTPUT),
    Setting("arm_timer", "ARM:TIM", "float", 0.1, "s", "arm timer (unverified default)", 1e-3, 99999.99),
)

_CH2 = {"ranges": (0.1, 1.0, 10.0)}
_TC = keywords("J", "K", "N", "T", "E", "R", "S", "B")
_RJ = keywords("SIMulated", "INTernal")
_TRAN = keywords("TCouple", "INTernal")
_CALC_2182 = keywords("MXB", "PERCent")
_STATS = keywords("MEAN", "SDEViation", "MAXimum", "MINimum", "PKPK")
_NR = {"reset": False}
_FEED_2182 = keywords("SENSe", "CALCulate", "NONE") | {"SENS1": "SENS", "CALC1": "CALC"}
_CONTROL = keywords("NEXT", "NEVer")
_TRIG_2182 = keywords("IMMediate", "TIMer", "MANual", "BUS", "EXTernal")
_DATA_2182 = keywords("ASCii", "SREal", "DREal")
_VUNIT = keywords("V", "DB", "DBM")

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
    # ---- the rest of the 2182A's SCPI summary (2182A manual, SCPI tables); "unverified" as for the 6221
    *(
        Setting(*args, **kwargs, instrument="2182A")  # type: ignore[misc]
        for args, kwargs in (
            (("aperture", "SENS:VOLT:APER", "float", 0.1, "s", "integration time = NPLC / mains Hz", 2e-4, 1.0), {}),
            (("digits", "SENS:VOLT:DIG", "int", 8, "", "display digits (unverified range)", 4, 8), {}),
            (("reference", "SENS:VOLT:REF", "float", 0.0, "V", "rel value subtracted", -120.0, 120.0), {}),
            (("reference_on", "SENS:VOLT:REF:STAT", "bool", False, "", "rel on"), {}),
            (("ch2_range", "SENS:VOLT:CHAN2:RANG", "range", 10.0, "V", "channel-2 range", 0.0, 12.0), _CH2),
            (("ch2_range_auto", "SENS:VOLT:CHAN2:RANG:AUTO", "bool", True, "", "channel-2 auto range"), {}),
            (("filter_window", "SENS:VOLT:DFIL:WIND", "float", 0.01, "%", "filter window (unverified)", 0.0, 10.0), {}),
            (("temp_nplc", "SENS:TEMP:NPLC", "float", 5.0, "PLC", "temperature integration time", 0.01, 60.0), {}),
            (("thermocouple", "SENS:TEMP:TC", "keyword", "J", "", "thermocouple type"), {"choices": _TC}),
            (("rjunction", "SENS:TEMP:RJUN:RSEL", "keyword", "SIM", "", "reference junction"), {"choices": _RJ}),
            (("rjunction_c", "SENS:TEMP:RJUN:SIM", "float", 23.0, "°C", "simulated reference junction", 0.0, 60.0), {}),
            (("transducer", "SENS:TEMP:TRAN", "keyword", "TC", "", "temperature sensor"), {"choices": _TRAN}),
            (("calc_format", "CALC1:FORM", "keyword", "MXB", "", "math (unverified choices)"), {"choices": _CALC_2182}),
            (("calc_mmf", "CALC1:KMAT:MMF", "float", 1.0, "", "math factor m", -MATH_LIMIT, MATH_LIMIT), {}),
            (("calc_mbf", "CALC1:KMAT:MBF", "float", 0.0, "", "math offset b", -MATH_LIMIT, MATH_LIMIT), {}),
            (("calc_state", "CALC1:STAT", "bool", False, "", "math on READ? results"), {}),
            (("calc2_format", "CALC2:FORM", "keyword", "MEAN", "", "buffer statistic"), {"choices": _STATS}),
            (("calc2_state", "CALC2:STAT", "bool", False, "", "buffer statistics on"), {}),
            (("trace_points", "TRAC:POIN", "int", 1024, "", "buffer size (unverified default)", 2, 1024), _NR),
            (("trace_feed", "TRAC:FEED", "keyword", "SENS", "", "buffer feed"), {"choices": _FEED_2182, **_NR}),
            (("trace_control", "TRAC:FEED:CONT", "keyword", "NEV", "", "buffer control"), {"choices": _CONTROL, **_NR}),
            (("init_continuous", "INIT:CONT", "bool", False, "", "continuous initiation (OFF after *RST)"), {}),
            (("trig_source", "TRIG:SOUR", "keyword", "IMM", "", "trigger event"), {"choices": _TRIG_2182}),
            (("trig_count", "TRIG:COUN", "int", 1, "", "trigger count", 1, 9999), {"infinite": True}),
            (("trig_delay", "TRIG:DEL", "float", 0.0, "s", "trigger delay", 0.0, 999999.999), {}),
            (("trig_delay_auto", "TRIG:DEL:AUTO", "bool", True, "", "auto delay"), {}),
            (("trig_timer", "TRIG:TIM", "float", 0.1, "s", "timer interval", 1e-3, 999999.999), {}),
            (("sample_count", "SAMP:COUN", "int", 1, "", "readings per trigger", 1, 1024), {}),
            (("front_autozero", "SYST:FAZ", "bool", True, "", "front autozero"), {}),
            (("beeper", "SYST:BEEP:STAT", "bool", True, "", "beeper"), {}),
            (("display", "DISP:ENAB", "bool", True, "", "front-panel display on"), {}),
            (("display_text", "DISP:TEXT:DATA", "text", "", "", "display message"), {"max_items": 12}),
            (("display_text_on", "DISP:TEXT:STAT", "bool", False, "", "display message shown"), {}),
            (("format_data", "FORM:DATA", "keyword", "ASC", "", "data format"), {"choices": _DATA_2182}),
            (("format_border", "FORM:BORD", "keyword", "NORM", "", "byte order (unverified)"), {"choices": _BORDER}),
            (("temp_unit", "UNIT:TEMP", "keyword", "C", "", "temperature unit"), {"choices": keywords("C", "F", "K")}),
            (("volt_unit", "UNIT:VOLT", "keyword", "V", "", "voltage unit"), {"choices": _VUNIT}),
            (("meas_enable", "STAT:MEAS:ENAB", "int", 0, "", "measurement event enable", 0, 65535), {}),
            (("oper_enable", "STAT:OPER:ENAB", "int", 0, "", "operation event enable", 0, 65535), {}),
            (("ques_enable", "STAT:QUES:ENAB", "int", 0, "", "questionable event enable", 0, 65535), {}),
        )
    ),
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


def _q(header: str, doc: str, reply: str | None = None, **kw: Any) -> Action:
    return Action(header, doc, reply, **kw)


#: The 6221's commands that are not settings: events and computed queries (RM section 14, and section 5 for Delta).
K6221_ACTIONS: dict[str, Action] = _actions(
    # ---- IEEE 488.2 common commands
    _q("*RST", "reset: aborts a running test, every setting but TRACe to its default"),
    _q("*CLS", "clear the error queue and every event register"),
    _q("*ESR?", "read and clear the standard event status register"),
    _q("*STB?", "status byte from the enabled summaries"),
    _q("*OPC", "set OPC in the standard event register when all is done (nothing is pending in the simulation)"),
    _q("*OPC?", "1 when all is done (whether it waits for a Delta run is unverified)", "1"),
    _q("*WAI", "wait for pending operations (none in the simulation)"),
    _q("*TST?", "self-test: 0 = passed", "0"),
    _q("*TRG", "bus trigger (for ARM:SOUR BUS; no effect on a Delta test)"),
    # ---- Delta, pulse Delta, differential conductance, sweeps, waveform (SOURce)
    _q("SOUR:DELT:NVPR?", "1 if a 2182A answers on the serial link"),
    _q("SOUR:DELT:ARM", "arm Delta: sizes the buffer to the count (RM 6-12); −241 without a 2182A"),
    _q("SOUR:DELT:ARM?", "1 once armed"),
    _q("SOUR:PDEL:NVPR?", "1 if a 2182A answers on the serial link"),
    _q("SOUR:PDEL:ARM", "arm pulse Delta (not simulated: never arms)"),
    _q("SOUR:PDEL:ARM?", "pulse Delta armed: always 0 here", "0"),
    _q("SOUR:DCON:NVPR?", "1 if a 2182A answers on the serial link"),
    _q("SOUR:DCON:ARM", "arm differential conductance (not simulated: never arms)"),
    _q("SOUR:DCON:ARM?", "differential conductance armed: always 0 here", "0"),
    _q("SOUR:SWE:ARM", "arm a staircase or list sweep (not simulated: accepted)"),
    _q("SOUR:SWE:ARM?", "sweep armed: always 0 here", "0"),
    _q("SOUR:SWE:ABOR", "stop and un-arm any test; the 2182A goes to local"),
    _q("SOUR:WAVE:ARM", "arm the waveform (not simulated: accepted)"),
    _q("SOUR:WAVE:ARM?", "waveform armed: always 0 here", "0"),
    _q("SOUR:WAVE:INIT", "start the armed waveform (not simulated: accepted)"),
    _q("SOUR:WAVE:ABOR", "stop the waveform (not simulated: accepted)"),
    _q("SOUR:CLE", "clear the source: output off (RM: SOURce:CLEar[:IMMediate])"),
    _q("SOUR:LIST:CURR:APP", "append currents to the list", example="1e-3,2e-3"),
    _q("SOUR:LIST:CURR:POIN?", "number of list currents (the list sweep's length)"),
    _q("SOUR:LIST:DEL:APP", "append delays to the list", example="0.01"),
    _q("SOUR:LIST:DEL:POIN?", "number of list delays"),
    _q("SOUR:LIST:COMP:APP", "append compliances to the list", example="5"),
    _q("SOUR:LIST:COMP:POIN?", "number of list compliances"),
    _q("INIT:IMM", "start the armed test; a new INIT overwrites the buffer; −221 when none is armed", idle_error=-221),
    _q("ABOR", "abort (whether it stops a Delta run is unverified: the simulation stops it)"),
    _q("OUTP:INT:TRIP?", "1 if the interlock is tripped (output cannot go on): never here", "0"),
    # ---- readings
    _q("SENS:DATA?", "latest reading while a test runs; −221 when idle (UM 5-41)", idle_error=-221),
    _q("SENS:DATA:FRES?", "latest reading, each only once; −221 when idle", idle_error=-221),
    _q("CALC1:DATA?", "latest reading after the math; −221 when idle", idle_error=-221),
    _q("CALC1:DATA:FRES?", "latest reading after the math, each only once; −221 when idle", idle_error=-221),
    # ---- buffer and format
    _q("TRAC:CLE", "clear the buffer; −221 while a test runs"),
    _q("TRAC:FREE?", "bytes free and in use (16 bytes per reading: unverified)"),
    _q("TRAC:POIN:ACT?", "readings stored so far"),
    _q("TRAC:DATA?", "every stored reading; −230 when empty", idle_error=-230),
    _q("TRAC:DATA:SEL?", "readings start … start+count−1 (first is #0); −222 beyond the stored",
       example="0,1", idle_error=-222),
    _q("TRAC:DATA:TYPE?", "kind of readings stored: NONE or DELT"),
    _q("CALC2:IMM", "compute the CALC2 statistic of the buffer; −230 when empty", idle_error=-230),
    _q("CALC2:IMM?", "compute and return the statistic; −230 when empty", idle_error=-230),
    _q("CALC2:DATA?", "the last statistic computed"),
    _q("FORM:ELEM", "buffer elements (any order; they come in the fixed order)", example="READ,TST"),
    _q("FORM:ELEM?", "the selected elements in the fixed order"),
    # ---- status
    _q("STAT:PRES", "every enable register to 0"),
    _q("STAT:OPER:EVEN?", "read and clear the operation event register"),
    _q("STAT:MEAS:EVEN?", "read and clear the measurement event register"),
    _q("STAT:QUES:EVEN?", "read and clear the questionable event register"),
    _q("STAT:OPER:COND?", "operation condition: bit 3 sweeping, bit 10 idle"),
    _q("STAT:MEAS:COND?", "measurement condition", "0"),
    _q("STAT:QUES:COND?", "questionable condition", "0"),
    _q("STAT:QUE?", "next error (as SYST:ERR?)"),
    _q("STAT:QUE:CLE", "clear the error queue"),
    _q("STAT:QUE:DIS", "errors not to queue (the simulation queues every error)", example="(-110:-100)"),
    # ---- system
    _q("SYST:PRES", "system preset: as *RST for the simulated settings"),
    _q("SYST:ERR?", "next error, code,\"message\"; 0,\"No error\" when empty"),
    _q("SYST:ERR:ALL?", "every queued error, emptying the queue"),
    _q("SYST:ERR:COUN?", "number of queued errors"),
    _q("SYST:ERR:CODE?", "next error's code only"),
    _q("SYST:ERR:CODE:ALL?", "every queued error's code, emptying the queue"),
    _q("SYST:CLE", "clear the error queue"),
    _q("SYST:VERS?", "SCPI version (unverified)", "1991.0"),
    _q("SYST:BEEP", "beep: frequency, duration (accepted)", example="1000,0.1"),
    _q("SYST:TIME:RES", "reset the timestamp (each test starts at 0 s here)"),
    _q("SYST:LOC", "RS-232: go to local"),
    _q("SYST:REM", "RS-232: go to remote"),
    _q("SYST:RWL", "RS-232: remote with local lockout"),
    _q("SYST:COMM:SER:SEND", "relay a command to the 2182A (double any \" inside)", example='"*CLS"'),
    _q("SYST:COMM:SER:ENT?", "the 2182A's reply to the last relayed query (may come in pieces)"),
)

#: The 2182A's commands that are not settings (2182A manual, SCPI tables), reached through the relay.
K2182A_ACTIONS: dict[str, Action] = _actions(
    *(
        Action(h, doc, reply, instrument="2182A", **kw)
        for h, doc, reply, kw in (
            ("*RST", "reset every setting but TRACe to its default", None, {}),
            ("*CLS", "clear the error queue and the event registers", None, {}),
            ("*ESR?", "read and clear the standard event status register", None, {}),
            ("*STB?", "status byte", None, {}),
            ("*OPC", "operation complete (nothing pending)", None, {}),
            ("*OPC?", "1 when all is done", "1", {}),
            ("*WAI", "wait for pending operations (none)", None, {}),
            ("*TST?", "self-test: 0 = passed", "0", {}),
            ("*TRG", "bus trigger (accepted)", None, {}),
            ("READ?", "one conversion at the 6221's DC output current (math and rel applied)", None, {}),
            ("FETC?", "the last reading again", None, {}),
            ("SENS:DATA?", "the last reading", None, {}),
            ("SENS:DATA:FRES?", "the last reading, each only once; −230 when none is new", None, {"idle_error": -230}),
            ("SENS:VOLT:REF:ACQ", "rel value = the last reading", None, {}),
            ("CALC1:DATA?", "the last reading after the math", None, {}),
            ("CALC2:IMM", "statistic of the buffer; −230 when empty", None, {"idle_error": -230}),
            ("CALC2:IMM?", "compute and return the statistic; −230 when empty", None, {"idle_error": -230}),
            ("CALC2:DATA?", "the last statistic computed", None, {}),
            ("TRAC:CLE", "clear the buffer", None, {}),
            ("TRAC:DATA?", "the stored readings; −230 when empty", None, {"idle_error": -230}),
            ("TRAC:FREE?", "bytes free and in use (unverified sizes)", None, {}),
            ("TRAC:POIN:ACT?", "readings stored", None, {}),
            ("INIT:IMM", "one trigger cycle (the simulation converts on READ?)", None, {}),
            ("ABOR", "abort (accepted)", None, {}),
            ("SYST:PRES", "system preset: as *RST", None, {}),
            ("SYST:ERR?", "next error", None, {}),
            ("SYST:ERR:ALL?", "every queued error, emptying the queue", None, {}),
            ("SYST:ERR:COUN?", "number of queued errors", None, {}),
            ("SYST:CLE", "clear the error queue", None, {}),
            ("SYST:LFR?", "mains frequency (Hz)", None, {}),
            ("SYST:VERS?", "SCPI version (unverified)", "1991.0", {}),
            ("SYST:KEY", "simulate a key press (accepted)", None, {"example": "1"}),
            ("STAT:PRES", "every enable register to 0", None, {}),
            ("STAT:MEAS:EVEN?", "measurement event register", "0", {}),
            ("STAT:OPER:EVEN?", "operation event register", "0", {}),
            ("STAT:QUES:EVEN?", "questionable event register", "0", {}),
            ("STAT:QUE?", "next error (as SYST:ERR?)", None, {}),
            ("STAT:QUE:CLE", "clear the error queue", None, {}),
        )
    )
)
