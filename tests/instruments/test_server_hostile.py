"""``serve-sim`` under hostile input: any bytes, any length, any connection pattern leave the server serving.

The simulated instrument is fuzzed directly (every program message, from arbitrary bytes or from the command table's
own headers with arbitrary parameters, is executed without an exception), then the server over real loopback
sockets: after every hypothesis case (bytes of any value and length, connections many at once, abruptly reset,
half-closed, left open and silent, slow, not reading their replies) a fresh client must get ``*IDN?`` answered.
Counts and times are bounded (a few seconds in all).
"""

from __future__ import annotations

import socket
import struct
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from instruments.commands import K2182A, K6221
from instruments.server import MAX_LINE_BYTES, SimServer
from instruments.simulated import SimulatedBench, SimulatedK6221, _load_definition

IDN = b"KEITHLEY INSTRUMENTS INC.,MODEL 6221"


def _device() -> SimulatedK6221:
    data = _load_definition()
    return SimulatedK6221("k6221", data["devices"]["k6221"], data["devices"]["k2182a"], SimulatedBench())


def _errors(dev: SimulatedK6221) -> list[str]:
    out = []
    while (e := dev.handle("SYST:ERR?")) and not e.startswith("0,"):
        out.append(e)
    return out


# ------------------------------------------------------------------------------------------ the instrument itself
_HEADERS = sorted({*K6221, *(f":{h}" for h in K6221), *K2182A, "*IDN?", "SYST:COMM:SER:SEND", "TRAC:DATA:SEL?"})
_WORDS = st.sampled_from(_HEADERS)
_QUERY = st.booleans()
_PARAM = st.one_of(
    st.text(max_size=20),
    st.sampled_from(["MIN", "MAX", "DEF", "INF", "ON", "OFF", "1e309", "-0", "nan", '"', "'", "1,2,3", "#"]),
    st.integers().map(str),
    st.floats().map(str),
)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=300))
def test_any_bytes_are_executed_without_an_exception(data: bytes):
    dev = _device()
    for line in data.split(b"\n"):
        dev.handle(line.decode("latin-1"))
    assert dev.handle("*IDN?").startswith(IDN.decode())
    _errors(dev)  # the queue reads out in the SCPI form, whatever was queued


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(_WORDS, _QUERY, _PARAM), min_size=1, max_size=5))
def test_every_header_with_any_parameter_is_executed_without_an_exception(commands):
    dev = _device()
    dev.handle(";".join(f"{h}{'?' if q and not h.endswith('?') else ''} {p}" for h, q, p in commands))
    relayed = ";".join(f"{h.lstrip(':')} {p}" for h, q, p in commands if h.lstrip(":") in K2182A)
    if relayed:
        dev.handle('SYST:COMM:SER:SEND "' + relayed.replace('"', '""') + '"')
        dev.handle("SYST:COMM:SER:ENT?")
    assert dev.handle("*IDN?").startswith(IDN.decode())


@pytest.mark.parametrize(
    "message",
    [b"ABCDE\xa5", b"*IDN\xa5?", b"SOUR:DELT:HIGH \xff", b"\x80", b"SOUR:\x00DELT:HIGH?", b"UNIT \xe9"],
)
def test_a_byte_that_is_not_ascii_is_invalid_character(message: bytes):
    dev = _device()
    assert dev.handle(message.decode("latin-1")) is None
    assert dev.handle("SYST:ERR?") == '-101,"Invalid character"'  # SCPI-99: a character invalid for the element
    assert dev.handle("SYST:ERR?") == '0,"No error"'


def test_eight_bit_bytes_inside_a_string_are_data_and_reach_the_2182a_as_invalid():
    dev = _device()
    dev.handle('SYST:COMM:SER:SEND "AB\xa5"')  # string data may hold any byte: the 6221 relays it
    assert _errors(dev) == []
    dev.handle('SYST:COMM:SER:SEND "SYST:ERR?"')
    assert dev.handle("SYST:COMM:SER:ENT?").strip() == '-101,"Invalid character"'


