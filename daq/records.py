"""The records a session is made of: one start record, one record per Delta block, one stop record.

After Bluesky's documents: the acquisition engine emits these records and independent writers consume them (the
HDF5 session file, the live display, the in-memory collector used by replay). Exchanges are
:class:`instruments.transport.Exchange` (kind, message, reply, t_s, error).

Units: resistance in Ω, weight in kg, times in s; ISO-8601 timestamps carry their time zone.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from contactrig.core.provenance import now_iso
from instruments.transport import Exchange

__all__ = [
    "BlockRecord",
    "BlockStatistics",
    "Exchange",
    "StopRecord",
    "block_digest",
    "block_statistics",
    "exchanges_digest",
    "now_iso",
]

StopStatus = Literal["success", "aborted", "failed"]


@dataclass(frozen=True)
class BlockStatistics:
    """Mean, sample standard deviation (ddof = 1) and standard error of the valid readings of one block, in Ω."""

    mean_ohm: float
    sd_ohm: float
    sem_ohm: float
    n: int
    n_invalid: int


def block_statistics(resistance_ohm: np.ndarray, valid: np.ndarray) -> BlockStatistics:
    """Statistics of one block over its valid readings.

    SEM = sd/√n. With no valid reading the mean is NaN; with one, sd and SEM are NaN (undefined, not zero).
    The same function serves acquisition, replay and the checks on load, so their results are bit-identical.
    """
    r = np.asarray(resistance_ohm, dtype=np.float64)
    ok = np.asarray(valid, dtype=bool)
    good = r[ok]
    n = int(good.size)
    mean = float(good.mean()) if n else math.nan
    sd = float(good.std(ddof=1)) if n > 1 else math.nan
    sem = sd / math.sqrt(n) if n > 1 else math.nan
    return BlockStatistics(mean_ohm=mean, sd_ohm=sd, sem_ohm=sem, n=n, n_invalid=int(r.size - n))


def block_digest(
    block: int,
    weight_kg: float,
    repeat: int,
    reading: np.ndarray,
    time_s: np.ndarray,
    resistance_ohm: np.ndarray,
    valid: np.ndarray,
    stats: BlockStatistics,
) -> str:
    """SHA-256 (hex) over one block's identity, its raw arrays and its summary, as stored on disk.

    Little-endian float64/int64 and uint8 bytes, so the digest does not depend on the machine.
    """
    h = hashlib.sha256()
    h.update(np.asarray([block, repeat, stats.n, stats.n_invalid], dtype="<i8").tobytes())
    h.update(np.asarray([weight_kg, stats.mean_ohm, stats.sd_ohm, stats.sem_ohm], dtype="<f8").tobytes())
    for arr in (reading, time_s, resistance_ohm):
        h.update(np.ascontiguousarray(arr, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(valid, dtype="u1").tobytes())
    return h.hexdigest()


def exchanges_digest(exchanges: Iterable[Any]) -> str:
    """SHA-256 (hex) over a block's recorded instrument exchanges (kind, message, reply, time, error)."""
    h = hashlib.sha256()
    for e in exchanges:
        h.update("\x1f".join((e.kind, e.message, e.reply or "", e.error or "")).encode("utf-8"))
        h.update(np.asarray([e.t_s], dtype="<f8").tobytes())
        h.update(b"\x1e")
    return h.hexdigest()


@dataclass(frozen=True)
class BlockRecord:
    """One completed Delta block: what the instrument returned, where it was taken, and how it was obtained.

    ``reading`` is in ``unit`` (``V`` or ``OHMS``, as the 6221 returned it; invalid entries NaN),
    ``resistance_ohm`` the same readings in Ω, ``time_s`` the 6221's buffer timestamps (first = 0 s).
    ``exchanges`` are the instrument exchanges of this block, for replay (empty for imported tables).
    """

    block: int
    run: int
    weight_kg: float
    repeat: int
    unit: str
    reading: np.ndarray
    time_s: np.ndarray
    resistance_ohm: np.ndarray
    valid: np.ndarray
    started: str
    exchanges: tuple[Exchange, ...] = ()
    stats: BlockStatistics = field(init=False)
    sha256: str = field(init=False)
    exchanges_sha256: str = field(init=False)

    def __post_init__(self) -> None:
        stats = block_statistics(self.resistance_ohm, self.valid)
        object.__setattr__(self, "stats", stats)
        digest = block_digest(
            self.block,
            self.weight_kg,
            self.repeat,
            self.reading,
            self.time_s,
            self.resistance_ohm,
            self.valid,
            stats,
        )
        object.__setattr__(self, "sha256", digest)
        object.__setattr__(self, "exchanges_sha256", exchanges_digest(self.exchanges))


@dataclass(frozen=True)
class StopRecord:
    """How a run ended: ``status`` success / aborted / failed, a one-line ``reason``, counts and the time."""

    status: StopStatus
    reason: str
    stopped: str
    blocks_planned: int
    blocks_done: int
    readings_done: int
    weights_skipped: tuple[float, ...] = ()
