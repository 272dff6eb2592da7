"""Day-one hardware check: run on the real 6221/2182A pair the behaviours the manuals leave open, and record them.

``contactrig instruments verify ADDRESS`` calls :func:`verify`. Each check is a small function that talks to the
6221 through a :class:`~instruments.k6221.Keithley6221` (whose transport records every exchange) and returns a
:class:`Check`: what was measured and whether the check ran. Nothing is assumed about the answers (they are what
the check is for); a check *fails* only when the instrument does not let it run (an error, a timeout, a reply of
the wrong shape). Whatever happens, every check ends with ``SOUR:SWE:ABOR``, and so does the whole run: the source
is left idle.

Safety: checks that drive current use ``current_a`` (default 100 µA, at most 1 mA) with a 1 V compliance; they
need a load (a resistor or the sample, ≤ 1 kΩ so that 100 µA stays below 0.1 V). The compliance-abort check sets
the compliance to its minimum (0.1 V) and never raises the current: it trips only on a load above
0.1 V / ``current_a`` (an open lead does it at no risk), and otherwise says it could not be triggered.
"""

from __future__ import annotations

import json
import math
import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from contactrig.core.files import write_text_atomic
from contactrig.core.validation import check_range
from instruments.delta import DeltaSettings
from instruments.k6221 import Keithley6221
from instruments.transport import RecordingTransport, Transport

__all__ = ["CHECKS", "Check", "VerifyReport", "verify", "write_report"]

_MAX_SAFE_CURRENT_A = 1e-3


@dataclass
class Check:
    """One check: ``name``, what it asks (``question``), what was found (``found``: JSON-able), ``ran`` (False:
    the instrument did not let it run, ``error`` says why), and ``needs_load`` (drives current into the load)."""

    name: str
    question: str
    found: dict[str, Any] = field(default_factory=dict)
    ran: bool = True
    error: str = ""
    needs_load: bool = False


@dataclass
class VerifyReport:
    address: str
    current_a: float
    checks: list[Check]
    transcript: list[dict[str, Any]]
    source_left_idle: bool

    @property
    def passed(self) -> bool:
        return self.source_left_idle and all(c.ran for c in self.checks)

    def markdown(self) -> str:
        lines = [
            f"# Day-one check of the 6221/2182A at `{self.address}`",
            "",
            f"Result: **{'all checks ran' if self.passed else 'some checks could not run'}**; source left idle: "
            f"{'yes (SOUR:SWE:ABOR sent last)' if self.source_left_idle else 'NO — press OUTPUT OFF'}.",
            f"Checks that drive current used {self.current_a:g} A with a 1 V compliance (a load ≤ 1 kΩ is needed).",
            "",
            "| check | question | found | ran |",
            "|---|---|---|---|",
        ]
        for c in self.checks:
            found = ", ".join(f"{k}: {_for_people(v)}" for k, v in c.found.items()) or c.error
            found = found.replace("|", "\\|")  # a "|" in a value (the "|low|" candidate) would split the cell
            load = " (needs a load)" if c.needs_load else ""
            lines.append(f"| {c.name}{load} | {c.question} | {found} | {'yes' if c.ran else 'NO: ' + c.error} |")
        lines += ["", f"Transcript: {len(self.transcript)} exchanges (JSON report)."]
        return "\n".join(lines) + "\n"


#: Significant digits of a number in ``verify.md`` (the JSON report keeps every digit).
PEOPLE_DIGITS = 6


