"""What watching costs the acquisition: time per block with and without a watcher attached.

The simulated bench runs with time_scale = 0 (no instrument time), so every block is pure software: the engine, the
HDF5 session file (append, flush, os.fsync) and the live line — the worst case for a watcher, which then competes
with nothing but software. Pair-wise, repeated and interleaved (median of the rounds):
  none      no watcher;
  view      the live view inside the process (analysis.watch.LiveView, a snapshot at most every 1 s, as --live);
  watcher   ``contactrig watch SESSION --png … --every 0.5`` in another process reading the file while it is written.
Overhead per block = (path − none) / blocks.
``--pace``: the simulated instruments at real pace (20 readings per block, ~0.4 s), as on the bench.
Run: python tests/benchmarks/bench_watch.py [BLOCKS] [ROUNDS] [--pace]
"""

from __future__ import annotations

import io
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from analysis.watch import LiveView
from daq.acquire import drive
from daq.link import InstrumentLink
from daq.plan import Measure, PlaceWeight
from daq.session_file import SessionFile
from daq.writers import FileWriter, LiveDisplay
from instruments.delta import DeltaSettings
from instruments.simulated import SimulatedBench, simulated_resource_manager
from instruments.transport import VisaTransport

ADDRESS = "GPIB0::12::INSTR"
ROOT = Path(__file__).resolve().parents[2]


def _steps(n: int):
    yield PlaceWeight(0, 5.44, n)
    for b in range(n):
        yield Measure(block=b, weight_index=0, weight_kg=5.44, repeat=b + 1)


def run(settings: DeltaSettings, n: int, path: Path, mode: str, time_scale: float = 0.0) -> float:
    bench = SimulatedBench(resistance_ohm=5e-3, seed=1, time_scale=time_scale)
    link = InstrumentLink(VisaTransport.open(ADDRESS, simulated_resource_manager(bench=bench), 2000), address=ADDRESS)
    sf = SessionFile.create(path, force=True)
    writers: list = [FileWriter(sf), LiveDisplay(n, stream=io.StringIO())]
    if mode == "view":
        writers.append(LiveView(path.with_suffix(".png"), every=1.0, stream=sys.stderr, force=True))
    start = {"started": "2026-01-01T00:00:00+00:00", "plan": {"blocks_planned": n}}
    watcher = None
    # the start record first (so the file is a session the watcher can read), then the timed blocks
    t = time.perf_counter()
    try:
        if mode == "watcher":
            sf.write_start(start, "")
            args = [sys.executable, "-m", "contactrig", "watch", str(path), "--png", str(path.with_suffix(".png"))]
            watcher = subprocess.Popen(
                [*args, "--every", "0.5", "--force"], cwd=ROOT, stderr=subprocess.DEVNULL, env={"MPLBACKEND": "Agg"}
            )
            time.sleep(2.0)  # the watcher is up and reading before the blocks start
            t = time.perf_counter()
        drive(link, settings, _steps(n), writers, start, "", blocks_planned=n)
        dt = time.perf_counter() - t
    finally:
        sf.close()
        if watcher is not None:
            watcher.wait(timeout=30)
    return dt


def main(argv: list[str]) -> None:
    pace = "--pace" in argv
    argv = [a for a in argv if a != "--pace"]
    n = int(argv[0]) if argv else (20 if pace else 200)
    rounds = int(argv[1]) if len(argv) > 1 else 3
    count = 20 if pace else 100
    settings = DeltaSettings(high_a=1e-3, count=count, delay_s=2e-3, nplc=1.0)
    times: dict[str, list[float]] = {"none": [], "view": [], "watcher": []}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(rounds):
            for mode in times:
                times[mode].append(run(settings, n, Path(tmp) / f"{mode}.h5", mode, 1.0 if pace else 0.0))
    base = statistics.median(times["none"]) / n
    how = "real instrument pace (time_scale 1)" if pace else "time_scale 0 (software only)"
    print(f"{n} blocks of {count} readings, {how}, fsync per block; median of {rounds} rounds")
    for mode, ts in times.items():
        per = statistics.median(ts) / n
        spread = (max(ts) - min(ts)) / n * 1e3
        extra = (
            "" if mode == "none" else f"  overhead {1e3 * (per - base):+.3f} ms/block ({100 * (per / base - 1):+.1f} %)"
        )
        print(f"  {mode:<8} {1e3 * per:7.3f} ms/block (spread {spread:.3f}){extra}")


if __name__ == "__main__":
    main(sys.argv[1:])
