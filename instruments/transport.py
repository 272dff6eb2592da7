"""Message transports: the only way the driver talks to an instrument.

A transport has ``write(msg)``, ``query(msg) -> str``, ``read() -> str`` and ``close()``. :class:`VisaTransport`
wraps a pyvisa resource (terminations and timeout set explicitly; Nagle's algorithm off on LAN sockets; serial
parameters from a :class:`SerialSettings`); :class:`RecordingTransport` records every
exchange of another transport; :class:`ReplayTransport` serves recorded exchanges back in order, so a session can
be replayed without hardware, and raises :class:`ReplayMismatch` as soon as the driver diverges from the record.
pyvisa is imported only when a VISA resource is opened.
"""

from __future__ import annotations

import math
import socket
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, Protocol

from contactrig.core.validation import SettingError, check_choice, check_int
from instruments.errors import CommunicationError, InstrumentTimeout, ReplayMismatch

__all__ = [
    "BAUD_RATES",
    "Exchange",
    "RecordingTransport",
    "ReplayMismatch",
    "ReplayTransport",
    "SerialSettings",
    "Transport",
    "VisaTransport",
    "socket_of",
]

#: Baud rates the 6221's RS-232 port offers.
BAUD_RATES = (300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200)
#: Terminators the 6221's RS-232 port can send (its TX terminator); the same is used for writing.
TERMINATORS = {"LF": "\n", "CR": "\r", "CRLF": "\r\n", "LFCR": "\n\r"}
FLOW_CONTROLS = ("none", "xon_xoff")
PARITIES = ("none", "odd", "even")
#: Bytes per buffer reading on the wire, as the 6221 prints them: ``+1.01194701E-05,+1.23456789E+00,`` (9 digits).
BYTES_PER_READING = 32


@dataclass(frozen=True)
class SerialSettings:
    """RS-232 parameters of the 6221 (they must match its front-panel COMMUNICATIONS settings).

    baud_rate: one of :data:`BAUD_RATES`. flow_control: ``"none"`` or ``"xon_xoff"`` (the 6221 knows no hardware
    handshake). terminator: ``"LF"``, ``"CR"``, ``"CRLF"`` or ``"LFCR"`` (its TX terminator; also used for
    writing). data_bits: 7 or 8. parity: ``"none"``, ``"odd"`` or ``"even"``. Errors name ``prefix + key``
    (``[instrument] baud_rate`` when read from a scene).
    """

    baud_rate: int = 19200
    flow_control: str = "none"
    terminator: str = "LF"
    data_bits: int = 8
    parity: str = "none"
    prefix: str = ""

    def __post_init__(self) -> None:
        p = self.prefix
        rate = check_int(p + "baud_rate", self.baud_rate)
        check_choice(p + "baud_rate", rate, BAUD_RATES)
        object.__setattr__(self, "baud_rate", rate)
        check_choice(p + "flow_control", self.flow_control, FLOW_CONTROLS)
        check_choice(p + "terminator", self.terminator, tuple(TERMINATORS))
        check_choice(p + "data_bits", self.data_bits, (7, 8))
        check_choice(p + "parity", self.parity, PARITIES)
        if self.data_bits == 7 and self.parity == "none":
            raise SettingError(
                p + "parity", self.parity, "7 data bits need parity 'odd' or 'even' (the 6221's 7N1 is not offered)"
            )

    @property
    def bytes_per_s(self) -> float:
        """Characters per second on the line: start bit, data bits, parity bit, one stop bit."""
        return self.baud_rate / (1 + self.data_bits + (self.parity != "none") + 1)

    def chunk_size(self, timeout_ms: int, largest: int = 1000) -> int:
        """Readings per ``TRAC:DATA:SEL?`` such that one reply takes at most a quarter of the VISA timeout on the
        line (at least 10, at most ``largest``): 1000 readings (~32 kB) take ~17 s at 19 200 baud."""
        fit = int(0.25 * timeout_ms / 1000.0 * self.bytes_per_s / BYTES_PER_READING)
        return max(10, min(largest, fit))

    def timeout_ms(self, timeout_ms: int, chunk_size: int) -> int:
        """``timeout_ms``, raised if needed so that a reply of ``chunk_size`` readings takes at most a quarter of it
        (slow baud rates with the smallest chunk)."""
        needed = 4.0 * chunk_size * BYTES_PER_READING / self.bytes_per_s * 1000.0
        return max(int(timeout_ms), math.ceil(needed))

    def as_dict(self) -> dict[str, Any]:
        return {
            "baud_rate": self.baud_rate,
            "flow_control": self.flow_control,
            "terminator": self.terminator,
            "data_bits": self.data_bits,
            "parity": self.parity,
        }


