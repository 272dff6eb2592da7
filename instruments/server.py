"""The simulated bench on a real TCP socket, as the 6221's LAN port: raw SCPI lines ended by LF.

``contactrig instruments serve-sim`` runs a :class:`SimServer`; any VISA library that speaks raw sockets (pyvisa-py:
``TCPIP0::127.0.0.1::<port>::SOCKET`` with ``@py``) then drives the simulated 6221 + 2182A over the network stack,
so LAN behaviour (Nagle, reply framing, a dropped connection) is tested without hardware. Each received line is one
program message for :class:`instruments.simulated.SimulatedK6221`; its reply, if any, goes back ended by LF.

Only loopback hosts are served unless ``allow_remote`` is given: the simulator has no authentication.

Hostile or broken clients never stop the server: every connection has its own thread and the one instrument
executes one message at a time; a byte that is not ASCII outside a quoted string is SCPI error −101 "Invalid
character" in the error queue (as on the instrument); a line longer than :data:`MAX_LINE_BYTES` is discarded up to
its LF with −363 "Input buffer overrun"; a client that does not read its replies for ``send_timeout_s`` is dropped;
at most ``max_clients`` connections are held, and a new one closes the one idle longest (so a silent or half-open
client cannot lock the port). ``stop()`` (or leaving the context manager) closes every socket within ``timeout_s``.
``faults.disconnect_on`` (a canonical header such as ``"TRAC:DATA:SEL?"``) closes the connection when that command
arrives, to test a connection lost mid-block.
"""

from __future__ import annotations

import ipaddress
import logging
import socket
import threading
import time
from dataclasses import dataclass, field

from contactrig.core.text import quote
from contactrig.core.validation import SettingError, check_int, check_range
from instruments.scpi import parse_message
from instruments.simulated import E_INPUT_OVERRUN, E_INTERNAL, SimulatedBench, SimulatedK6221, _load_definition

__all__ = ["MAX_LINE_BYTES", "ServerFaults", "SimServer", "is_loopback"]

#: Longest program message the simulator takes (bytes before the LF); longer ones are discarded with −363.
MAX_LINE_BYTES = 1 << 16
_POLL_S = 0.1
_log = logging.getLogger(__name__)


def is_loopback(host: str) -> bool:
    """``host`` names only this machine (127.0.0.0/8, ::1, ``localhost``)."""
    if host.strip().lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip()).is_loopback
    except ValueError:
        return False


@dataclass
class ServerFaults:
    """Faults of the connection itself. disconnect_on: canonical headers whose arrival closes the connection."""

    disconnect_on: set[str] = field(default_factory=set)


@dataclass
class _Client:
    sock: socket.socket
    last_active: float = field(default_factory=time.monotonic)
    thread: threading.Thread | None = None


