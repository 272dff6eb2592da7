"""Replay time for a session of 10^5 readings (goal: < 1 s), pair-wise with its parts and the acquisition.

Records a simulated session (time_scale 0) of BLOCKS × COUNT readings through the real acquisition path, then
times, in one run: load_session (read + SHA-256 checks), replay_session (load + re-run of the acquisition code on
the recorded replies + comparison), and the original acquisition on the simulated bench for reference.
Run: python tests/benchmarks/bench_session_replay.py [BLOCKS COUNT]   (default 100 × 1000 = 10^5 readings)
"""

from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path

from daq.acquire import drive
from daq.link import InstrumentLink
from daq.plan import Measure, PlaceWeight
from daq.replay import replay_session
from daq.session_file import SessionFile, load_session
from daq.writers import FileWriter
from instruments.delta import DeltaSettings
from instruments.simulated import SimulatedBench, simulated_resource_manager
from instruments.transport import VisaTransport


def record(path: Path, blocks: int, count: int) -> float:
    settings = DeltaSettings(high_a=1e-2, count=count)
    bench = SimulatedBench(resistance_ohm=5e-3, seed=1, time_scale=0.0)
    link = InstrumentLink(VisaTransport.open("GPIB0::12::INSTR", simulated_resource_manager(bench=bench), 5000))
    per_weight = 10

    def steps():
        for b in range(blocks):
            if b % per_weight == 0:
                yield PlaceWeight(b // per_weight, 5.0 + b // per_weight, per_weight)
            yield Measure(
                block=b, weight_index=b // per_weight, weight_kg=5.0 + b // per_weight, repeat=b % per_weight + 1
            )

    start = {"started": "", "plan": {"delta": {f: getattr(settings, f) for f in settings.__dataclass_fields__}}}
    with SessionFile.create(path, force=True) as sf:
        t = time.perf_counter()
        out = drive(link, settings, steps(), [FileWriter(sf)], start, "", blocks_planned=blocks)
        dt = time.perf_counter() - t
    assert out.error is None, out.error
    return dt


def main() -> None:
    blocks, count = (int(sys.argv[1]), int(sys.argv[2])) if len(sys.argv) > 2 else (100, 1000)
    with tempfile.TemporaryDirectory(dir=".") as d:
        path = Path(d) / "replay.h5"
        t_acq = record(path, blocks, count)
        replay_session(path)  # warm-up
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t = time.perf_counter()
            s = load_session(path)
            t_load = time.perf_counter() - t
        t = time.perf_counter()
        report = replay_session(path)
        t_replay = time.perf_counter() - t
        n_ex = len(s.exchanges)
    print(
        f"{blocks} blocks × {count} readings = {report.readings_replayed} readings, {n_ex} exchanges: "
        f"identical={report.identical} | load+verify {t_load:.3f} s | replay (incl. load) {t_replay:.3f} s "
        f"(goal < 1 s) | original acquisition on the simulated bench {t_acq:.3f} s"
    )


if __name__ == "__main__":
    main()
