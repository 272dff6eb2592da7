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
import pandas as pd

from daq.acquire import drive
from daq.errors import SessionFileError, SessionStateError
from daq.link import InstrumentLink
from daq.pause import pauses_of
from daq.plan import Measure, PlaceWeight, settings_from_record
from daq.records import BlockRecord, block_number, how_run_ended
from daq.session_file import Session, exchange_list, load_session
from daq.writers import MemoryWriter
from instruments.errors import ReplayMismatch
from instruments.pairs import InstrumentPair
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

    def verdict(self) -> str:
        """One line saying what differs (empty when identical)."""
        if self.identical:
            return ""
        if self.differences:
            more = f" (and {len(self.differences) - 1} more)" if len(self.differences) > 1 else ""
            return f"{self.path}: replay DIFFERENT: {self.differences[0]}{more}"
        return f"{self.path}: replay DIFFERENT: {self.blocks_replayed} of {self.blocks_recorded} blocks reproduced"


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


#: What the driver sends last when it closes the instrument: the source left idle.
_ABORT = "SOUR:SWE:ABOR"


def _run_stop(session: Session, run: int) -> dict[str, Any] | None:
    """The stop record of ``run``: the session's own for its last run, else the one ``--resume`` moved into the run
    record; None when the run has none (killed, or still running)."""
    stop = session.stop
    if isinstance(stop, dict) and stop.get("run", run) == run:
        return stop
    record = session.runs[run] if 0 <= run < len(session.runs) else None
    moved = record.get("stop") if isinstance(record, dict) else None
    return moved if isinstance(moved, dict) and moved.get("run", run) == run else None


def _close_after_discarded_block(session: Session, run: int, blocks: set[int]) -> tuple[list[Exchange], str]:
    """The close of a run stopped inside a block (Ctrl-C twice, or an error): the engine tagged it with the block it
    discarded, so it is not among the exchanges replayed. When the run's transcript ends with ``SOUR:SWE:ABOR`` and
    its stop record says it stopped early or failed, that closing abort is served back too, and a note says how the
    run ended; otherwise (a killed run: no stop record, no close) nothing."""
    stop = _run_stop(session, run)
    if stop is None or stop.get("status") not in ("aborted", "failed"):
        return [], ""
    ex = session.exchanges
    rows = np.flatnonzero(ex["run"].to_numpy() == run)
    if not rows.size:
        return [], ""
    last = int(rows[-1])
    block = int(ex["block"].iloc[last])
    if block == -1 or block in blocks:
        return [], ""  # closed between blocks: already among the exchanges replayed
    tail = exchange_list({name: ex[name].to_numpy()[last : last + 1] for name in ("kind", "message", "reply", "t_s",
                                                                               "error")})  # fmt: skip
    if tail[0].kind != "write" or tail[0].message != _ABORT or tail[0].error:
        return [], ""
    note = (
        f"run {run}: {how_run_ended(stop)} during block {block_number(block)}, which was discarded; the recording "
        f"ends with {_ABORT} (source left idle)"
    )
    return tail, note


def _steps(rows: pd.DataFrame) -> Iterator[PlaceWeight | Measure]:
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


@dataclass
class _Tally:
    """What the replay found so far."""

    differences: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    blocks: int = 0
    readings: int = 0


