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
    InstrumentError,
    InstrumentTimeout,
    InvalidReadingsWarning,
    NanovoltmeterMissing,
    ReplyError,
    SweepAborted,
)
from instruments.pairs import Identity
from instruments.transport import Transport, VisaTransport

__all__ = ["Keithley6221"]

#: Operation event register bits (6221 reference manual).
SWEEP_DONE = 1 << 1
SWEEP_ABORTED = 1 << 2
#: Measurement event register bits.
READING_OVERFLOW = 1 << 0
COMPLIANCE = 1 << 3

_XOFF = "\x13"
_MAX_ERRORS = 50


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


class Keithley6221:
    """A 6221 (+2182A) behind ``transport``.

    clock/sleep: time source and sleep function (injected in tests and replays).
    poll_interval_s: longest sleep between status polls. arm_timeout_s: deadline for ``SOUR:DELT:ARM?``.
    relay_timeout_s: deadline for a complete line from the 2182A. chunk_size: readings per ``TRAC:DATA:SEL?``:
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
        chunk_size: int = 1000,
    ) -> None:
        self.transport = transport
        self.clock = clock
        self.sleep = sleep
        self.poll_interval_s = check_range("poll_interval_s", poll_interval_s, 0.0, 60.0, lo_open=True, unit="s")
        self.arm_timeout_s = check_range("arm_timeout_s", arm_timeout_s, 0.0, 3600.0, lo_open=True, unit="s")
        self.relay_timeout_s = check_range("relay_timeout_s", relay_timeout_s, 0.0, 3600.0, lo_open=True, unit="s")
        self.chunk_size = check_int("chunk_size", chunk_size, 1, 65536)
        self._closed = False

    # ------------------------------------------------------------------ opening and closing
    @classmethod
    def open(
        cls,
        address: str,
        resource_manager: Any = None,
        timeout_ms: int = 5000,
        **kwargs: Any,
    ) -> Keithley6221:
        """Open the 6221 at VISA ``address`` (GPIB, ``TCPIP0::<ip>::1394::SOCKET`` or serial) with LF
        terminations and a ``timeout_ms`` VISA timeout. Use as a context manager."""
        transport = VisaTransport.open(address, resource_manager, timeout_ms)
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

    def errors(self) -> list[tuple[int, str]]:
        """Drain the error queue (``SYST:ERR?`` until ``0,"No error"``); return the errors found."""
        found: list[tuple[int, str]] = []
        for _ in range(_MAX_ERRORS):
            reply = self.query("SYST:ERR?")
            code_text, _, message = reply.partition(",")
            try:
                code = int(code_text)
            except ValueError:
                raise ReplyError("SYST:ERR?", reply, 'code,"message"') from None
            if code == 0:
                return found
            found.append((code, message.strip().strip('"')))
        raise ReplyError("SYST:ERR?", "", f"the queue to empty within {_MAX_ERRORS} reads")

    def check_errors(self) -> None:
        """Raise :class:`InstrumentError` for the first error in the queue (all are drained)."""
        found = self.errors()
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
        self.relay_write(command)
        start = self.clock()
        text = ""
        wait = 0.005
        while True:
            piece = self.transport.query("SYST:COMM:SER:ENT?").replace(_XOFF, "")
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

    def require_voltmeter(self) -> None:
        """Raise :class:`NanovoltmeterMissing` unless ``SOUR:DELT:NVPR?`` answers 1."""
        reply = self.query("SOUR:DELT:NVPR?")
        if reply not in ("1", "0"):
            raise ReplyError("SOUR:DELT:NVPR?", reply, "1 or 0")
        if reply != "1":
            raise NanovoltmeterMissing(reply)

    # ------------------------------------------------------------------ Delta block
    def configure_delta(self, s: DeltaSettings) -> None:
        """Send the settings (2182A through the relay), clear and size the buffer, set the reading format."""
        self.relay_write(f":SENS:VOLT:NPLC {_fmt(s.nplc)}")
        if s.voltmeter_range_v is None:
            self.relay_write(":SENS:VOLT:RANG:AUTO ON")
        else:
            self.relay_write(f":SENS:VOLT:RANG {_fmt(s.voltmeter_range_v)}")
        # Read the NPLC back: proves the 2182A took the relayed settings (no blind sleep) and that nothing changed it.
        reply = self.relay_query(":SENS:VOLT:NPLC?", complete=_is_number)
        try:
            nplc = float(reply)
        except ValueError:
            raise ReplyError(":SENS:VOLT:NPLC? (2182A)", reply, "a number") from None
        if not math.isclose(nplc, s.nplc, rel_tol=1e-6):
            raise ReplyError(":SENS:VOLT:NPLC? (2182A)", reply, f"the NPLC just sent, {s.nplc:g}")
        if s.current_range_a is None:
            self.write("SOUR:CURR:RANG:AUTO ON")
        else:
            self.write(f"SOUR:CURR:RANG {_fmt(s.current_range_a)}")
        self.write(f"SOUR:CURR:COMP {_fmt(s.compliance_v)}")
        self.write(f"SOUR:DELT:HIGH {_fmt(s.high_a)}")  # also sets LOW to -HIGH: LOW must come after
        self.write(f"SOUR:DELT:LOW {_fmt(s.low_a)}")
        self.write(f"SOUR:DELT:DEL {_fmt(s.delay_s)}")
        self.write(f"SOUR:DELT:COUN {s.count:d}")
        self.write(f"SOUR:DELT:CAB {'ON' if s.compliance_abort else 'OFF'}")
        self.write("SOUR:SWE:COUN 1")
        self.write(f"UNIT {s.unit}")
        self.write("TRAC:CLE")
        self.write(f"TRAC:POIN {s.count:d}")
        self.write("FORM:ELEM READ,TST")

    def _arm(self) -> None:
        self.write("SOUR:DELT:ARM")
        deadline = self.clock() + self.arm_timeout_s
        wait = 0.005
        while True:
            reply = self.query("SOUR:DELT:ARM?")
            if reply == "1":
                return
            if reply != "0":
                raise ReplyError("SOUR:DELT:ARM?", reply, "1 or 0")
            if self.clock() > deadline:
                raise InstrumentTimeout("SOUR:DELT:ARM?", self.arm_timeout_s, "the Delta test did not arm")
            self.sleep(wait)
            wait = min(2 * wait, self.poll_interval_s)

    def _wait_done(self, s: DeltaSettings) -> int:
        """Poll the operation event register until sweep done or aborted; return the event bits."""
        budget = s.deadline_s()
        deadline = self.clock() + budget
        wait = min(self.poll_interval_s, max(0.002, s.conversion_period_s))
        while True:
            bits = self.query_int("STAT:OPER:EVEN?")
            if bits & (SWEEP_DONE | SWEEP_ABORTED):
                return bits
            if self.clock() > deadline:
                stored = self.query_int("TRAC:POIN:ACT?")
                raise InstrumentTimeout(
                    "STAT:OPER:EVEN?", budget, f"the Delta sweep did not finish ({stored} of {s.count} readings stored)"
                )
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

        Sequence: presence check, abort, error queue must be empty (errors left by earlier commands raise
        :class:`InstrumentError` before anything is configured), configure, check errors, arm (confirmed by
        ``SOUR:DELT:ARM?``), clear the event register, ``INIT:IMM``, poll ``STAT:OPER:EVEN?`` with a deadline
        derived from the settings, ``TRAC:POIN:ACT?``, chunked buffer read, drain ``SYST:ERR?``, abort.
        """
        if not isinstance(settings, DeltaSettings):
            raise TypeError("run_delta expects a DeltaSettings")
        try:
            self.require_voltmeter()
            self.abort()
            self.check_errors()
            self.configure_delta(settings)
            self.check_errors()
            self._arm()
            self.query("STAT:OPER:EVEN?")  # reading clears the event register
            self.write("INIT:IMM")
            bits = self._wait_done(settings)
            stored = self.query_int("TRAC:POIN:ACT?")
            if bits & SWEEP_ABORTED:
                meas = self.query_int("STAT:MEAS:EVEN?")
                self.check_errors()
                reason = "compliance (compliance abort is on)" if meas & COMPLIANCE else "sweep aborted"
                raise SweepAborted(reason, stored)
            if stored != settings.count:
                raise ReplyError("TRAC:POIN:ACT?", str(stored), f"{settings.count} stored readings")
            readings, stamps = self.read_buffer(stored)
            self.check_errors()
        finally:
            self._abort_quietly()
        n_invalid = int(np.count_nonzero(np.isnan(readings)))
        if n_invalid:
            warnings.warn(
                f"{n_invalid} of {readings.size} Delta readings invalid (+9.9E37: 2182A overflow or no reading); "
                "they are counted and not averaged"
                + (
                    "; no valid reading in this block — check the 2182A range and the sample leads"
                    if n_invalid == readings.size
                    else ""
                ),
                InvalidReadingsWarning,
                stacklevel=2,
            )
        return DeltaBlock(
            settings=settings,
            readings=readings,
            timestamps_s=stamps,
            n_invalid=n_invalid,
            unit=settings.unit,
        )

    def run_block(self, settings: DeltaSettings) -> DeltaBlock:
        """One block for a bench session (:class:`instruments.pairs.PairDriver`): :meth:`run_delta`."""
        return self.run_delta(settings)

    def _abort_quietly(self) -> None:
        """``SOUR:SWE:ABOR`` from a ``finally``: never masks the exception already under way."""
        try:
            self.abort()
        except Exception:  # the original error matters more; close() tries again
            pass
