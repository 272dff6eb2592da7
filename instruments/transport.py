"""Message transports: the only way the driver talks to an instrument.

A transport has ``write(msg)``, ``query(msg) -> str``, ``read() -> str`` and ``close()``. :class:`VisaTransport`
wraps a pyvisa resource (terminations and timeout set explicitly); :class:`RecordingTransport` records every
exchange of another transport; :class:`ReplayTransport` serves recorded exchanges back in order, so a session can
be replayed without hardware, and raises :class:`ReplayMismatch` as soon as the driver diverges from the record.
pyvisa is imported only when a VISA resource is opened.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, Protocol

from contactrig.core.validation import check_int
from instruments.errors import CommunicationError, InstrumentTimeout, ReplayMismatch

__all__ = [
    "Exchange",
    "RecordingTransport",
    "ReplayMismatch",
    "ReplayTransport",
    "Transport",
    "VisaTransport",
]


class Transport(Protocol):
    """What the driver needs from a connection."""

    def write(self, message: str) -> None: ...

    def query(self, message: str) -> str: ...

    def read(self) -> str: ...

    def close(self) -> None: ...


@dataclass(frozen=True)
class Exchange:
    """One recorded exchange. kind: "write", "query" or "read"; reply is None for writes.

    ``t_s`` is the time since recording began (s); ``error`` is ``"timeout"`` if the exchange timed out.
    """

    kind: str
    message: str
    reply: str | None
    t_s: float
    error: str | None = None


class VisaTransport:
    """A pyvisa message-based resource with LF terminations and an explicit timeout.

    The 6221 ends replies with LF (GPIB adds EOI; the LAN socket on port 1394 sends only LF, so without an
    explicit read termination reads would time out). A VISA timeout raises :class:`InstrumentTimeout` naming
    the command.
    """

    def __init__(self, resource: Any, timeout_ms: int = 5000) -> None:
        self.resource = resource
        resource.read_termination = "\n"
        resource.write_termination = "\n"
        resource.timeout = check_int("timeout_ms", timeout_ms, 1, 3_600_000)
        self._last = ""

    @classmethod
    def open(cls, address: str, resource_manager: Any = None, timeout_ms: int = 5000) -> VisaTransport:
        """Open ``address`` on ``resource_manager`` (default: pyvisa's default VISA library)."""
        import pyvisa

        check_int("timeout_ms", timeout_ms, 1, 3_600_000)
        if resource_manager is None:
            try:
                resource_manager = pyvisa.ResourceManager()
            except (ValueError, OSError) as exc:  # no VISA library installed (pyvisa raises ValueError)
                raise CommunicationError(
                    f"no VISA library is installed to open {address!r}: install NI-VISA, or `pip install pyvisa-py`"
                ) from exc
        try:
            resource = resource_manager.open_resource(
                address, read_termination="\n", write_termination="\n", timeout=int(timeout_ms)
            )
        except pyvisa.errors.VisaIOError as exc:
            raise CommunicationError(
                f"cannot open {address!r} ({exc.abbreviation}): check the address, that the 6221 is on and cabled"
            ) from exc
        return cls(resource, timeout_ms)

    @property
    def timeout_s(self) -> float:
        return float(self.resource.timeout) / 1000.0

    def _guard(self, command: str, fn: Callable[[], Any]) -> Any:
        import pyvisa

        try:
            return fn()
        except pyvisa.errors.VisaIOError as exc:
            if exc.error_code == pyvisa.constants.StatusCode.error_timeout:
                raise InstrumentTimeout(command, self.timeout_s) from None
            raise CommunicationError(f"VISA error during {command!r}: {exc.abbreviation}") from exc

    def write(self, message: str) -> None:
        self._last = message
        self._guard(message, lambda: self.resource.write(message))

    def query(self, message: str) -> str:
        self._last = message
        return self._guard(message, lambda: self.resource.query(message))

    def read(self) -> str:
        return self._guard(self._last or "read", self.resource.read)

    def close(self) -> None:
        self.resource.close()


class RecordingTransport:
    """Passes everything to ``inner`` and appends an :class:`Exchange` to ``exchanges`` for each call."""

    def __init__(self, inner: Transport, clock: Callable[[], float] = time.monotonic) -> None:
        self.inner = inner
        self.clock = clock
        self.exchanges: list[Exchange] = []
        self._t0 = clock()

    def _record(self, kind: str, message: str, fn: Callable[[], str | None]) -> Any:
        t = self.clock() - self._t0
        try:
            reply = fn()
        except InstrumentTimeout:
            self.exchanges.append(Exchange(kind, message, None, t, "timeout"))
            raise
        self.exchanges.append(Exchange(kind, message, reply, t))
        return reply

    def write(self, message: str) -> None:
        self._record("write", message, lambda: self.inner.write(message))

    def query(self, message: str) -> str:
        return self._record("query", message, lambda: self.inner.query(message))

    def read(self) -> str:
        return self._record("read", "", self.inner.read)

    def close(self) -> None:
        self.inner.close()


class ReplayTransport:
    """Serves recorded exchanges in order.

    strict: the driver must send exactly the recorded messages; otherwise only the kinds must match.
    A recorded timeout is raised again as :class:`InstrumentTimeout`.
    """

    def __init__(self, exchanges: Iterable[Exchange], strict: bool = True) -> None:
        self.exchanges = list(exchanges)
        self.strict = strict
        self.position = 0
        self.closed = False

    def _next(self, kind: str, message: str) -> Exchange:
        if self.position >= len(self.exchanges):
            raise ReplayMismatch(
                f"replay exhausted: the driver sent {kind} {message!r} after the last recorded exchange"
            )
        ex = self.exchanges[self.position]
        if ex.kind != kind or (self.strict and kind != "read" and ex.message != message):
            raise ReplayMismatch(
                f"replay diverged at exchange {self.position}: recorded {ex.kind} {ex.message!r}, "
                f"the driver sent {kind} {message!r}"
            )
        self.position += 1
        if ex.error == "timeout":
            raise InstrumentTimeout(ex.message or "read", 0.0, "recorded timeout")
        return ex

    @property
    def remaining(self) -> int:
        return len(self.exchanges) - self.position

    def write(self, message: str) -> None:
        self._next("write", message)

    def query(self, message: str) -> str:
        return self._next("query", message).reply or ""

    def read(self) -> str:
        return self._next("read", "").reply or ""

    def close(self) -> None:
        self.closed = True
