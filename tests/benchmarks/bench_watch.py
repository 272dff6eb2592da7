"""What watching costs the acquisition: time per block with and without a watcher attached.

The simulated bench runs with time_scale = 0 (no instrument time), so every block is pure software: the engine, the
HDF5 session file (append, flush, os.fsync) and the live line — the worst case for a watcher, which then competes
with nothing but software. Pair-wise, repeated and interleaved (median of the rounds):
  none      no watcher;
  view      the live view of the acquisition (analysis.watch.LiveView, as --live: a snapshot at most every 1 s, drawn
            by a process of its own spawned on the first block; the acquisition only queues a small update a block);
  watcher   ``contactrig watch SESSION --png … --every 0.5`` in another process reading the file while it is written.
Overhead per block = (path − none) / blocks, timed from the first block until the session file is sealed (the stop
record written and flushed). After that the view gets up to its stop_timeout to draw its last frame and end: shown
apart as "then", once per session, the file already complete.
``--pace``: the simulated instruments at real pace (20 readings per block, ~0.4 s), as on the bench.
Run: python tests/benchmarks/bench_watch.py [BLOCKS] [ROUNDS] [--pace]
"""

from __future__ import annotations

import io
import math
import os
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


class _Sealed:
    """A writer right after the session file's: notes when the stop record is on disk."""

    def __init__(self) -> None:
        self.at = math.nan

    def start(self, start: dict, scene_text: str) -> None:
        pass

    def exchanges(self, exchanges: object, block: int) -> None:
        pass

    def block(self, rec: object) -> None:
        pass

    def stop(self, stop: object) -> None:
        self.at = time.perf_counter()


def run(settings: DeltaSettings, n: int, path: Path, mode: str, time_scale: float = 0.0) -> tuple[float, float]:
    """(seconds until the file is sealed, seconds from then until every writer has stopped)."""
    bench = SimulatedBench(resistance_ohm=5e-3, seed=1, time_scale=time_scale)
    link = InstrumentLink(VisaTransport.open(ADDRESS, simulated_resource_manager(bench=bench), 2000), address=ADDRESS)
    sf = SessionFile.create(path, force=True)
    sealed = _Sealed()
    writers: list = [FileWriter(sf), sealed, LiveDisplay(n, stream=io.StringIO())]
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
        end = time.perf_counter()
    finally:
        sf.close()
        if watcher is not None:
            watcher.wait(timeout=30)
    return sealed.at - t, end - sealed.at


def main(argv: list[str]) -> None:
    pace = "--pace" in argv
    argv = [a for a in argv if a != "--pace"]
    n = int(argv[0]) if argv else (20 if pace else 200)
    rounds = int(argv[1]) if len(argv) > 1 else 3
    count = 20 if pace else 100
    settings = DeltaSettings(high_a=1e-3, count=count, delay_s=2e-3, nplc=1.0)
    times: dict[str, list[float]] = {"none": [], "view": [], "watcher": []}
    after: dict[str, list[float]] = {mode: [] for mode in times}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(rounds):
            for mode in times:
                sealed, then = run(settings, n, Path(tmp) / f"{mode}.h5", mode, 1.0 if pace else 0.0)
                times[mode].append(sealed)
                after[mode].append(then)
    base = statistics.median(times["none"]) / n
    how = "real instrument pace (time_scale 1)" if pace else "time_scale 0 (software only)"
    print(f"{n} blocks of {count} readings, {how}, fsync per block; median of {rounds} rounds; load {_load()}")
    for mode, ts in times.items():
        per = statistics.median(ts) / n
        spread = (max(ts) - min(ts)) / n * 1e3
        extra = (
            "" if mode == "none" else f"  overhead {1e3 * (per - base):+.3f} ms/block ({100 * (per / base - 1):+.1f} %)"
        )
        then = f"  then {statistics.median(after[mode]):.2f} s to stop" if mode == "view" else ""
        print(f"  {mode:<8} {1e3 * per:7.3f} ms/block (spread {spread:.3f}){extra}{then}")


def _load() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg()) + f" on {os.cpu_count()} CPUs"
    except OSError:
        return "unknown"


if __name__ == "__main__":
    main(sys.argv[1:])
