"""Driver for a Keithley 6221 current source with a 2182A nanovoltmeter in Delta mode.

The driver talks only through a transport (:mod:`instruments.transport`), so the same code runs against real
hardware, the simulated bench, or a replayed record. Time comes from the injectable ``clock`` and ``sleep``.

Bench safety: :meth:`Keithley6221.run_delta` sends ``SOUR:SWE:ABOR`` in ``finally`` and the context manager sends
it again on every exit (normal, exception, KeyboardInterrupt), so the source is left idle.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from contactrig.core.validation import check_int, check_range
from instruments.delta import DeltaBlock, DeltaSettings, parse_buffer
from instruments.errors import (
    ComplianceWarning,
    InstrumentError,
    InstrumentTimeout,
    InvalidReadingsWarning,
    NanovoltmeterMissing,
    ReplyError,
    SweepAborted,
    SweepStalled,
)
from instruments.pairs import Identity
from instruments.transport import SerialSettings, Transport, VisaTransport

__all__ = ["Keithley6221"]

#: Operation event register bits (6221 reference manual).
SWEEP_DONE = 1 << 1
SWEEP_ABORTED = 1 << 2
#: Measurement event register bits.
READING_OVERFLOW = 1 << 0
COMPLIANCE = 1 << 3

_XOFF = "\x13"
_MAX_ERRORS = 50

#: 6221 state the Delta readings depend on, pinned before every block (command, query, expected answer). A previous
#: user may have left any of it set: the 6221's averaging filter acts on Delta readings, CALC1 math rescales them when
#: the buffer is fed from CALC1, relative timestamps change the time axis, cold switching changes the timing.
SOURCE_STATE: tuple[tuple[str, str, str], ...] = (
    ("SOUR:DELT:CSW OFF", "SOUR:DELT:CSW?", "0"),
    ("SENS:AVER:STAT OFF", "SENS:AVER:STAT?", "0"),
    ("CALC1:STAT OFF", "CALC1:STAT?", "0"),
    ("TRAC:FEED SENS1", "TRAC:FEED?", "SENS1"),
    ("TRAC:TST:FORM ABS", "TRAC:TST:FORM?", "ABS"),
)
#: 2182A state (relayed): channel 1, digital and analog filters off (a digital filter averages conversions of
#: opposite polarity), autozero on (its reset default). NPLC and range come from the settings.
VOLTMETER_STATE: tuple[tuple[str, str, str], ...] = (
    (":SENS:CHAN 1", ":SENS:CHAN?", "1"),
    (":SENS:VOLT:DFIL:STAT OFF", ":SENS:VOLT:DFIL:STAT?", "0"),
    (":SENS:VOLT:LPAS OFF", ":SENS:VOLT:LPAS?", "0"),
    (":SYST:AZER ON", ":SYST:AZER?", "1"),
)


def _idn_complete(text: str) -> bool:
    fields = text.split(",")
    return len(fields) >= 4 and all(f.strip() for f in fields[:4])


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _fmt(x: float) -> str:
    return format(float(x), ".9g")


def _error_entry(reply: str) -> tuple[int, str]:
    """``code,"message"`` → (code, message); a reply of another shape is a :class:`ReplyError`."""
    code_text, _, message = reply.strip().partition(",")
    try:
        return int(code_text), message.strip().strip('"')
    except ValueError:
        raise ReplyError("SYST:ERR?", reply, 'code,"message"') from None


def _parts(command: str, reply: str, n: int) -> list[str]:
    """The ``n`` answers of a compound query (the last may itself hold ``;``, as an error message can)."""
    parts = reply.strip().split(";", n - 1)
    if len(parts) != n:
        raise ReplyError(command, reply, f"{n} answers separated by ';'")
    return parts


def _integer(command: str, text: str) -> int:
    try:
        return int(float(text))
    except ValueError:
        raise ReplyError(command, text, "an integer") from None


def _same_answer(reply: str, expected: str) -> bool:
    """A state read-back matches: keywords compare on their short form (``SENS`` = ``SENS1``), numbers as numbers."""
    r, e = reply.strip().strip('"').upper(), expected.upper()
    if _is_number(r) and _is_number(e):
        return math.isclose(float(r), float(e), rel_tol=1e-6)
    return r == e or r.rstrip("1") == e.rstrip("1")


def pinned_state() -> dict[str, dict[str, str]]:
    """What every block sets on the 6221 and (relayed) the 2182A besides the block settings: command → expected
    read-back. Stored in a session's start record."""
    return {
        "6221": {cmd: expected for cmd, _, expected in SOURCE_STATE},
        "2182A": {cmd: expected for cmd, _, expected in VOLTMETER_STATE},
    }


