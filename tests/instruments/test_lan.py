"""The driver through pyvisa-py over a real TCP socket on 127.0.0.1, against the simulated bench served by
``instruments.server.SimServer`` (an OS-chosen free port). Every test bounds its time with short VISA timeouts and an
elapsed-time check."""

from __future__ import annotations

import math
import signal
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

pyvisa = pytest.importorskip("pyvisa")
pytest.importorskip("pyvisa_py")

from contactrig.core.validation import SettingError  # noqa: E402
from instruments.delta import DeltaSettings  # noqa: E402
from instruments.errors import CommunicationError, InstrumentTimeout, NanovoltmeterMissing  # noqa: E402
from instruments.k6221 import Keithley6221  # noqa: E402
from instruments.server import ServerFaults, SimServer  # noqa: E402
from instruments.simulated import SimulatedBench  # noqa: E402
from instruments.transport import socket_of  # noqa: E402


def open_lan(server, timeout_ms=2000, **kw):
    return Keithley6221.open(
        server.address, resource_manager=pyvisa.ResourceManager("@py"), timeout_ms=timeout_ms, **kw
    )


@pytest.mark.parametrize(("count", "limit_s"), [(10, 5.0), (1000, 5.0), (65536, 20.0)])
def test_delta_blocks_over_pyvisa_py(count, limit_s):
    t0 = time.monotonic()
    with SimServer(port=0, bench=SimulatedBench(resistance_ohm=5e-3, seed=1, time_scale=0.0)) as server:
        assert server.port != 0
        with open_lan(server, timeout_ms=5000) as k:
            ident = k.identify()
            block = k.run_delta(DeltaSettings(high_a=1e-3, count=count))
            assert k.source_state == "idle"
    assert "6221" in ident.source and "2182A" in ident.voltmeter
    assert block.readings.shape == (count,) and block.n == count
    assert block.mean == pytest.approx(1e-3 * 5e-3, rel=1e-3)
    assert np.all(np.diff(block.timestamps_s) > 0)
    assert time.monotonic() - t0 < limit_s


def test_nagle_is_turned_off_on_the_pyvisa_py_socket():
    with SimServer(port=0) as server, open_lan(server) as k:
        sock = socket_of(k.transport.resource)
        assert sock is not None and sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
        assert k.transport.nodelay == "socket"


def test_relay_fault_over_lan():
    bench = SimulatedBench(seed=1)
    bench.faults.relay_xoff = True
    bench.faults.relay_pieces = 3
    bench.faults.relay_terminator = "\n"
    t0 = time.monotonic()
    with SimServer(port=0, bench=bench) as server, open_lan(server) as k:
        assert k.identify().voltmeter.endswith("C02  /A02")
        assert k.run_delta(DeltaSettings(high_a=1e-3, count=20)).n == 20
        bench.faults.voltmeter_absent = True
        with pytest.raises(NanovoltmeterMissing, match="Trigger Link"):
            k.run_delta(DeltaSettings(high_a=1e-3, count=20))
    assert time.monotonic() - t0 < 10


@pytest.mark.parametrize("header", ["TRAC:DATA:SEL?", "STAT:OPER:EVEN?", "INIT:IMM"])
def test_disconnect_mid_block_is_a_clear_error_never_a_block(header):
    faults = ServerFaults(disconnect_on={header})
    t0 = time.monotonic()
    with SimServer(port=0, bench=SimulatedBench(seed=1), faults=faults) as server:
        k = open_lan(server, timeout_ms=500)
        result = None
        with pytest.raises((CommunicationError, InstrumentTimeout)) as err:
            with k:
                result = k.run_delta(DeltaSettings(high_a=1e-3, count=50))
    assert result is None
    notes = " ".join(getattr(err.value, "__notes__", []))
    assert k.source_state in ("idle", "unknown")
    assert ("UNKNOWN" in notes) or ("left idle" in notes)
    if k.source_state == "unknown":
        assert "UNKNOWN" in notes
    assert time.monotonic() - t0 < 10


def test_non_loopback_host_is_refused_unless_allowed():
    with pytest.raises(SettingError) as err:
        SimServer(host="0.0.0.0", port=0)
    assert err.value.field == "host" and "--allow-remote" in err.value.allowed
    with pytest.raises(SettingError):
        SimServer(host="192.168.1.5", port=0)
    server = SimServer(host="0.0.0.0", port=0, allow_remote=True)  # explicit: accepted (not started)
    assert server.host == "0.0.0.0"


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_serve_sim_command_serves_and_stops_cleanly_on_ctrl_c():
    port = _free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "contactrig", "instruments", "serve-sim", "--port", str(port), "--sim-speed", "inf"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = proc.stdout.readline()  # announced once it listens
        assert f"127.0.0.1::{port}::SOCKET" in line, line + proc.stderr.read()
        rm = pyvisa.ResourceManager("@py")
        with Keithley6221.open(f"TCPIP0::127.0.0.1::{port}::SOCKET", resource_manager=rm, timeout_ms=2000) as k:
            block = k.run_delta(DeltaSettings(high_a=1e-3, count=10))
        assert block.n == 10 and math.isfinite(block.mean)
        t0 = time.monotonic()
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=10)
        assert time.monotonic() - t0 < 5
        assert code == 0, proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=5)


def test_serve_sim_command_refuses_a_remote_host_without_the_flag():
    out = subprocess.run(
        [sys.executable, "-m", "contactrig", "instruments", "serve-sim", "--host", "0.0.0.0", "--port", "0"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert out.returncode == 2 and "--allow-remote" in out.stderr
