"""Append-and-flush rate of the session file: flush only vs flush + os.fsync, pair-wise in one run.

Each row is one block appended by SessionFile.append_block (readings, ~30 exchanges, summary row, two flushes,
and os.fsync when on). Reference figure (data-and-sessions.md, h5py 3.16, one row per append): ~5 000 rows/s with
flush, ~2 400 rows/s with fsync. Run: python tests/benchmarks/bench_session_flush.py [BLOCKS]
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from contactrig.core.provenance import now_iso
from daq.records import BlockRecord
from daq.session_file import SessionFile
from instruments.transport import Exchange


def _blocks(n: int, count: int) -> list[BlockRecord]:
    rng = np.random.default_rng(0)
    ex = tuple(Exchange("query", "STAT:OPER:EVEN?", "0", 0.01 * i) for i in range(30))
    out = []
    for b in range(n):
        r = 5e-3 + 1e-6 * rng.standard_normal(count)
        out.append(
            BlockRecord(
                block=b, run=0, weight_kg=5.44, repeat=b + 1, unit="V", reading=r * 0.1,
                time_s=0.022 * np.arange(count), resistance_ohm=r, valid=np.ones(count, bool), started=now_iso(),
                exchanges=ex,
            )
        )  # fmt: skip
    return out


def rate(blocks: list[BlockRecord], path: Path, fsync: bool) -> float:
    with SessionFile.create(path, force=True, fsync=fsync) as sf:
        sf.write_start({"started": now_iso()}, "")
        t = time.perf_counter()
        for rec in blocks:
            sf.append_block(rec)
        return len(blocks) / (time.perf_counter() - t)


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 300
    with tempfile.TemporaryDirectory(dir=".") as d:
        for count in (1, 100, 1000):
            blocks = _blocks(n, count)
            rate(blocks[:10], Path(d) / "warm.h5", False)
            a = rate(blocks, Path(d) / "flush.h5", False)
            b = rate(blocks, Path(d) / "fsync.h5", True)
            print(
                f"{count:5d} readings/block, {n} blocks: flush {a:8.0f} blocks/s ({a * count:9.0f} readings/s) | "
                f"flush+fsync {b:8.0f} blocks/s ({b * count:9.0f} readings/s) | "
                f"fsync costs {1e3 * (1 / b - 1 / a):.2f} ms"
            )


if __name__ == "__main__":
    main()
