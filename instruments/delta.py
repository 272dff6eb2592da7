"""Delta-mode settings and results: one validated, immutable settings object and one block of readings.

Delta mode (seed paper sect. 2.3; Keithley 6221/2182A manuals): the 6221 alternates its output between ``high_a``
and ``low_a``; the 2182A converts once per step and the 6221 forms each Delta reading from three consecutive
conversions,

    Δn = (Vn − 2·Vn+1 + Vn+2) / 4 · (−1)^(n−1),

which equals R·(high − low)/2 and cancels a constant thermal EMF and a linear drift (:func:`delta_readings`).
Limits, units and ranges are those of the one command table, :mod:`instruments.commands`.
This module imports only numpy, :mod:`contactrig.core.validation`, :mod:`instruments.block` and
:mod:`instruments.commands`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from contactrig.core.validation import SettingError, check_choice
from instruments.block import BlockStatistics, block_statistics
from instruments.commands import CURRENT_RANGES_A, K2182A, K6221, OVER_RANGE, VOLTMETER_RANGES_V, check_nplc

__all__ = [
    "CURRENT_RANGES_A",
    "INVALID_THRESHOLD",
    "VOLTMETER_RANGES_V",
    "DeltaBlock",
    "DeltaSettings",
    "delta_readings",
    "parse_buffer",
]

#: Overflow / invalid readings come back as +9.9E37; anything at or above this magnitude is invalid.
INVALID_THRESHOLD = 9.9e37
# Limits come from the one declaration of each setting (instruments.commands).
_HIGH, _LOW = K6221["SOUR:DELT:HIGH"], K6221["SOUR:DELT:LOW"]


@dataclass(frozen=True, init=False)
class DeltaSettings:
    """One Delta block's settings, validated on construction (SI units; nothing is clamped).

    high_a, low_a: source levels in A, each within ±0.105 A and different; ``low_a`` defaults to ``-high_a``.
    delay_s: delay before each conversion, 1e-3 … 9999.999 s.
    count: Delta readings per block, 1 … 65536 (the buffer is sized to it).
    compliance_v: voltage compliance, 0.1 … 105 V in 10 mV steps.
    compliance_abort: abort the sweep when the source goes into compliance.
    current_range_a: fixed source range (one of :data:`CURRENT_RANGES_A`) or ``None`` for auto range.
    unit: reading unit, ``"V"`` or ``"OHMS"``. ``"OHMS"`` needs symmetric levels (``low_a == -high_a``): the 6221
    divides by "the sourced current", and with asymmetric levels which one is undocumented, so that combination is
    refused (a :class:`SettingError` naming ``unit``); use ``"V"``, from which R = V/ΔI, ΔI = (high − low)/2.
    nplc: 2182A integration time in power-line cycles, 0.01 … 50 (60 Hz lines: 60).
    voltmeter_range_v: 2182A range (one of :data:`VOLTMETER_RANGES_V`) or ``None`` for auto range.
    line_frequency_hz: mains frequency, 50 or 60 (sets the NPLC limit and the conversion time).
    """

    # The constructor is written out because ``low_a`` is optional when given (None → −high_a) but always a
    # number once validated; a generated one would type the field as optional for every reader.
    high_a: float
    low_a: float
    delay_s: float
    count: int
    compliance_v: float
    compliance_abort: bool
    current_range_a: float | None
    unit: str
    nplc: float
    voltmeter_range_v: float | None
    line_frequency_hz: float

    def __init__(
        self,
        high_a: float,
        low_a: float | None = None,
        delay_s: float = 2e-3,
        count: int = 10,
        compliance_v: float = 10.0,
        compliance_abort: bool = True,
        current_range_a: float | None = None,
        unit: str = "V",
        nplc: float = 1.0,
        voltmeter_range_v: float | None = None,
        line_frequency_hz: float = 50.0,
    ) -> None:
        set_ = object.__setattr__
        line = float(check_choice("line_frequency_hz", line_frequency_hz, (50, 60)))
        set_(self, "line_frequency_hz", line)
        high, low = _source_levels(high_a, low_a)
        set_(self, "high_a", high)
        set_(self, "low_a", low)
        set_(self, "delay_s", K6221["SOUR:DELT:DEL"].check("delay_s", delay_s))
        set_(self, "count", K6221["SOUR:DELT:COUN"].check("count", count))
        set_(self, "compliance_v", K6221["SOUR:CURR:COMP"].check("compliance_v", compliance_v))
        if not isinstance(compliance_abort, (bool, np.bool_)):
            raise SettingError("compliance_abort", compliance_abort, "expected True or False")
        set_(self, "compliance_abort", bool(compliance_abort))
        set_(self, "current_range_a", _source_range(current_range_a, high, low))
        set_(self, "unit", _unit(check_choice("unit", unit, ("V", "OHMS")), high, low))
        set_(self, "nplc", check_nplc("nplc", nplc, line))
        set_(self, "voltmeter_range_v", _fixed_range("voltmeter_range_v", voltmeter_range_v, K2182A["SENS:VOLT:RANG"]))

    @property
    def delta_current_a(self) -> float:
        """ΔI = (high − low)/2 in A: a V Delta reading divided by ΔI is the resistance in Ω."""
        return (self.high_a - self.low_a) / 2.0

    @property
    def conversion_period_s(self) -> float:
        """Nominal time per 2182A conversion: delay + NPLC / line frequency (s), without instrument overhead."""
        return self.delay_s + self.nplc / self.line_frequency_hz

    def expected_duration_s(self) -> float:
        """Nominal duration of the block in s: count + 2 conversions (the first reading needs three)."""
        return (self.count + 2) * self.conversion_period_s

    def deadline_s(self, margin_s: float = 10.0, factor: float = 2.0) -> float:
        """Time (s) after INIT after which a block that has not finished is declared hung."""
        return factor * self.expected_duration_s() + margin_s


def _source_levels(high_a: float, low_a: float | None) -> tuple[float, float]:
    """The validated (high, low) source levels in A; low defaults to −high."""
    high = _HIGH.check("high_a", high_a)
    low = -high if low_a is None else _LOW.check("low_a", low_a)
    if high == low:
        raise SettingError("low_a", low, f"must differ from high_a = {high:g} A (Delta alternates between them)")
    return high, low


def _unit(unit: str, high: float, low: float) -> str:
    """``OHMS`` only with symmetric levels: the 6221's divisor for asymmetric ones is undocumented."""
    if unit == "OHMS" and not math.isclose(low, -high, rel_tol=1e-12, abs_tol=0.0):
        raise SettingError(
            "unit",
            unit,
            f"'OHMS' needs low_a = -high_a (got high_a = {high:g} A, low_a = {low:g} A: which current the 6221 "
            "divides by is undocumented); use unit 'V' — R is then computed as V / ((high - low)/2)",
        )
    return unit


