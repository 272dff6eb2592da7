"""Study ``acquisition``: how the error of a Delta-mode resistance falls with acquisition time.

On the simulated bench (known resistance R, thermal EMF, linear drift and white conversion noise that falls as
1/√NPLC), each setting (Delta readings per block × NPLC) is measured in several independent blocks. Error: the
RMS relative deviation of the block means from the set R (the reference is the resistance the bench was given,
independent of the driver and of the Delta arithmetic); ``extra['sem_rel']`` is the standard error the block
itself reports, which should match it. Seconds: the instrument time the block takes (count × (delay + NPLC/line
frequency + overhead), read from the 6221's buffer timestamps), i.e. what the user waits at the bench; the
software overhead is in ``extra['wall_s']``. A final set of rows is the overlapping Allan deviation of one long
block (method ``allan``, seconds = averaging time τ): where it stops falling as 1/√τ, averaging longer no longer
pays.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from analysis.studies.rows import Row
from instruments.block import block_statistics

if TYPE_CHECKING:
    from instruments.delta import DeltaBlock

REFERENCE = "the resistance set on the simulated bench (R = 5 mΩ, 100 mA Delta current)"
_R_OHM = 5e-3
_CURRENT_A = 0.1


def _blocks(count: int, nplc: float, n_blocks: int, seed: int) -> tuple[list[DeltaBlock], float]:
    """``n_blocks`` Delta blocks of ``count`` readings at ``nplc`` on a fresh seeded bench, and the wall time per
    block (s)."""
    from instruments.delta import DeltaSettings
    from instruments.k6221 import Keithley6221
    from instruments.simulated import SimulatedBench, simulated_resource_manager

    bench = SimulatedBench(resistance_ohm=_R_OHM, seed=seed, time_scale=0.0)
    settings = DeltaSettings(high_a=_CURRENT_A, count=count, delay_s=2e-3, nplc=nplc, unit="V")
    rm = simulated_resource_manager(bench=bench)
    t0 = time.perf_counter()
    with Keithley6221.open("GPIB0::12::INSTR", resource_manager=rm, timeout_ms=2000) as k:
        blocks = [k.run_delta(settings) for _ in range(n_blocks)]
    return blocks, (time.perf_counter() - t0) / n_blocks


def run(quick: bool) -> list[Row]:
    from analysis.studies.allan import allan_deviation

    counts = (10, 100, 1000) if quick else (10, 100, 1000, 10000)
    nplcs = (0.1, 1.0, 5.0) if quick else (0.1, 1.0, 5.0, 20.0)
    n_blocks = 8 if quick else 16
    rows: list[Row] = []
    for nplc in nplcs:
        for count in counts:
            blocks, wall = _blocks(count, nplc, n_blocks, seed=count + int(100 * nplc))
            stats = [block_statistics(b.resistance_ohm(), b.valid) for b in blocks]
            r = np.array([st.mean for st in stats])
            sem = np.array([st.sem for st in stats])
            instrument_s = float(np.mean([b.timestamps_s[-1] - b.timestamps_s[0] for b in blocks]))
            rows.append(
                Row(
                    study="acquisition",
                    method=f"delta NPLC {nplc:g}",
                    setting=f"{count} readings",
                    error=float(np.sqrt(np.mean((r / _R_OHM - 1.0) ** 2))),
                    seconds=instrument_s,
                    extra={
                        "error_kind": "RMS relative error of block means",
                        "sem_rel": float(np.mean(sem) / _R_OHM),
                        "wall_s": wall,
                        "n_blocks": n_blocks,
                    },
                )
            )
    n_long = 4096 if quick else 65536
    (block,), _ = _blocks(n_long, 1.0, 1, seed=99)
    r = block.resistance_ohm()[block.valid]
    interval = float(np.median(np.diff(block.timestamps_s)))
    res = allan_deviation(r, interval)
    for tau, m, adev, pairs in zip(res.tau_s, res.m, res.adev, res.n_pairs, strict=True):
        rows.append(
            Row(
                study="acquisition",
                method="allan (NPLC 1)",
                setting=f"{int(m)} readings",
                error=float(adev / _R_OHM),
                seconds=float(tau),
                extra={"error_kind": "relative Allan deviation", "n_pairs": int(pairs)},
            )
        )
    return rows