def replay_session(path: str | Path, *, pace: bool = False) -> ReplayReport:
    """Replay the session at ``path`` and compare what it produces with what it recorded."""
    t0 = time.perf_counter()
    p = Path(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        session = load_session(p)
    if session.imported:
        raise SessionStateError(f"{p} is an imported table: it has no recorded instrument exchanges to replay")
    pair, settings = _recorded_settings(session)
    tally = _Tally(notes=list(session.warnings))
    run_ids = sorted(set(session.summary["run"].tolist()) | set(session.exchanges["run"].tolist()))
    for run in run_ids:
        _replay_run(session, run, pair, settings, pace, tally)
    tally.notes += [_pause_note(p) for p in pauses_of(session.runs)]
    return ReplayReport(
        path=p,
        identical=not tally.differences and tally.blocks == len(session.summary),
        blocks_recorded=len(session.summary),
        blocks_replayed=tally.blocks,
        readings_replayed=tally.readings,
        differences=tuple(tally.differences),
        runs=len(run_ids),
        elapsed_s=time.perf_counter() - t0,
        complete=session.complete,
        notes=tuple(tally.notes),
    )


def _pause_note(p: dict[str, Any]) -> str:
    """A pause of the session (:mod:`daq.pause`): said, not replayed (nothing went to the instruments meanwhile)."""
    until = f"resumed {p.get('resumed')} by {p.get('resumed_by')}" if "resumed" in p else "not resumed"
    return (f"run {p.get('run')}: paused after block {p.get('after_block')} at {p.get('paused')} by {p.get('who')} "
            f"({p.get('reason')}), {until}; nothing is sent to the instruments while paused")  # fmt: skip


def _recorded_settings(session: Session) -> tuple[InstrumentPair, object]:
    """The instrument pair and block settings of the start record's plan; a plan that cannot be read is one line."""
    plan = session.start.get("plan")
    if not isinstance(plan, dict):
        raise SessionFileError(f"{session.path}: /entry/start/record has no plan: nothing to replay")
    try:
        return settings_from_record(plan)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise SessionFileError(
            f"{session.path}: the plan in /entry/start/record cannot be read ({type(exc).__name__}: {exc})"
        ) from None


def _replay_run(session: Session, run: int, pair: InstrumentPair, settings: object, pace: bool, tally: _Tally) -> None:
    """Run ``run`` again on its recorded replies through :func:`daq.acquire.drive`, and compare its blocks."""
    rows = session.summary[session.summary["run"] == run]
    blocks = set(rows["block"].tolist())
    exchanges = _exchanges(session, run, blocks)
    if not exchanges:
        return
    close, ended = _close_after_discarded_block(session, run, blocks)
    exchanges += close
    if ended:
        tally.notes.append(ended)
    replay = ReplayTransport(exchanges, strict=True)
    transport = _PacedTransport(replay) if pace else replay
    link = InstrumentLink(
        transport, pair=pair, clock=lambda: 0.0, sleep=lambda s: None, driver_options=_driver_options(session.start)
    )
    collector = MemoryWriter()
    try:
        outcome = drive(link, settings, _steps(rows), [collector], {}, "", run=run)
    except ReplayMismatch as exc:
        tally.differences.append(f"run {run}: {exc}")
        return
    if outcome.error is not None:
        if isinstance(outcome.error, ReplayMismatch) and replay.remaining == 0 and len(collector.blocks) == len(rows):
            # the recording ended with the blocks (a killed run never closed the instrument): nothing is missing
            tally.notes.append(f"run {run}: the recording ends without the instrument being closed (killed run)")
        else:
            tally.differences.append(f"run {run}: {type(outcome.error).__name__}: {outcome.error}")
    if replay.remaining:
        tally.notes.append(f"run {run}: {replay.remaining} recorded exchanges were not used")
    _compare(rows, collector.blocks, tally)


def _driver_options(start: dict[str, Any]) -> dict[str, Any]:
    """The driver options the recording was taken with (a serial link's chunk size), so that the replayed driver
    sends the same commands."""
    instrument = start.get("instrument", {})
    chunk = instrument.get("chunk_size") if isinstance(instrument, dict) else None
    return {"chunk_size": int(chunk)} if isinstance(chunk, int) and not isinstance(chunk, bool) else {}


#: summary column → the block statistic it holds
_STATISTICS = {"mean_ohm": "mean", "sd_ohm": "sd", "sem_ohm": "sem"}


def _compare(rows: pd.DataFrame, blocks: list[BlockRecord], tally: _Tally) -> None:
    """Every recorded row against the replayed block of the same number: statistics, counts, place, SHA-256."""
    by_block = {rec.block: rec for rec in blocks}
    for _, row in rows.iterrows():
        rec = by_block.get(int(row["block"]))
        where = f"block {block_number(row['block'])} (weight {row['weight_kg']:g} kg, repeat {int(row['repeat'])})"
        if rec is None:
            tally.differences.append(f"{where}: not reproduced")
            continue
        tally.blocks += 1
        tally.readings += int(rec.reading.size)
        tally.differences += _row_differences(where, row, rec)
    stored = dict(zip(rows["block"].tolist(), rows["sha256"].tolist(), strict=True))
    for rec in blocks:
        if rec.block in stored and stored[rec.block] != rec.sha256:
            number = block_number(rec.block)
            tally.differences.append(f"block {number}: readings differ from the recorded ones (SHA-256)")


def _row_differences(where: str, row: pd.Series, rec: BlockRecord) -> list[str]:
    out = []
    st = rec.stats
    for column, name in _STATISTICS.items():
        if not _same(float(getattr(st, name)), float(row[column])):
            out.append(f"{where}: {column} recorded {row[column]!r}, replayed {getattr(st, name)!r}")
    if "compliance" in row.index and bool(row["compliance"]) != rec.compliance:
        out.append(f"{where}: compliance recorded {bool(row['compliance'])}, replayed {rec.compliance}")
    for name in ("n", "n_invalid"):
        if int(getattr(st, name)) != int(row[name]):
            out.append(f"{where}: {name} recorded {int(row[name])}, replayed {getattr(st, name)}")
    if rec.weight_kg != float(row["weight_kg"]) or rec.repeat != int(row["repeat"]):
        out.append(f"{where}: replayed as weight {rec.weight_kg:g} kg, repeat {rec.repeat}")
    return out