def _fixed_range(field: str, value: float | None, setting: Any) -> float | None:
    """None (auto range) or one of the setting's ranges, matched to 1e-9 relative."""
    return None if value is None else float(setting.check(field, value))


def _source_range(current_range_a: float | None, high: float, low: float) -> float | None:
    """The fixed source range (or None); both levels must fit in it with the 6221's 5 % over-range."""
    rng = _fixed_range("current_range_a", current_range_a, K6221["SOUR:CURR:RANG"])
    if rng is not None:
        limit = rng * OVER_RANGE
        for name, value in (("high_a", high), ("low_a", low)):
            if abs(value) > limit * (1 + 1e-12):
                raise SettingError(name, value, f"exceeds the {rng:g} A range (at most ±{limit:g} A)")
    return rng


@dataclass(frozen=True)
class DeltaBlock:
    """One Delta block as read from the 6221 buffer.

    readings: in ``unit`` (V or Ω); invalid readings (+9.9E37) are NaN and counted in ``n_invalid``.
    compliance: the 6221 latched its compliance bit (``STAT:MEAS:EVEN?`` bit 3) during this block: the source could
    not drive the set current, so every reading is wrong by an unknown amount. ``valid`` is then all False and the
    statistics have no value (NaN mean, n = 0); the readings are kept as returned, for the record.
    timestamps_s: 6221 buffer timestamps in s, the first is 0.
    Statistics (``stats``, and ``mean``, ``sd``, ``sem``, ``n`` from it) are those of
    :func:`instruments.block.block_statistics` over the valid readings, in ``unit``.
    """

    settings: DeltaSettings
    readings: np.ndarray
    timestamps_s: np.ndarray
    n_invalid: int
    unit: str
    compliance: bool = False

    def __post_init__(self) -> None:
        r = np.array(self.readings, dtype=float)
        t = np.array(self.timestamps_s, dtype=float)
        if r.shape != t.shape or r.ndim != 1:
            raise ValueError(f"readings {r.shape} and timestamps {t.shape} must be 1-D and of equal length")
        r.flags.writeable = False
        t.flags.writeable = False
        object.__setattr__(self, "readings", r)
        object.__setattr__(self, "timestamps_s", t)

    @property
    def valid(self) -> np.ndarray:
        """Boolean mask of valid readings: finite, and none at all in a block taken in compliance."""
        ok = np.isfinite(self.readings)
        return ok & False if self.compliance else ok

    def resistance_ohm(self) -> np.ndarray:
        """Readings in Ω: V readings divided by ΔI = (high − low)/2; OHMS readings as they are."""
        if self.unit == "OHMS":
            return self.readings.copy()
        return self.readings / self.settings.delta_current_a

    @cached_property
    def stats(self) -> BlockStatistics:
        """Mean, SD, SEM and counts of the valid readings, in ``unit``."""
        return block_statistics(self.readings, self.valid)

    @property
    def n(self) -> int:
        """Number of valid readings."""
        return self.stats.n

    @property
    def mean(self) -> float:
        return self.stats.mean

    @property
    def sd(self) -> float:
        return self.stats.sd

    @property
    def sem(self) -> float:
        return self.stats.sem


