"""The simulated bench on a real TCP socket, as the 6221's LAN port: raw SCPI lines ended by LF.

``contactrig instruments serve-sim`` runs a :class:`SimServer`; any VISA library that speaks raw sockets (pyvisa-py:
``TCPIP0::127.0.0.1::<port>::SOCKET`` with ``@py``) then drives the simulated 6221 + 2182A over the network stack,
so LAN behaviour (Nagle, reply framing, a dropped connection) is tested without hardware. Each received line is one
program message for :class:`instruments.simulated.SimulatedK6221`; its reply, if any, goes back ended by LF.

Only loopback hosts are served unless ``allow_remote`` is given: the simulator has no authentication. One client at
a time, as on the instrument; ``stop()`` (or leaving the context manager) closes every socket within ``timeout_s``.
``faults.disconnect_on`` (a canonical header such as ``"TRAC:DATA:SEL?"``) closes the connection when that command
arrives, to test a connection lost mid-block.
"""

from __future__ import annotations

import ipaddress
import socket
import threading
from dataclasses import dataclass, field

from contactrig.core.validation import SettingError, check_int
from instruments.scpi import parse_message
from instruments.simulated import SimulatedBench, SimulatedK6221, _load_definition

__all__ = ["ServerFaults", "SimServer", "is_loopback"]

_MAX_LINE = 1 << 20


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


class SimServer:
    """A simulated 6221 (+2182A) on ``host``:``port`` (0 = a free port chosen by the OS; see :attr:`port`).

    bench: the simulated world (default :class:`SimulatedBench`); allow_remote: serve a non-loopback host
    (refused otherwise, with a :class:`SettingError` naming ``host``); nodelay: turn Nagle off on the server's
    side of each connection (the instrument answers at once; the client's Nagle is what the benchmark measures).
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
    ) -> None:
        if not isinstance(host, str) or not host.strip():
            raise SettingError("host", host, "expected a host name or address, e.g. 127.0.0.1")
        if not allow_remote and not is_loopback(host):
            raise SettingError(
                "host", host, "only loopback hosts (127.0.0.1, ::1, localhost) unless --allow-remote is given"
            )
        self.host = host
        self.requested_port = check_int("port", port, 0, 65535)
        self.bench = bench if bench is not None else SimulatedBench()
        self.nodelay = nodelay
        self.faults = faults if faults is not None else ServerFaults()
        data = _load_definition()
        self.device = SimulatedK6221("k6221", data["devices"]["k6221"], data["devices"]["k2182a"], self.bench)
        self._listener: socket.socket | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._clients: list[socket.socket] = []
        self._lock = threading.Lock()
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
        listener.listen(1)
        listener.settimeout(0.1)
        self._listener = listener
        self._thread = threading.Thread(target=self._serve, name="contactrig-sim-server", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout_s: float = 2.0) -> None:
        """Stop serving: close the listener and every connection; wait at most ``timeout_s`` for the thread."""
        self._stop.set()
        with self._lock:
            for c in self._clients:
                _close(c)
            self._clients.clear()
        if self._thread is not None:
            self._thread.join(timeout_s)
        if self._listener is not None:
            _close(self._listener)

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

    # ---------------------------------------------------------------- serving
    def _serve(self) -> None:
        assert self._listener is not None
        while not self._stop.is_set():
            try:
                conn, _ = self._listener.accept()
            except TimeoutError:
                continue
            except OSError:  # listener closed by stop()
                return
            self.connections += 1
            with self._lock:
                self._clients.append(conn)
            try:
                self._talk(conn)
            finally:
                with self._lock:
                    if conn in self._clients:
                        self._clients.remove(conn)
                _close(conn)

    def _talk(self, conn: socket.socket) -> None:
        """Serve one client: LF-terminated messages in, replies out, until it leaves or the server stops."""
        if self.nodelay:
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        conn.settimeout(0.1)
        buf = b""
        while not self._stop.is_set():
            try:
                data = conn.recv(65536)
            except TimeoutError:
                continue
            except OSError:
                return
            if not data:
                return
            buf += data
            if len(buf) > _MAX_LINE:  # a client that never ends its line
                return
            while b"\n" in buf:
                line, buf = buf.split(b"\n", 1)
                if not self._answer(conn, line.decode("latin-1").rstrip("\r")):
                    return

    def _answer(self, conn: socket.socket, message: str) -> bool:
        """Execute one message and send its reply; False when the connection is to be (or was) dropped."""
        if self.faults.disconnect_on and any(c.header in self.faults.disconnect_on for c in parse_message(message)):
            return False
        reply = self.device.handle(message)
        if reply is None:
            return True
        try:
            conn.sendall(reply.encode("latin-1") + b"\n")
        except OSError:
            return False
        return True


def _close(s: socket.socket) -> None:
    try:
        s.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    s.close()
