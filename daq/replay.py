"""Replay: run a recorded session again through the acquisition code, against its recorded instrument replies.

For each run of the session (the first and every ``--resume``) the recorded exchanges — set-up, every completed
block, close — are served back by ``instruments.transport.ReplayTransport`` (strict: the driver must send exactly
the recorded commands). The same :func:`daq.acquire.drive` runs the same engine and driver on it, and the blocks it
produces are compared with the file: summaries (mean, SD, SEM, n, invalid) and each block's SHA-256 over its
readings must be identical. Exchanges of blocks that never completed (a timeout, a second Ctrl-C, a kill) are
left out, as the acquisition discarded those blocks.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from daq.acquire import drive
from daq.errors import SessionStateError
from daq.link import InstrumentLink
from daq.plan import Measure, PlaceWeight
from daq.session_file import Session, exchange_list, load_session
from daq.writers import MemoryWriter
from instruments.errors import ReplayMismatch
from instruments.transport import Exchange, ReplayTransport

__all__ = ["ReplayReport", "replay_session"]


@dataclass(frozen=True)
class ReplayReport:
    """Result of a replay: ``identical`` when every recorded block was reproduced exactly."""

    path: Path
    identical: bool
    blocks_recorded: int
    blocks_replayed: int
    readings_replayed: int
    differences: tuple[str, ...] = ()
    runs: int = 0
    elapsed_s: float = 0.0
    complete: bool = True
    notes: tuple[str, ...] = field(default=())

    def as_dict(self) -> dict[str, Any]:
        return {
            "path": str(self.path),
            "identical": self.identical,
            "blocks_recorded": self.blocks_recorded,
            "blocks_replayed": self.blocks_replayed,
            "readings_replayed": self.readings_replayed,
            "runs": self.runs,
            "complete": self.complete,
            "elapsed_s": self.elapsed_s,
            "differences": list(self.differences),
            "notes": list(self.notes),
        }


class _PacedTransport:
    """Wraps a ReplayTransport and waits so that each exchange happens at its recorded time (``--pace``)."""

    def __init__(self, inner: ReplayTransport) -> None:
        self.inner = inner
        self._t0_real: float | None = None
        self._t0_rec = inner.exchanges[0].t_s if inner.exchanges else 0.0

    def _wait(self) -> None:
        if self.inner.position >= len(self.inner.exchanges):
            return
        now = time.monotonic()
        if self._t0_real is None:
            self._t0_real = now
        target = self._t0_real + (self.inner.exchanges[self.inner.position].t_s - self._t0_rec)
        if target > now:
            time.sleep(target - now)

    def write(self, message: str) -> None:
        self._wait()
        self.inner.write(message)

    def query(self, message: str) -> str:
        self._wait()
        return self.inner.query(message)

    def read(self) -> str:
        self._wait()
        return self.inner.read()

    def close(self) -> None:
        self.inner.close()


def _exchanges(session: Session, run: int, blocks: set[int]) -> list[Exchange]:
    """The recorded exchanges of ``run`` outside blocks (set-up, close) and of the completed ``blocks``."""
    ex = session.exchanges
    block = ex["block"].to_numpy()
    sel = (ex["run"].to_numpy() == run) & ((block == -1) | np.isin(block, sorted(blocks)))
    return exchange_list({name: ex[name].to_numpy()[sel] for name in ("kind", "message", "reply", "t_s", "error")})


def _steps(rows: Any) -> Iterator[PlaceWeight | Measure]:
    """The recorded blocks of one run as plan steps: a PlaceWeight whenever the weight changes, then its blocks."""
    weights = rows["weight_kg"].to_numpy()
    wi = -1
    for i, (block, weight, repeat) in enumerate(
        zip(rows["block"].to_numpy(), weights, rows["repeat"].to_numpy(), strict=True)
    ):
        if i == 0 or weight != weights[i - 1]:
            wi += 1
            left = int(np.count_nonzero(weights[i:] == weight))
            yield PlaceWeight(weight_index=wi, weight_kg=float(weight), repeats_left=left)
        yield Measure(block=int(block), weight_index=wi, weight_kg=float(weight), repeat=int(repeat))


def _same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


def replay_session(path: str | Path, *, pace: bool = False) -> ReplayReport:
    """Replay the session at ``path`` and compare what it produces with what it recorded."""
    from instruments.delta import DeltaSettings

    t0 = time.perf_counter()
    p = Path(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        session = load_session(p)
    if session.imported:
        raise SessionStateError(f"{p} is an imported table: it has no recorded instrument exchanges to replay")
    settings = DeltaSettings(**session.start["plan"]["delta"])
    summary = session.summary
    differences: list[str] = []
    notes: list[str] = list(session.warnings)
    replayed = 0
    n_readings = 0
    run_ids = sorted(set(summary["run"].tolist()) | set(session.exchanges["run"].tolist()))
    for run in run_ids:
        rows = summary[summary["run"] == run]
        blocks = set(rows["block"].tolist())
        exchanges = _exchanges(session, run, blocks)
        if not exchanges:
            continue
        replay = ReplayTransport(exchanges, strict=True)
        transport = _PacedTransport(replay) if pace else replay
        link = InstrumentLink(transport, clock=lambda: 0.0, sleep=lambda s: None)
        collector = MemoryWriter()
        try:
            outcome = drive(link, settings, _steps(rows), [collector], {}, "", run=run)
        except ReplayMismatch as exc:
            differences.append(f"run {run}: {exc}")
            continue
        if outcome.error is not None:
            if (
                isinstance(outcome.error, ReplayMismatch)
                and replay.remaining == 0
                and len(collector.blocks) == len(rows)
            ):
                # the recording ended with the blocks (a killed run never closed the instrument): nothing is missing
                notes.append(f"run {run}: the recording ends without the instrument being closed (killed run)")
            else:
                differences.append(f"run {run}: {type(outcome.error).__name__}: {outcome.error}")
        if replay.remaining:
            notes.append(f"run {run}: {replay.remaining} recorded exchanges were not used")
        by_block = {rec.block: rec for rec in collector.blocks}
        for _, row in rows.iterrows():
            rec = by_block.get(int(row["block"]))
            where = f"block {int(row['block'])} (weight {row['weight_kg']:g} kg, repeat {int(row['repeat'])})"
            if rec is None:
                differences.append(f"{where}: not reproduced")
                continue
            replayed += 1
            n_readings += int(rec.reading.size)
            st = rec.stats
            for name in ("mean_ohm", "sd_ohm", "sem_ohm"):
                if not _same(float(getattr(st, name)), float(row[name])):
                    differences.append(f"{where}: {name} recorded {row[name]!r}, replayed {getattr(st, name)!r}")
            for name in ("n", "n_invalid"):
                if int(getattr(st, name)) != int(row[name]):
                    differences.append(f"{where}: {name} recorded {int(row[name])}, replayed {getattr(st, name)}")
            if rec.weight_kg != float(row["weight_kg"]) or rec.repeat != int(row["repeat"]):
                differences.append(f"{where}: replayed as weight {rec.weight_kg:g} kg, repeat {rec.repeat}")
        stored = dict(zip(rows["block"].tolist(), rows["sha256"].tolist(), strict=True))
        for rec in collector.blocks:
            if rec.block in stored and stored[rec.block] != rec.sha256:
                differences.append(f"block {rec.block}: readings differ from the recorded ones (SHA-256)")
    return ReplayReport(
        path=p,
        identical=not differences and replayed == len(summary),
        blocks_recorded=len(summary),
        blocks_replayed=replayed,
        readings_replayed=n_readings,
        differences=tuple(differences),
        runs=len(run_ids),
        elapsed_s=time.perf_counter() - t0,
        complete=session.complete,
        notes=tuple(notes),
    )
