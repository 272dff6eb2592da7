"""Software overhead per Delta block beyond instrument time (goal: < 5 ms per block).

The simulated bench runs with time_scale = 0 (no instrument time), so what remains is software. Pair-wise in one run:
  baseline  the driver alone: Keithley6221.run_delta in a loop on the simulated bench;
  engine    the same blocks through the acquisition engine (recording transport, records, statistics), in memory;
  flush     engine + HDF5 session file (append, flush per block) + live line, without fsync;
  session   the full path: engine + HDF5 session file (append, flush, os.fsync per block) + live line.
Overhead per block = (path − baseline) / blocks. Run: python tests/benchmarks/bench_session_overhead.py [BLOCKS]
"""

from __future__ import annotations

import io
import sys
import tempfile
import time
from pathlib import Path

from daq.acquire import drive
from daq.link import InstrumentLink
from daq.plan import Measure, PlaceWeight
from daq.session_file import SessionFile
from daq.writers import FileWriter, LiveDisplay, MemoryWriter
from instruments.delta import DeltaSettings
from instruments.k6221 import Keithley6221
from instruments.simulated import SimulatedBench, simulated_resource_manager
from instruments.transport import VisaTransport

ADDRESS = "GPIB0::12::INSTR"


def _transport(seed: int) -> VisaTransport:
    bench = SimulatedBench(resistance_ohm=5e-3, seed=seed, time_scale=0.0)
    return VisaTransport.open(ADDRESS, simulated_resource_manager(bench=bench), 2000)


def _steps(n: int):
    yield PlaceWeight(0, 5.44, n)
    for b in range(n):
        yield Measure(block=b, weight_index=0, weight_kg=5.44, repeat=b + 1)


def run_baseline(settings: DeltaSettings, n: int) -> float:
    k = Keithley6221(_transport(1))
    k.identify()
    t = time.perf_counter()
    for _ in range(n):
        k.run_delta(settings)
    dt = time.perf_counter() - t
    k.close()
    return dt


def run_engine(settings: DeltaSettings, n: int, path: Path | None, fsync: bool = True) -> float:
    link = InstrumentLink(_transport(1), address=ADDRESS)
    writers: list = [MemoryWriter()]
    sf = None
    if path is not None:
        sf = SessionFile.create(path, force=True, fsync=fsync)
        writers = [FileWriter(sf), LiveDisplay(n, stream=io.StringIO())]
    t = time.perf_counter()
    out = drive(link, settings, _steps(n), writers, {"started": ""}, "", blocks_planned=n)
    dt = time.perf_counter() - t
    if sf is not None:
        sf.close()
    assert out.error is None and out.stop.blocks_done == n, out.stop
    return dt


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    for count in (10, 100, 1000):
        s = DeltaSettings(high_a=1e-2, count=count)
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "bench.h5"
            run_engine(s, 5, path)  # warm-up (imports, caches)
            base = run_baseline(s, n)
            eng = run_engine(s, n, None)
            flu = run_engine(s, n, path, fsync=False)
            ses = run_engine(s, n, path)
        print(
            f"count={count:5d} blocks={n}: driver alone {1e3 * base / n:6.3f} ms/block | overhead per block: "
            f"engine {1e3 * (eng - base) / n:+6.3f} ms, +HDF5 flush {1e3 * (flu - base) / n:+6.3f} ms, "
            f"+HDF5 flush+fsync {1e3 * (ses - base) / n:+6.3f} ms (goal < 5 ms)"
        )


if __name__ == "__main__":
    main()
