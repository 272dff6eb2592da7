"""Cost per block of the console attached to an acquisition (target: ≤ 1 ms per block).

What the console adds inside the acquisition process is one more writer (``contactrig.console.child.ConsoleWriter``,
guarded) that writes each block's summary and readings as one JSON line into the pipe the console reads; everything
else (the state, the pages, the browsers) lives in the console's own process. Measured two ways:

  writer    ConsoleWriter.block alone on real block records, through a real pipe drained by a reader thread as in
            the console (median of many calls) — the cost itself, free of the acquisition's own noise;
  session   acquire() of the same simulated session (instrument time 0, fsync per block) with the console writer
            and without it (the baseline), alternated, median per block of each.

And the sessions page's listing (issue 23: 1 000 session files in under a second after the first scan):

  index     daq.index.index_sessions over N names of one session file (hard links), the first scan (every file
            read, each in a bounded child process) and the next (the console's cache: a stat per file).

Run: python tests/benchmarks/bench_console.py [REPEATS]      python tests/benchmarks/bench_console.py --index [N]
"""

from __future__ import annotations

import os
import re
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

from analysis.simulated_session import SimulatedRigBench
from analysis.watch import Guarded
from contactrig.console.child import ConsoleWriter, _Channel
from contactrig.core.scene import default_scene_text
from daq.acquire import acquire
from daq.writers import MemoryWriter


def _pipe_channel() -> tuple[_Channel, threading.Thread, int]:
    """A channel whose output is a real pipe drained by a thread (the console's reader), and the pipe's read end."""
    r, w = os.pipe()
    out = os.fdopen(w, "w", encoding="utf-8")
    reader = os.fdopen(r, "r", encoding="utf-8")

    def drain() -> None:
        for _ in reader:
            pass

    t = threading.Thread(target=drain, daemon=True)
    t.start()
    return _Channel(out, iter(())), t, w


def _scene(folder: Path, count: int) -> Path:
    text = re.sub(r"(?m)^count = .*$", f"count = {count}", default_scene_text())
    path = folder / "scene.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _session(scene: Path, out: Path, writers: list) -> float:
    t0 = time.perf_counter()
    result = acquire(scene, out, bench=SimulatedRigBench(float("inf")), yes=True, quiet=True, extra_writers=writers)
    return (time.perf_counter() - t0) / result.blocks_done


def main(repeats: int = 5, count: int = 100) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        scene = _scene(folder, count)
        memory = MemoryWriter()  # the records of a real session, sent many times by the writer alone
        acquire(scene, folder / "warm.h5", bench=SimulatedRigBench(float("inf")), yes=True, quiet=True,
                extra_writers=[memory])  # fmt: skip
        recs, n_blocks = memory.blocks, len(memory.blocks)
        channel, _, _ = _pipe_channel()
        writer = ConsoleWriter(channel)
        calls = []
        for _ in range(20):
            for rec in recs:
                t0 = time.perf_counter()
                writer.block(rec)
                calls.append(time.perf_counter() - t0)

        base, console = [], []
        for i in range(repeats):
            base.append(_session(scene, folder / f"base{i}.h5", []))
            ch, _, _ = _pipe_channel()
            console.append(_session(scene, folder / f"console{i}.h5", [Guarded(ConsoleWriter(ch), "console")]))
    b, c = statistics.median(base), statistics.median(console)
    print(f"{n_blocks} blocks of {count} readings per session, simulated bench at instrument time 0, fsync per block")
    print(f"{'path':<34} {'per block':>12}")
    print(f"{'ConsoleWriter.block alone':<34} {statistics.median(calls) * 1e3:>9.3f} ms  (median of {len(calls)})")
    print(f"{'acquire, no console (baseline)':<34} {b * 1e3:>9.3f} ms  (median of {repeats} sessions)")
    print(f"{'acquire, console attached':<34} {c * 1e3:>9.3f} ms  (median of {repeats} sessions)")
    print(f"{'difference (target ≤ 1 ms)':<34} {(c - b) * 1e3:>9.3f} ms")


def index(n: int = 1000) -> None:
    from daq.index import index_sessions

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        scene = _scene(folder, 10)
        acquire(scene, folder / "one.h5", bench=SimulatedRigBench(float("inf")), yes=True, quiet=True)
        (folder / "all").mkdir()
        for i in range(n):
            os.link(folder / "one.h5", folder / "all" / f"s{i:04d}.h5")
        cache: dict = {}
        t0 = time.perf_counter()
        first = index_sessions(folder / "all", cache=cache)
        t1 = time.perf_counter()
        again = index_sessions(folder / "all", cache=cache)
        t2 = time.perf_counter()
        plain = index_sessions(folder / "all", cache=None) if n <= 50 else None
        assert len(first) == len(again) == n and (plain is None or plain == first)
    print(f"{'index of':<34} {n:>9d} session files")
    print(f"{'first scan (every file read)':<34} {t1 - t0:>9.2f} s")
    print(f"{'next scan (cached; target < 1 s)':<34} {t2 - t1:>9.3f} s")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--index":
        index(int(sys.argv[2]) if len(sys.argv) > 2 else 1000)
    else:
        main(int(sys.argv[1]) if len(sys.argv) > 1 else 5)
