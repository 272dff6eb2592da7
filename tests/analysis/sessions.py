"""Small session files written directly for analysis tests (no bench): one helper instead of a loop per test file."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np


def model_resistance(weight_kg: float, rng: np.random.Generator, scatter: float) -> np.ndarray:
    """Five readings [Ω] of a made-up contact: 0.2 mΩ in series with 5 mΩ·(W/5 kg)^-0.8, repeat scatter
    ``scatter`` (relative) and 0.1 µΩ of reading noise."""
    return 2e-4 + 5e-10 / (1e-7 * (weight_kg / 5) ** 0.8) * (1 + scatter * rng.normal()) + 1e-7 * rng.normal(size=5)


def write_session(
    path: str | Path,
    blocks: Iterable[tuple[float, int, np.ndarray]],
    *,
    start: Mapping[str, Any] | None = None,
    scene_text: str = "",
    stop: Callable[[int], Any] | None = None,
) -> Path:
    """Write ``blocks`` (weight [kg], repeat, readings [Ω]) as a session; ``stop(n_blocks)`` makes the stop record
    (None: no stop record, as a killed run leaves it)."""
    from daq.records import BlockRecord, now_iso
    from daq.session_file import SessionFile

    with SessionFile.create(path) as sf:
        sf.write_start(dict(start) if start is not None else {"started": now_iso(), "operator": "tester"}, scene_text)
        n = 0
        for n, (weight, repeat, readings) in enumerate(blocks, start=1):
            r = np.asarray(readings, dtype=float)
            sf.append_block(
                BlockRecord(
                    block=n - 1, run=0, weight_kg=float(weight), repeat=repeat, unit="V", reading=r,
                    time_s=np.arange(float(r.size)), resistance_ohm=r, valid=np.ones(r.size, bool), started=now_iso(),
                )
            )  # fmt: skip
        if stop is not None:
            sf.write_stop(stop(n))
    return Path(path)