# ------------------------------------------------------------------------------------------ the server on sockets
@pytest.fixture(scope="module")
def server():
    with SimServer(port=0, bench=SimulatedBench(seed=1), send_timeout_s=0.3, max_clients=4) as s:
        yield s


def _connect(server: SimServer, timeout: float = 5.0) -> socket.socket:
    return socket.create_connection(("127.0.0.1", server.port), timeout=timeout)


def _fresh_client_is_answered(server: SimServer) -> None:
    t0 = time.monotonic()
    with _connect(server) as c:
        c.sendall(b"*IDN?\n")
        reply = b""
        while not reply.endswith(b"\n"):
            chunk = c.recv(4096)
            assert chunk, "the server closed a fresh connection"
            reply += chunk
    assert reply.startswith(IDN), reply
    assert time.monotonic() - t0 < 5.0  # generous: the machine is shared; a dead server never answers at all
    assert server.serving


def _reset(sock: socket.socket) -> None:
    """Close abruptly: RST instead of FIN (what a crashed client or a pulled cable looks like)."""
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    sock.close()


_CHUNK = st.one_of(
    st.binary(max_size=200),
    st.binary(max_size=40).map(lambda b: b + b"\n"),
    st.sampled_from([b"*IDN?\n", b"SYST:ERR?\n", b"TRAC:DATA?\n", b"ABCDE\xa5\n", b"\n", b"\r\n", b";;;\n"]),
    st.integers(1, 3).map(lambda k: b"A" * (MAX_LINE_BYTES * k // 2) + b"\n"),  # overlong lines
)
_ENDING = st.sampled_from(["close", "reset", "half_close", "leave_open", "read_and_close"])
_CONNECTION = st.tuples(st.lists(_CHUNK, max_size=6), _ENDING, st.booleans())


def _play(sock: socket.socket, chunks: list[bytes], ending: str, slow: bool) -> None:
    for chunk in chunks:
        sock.sendall(chunk)
        if slow:
            time.sleep(0.002)
    if ending == "reset":
        _reset(sock)
    elif ending == "close":
        sock.close()
    elif ending == "half_close":
        sock.shutdown(socket.SHUT_WR)  # no more requests, replies never read
    elif ending == "read_and_close":
        sock.settimeout(0.05)
        try:
            sock.recv(65536)
        except TimeoutError:
            pass
        sock.close()
    # "leave_open": stays connected and silent while the fresh client asks


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(_CONNECTION, min_size=1, max_size=6))
def test_server_keeps_serving_whatever_the_clients_do(server, connections):
    opened: list[socket.socket] = []
    try:
        for _ in connections:  # all connected at once (more than max_clients sometimes)
            opened.append(_connect(server))
        for sock, (chunks, ending, slow) in zip(opened, connections, strict=True):
            try:
                _play(sock, chunks, ending, slow)
            except OSError:  # evicted to make room for a newer connection, or dropped: the client's problem
                sock.close()
        _fresh_client_is_answered(server)
    finally:
        for sock in opened:
            sock.close()


def test_a_client_that_never_reads_its_replies_is_dropped_and_others_are_served(server):
    t0 = time.monotonic()
    with _connect(server) as greedy:
        greedy.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        greedy.settimeout(5.0)
        try:
            for _ in range(400):  # ≈ 20 MB of replies asked for, none read
                greedy.sendall(b"*IDN?\n" * 1000)
        except OSError:
            pass  # dropped by the server (send timeout): expected
        _fresh_client_is_answered(server)
    assert time.monotonic() - t0 < 15


def test_many_silent_connections_cannot_lock_the_port(server):
    silent = [_connect(server) for _ in range(3 * server.max_clients)]
    try:
        _fresh_client_is_answered(server)
    finally:
        for s in silent:
            s.close()


def test_the_simulator_error_queue_tells_the_client_what_happened(server):
    with _connect(server) as c:
        c.sendall(b"*CLS\nABCDE\xa5\n" + b"X" * (MAX_LINE_BYTES + 10) + b"\nSYST:ERR?;ERR?\n")
        reply = b""
        while not reply.endswith(b"\n"):
            reply += c.recv(4096)
    assert reply == b'-101,"Invalid character";-363,"Input buffer overrun"\n'