def _for_people(value: Any) -> str:
    """A found value as people read it: floats to :data:`PEOPLE_DIGITS` significant digits (``0.103``, not
    ``0.10299999999999998``, the binary rounding of a difference of timestamps), inside lists and dicts too."""
    if isinstance(value, float):
        return f"{value:.{PEOPLE_DIGITS}g}"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k!r}: {_for_people(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_for_people(v) for v in value) + "]"
    return str(value)


def _block(k: Keithley6221, current_a: float, **kw: Any) -> Any:
    return k.run_delta(DeltaSettings(high_a=current_a, compliance_v=1.0, count=kw.pop("count", 10), **kw))


def check_identity(k: Keithley6221, current_a: float) -> dict[str, Any]:
    ident = k.identify()
    return {"6221": ident.source, "2182A": ident.voltmeter}


def check_relay_framing(k: Keithley6221, current_a: float) -> dict[str, Any]:
    """The raw pieces ``SYST:COMM:SER:ENT?`` returns for a relayed ``*IDN?`` (XOFF bytes, CR/LF, empty replies)."""
    k.relay_write("*IDN?")
    pieces = []
    for _ in range(10):
        piece = k.transport.query("SYST:COMM:SER:ENT?")
        pieces.append(piece)
        if "\r" in piece or "\n" in piece or piece.count(",") >= 3:
            break
        k.sleep(0.05)
    k._resync()
    text = "".join(pieces)
    return {
        "pieces": [repr(p) for p in pieces],
        "xoff": "\x13" in text,
        "ends_with": repr(text[-1:]) if text else "''",
        "empty_first": bool(pieces) and pieces[0] == "",
    }


def check_opc_waits(k: Keithley6221, current_a: float) -> dict[str, Any]:
    """Does ``*OPC?`` wait for the end of a Delta run? Readings stored when it answers, against the count."""
    s = DeltaSettings(high_a=current_a, compliance_v=1.0, count=20)
    k._start()
    k.configure_delta(s)
    k._arm()
    k.write("INIT:IMM")
    t0 = k.clock()
    k.query("*OPC?")
    waited = k.clock() - t0
    stored = k.query_int("TRAC:POIN:ACT?")
    k.abort()
    return {"opc_waited_s": round(waited, 4), "stored_when_answered": stored, "count": 20, "waits": stored == 20}


def check_ohms_divisor(k: Keithley6221, current_a: float) -> dict[str, Any]:
    """UNIT OHMS with asymmetric levels (high = I, low = −I/2): which current does the 6221 divide by?"""
    high, low = current_a, -current_a / 2
    volts = _raw_block(k, high, low, "V")
    ohms = _raw_block(k, high, low, "OHMS")
    divisor = volts / ohms if ohms else math.nan
    candidates = {"(high-low)/2": (high - low) / 2, "high": high, "high-low": high - low, "|low|": abs(low)}
    best = min(candidates, key=lambda n: abs(candidates[n] - divisor)) if math.isfinite(divisor) else "none"
    return {"divisor_a": divisor, "closest": best, "candidates_a": candidates}


def _raw_block(k: Keithley6221, high: float, low: float, unit: str) -> float:
    """Mean of a 10-reading block in ``unit``, configured by hand (the driver refuses OHMS with asymmetric levels)."""
    k._start()
    k.configure_delta(DeltaSettings(high_a=high, low_a=low, compliance_v=1.0, count=10))
    k.write(f"UNIT {unit}")
    k._arm()
    k.write("INIT:IMM")
    _, stored, _ = k._wait_done(DeltaSettings(high_a=high, low_a=low, compliance_v=1.0, count=10))
    readings, _ = k.read_buffer(stored)
    k.abort()
    return float(statistics.fmean(x for x in readings if math.isfinite(x)))


def check_arm_without_2182a(k: Keithley6221, current_a: float) -> dict[str, Any]:
    """The error when arming with no 2182A: only observable with the RS-232 cable out (else reported as such)."""
    present = k.query("SOUR:DELT:NVPR?")
    if present == "1":
        return {"observed": False, "note": "2182A present; unplug the RS-232 cable and run again to observe it"}
    k.write("SOUR:DELT:ARM")
    errors = k.errors()
    k.abort()
    return {"observed": True, "errors": errors, "armed": k.query("SOUR:DELT:ARM?")}


def check_rate_vs_nplc(k: Keithley6221, current_a: float) -> dict[str, Any]:
    """Reading period against delay + NPLC / line frequency, at NPLC 1 and 5."""
    out: dict[str, Any] = {}
    for nplc in (1.0, 5.0):
        block = _block(k, current_a, nplc=nplc, count=12)
        period = statistics.median(b - a for a, b in zip(block.timestamps_s, block.timestamps_s[1:], strict=False))
        out[f"nplc_{nplc:g}_period_s"] = period
        out[f"nplc_{nplc:g}_nominal_s"] = block.settings.conversion_period_s
    return out


def check_range_auto_in_delta(k: Keithley6221, current_a: float) -> dict[str, Any]:
    """``SOUR:CURR:RANG:AUTO ON`` in Delta mode: does arming keep it, and which range is used?"""
    k._start()
    k.configure_delta(DeltaSettings(high_a=current_a, compliance_v=1.0, count=5))
    k._arm()
    auto, rng = k.query("SOUR:CURR:RANG:AUTO?;:SOUR:CURR:RANG?").split(";")
    errors = k.errors()
    k.abort()
    return {"auto_after_arm": auto, "range_a": rng, "errors": errors}


def check_timestamp_resolution(k: Keithley6221, current_a: float) -> dict[str, Any]:
    """Smallest step and printed digits of the buffer timestamps."""
    block = _block(k, current_a, count=20)
    steps = [b - a for a, b in zip(block.timestamps_s, block.timestamps_s[1:], strict=False) if b > a]
    return {"smallest_step_s": min(steps) if steps else math.nan, "first_s": float(block.timestamps_s[0])}


def check_compliance_abort_bits(k: Keithley6221, current_a: float) -> dict[str, Any]:
    """Which status bits a compliance abort sets: compliance 0.1 V (the minimum), abort on, the same safe current."""
    s = DeltaSettings(high_a=current_a, compliance_v=0.1, count=10, compliance_abort=True)
    k._start()
    k.configure_delta(s)
    k._arm()
    k.write("INIT:IMM")
    bits, stored, meas = k._wait_done(s)
    errors = k.errors()
    k.abort()
    tripped = bool(bits & (1 << 2))
    note = "" if tripped else f"not triggered: the load needs more than 0.1 V at {current_a:g} A (open a lead)"
    return {
        "tripped": tripped,
        "operation_bits": bits,
        "measurement_bits": meas,
        "stored": stored,
        "errors": errors,
        "note": note,
    }


#: (name, question, function, drives current into the load)
CHECKS: tuple[tuple[str, str, Callable[[Keithley6221, float], dict[str, Any]], bool], ...] = (
    ("identity", "*IDN? of the 6221 and (relayed) the 2182A", check_identity, False),
    ("relay_framing", "SYST:COMM:SER:ENT? framing (XOFF, terminators, partial replies)", check_relay_framing, False),
    ("opc_waits", "does *OPC? wait for a Delta run?", check_opc_waits, True),
    ("ohms_divisor", "the OHMS divisor with asymmetric currents", check_ohms_divisor, True),
    ("arm_without_2182a", "the error when arming without a 2182A", check_arm_without_2182a, False),
    ("rate_vs_nplc", "the Delta reading rate against NPLC", check_rate_vs_nplc, True),
    ("range_auto_in_delta", "SOUR:CURR:RANG:AUTO in Delta mode", check_range_auto_in_delta, True),
    ("timestamp_resolution", "buffer timestamp resolution", check_timestamp_resolution, True),
    ("compliance_abort_bits", "which status bits a compliance abort sets", check_compliance_abort_bits, True),
)


def _run_check(
    k: Keithley6221, name: str, question: str, fn: Callable[..., dict[str, Any]], load: bool, current_a: float
) -> Check:
    check = Check(name, question, needs_load=load)
    try:
        check.found = fn(k, current_a)
    except Exception as exc:  # a check that cannot run is a result, not the end of the run
        check.ran, check.error = False, f"{type(exc).__name__}: {exc}".splitlines()[0][:200]
    finally:
        k.abort()  # every check ends with the source idle
    return check


def verify(
    transport: Transport,
    address: str = "",
    *,
    current_a: float = 1e-4,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
    only: tuple[str, ...] = (),
) -> VerifyReport:
    """Run the checks (``only``: a subset by name) on the 6221 behind ``transport``; the transport is closed and
    ``SOUR:SWE:ABOR`` is the last command sent, whatever happens (KeyboardInterrupt included)."""
    current_a = check_range("current_a", current_a, 0.0, _MAX_SAFE_CURRENT_A, lo_open=True, unit="A")
    rec = RecordingTransport(transport, clock=clock)
    k = Keithley6221(rec, clock=clock, sleep=sleep)
    checks: list[Check] = []
    try:
        for name, question, fn, load in CHECKS:
            if not only or name in only:
                checks.append(_run_check(k, name, question, fn, load, current_a))
    finally:
        idle = k._abort_quietly() is None
        rec.close()
    transcript = [asdict(e) for e in rec.exchanges]
    return VerifyReport(address, current_a, checks, transcript, idle)


def write_report(report: VerifyReport, directory: Path) -> tuple[Path, Path]:
    """Write ``verify.json`` (checks and the full transcript) and ``verify.md`` into ``directory``."""
    directory.mkdir(parents=True, exist_ok=True)
    data = {
        "address": report.address,
        "current_a": report.current_a,
        "passed": report.passed,
        "source_left_idle": report.source_left_idle,
        "checks": [asdict(c) for c in report.checks],
        "transcript": report.transcript,
    }
    # atomic, and a link at either name is replaced, never followed (contactrig.core.files: every output's rule)
    js = write_text_atomic(directory / "verify.json", json.dumps(data, indent=1, default=str), force=True)
    md = write_text_atomic(directory / "verify.md", report.markdown(), force=True)
    return js, md