class SimServer:
    """A simulated 6221 (+2182A) on ``host``:``port`` (0 = a free port chosen by the OS; see :attr:`port`).

    bench: the simulated world (default :class:`SimulatedBench`); allow_remote: serve a non-loopback host
    (refused otherwise, with a :class:`SettingError` naming ``host``); nodelay: turn Nagle off on the server's
    side of each connection (the instrument answers at once; the client's Nagle is what the benchmark measures).
    max_clients: connections held at once (the oldest idle one makes room for a new one); send_timeout_s (s): a
    client that takes no reply bytes for this long is dropped.
    """

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 1394,
        *,
        bench: SimulatedBench | None = None,
        allow_remote: bool = False,
        nodelay: bool = True,
        faults: ServerFaults | None = None,
        max_clients: int = 4,
        send_timeout_s: float = 5.0,
    ) -> None:
        if not isinstance(host, str) or not host.strip():
            raise SettingError("host", host, "expected a host name or address, e.g. 127.0.0.1")
        if not allow_remote and not is_loopback(host):
            raise SettingError(
                "host", host, "only loopback hosts (127.0.0.1, ::1, localhost) unless --allow-remote is given"
            )
        self.host = host
        self.requested_port = check_int("port", port, 0, 65535)
        self.max_clients = check_int("max_clients", max_clients, 1, 64)
        self.send_timeout_s = check_range("send_timeout_s", send_timeout_s, 0.01, 3600.0, unit="s")
        self.bench = bench if bench is not None else SimulatedBench()
        self.nodelay = nodelay
        self.faults = faults if faults is not None else ServerFaults()
        data = _load_definition()
        self.device = SimulatedK6221("k6221", data["devices"]["k6221"], data["devices"]["k2182a"], self.bench)
        self._listener: socket.socket | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._clients: list[_Client] = []
        self._lock = threading.Lock()  # guards _clients
        self._device_lock = threading.Lock()  # one message at a time, as one instrument
        self.connections = 0

    @property
    def port(self) -> int:
        """The port being served (the OS's choice when 0 was asked)."""
        if self._listener is None:
            return self.requested_port
        return int(self._listener.getsockname()[1])

    @property
    def address(self) -> str:
        """The VISA resource name of the served instrument."""
        return f"TCPIP0::{self.host}::{self.port}::SOCKET"

    def start(self) -> SimServer:
        """Listen and serve in a background thread; return self."""
        family = socket.AF_INET6 if ":" in self.host else socket.AF_INET
        listener = socket.socket(family, socket.SOCK_STREAM)
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            listener.bind((self.host, self.requested_port))
        except OSError as exc:
            listener.close()
            raise OSError(exc.errno, f"cannot serve on {self.host}:{self.requested_port}: {exc.strerror}") from exc
        listener.listen(16)
        listener.settimeout(_POLL_S)
        self._listener = listener
        self._thread = threading.Thread(target=self._serve, name="contactrig-sim-server", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout_s: float = 2.0) -> None:
        """Stop serving: close the listener and every connection; wait at most ``timeout_s`` for the threads."""
        self._stop.set()
        deadline = time.monotonic() + timeout_s
        if self._thread is not None:
            self._thread.join(timeout_s)
        if self._listener is not None:
            _close(self._listener)
        with self._lock:
            clients = list(self._clients)
            self._clients.clear()
        for c in clients:
            _close(c.sock)
        for c in clients:
            if c.thread is not None:
                c.thread.join(max(0.0, deadline - time.monotonic()))

    def __enter__(self) -> SimServer:
        return self.start() if self._listener is None else self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def serve_until_stopped(self, poll_s: float = 0.2) -> None:
        """Block until :meth:`stop` (or KeyboardInterrupt, which stops the server and propagates)."""
        try:
            while not self._stop.wait(poll_s):
                pass
        finally:
            self.stop()

    @property
    def serving(self) -> bool:
        """The accepting thread is alive (it only ends with :meth:`stop`)."""
        return self._thread is not None and self._thread.is_alive() and not self._stop.is_set()

    # ---------------------------------------------------------------- serving
    def _serve(self) -> None:
        assert self._listener is not None
        while not self._stop.is_set():
            try:
                conn, _ = self._listener.accept()
            except TimeoutError:
                continue
            except OSError:  # listener closed by stop(), or a connection reset before accept
                if self._stop.is_set():
                    return
                continue
            self._admit(conn)

    def _admit(self, conn: socket.socket) -> None:
        """Start serving ``conn`` in its own thread, closing the longest-idle client if all slots are taken."""
        self.connections += 1
        client = _Client(conn)
        with self._lock:
            if len(self._clients) >= self.max_clients:
                idle = min(self._clients, key=lambda c: c.last_active)
                self._clients.remove(idle)
                _close(idle.sock)
            self._clients.append(client)
        client.thread = threading.Thread(target=self._run_client, args=(client,), name="contactrig-sim-client")
        client.thread.daemon = True
        client.thread.start()

    def _run_client(self, client: _Client) -> None:
        try:
            self._talk(client)
        except OSError:
            pass  # the peer vanished, or the socket was closed to make room or to stop
        finally:
            with self._lock:
                if client in self._clients:
                    self._clients.remove(client)
            _close(client.sock)

    def _talk(self, client: _Client) -> None:
        """Serve one client: LF-terminated messages in, replies out, until it leaves or the server stops."""
        conn = client.sock
        if self.nodelay:
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        conn.settimeout(_POLL_S)
        buf = bytearray()
        overrun = False  # discarding an overlong line up to its LF
        while not self._stop.is_set():
            try:
                data = conn.recv(65536)
            except TimeoutError:
                continue
            if not data:
                return
            client.last_active = time.monotonic()
            buf += data
            while (k := buf.find(b"\n")) >= 0:
                line = bytes(buf[:k])
                del buf[: k + 1]
                if overrun or k > MAX_LINE_BYTES:  # the end of a line too long to take
                    self._overrun(already=overrun)
                    overrun = False
                    continue
                if not self._answer(client, line.rstrip(b"\r")):
                    return
            if len(buf) > MAX_LINE_BYTES:  # a line that does not end within the bound: dropped as it comes
                buf.clear()
                self._overrun(already=overrun)
                overrun = True

    def _overrun(self, *, already: bool) -> None:
        """A line over :data:`MAX_LINE_BYTES`: −363 queued once for it (its bytes are dropped up to its LF)."""
        if not already:
            with self._device_lock:
                self.device.push_error(E_INPUT_OVERRUN)

    def _answer(self, client: _Client, line: bytes) -> bool:
        """Execute one message and send its reply; False when the connection is to be (or was) dropped."""
        message = line.decode("latin-1")
        if self.faults.disconnect_on and any(c.header in self.faults.disconnect_on for c in parse_message(message)):
            return False
        with self._device_lock:
            try:
                reply = self.device.handle(message)
            except Exception as exc:  # a simulator bug must not end the service: logged, and an error queued
                _log.error("simulated bench failed on %s: %s: %s", quote(message), type(exc).__name__, exc)
                self.device.push_error(E_INTERNAL)
                reply = None
        if reply is None:
            return True
        return self._send(client, reply.encode("latin-1") + b"\n")

    def _send(self, client: _Client, data: bytes) -> bool:
        """Send ``data``; False when the client took no byte for ``send_timeout_s`` or the server stops."""
        view = memoryview(data)
        stalled_since = time.monotonic()
        while view and not self._stop.is_set():
            try:
                n = client.sock.send(view)
            except TimeoutError:
                if time.monotonic() - stalled_since > self.send_timeout_s:
                    return False
                continue
            view = view[n:]
            stalled_since = client.last_active = time.monotonic()
        return not view


def _close(s: socket.socket) -> None:
    try:
        s.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    s.close()
