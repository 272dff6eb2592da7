"""The records a session is made of: one start record, one record per block, one stop record.

After Bluesky's documents: the acquisition engine emits these records and independent writers consume them (the
HDF5 session file, the live display, the in-memory collector used by replay). Exchanges are
:class:`instruments.transport.Exchange` (kind, message, reply, t_s, error); block statistics are
:func:`instruments.block.block_statistics` (the one implementation, shared with the drivers).

Units: resistance in Ω, weight in kg, times in s; ISO-8601 timestamps carry their time zone.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from contactrig.core.provenance import now_iso
from instruments.block import BlockStatistics, block_statistics
from instruments.transport import Exchange

# now_iso is contactrig.core.provenance's, re-exported for the writers that import it from here
__all__ = ["BlockRecord", "StopRecord", "block_digest", "exchanges_digest", "now_iso"]

StopStatus = Literal["success", "aborted", "failed"]


def block_digest(
    block: int,
    weight_kg: float,
    repeat: int,
    reading: np.ndarray,
    time_s: np.ndarray,
    resistance_ohm: np.ndarray,
    valid: np.ndarray,
    stats: BlockStatistics,
    compliance: bool = False,
) -> str:
    """SHA-256 (hex) over one block's identity, its raw arrays, its summary and its compliance flag, as stored on
    disk.

    Little-endian float64/int64 and uint8 bytes, so the digest does not depend on the machine. The compliance flag
    enters only when set, so the digest of a block without it is the one schema 1 stored.
    """
    h = hashlib.sha256()
    h.update(np.asarray([block, repeat, stats.n, stats.n_invalid], dtype="<i8").tobytes())
    h.update(np.asarray([weight_kg, stats.mean, stats.sd, stats.sem], dtype="<f8").tobytes())
    for arr in (reading, time_s, resistance_ohm):
        h.update(np.ascontiguousarray(arr, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(valid, dtype="u1").tobytes())
    if compliance:
        h.update(b"compliance")
    return h.hexdigest()


def exchanges_digest(exchanges: Iterable[Exchange]) -> str:
    """SHA-256 (hex) over a block's recorded instrument exchanges (kind, message, reply, time, error)."""
    h = hashlib.sha256()
    for e in exchanges:
        h.update("\x1f".join((e.kind, e.message, e.reply or "", e.error or "")).encode("utf-8"))
        h.update(np.asarray([e.t_s], dtype="<f8").tobytes())
        h.update(b"\x1e")
    return h.hexdigest()


@dataclass(frozen=True)
class BlockRecord:
    """One completed block: what the instruments returned, where it was taken, and how it was obtained.

    ``reading`` is in ``unit`` (e.g. ``V`` or ``OHMS``, as the instrument returned it; invalid entries NaN),
    ``resistance_ohm`` the same readings in Ω, ``time_s`` the instrument's timestamps (first = 0 s).
    ``exchanges`` are the instrument exchanges of this block, for replay (empty for imported tables).
    ``stats`` are the block statistics of ``resistance_ohm`` over ``valid``, in Ω.
    ``compliance``: the source was in compliance during the block (readings wrong by an unknown amount): ``valid``
    is then all False whatever was passed, so the statistics have no value (NaN mean, n = 0, every reading counted
    invalid) and no fit or report can average the block in.
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
    compliance: bool = False
    stats: BlockStatistics = field(init=False)
    sha256: str = field(init=False)
    exchanges_sha256: str = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "compliance", bool(self.compliance))
        if self.compliance:
            object.__setattr__(self, "valid", np.zeros(np.shape(self.valid), dtype=bool))
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
            self.compliance,
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