def is_serial(address: str) -> bool:
    """A VISA serial resource (``ASRL<n>::INSTR`` or ``ASRL/dev/ttyUSB0::INSTR``)."""
    return address.strip().upper().startswith("ASRL")


def is_socket(address: str) -> bool:
    """A raw TCP socket resource (``TCPIP0::<host>::<port>::SOCKET``), as the 6221's LAN port is."""
    return address.strip().upper().startswith("TCPIP") and address.strip().upper().endswith("::SOCKET")


def socket_of(resource: Any) -> socket.socket | None:
    """The OS socket under a pyvisa-py TCPIP SOCKET session, or None (other backends, other resources).

    pyvisa-py keeps it as ``visalib.sessions[session].interface``: internals, so every step is checked.
    """
    try:
        session = resource.visalib.sessions[resource.session]
    except Exception:  # NI-VISA, pyvisa-sim, a closed resource: no such mapping
        return None
    sock = getattr(session, "interface", None)
    return sock if isinstance(sock, socket.socket) else None


def _set_nodelay(resource: Any) -> str:
    """Turn Nagle's algorithm off on a TCPIP SOCKET session; return how (for the start record).

    The VISA attribute first (NI-VISA honours it, and turns Nagle off by default anyway); pyvisa-py 0.8's setter for
    it raises, so then the socket itself. With Nagle on, every write-then-query turn waits for a delayed ACK
    (~40 ms): tests/benchmarks/bench_socket.py.
    """
    from pyvisa import constants

    try:
        resource.set_visa_attribute(constants.ResourceAttribute.tcpip_nodelay, constants.VI_TRUE)
        visa_ok = True
    except Exception:  # pyvisa-py raises UnknownAttribute (or NotImplementedError) here
        visa_ok = False
    sock = socket_of(resource)
    if sock is not None:
        try:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        except OSError as exc:
            return f"failed ({exc})"
        return "socket" if sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY) else "failed (not taken)"
    return "visa-attribute" if visa_ok else "unavailable"