#: A conservative sustained rate of GPIB and LAN replies [bytes/s] (GPIB reaches ~1 MB/s; the 6221's LAN more).
FAST_LINK_BYTES_PER_S = 250e3


def fast_chunk_size(timeout_ms: int, largest: int = 10_000) -> int:
    """Readings per ``TRAC:DATA:SEL?`` on GPIB or LAN: a reply (~27 bytes per reading,timestamp pair) takes at most
    a quarter of the VISA timeout at :data:`FAST_LINK_BYTES_PER_S`, between 1000 (Tektronix's chunk) and
    ``largest``; fewer, longer replies cost fewer turns (tests/benchmarks/bench_delta_overhead.py)."""
    fits = int(0.25 * timeout_ms / 1000.0 * FAST_LINK_BYTES_PER_S / 27.0)
    return max(1000, min(largest, fits))


class Keithley6221:
    """A 6221 (+2182A) behind ``transport``.

    clock/sleep: time source and sleep function (injected in tests and replays).
    poll_interval_s: longest sleep between status polls. arm_timeout_s: deadline for ``SOUR:DELT:ARM?``.
    relay_timeout_s: deadline for a complete line from the 2182A. stall_timeout_s: how long a running sweep may go
    without a new reading (on top of three conversion periods) before it counts as stalled — the completion deadline
    follows progress (``TRAC:POIN:ACT?``), so a long block never times out while readings keep arriving.
    chunk_size: readings per ``TRAC:DATA:SEL?``:
    every reply stays short against the VISA timeout (a full 65536-reading buffer is ~1.8 MB, minutes over
    RS-232), and on the simulator chunks cost no more than one ``TRAC:DATA?``
    (tests/benchmarks/bench_delta_overhead.py).
    Implements :class:`instruments.pairs.PairDriver` (``identify``, ``run_block``, ``close``).
    """

    def __init__(
        self,
        transport: Transport,
        *,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        poll_interval_s: float = 0.05,
        arm_timeout_s: float = 10.0,
        relay_timeout_s: float = 3.0,
        stall_timeout_s: float = 10.0,
        chunk_size: int = 1000,
    ) -> None:
        self.transport = transport
        self.clock = clock
        self.sleep = sleep
        self.poll_interval_s = check_range("poll_interval_s", poll_interval_s, 0.0, 60.0, lo_open=True, unit="s")
        self.arm_timeout_s = check_range("arm_timeout_s", arm_timeout_s, 0.0, 3600.0, lo_open=True, unit="s")
        self.relay_timeout_s = check_range("relay_timeout_s", relay_timeout_s, 0.0, 3600.0, lo_open=True, unit="s")
        self.stall_timeout_s = check_range("stall_timeout_s", stall_timeout_s, 0.0, 86400.0, lo_open=True, unit="s")
        self.chunk_size = check_int("chunk_size", chunk_size, 1, 65536)
        self._closed = False
        #: "idle" after SOUR:SWE:ABOR went out, "unknown" when it could not be sent, "" before any block
        self.source_state = ""
        #: the pinned state as read back before the last block (see :func:`pinned_state`)
        self.state_read: dict[str, dict[str, str]] = {}

    # ------------------------------------------------------------------ opening and closing
    @classmethod
    def open(
        cls,
        address: str,
        resource_manager: Any = None,
        timeout_ms: int = 5000,
        *,
        visa_library: str = "",
        serial: SerialSettings | None = None,
        **kwargs: Any,
    ) -> Keithley6221:
        """Open the 6221 at VISA ``address`` (GPIB, ``TCPIP0::<ip>::1394::SOCKET`` or serial ``ASRL…``) with LF
        terminations (over RS-232: those of ``serial``, whose parameters are set and whose baud rate sizes the
        buffer chunks unless ``chunk_size`` is given) and a ``timeout_ms`` VISA timeout, on ``resource_manager`` or
        a new one on ``visa_library`` (e.g. ``"@py"``). Use as a context manager."""
        transport = VisaTransport.open(address, resource_manager, timeout_ms, visa_library=visa_library, serial=serial)
        if "chunk_size" not in kwargs:
            serial_link = transport.serial
            kwargs["chunk_size"] = serial_link.chunk_size(timeout_ms) if serial_link else fast_chunk_size(timeout_ms)
        try:
            return cls(transport, **kwargs)
        except BaseException:  # invalid driver options: nothing was sent, but the connection must not leak
            transport.close()
            raise

    def __enter__(self) -> Keithley6221:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: object) -> None:
        if exc is None:
            self.close()
            return
        try:  # an error while closing must not hide the one that is propagating
            self.close()
        except Exception as close_error:
            exc.add_note(f"also, while leaving the source idle: {close_error}")

    def close(self) -> None:
        """Leave the source idle (``SOUR:SWE:ABOR``) and close the transport. Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        try:
            self.abort()
        finally:
            self.transport.close()

    def pinned_state(self) -> dict[str, dict[str, str]]:
        """What every block sets besides its settings (see the module function :func:`pinned_state`)."""
        return pinned_state()

    # ------------------------------------------------------------------ low level
    def write(self, command: str) -> None:
        self.transport.write(command)

    def query(self, command: str) -> str:
        return self.transport.query(command).strip()

    def query_int(self, command: str) -> int:
        reply = self.query(command)
        try:
            return int(float(reply))
        except ValueError:
            raise ReplyError(command, reply, "an integer") from None

    def abort(self) -> None:
        """Stop and un-arm any Delta sweep: the source goes idle."""
        self.write("SOUR:SWE:ABOR")

    def errors(self, first: str | None = None) -> list[tuple[int, str]]:
        """Drain the error queue (``SYST:ERR?`` until ``0,"No error"``); return the errors found. ``first``: the
        answer to a ``SYST:ERR?`` already sent as part of a compound message."""
        found: list[tuple[int, str]] = []
        for _ in range(_MAX_ERRORS):
            reply = self.query("SYST:ERR?") if first is None else first
            first = None
            code, message = _error_entry(reply)
            if code == 0:
                return found
            found.append((code, message))
        raise ReplyError("SYST:ERR?", "", f"the queue to empty within {_MAX_ERRORS} reads")

    def check_errors(self, first: str | None = None) -> None:
        """Raise :class:`InstrumentError` for the first error in the queue (all are drained); ``first`` as in
        :meth:`errors`."""
        found = self.errors(first)
        if found:
            (code, message), *others = found
            raise InstrumentError(code, message, tuple(others))

    # ------------------------------------------------------------------ serial relay to the 2182A
    def relay_write(self, command: str) -> None:
        """Send ``command`` to the 2182A through the 6221's serial port."""
        self.write('SYST:COMM:SER:SEND "' + command.replace('"', '""') + '"')

    def relay_query(self, command: str, complete: Callable[[str], bool] | None = None) -> str:
        """Relay a query to the 2182A and return its complete answer line.

        ``SYST:COMM:SER:ENT?`` may answer nothing yet or part of the line, lead with XOFF (0x13) bytes, and carry
        the 2182A's own terminator (CR or LF). Pieces are gathered until the line is complete (a CR/LF from the
        2182A, or ``complete(text)``), with a deadline; afterwards the link is resynchronised so that no stray
        terminator is left to be read as an empty answer to the next query.
        """
        send = 'SYST:COMM:SER:SEND "' + command.replace('"', '""') + '"'
        enter = send + ";:SYST:COMM:SER:ENT?"  # the first ENT? rides with the SEND (it may find nothing yet)
        start = self.clock()
        text = ""
        wait = 0.005
        while True:
            piece = self.transport.query(enter).replace(_XOFF, "")
            enter = "SYST:COMM:SER:ENT?"
            text = (text + piece).lstrip("\r\n")  # a terminator left over from an earlier reply is not a line
            cut = min((i for i in (text.find("\r"), text.find("\n")) if i >= 0), default=-1)
            if cut >= 0 and text[:cut].strip():
                line = text[:cut]
                break
            if complete is not None and complete(text.strip()):
                line = text
                break
            if self.clock() - start > self.relay_timeout_s:
                self._resync()
                raise InstrumentTimeout(
                    f'SYST:COMM:SER:ENT? (relaying "{command}" to the 2182A)',
                    self.relay_timeout_s,
                    f"no complete line; got {text!r}",
                )
            self.sleep(wait)
            wait = min(wait * 2, 0.1)
        self._resync()
        return line.strip().strip(_XOFF)

    def _resync(self) -> None:
        """Query ``*OPC?`` and skip empty lines until its ``1``: consumes a stray terminator left by the relay."""
        reply = self.transport.query("*OPC?").strip()
        for _ in range(4):
            if reply == "1":
                return
            reply = self.transport.read().strip()
        if reply != "1":
            raise ReplyError("*OPC?", reply, "1 (link out of step after a relayed reply)")

    # ------------------------------------------------------------------ identification
    def identify(self) -> Identity:
        """``*IDN?`` of the 6221 and, relayed, of the 2182A (which must be present)."""
        source = self.query("*IDN?")
        if not _idn_complete(source):
            raise ReplyError("*IDN?", source, "manufacturer,model,serial,firmware")
        self.require_voltmeter()
        voltmeter = self.relay_query("*IDN?", complete=_idn_complete)
        if not _idn_complete(voltmeter):
            raise ReplyError("*IDN? (2182A)", voltmeter, "manufacturer,model,serial,firmware")
        return Identity(source=source, voltmeter=voltmeter)

    def require_voltmeter(self, reply: str | None = None) -> None:
        """Raise :class:`NanovoltmeterMissing` unless ``SOUR:DELT:NVPR?`` answers 1 (``reply``: its answer, if it
        was already asked as part of a compound message)."""
        reply = self.query("SOUR:DELT:NVPR?") if reply is None else reply.strip()
        if reply not in ("1", "0"):
            raise ReplyError("SOUR:DELT:NVPR?", reply, "1 or 0")
        if reply != "1":
            raise NanovoltmeterMissing(reply)

    # ------------------------------------------------------------------ Delta block
    # Every check of the robust sequence is kept, but checks ride in compound messages (';'), so that a block
    # costs about ten messages (tests/benchmarks/bench_delta_overhead.py compares with PyMeasure's driver).
    _START = "SOUR:SWE:ABOR;:SOUR:DELT:NVPR?;:SYST:ERR?"

    def _start(self) -> None:
        """Stop anything running, check that the 2182A answers and that the error queue is empty (errors left by
        earlier commands raise :class:`InstrumentError` before anything is configured)."""
        present, error = _parts(self._START, self.query(self._START), 2)
        self.require_voltmeter(present)
        self.check_errors(error)

    def configure_delta(self, s: DeltaSettings) -> None:
        """Send the settings (2182A through the relay) and pin every other state the readings depend on
        (:data:`SOURCE_STATE`, :data:`VOLTMETER_STATE`), clear and size the buffer, set the reading format — in one
        message to the 6221 that ends by reading the pinned state back and ``SYST:ERR?``: a rejected setting raises
        :class:`InstrumentError`, a state that did not take :class:`ReplyError`."""
        self._configure_voltmeter(s)
        commands = [
            "SOUR:CURR:RANG:AUTO ON" if s.current_range_a is None else f"SOUR:CURR:RANG {_fmt(s.current_range_a)}",
            f"SOUR:CURR:COMP {_fmt(s.compliance_v)}",
            f"SOUR:DELT:HIGH {_fmt(s.high_a)}",  # also sets LOW to -HIGH: LOW must come after
            f"SOUR:DELT:LOW {_fmt(s.low_a)}",
            f"SOUR:DELT:DEL {_fmt(s.delay_s)}",
            f"SOUR:DELT:COUN {s.count:d}",
            f"SOUR:DELT:CAB {'ON' if s.compliance_abort else 'OFF'}",
            "SOUR:SWE:COUN 1",
            f"UNIT {s.unit}",
            *(command for command, _, _ in SOURCE_STATE),
            "TRAC:CLE",
            f"TRAC:POIN {s.count:d}",
            "FORM:ELEM READ,TST",
        ]
        queries = [q for _, q, _ in SOURCE_STATE]
        message = ";:".join([*commands, *queries, "SYST:ERR?"])
        parts = _parts(message, self.query(message), len(queries) + 1)
        self.check_errors(parts[-1])
        query = ";:".join(queries)
        self.state_read["6221"] = self._check_state(query, ";".join(parts[:-1]), SOURCE_STATE, "")

    def _configure_voltmeter(self, s: DeltaSettings) -> None:
        """2182A: pinned state, NPLC and range, then all of it read back — one relayed message (proves the 2182A
        took the relayed settings, with no blind sleep, and that nothing changed them)."""
        rng = ":SENS:VOLT:RANG:AUTO ON"
        if s.voltmeter_range_v is not None:
            rng = f":SENS:VOLT:RANG {_fmt(s.voltmeter_range_v)}"
        sets = [*(command for command, _, _ in VOLTMETER_STATE), f":SENS:VOLT:NPLC {_fmt(s.nplc)}", rng]
        expected = ((":SENS:VOLT:NPLC", ":SENS:VOLT:NPLC?", _fmt(s.nplc)), *VOLTMETER_STATE)
        query = ";".join(q for _, q, _ in expected)
        n = len(expected)

        def complete(text: str) -> bool:
            return len(text.split(";")) == n and all(p.strip() for p in text.split(";"))

        reply = self.relay_query(";".join([*sets, query]), complete=complete)
        self.state_read["2182A"] = self._check_state(query, reply, expected, " (2182A)")

    @staticmethod
    def _check_state(query: str, reply: str, expected: tuple[tuple[str, str, str], ...], who: str) -> dict[str, str]:
        """Compare a compound read-back with what was set; raise :class:`ReplyError` naming the first mismatch."""
        parts = reply.split(";")
        if len(parts) != len(expected):
            raise ReplyError(query + who, reply, f"{len(expected)} answers separated by ';'")
        for (command, q, want), got in zip(expected, parts, strict=True):
            if not _same_answer(got, want):
                raise ReplyError(
                    q + who, got, f"{want} (just set with {command.split()[0]!r}: the setting did not take)"
                )
        return {command: got.strip() for (command, _, _), got in zip(expected, parts, strict=True)}

    _ARM_POLL = "SOUR:DELT:ARM?;:STAT:OPER:EVEN?;:STAT:MEAS:EVEN?"

    def _arm(self) -> None:
        """Arm and poll ``SOUR:DELT:ARM?`` until 1, with a deadline. Each poll also reads (and so clears) the
        operation and measurement event registers, the last one just before ``INIT``: a compliance bit latched
        before this block must not leak into it."""
        command = "SOUR:DELT:ARM;:" + self._ARM_POLL
        deadline = self.clock() + self.arm_timeout_s
        wait = 0.005
        while True:
            reply = _parts(command, self.query(command), 3)[0]
            if reply == "1":
                return
            if reply != "0":
                raise ReplyError("SOUR:DELT:ARM?", reply, "1 or 0")
            if self.clock() > deadline:
                raise InstrumentTimeout("SOUR:DELT:ARM?", self.arm_timeout_s, "the Delta test did not arm")
            self.sleep(wait)
            wait = min(2 * wait, self.poll_interval_s)
            command = self._ARM_POLL

    def stall_window_s(self, s: DeltaSettings, stored: int) -> float:
        """How long (s) the sweep may go without a new reading: the first needs three conversions, each later one
        one conversion; both get ``stall_timeout_s`` on top for the instrument's own overhead (unknown, measured on
        no hardware yet)."""
        conversions = 3 if stored == 0 else 1
        return 2.0 * conversions * s.conversion_period_s + self.stall_timeout_s

    _POLL = "STAT:OPER:EVEN?;:TRAC:POIN:ACT?;:STAT:MEAS:EVEN?"

    def _wait_done(self, s: DeltaSettings) -> tuple[int, int, int]:
        """Poll the operation event register until sweep done or aborted; return (operation bits, stored
        readings, measurement bits seen during the sweep).

        The deadline follows progress: each poll also reads ``TRAC:POIN:ACT?`` (and the measurement event register,
        whose bits are gathered: reading clears it), and the sweep counts as stalled (:class:`SweepStalled`) only
        when the count has not grown for :meth:`stall_window_s`.
        """
        wait = min(self.poll_interval_s, max(0.002, s.conversion_period_s))
        stored = 0
        meas = 0
        last_progress = self.clock()
        while True:
            bits_text, stored_text, meas_text = _parts(self._POLL, self.query(self._POLL), 3)
            bits = _integer("STAT:OPER:EVEN?", bits_text)
            now_stored = _integer("TRAC:POIN:ACT?", stored_text)
            meas |= _integer("STAT:MEAS:EVEN?", meas_text)
            if bits & (SWEEP_DONE | SWEEP_ABORTED):
                return bits, now_stored, meas
            now = self.clock()
            window = self.stall_window_s(s, stored)
            if now_stored > stored:
                stored, last_progress = now_stored, now
            elif now - last_progress > window:
                raise SweepStalled(stored, s.count, window)
            self.sleep(wait)

    def read_buffer(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """Read ``n`` reading,timestamp pairs: chunks of ``chunk_size`` with ``TRAC:DATA:SEL?`` (first is #0)."""
        if n == 0:
            return np.empty(0), np.empty(0)
        rs, ts = [], []
        for start in range(0, n, self.chunk_size):
            size = min(self.chunk_size, n - start)
            r, t = self._parse(f"TRAC:DATA:SEL? {start:d},{size:d}", size)
            rs.append(r)
            ts.append(t)
        return np.concatenate(rs), np.concatenate(ts)

    def _parse(self, command: str, expected: int) -> tuple[np.ndarray, np.ndarray]:
        reply = self.query(command)
        try:
            r, t = parse_buffer(reply, 2)
        except ValueError as exc:
            raise ReplyError(command, reply, f"reading,timestamp pairs ({exc})") from None
        if r.size != expected:
            raise ReplyError(command, reply, f"{expected} reading,timestamp pairs, got {r.size}")
        return r, t

    def run_delta(self, settings: DeltaSettings) -> DeltaBlock:
        """Run one Delta block and return its readings (see the module docstring for the exit guarantees).

        Sequence: abort, presence check, error queue must be empty (errors left by earlier commands raise
        :class:`InstrumentError` before anything is configured), configure and pin the state (read back), check
        errors, arm (confirmed by ``SOUR:DELT:ARM?``), clear the operation and measurement event registers,
        ``INIT:IMM``, poll ``STAT:OPER:EVEN?``, ``TRAC:POIN:ACT?`` (deadline follows progress) and
        ``STAT:MEAS:EVEN?`` (compliance), chunked buffer read, drain ``SYST:ERR?``, abort. Checks share compound
        messages: about ten messages per block of up to ``chunk_size`` readings.

        Every error leaves with a note saying whether the source is idle (``SOUR:SWE:ABOR`` sent) or in an unknown
        state (it could not be sent, e.g. the connection is gone); :attr:`source_state` says the same.
        """
        if not isinstance(settings, DeltaSettings):
            raise TypeError("run_delta expects a DeltaSettings")
        try:
            readings, stamps, compliance = self._take_block(settings)
        except BaseException as exc:
            exc.add_note(self._leave_idle())
            raise
        self._leave_idle()
        return self._block(settings, readings, stamps, compliance)

    def _take_block(self, settings: DeltaSettings) -> tuple[np.ndarray, np.ndarray, bool]:
        """The instrument part of :meth:`run_delta`: readings, timestamps and the compliance flag."""
        self._start()
        self.configure_delta(settings)
        self._arm()
        self.write("INIT:IMM")
        bits, stored, meas = self._wait_done(settings)
        if bits & SWEEP_ABORTED:
            self.check_errors()
            reason = "compliance (compliance abort is on)" if meas & COMPLIANCE else "sweep aborted"
            raise SweepAborted(reason, stored)
        if stored != settings.count:  # done latched before the last count showed: ask once more
            stored = self.query_int("TRAC:POIN:ACT?")
        if stored != settings.count:
            raise ReplyError("TRAC:POIN:ACT?", str(stored), f"{settings.count} stored readings")
        readings, stamps = self.read_buffer(stored)
        self.check_errors()
        return readings, stamps, bool(meas & COMPLIANCE)

    def _leave_idle(self) -> str:
        """``SOUR:SWE:ABOR``; return one line saying what state the source was left in."""
        error = self._abort_quietly()
        if error is None:
            self.source_state = "idle"
            return "the current source was left idle (SOUR:SWE:ABOR sent)"
        self.source_state = "unknown"
        return (
            f"the current source state is UNKNOWN: SOUR:SWE:ABOR could not be sent ({error}); check the 6221's "
            "front panel and press OUTPUT OFF"
        )

    @staticmethod
    def _block(settings: DeltaSettings, readings: np.ndarray, stamps: np.ndarray, compliance: bool) -> DeltaBlock:
        """The block, with a warning for invalid readings and for compliance."""
        n_invalid = int(np.count_nonzero(np.isnan(readings)))
        if compliance:
            warnings.warn(
                f"the 6221 was in compliance ({settings.compliance_v:g} V) during this block of {readings.size} "
                "readings: the source could not drive the set current, so the readings are wrong and none is "
                "counted as valid — lower the current or raise the compliance",
                ComplianceWarning,
                stacklevel=3,
            )
        elif n_invalid:
            warnings.warn(
                f"{n_invalid} of {readings.size} Delta readings invalid (+9.9E37: 2182A overflow or no reading); "
                "they are counted and not averaged"
                + (
                    "; no valid reading in this block — check the 2182A range and the sample leads"
                    if n_invalid == readings.size
                    else ""
                ),
                InvalidReadingsWarning,
                stacklevel=3,
            )
        return DeltaBlock(
            settings=settings,
            readings=readings,
            timestamps_s=stamps,
            n_invalid=n_invalid,
            unit=settings.unit,
            compliance=compliance,
        )

    def run_block(self, settings: DeltaSettings) -> DeltaBlock:
        """One block for a bench session (:class:`instruments.pairs.PairDriver`): :meth:`run_delta`."""
        return self.run_delta(settings)

    def _abort_quietly(self) -> Exception | None:
        """``SOUR:SWE:ABOR`` on the way out: never masks the exception already under way; returns the error if it
        could not be sent (close() tries again)."""
        try:
            self.abort()
        except Exception as exc:  # the original error matters more
            return exc
        return None
