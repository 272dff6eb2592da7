"""One Delta block over a real loopback TCP socket through pyvisa-py, with Nagle's algorithm on (pyvisa-py's
default) and off (what VisaTransport sets).

Run by hand:  python tests/benchmarks/bench_socket.py [--counts 10 100 1000] [--repeats 5]

The simulated bench is served by ``instruments.server.SimServer`` on 127.0.0.1 (OS-chosen port, instrument time 0,
Nagle off on the server side, as an instrument answers at once), so the time per block is the driver's turns over
the network stack. "nagle on" re-enables Nagle on the client socket after the transport turned it off: every
write followed by another write or a query then waits for the server's delayed ACK (~40 ms on Linux).
"""

from __future__ import annotations

import argparse
import socket
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import pyvisa

from instruments.delta import DeltaSettings
from instruments.k6221 import Keithley6221
from instruments.server import SimServer
from instruments.simulated import SimulatedBench
from instruments.transport import socket_of


def one_block(address: str, count: int, nagle: bool) -> tuple[float, int]:
    rm = pyvisa.ResourceManager("@py")
    with Keithley6221.open(address, resource_manager=rm, timeout_ms=20_000) as k:
        sock = socket_of(k.transport.resource)  # type: ignore[attr-defined]
        assert sock is not None and sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
        if nagle:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 0)
        t0 = time.perf_counter()
        block = k.run_delta(DeltaSettings(high_a=1e-3, count=count))
        dt = time.perf_counter() - t0
    assert block.n == count
    return dt, block.n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--counts", type=int, nargs="+", default=[10, 100, 1000])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    print(f"Delta block over loopback TCP (pyvisa-py), median of {args.repeats}")
    print(f"{'count':>7} {'nagle on':>12} {'nagle off':>12} {'speed-up':>9}")
    with SimServer(port=0, bench=SimulatedBench(seed=1, time_scale=0.0)) as server:
        for count in args.counts:
            on = statistics.median(one_block(server.address, count, True)[0] for _ in range(args.repeats))
            off = statistics.median(one_block(server.address, count, False)[0] for _ in range(args.repeats))
            print(f"{count:>7} {on * 1e3:>9.1f} ms {off * 1e3:>9.1f} ms {on / off:>8.1f}x")


if __name__ == "__main__":
    main()