def _configure_serial(resource: Any, serial: SerialSettings) -> None:
    """Baud rate, data bits, parity, one stop bit, flow control on a pyvisa serial resource."""
    from pyvisa import constants

    resource.baud_rate = serial.baud_rate
    resource.data_bits = serial.data_bits
    resource.parity = {"none": constants.Parity.none, "odd": constants.Parity.odd, "even": constants.Parity.even}[
        serial.parity
    ]
    resource.stop_bits = constants.StopBits.one
    resource.flow_control = (
        constants.ControlFlow.xon_xoff if serial.flow_control == "xon_xoff" else constants.ControlFlow.none
    )


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
    """A pyvisa message-based resource with explicit terminations and timeout.

    The 6221 ends replies with LF (GPIB adds EOI; the LAN socket on port 1394 sends only LF, so without an
    explicit read termination reads would time out); over RS-232 the terminator is the one its port is set to.
    On TCPIP SOCKET resources Nagle's algorithm is turned off (:attr:`nodelay` says how). A VISA timeout raises
    :class:`InstrumentTimeout` naming the command; a connection the instrument closed, or any other transfer failure,
    raises :class:`CommunicationError`.
    """

    def __init__(
        self, resource: Any, timeout_ms: int = 5000, *, read_termination: str = "\n", write_termination: str = "\n"
    ) -> None:
        self.resource = resource
        resource.read_termination = read_termination
        resource.write_termination = write_termination
        resource.timeout = check_int("timeout_ms", timeout_ms, 1, 3_600_000)
        self._last = ""
        #: how Nagle's algorithm was turned off ("socket", "visa-attribute"), "" for resources that are no socket
        self.nodelay = _set_nodelay(resource) if is_socket(str(getattr(resource, "resource_name", ""))) else ""
        #: the serial parameters set (None: not a serial resource)
        self.serial: SerialSettings | None = None

    @classmethod
    def open(
        cls,
        address: str,
        resource_manager: Any = None,
        timeout_ms: int = 5000,
        *,
        visa_library: str = "",
        serial: SerialSettings | None = None,
    ) -> VisaTransport:
        """Open ``address`` on ``resource_manager`` (default: a new one on ``visa_library``, e.g. ``"@py"`` for
        pyvisa-py; empty = pyvisa's default VISA library). ``serial`` configures a serial (``ASRL``) resource
        (default :class:`SerialSettings`); its timeout is raised if the baud rate needs it (see
        :meth:`SerialSettings.timeout_ms`)."""
        import pyvisa

        check_int("timeout_ms", timeout_ms, 1, 3_600_000)
        if resource_manager is None:
            resource_manager = _resource_manager(address, visa_library)
        term = "\n"
        if is_serial(address):
            serial = serial if serial is not None else SerialSettings()
            term = TERMINATORS[serial.terminator]
            timeout_ms = serial.timeout_ms(timeout_ms, serial.chunk_size(timeout_ms))
        try:
            resource = resource_manager.open_resource(
                address, read_termination=term, write_termination=term, timeout=int(timeout_ms)
            )
        except pyvisa.errors.VisaIOError as exc:
            raise CommunicationError(
                f"cannot open {address!r} ({exc.abbreviation}): check the address, that the 6221 is on and cabled"
            ) from exc
        except OSError as exc:  # pyvisa-py: a refused or unreachable socket
            raise CommunicationError(f"cannot open {address!r} ({exc}): check the address and the network") from exc
        try:
            if serial is not None:
                _configure_serial(resource, serial)
            transport = cls(resource, timeout_ms, read_termination=term, write_termination=term)
        except BaseException:
            resource.close()
            raise
        transport.serial = serial
        return transport

    @property
    def timeout_s(self) -> float:
        return float(self.resource.timeout) / 1000.0

    def _peer_closed(self) -> bool:
        """True if the socket under a pyvisa-py session was closed by the other end (reads would only time out)."""
        sock = socket_of(self.resource)
        if sock is None:
            return False
        try:
            sock.setblocking(False)
            try:
                return sock.recv(1, socket.MSG_PEEK) == b""
            finally:
                sock.setblocking(True)
        except BlockingIOError:
            return False
        except OSError:
            return True

    def _guard(self, command: str, fn: Callable[[], Any]) -> Any:
        import pyvisa

        try:
            return fn()
        except pyvisa.errors.VisaIOError as exc:
            if exc.error_code == pyvisa.constants.StatusCode.error_timeout:
                if self._peer_closed():
                    raise CommunicationError(
                        f"the instrument closed the connection during {command!r} (LAN cable, power, or another "
                        "client took the port)"
                    ) from None
                raise InstrumentTimeout(command, self.timeout_s) from None
            raise CommunicationError(f"VISA error during {command!r}: {exc.abbreviation}") from exc
        except (OSError, ValueError) as exc:  # pyvisa-py passes socket errors through; a closed resource: ValueError
            raise CommunicationError(f"connection lost during {command!r}: {exc}") from exc

    def write(self, message: str) -> None:
        self._last = message
        self._guard(message, lambda: self.resource.write(message))

    def query(self, message: str) -> str:
        self._last = message
        return self._guard(message, lambda: self.resource.query(message))

    def read(self) -> str:
        return self._guard(self._last or "read", self.resource.read)

    def close(self) -> None:
        try:
            self.resource.close()
        except OSError:  # the connection is gone already
            pass


def _resource_manager(address: str, visa_library: str) -> Any:
    """A pyvisa ResourceManager on ``visa_library`` ("" = pyvisa's default), or a CommunicationError saying how to
    get one."""
    import pyvisa

    try:
        return pyvisa.ResourceManager(visa_library) if visa_library else pyvisa.ResourceManager()
    except (ValueError, OSError) as exc:  # no such VISA library (pyvisa raises ValueError)
        if visa_library:
            raise CommunicationError(
                f"cannot load the VISA library {visa_library!r} to open {address!r} ({exc}): for pyvisa-py "
                "`pip install pyvisa-py` and use --visa-library @py"
            ) from exc
        raise CommunicationError(
            f"no VISA library is installed to open {address!r}: install NI-VISA, or `pip install pyvisa-py` and "
            "use --visa-library @py"
        ) from exc


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
