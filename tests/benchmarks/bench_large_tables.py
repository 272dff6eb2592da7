"""Large tables and sessions (issue 19, item 6): time and peak RSS of the real commands, beside the targets and
the figures before the change.

* ``contactrig import`` of a 10 000-row × 6-repeat Tab. 1-style table (target ≤ 2 s; before: 123 s in the issue,
  60 000 separately fsynced blocks),
* ``contactrig fit`` on it (target ≤ 5 s and ≤ 300 MB peak; before: 45 s, 3.36 GB),
* ``contactrig fit`` on one session of 10⁶ readings (1 000 blocks × 1 000 readings: load and fit, target ≤ 10 s),
  and on 9.6 × 10⁴ readings, whose difference gives the memory per reading (linear growth).

Each command runs as its own process (``os.wait4`` gives its time and peak RSS; a ``load_session`` child is
counted by the kernel in the same RUSAGE only for its own maximum, so the parent's is reported, as /usr/bin/time).
Run: ``python tests/benchmarks/bench_large_tables.py [ROWS]``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def run(*args: str) -> tuple[float, float, int]:
    """(seconds, peak RSS in MB, exit code) of ``contactrig ARGS`` (peak RSS: the larger of the command and the
    children it waited for)."""
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "contactrig", *args], cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)  # fmt: skip
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    return time.perf_counter() - t0, usage.ru_maxrss / 1024, proc.returncode


def write_table(path: Path, rows: int) -> None:
    rng = np.random.default_rng(1)
    w = np.linspace(5.0, 26.0, rows)
    r = (40.0 / w)[:, None] * (1 + 0.1 * rng.standard_normal((rows, 6)))  # mΩ, Tab. 1's trend
    lines = ["weight_kg,M1,M2,M3,M4,M5,M6"] + [
        f"{wi:.6f}," + ",".join(f"{x:.5f}" for x in row) for wi, row in zip(w, r, strict=True)
    ]
    path.write_text("\n".join(lines) + "\n")


def write_session(path: Path, blocks: int, count: int) -> None:
    """A session of ``blocks`` × ``count`` readings over the 8 Tab. 1 weights (written in one batch)."""
    from daq.records import StopRecord, now_iso
    from daq.session_file import SessionFile
    from daq.session_writer import BlockBatch
    from daq.table_import import tab1_path

    weights = np.loadtxt(tab1_path(), delimiter=",", skiprows=1)[:, 0]
    rng = np.random.default_rng(2)
    per = blocks // weights.size
    wk = np.repeat(weights, per)[:blocks]
    r = np.repeat(40e-3 / wk, count) * (1 + 0.05 * rng.standard_normal(blocks * count))
    with SessionFile.create(path, reading_unit="ohm", force=True) as sf:
        sf.write_start({"started": now_iso(), "imported": False, "operator": "bench"}, "")
        repeat = (np.arange(blocks) % per + 1).astype(np.int32)
        sf.append_blocks(BlockBatch(
            block=np.arange(blocks, dtype=np.int32), weight_kg=wk, repeat=repeat,
            count=np.full(blocks, count, np.int32), reading=r, time_s=np.tile(0.02 * np.arange(count), blocks),
            resistance_ohm=r, valid=np.ones(r.size, bool), started=now_iso(),
        ))  # fmt: skip
        sf.write_stop(StopRecord("success", "bench", now_iso(), blocks, blocks, r.size))


def main(rows: int = 10_000) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        write_table(d / "t.csv", rows)
        results = []
        t, rss, rc = run("import", str(d / "t.csv"), "--unit", "mohm", "-o", str(d / "t.h5"))
        results.append((f"import {rows} × 6 table", t, rss, rc, "≤ 2 s", "123 s (60 000 fsynced blocks)"))
        t, rss, rc = run("fit", str(d / "t.h5"))
        results.append((f"fit {rows} × 6 table", t, rss, rc, "≤ 5 s, ≤ 300 MB", "45 s, 3 360 MB"))
        mem = {}
        for blocks in (96, 1000):  # 8 weights × 12 and × 125 repeats
            write_session(d / f"s{blocks}.h5", blocks, 1000)
            t, rss, rc = run("fit", str(d / f"s{blocks}.h5"))
            mem[blocks] = rss
            results.append((f"load + fit {blocks * 1000:.0e} readings", t, rss, rc, "≤ 10 s (10⁶)", "—"))
    print(f"{'what':32} {'time':>8} {'peak RSS':>10} {'exit':>5}   target            before")
    for what, t, rss, rc, target, before in results:
        print(f"{what:32} {t:7.2f}s {rss:8.0f}MB {rc:5d}   {target:17} {before}")
    per = (mem[1000] - mem[96]) * 1e6 / ((1000 - 96) * 1000)
    print(f"memory per reading (10⁵ → 10⁶ readings): {per:.0f} bytes")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10_000)