def delta_readings(conversions_v: np.ndarray) -> np.ndarray:
    """3-point Delta readings from alternating-polarity conversions V1, V2, … (first conversion at high current).

    Δn = (Vn − 2·Vn+1 + Vn+2)/4 · (−1)^(n−1) for n = 1 … len − 2 (Keithley 6221 manual, Delta mode).
    """
    v = np.asarray(conversions_v, dtype=float)
    if v.size < 3:
        return np.empty(0)
    d = (v[:-2] - 2.0 * v[1:-1] + v[2:]) / 4.0
    sign = np.where(np.arange(d.size) % 2 == 0, 1.0, -1.0)
    return d * sign


def parse_buffer(text: str, elements: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Parse ``reading,timestamp,…`` buffer text into (readings, timestamps); raise ValueError if malformed.

    Values with ``abs(x) >= 9.9e37`` (the instrument's overflow/invalid marker) become NaN.
    """
    text = text.strip()
    if not text:
        return np.empty(0), np.empty(0)
    n_values = text.count(",") + 1
    if n_values % elements:
        raise ValueError(f"{n_values} values is not a whole number of {elements}-element readings")
    # numpy's C text parser: ~2x faster than float() per item; ValueError on garbage or an empty field
    values = np.loadtxt([text], delimiter=",", dtype=float, ndmin=1)
    if values.size != n_values:
        raise ValueError(f"expected {n_values} values, parsed {values.size}")
    if not np.all(np.isfinite(values)):
        raise ValueError("non-finite value in buffer")
    values = values.reshape(-1, elements)
    readings = values[:, 0].copy()
    readings[np.abs(readings) >= INVALID_THRESHOLD] = np.nan
    stamps = values[:, 1].copy() if elements > 1 else np.zeros(len(readings))
    return readings, stamps
