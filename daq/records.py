"""The records a session is made of: one start record, one record per block, one stop record.

After Bluesky's documents: the acquisition engine emits these records and independent writers consume them (the
HDF5 session file, the live display, the in-memory collector used by replay). Exchanges are
:class:`instruments.transport.Exchange` (kind, message, reply, t_s, error); block statistics are
:func:`instruments.block.block_statistics` (the one implementation, shared with the drivers).

Units: resistance in Ω, weight in kg, times in s; ISO-8601 timestamps carry their time zone.

Block numbers: a record's ``block`` is the block's 0-based position in the session's full plan (weight index ×
repeats + repeat − 1), as the file stores it; a person always reads :func:`block_number` (1-based), in the live line,
stop messages, exports, ``watch``, replay messages and reports.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from contactrig.core.provenance import now_iso
from instruments.block import BlockStatistics, block_statistics
from instruments.transport import Exchange

# now_iso is contactrig.core.provenance's, re-exported for the writers that import it from here
__all__ = [
    "BlockRecord",
    "StopRecord",
    "block_digest",
    "block_digests",
    "block_number",
    "exchanges_digest",
    "how_run_ended",
    "now_iso",
    "session_history",
]

StopStatus = Literal["success", "aborted", "failed"]


def block_number(block: int) -> int:
    """The number a person reads for the block stored as ``block`` (0-based position in the plan): 1-based."""
    return int(block) + 1


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


def block_digests(summary: Mapping[str, np.ndarray], readings: Mapping[str, np.ndarray]) -> list[str]:
    """:func:`block_digest` of every block at once (the same bytes, so the same digests), from the summary columns
    (block, repeat, n, n_invalid, weight_kg, mean_ohm, sd_ohm, sem_ohm, first_reading, count and, if present,
    compliance) and the reading columns (reading, time_s, resistance_ohm, valid). About 3 µs a block instead of
    30 µs: a 60 000-block table is checked in a fraction of a second."""
    k = len(summary["block"])
    ints = np.empty((k, 4), dtype="<i8")
    for j, name in enumerate(("block", "repeat", "n", "n_invalid")):
        ints[:, j] = summary[name]
    floats = np.empty((k, 4), dtype="<f8")
    for j, name in enumerate(("weight_kg", "mean_ohm", "sd_ohm", "sem_ohm")):
        floats[:, j] = summary[name]
    ib, fb = ints.tobytes(), floats.tobytes()
    columns = [np.ascontiguousarray(readings[name], dtype="<f8").tobytes() for name in ("reading", "time_s",
               "resistance_ohm")] + [np.ascontiguousarray(readings["valid"], dtype="u1").tobytes()]  # fmt: skip
    widths = (8, 8, 8, 1)
    first = np.asarray(summary["first_reading"], dtype=np.int64).tolist()
    count = np.asarray(summary["count"], dtype=np.int64).tolist()
    flags = np.asarray(summary.get("compliance", np.zeros(k)), dtype=bool).tolist()
    out = []
    sha = hashlib.sha256
    for i in range(k):
        h = sha(ib[32 * i : 32 * i + 32])
        h.update(fb[32 * i : 32 * i + 32])
        a, b = first[i], first[i] + count[i]
        for data, w in zip(columns, widths, strict=True):
            h.update(data[w * a : w * b])
        if flags[i]:
            h.update(b"compliance")
        out.append(h.hexdigest())
    return out


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
    ``adaptive``: in an adaptive session, the suggestion that led to this block, the evidence behind it and what
    the operator did (:class:`daq.plan.Measure`'s ``adaptive``), written with the block (``/entry/adaptive``).
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
    #: an adaptive session's record of the suggestion that led to this block (schema 5; not part of its digest)
    adaptive: dict[str, Any] | None = None
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
    #: an adaptive session's record (schema 4): suggestions, evidence, operator's actions, stop decision
    adaptive: dict[str, Any] | None = None


# ---- the session's history, from its run records and stop records ------------------------------------------------


def _kg(values: Any) -> str:
    """``5.44, 10.526 kg`` (values from a file: anything that is not a number is shown as it is)."""
    items = values if isinstance(values, (list, tuple)) else [values]
    return ", ".join(f"{v:g}" if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v) for v in items) + (
        " kg"
    )


def how_run_ended(stop: Mapping[str, Any] | None, *, running: bool = False) -> str:
    """How a run ended, from its stop record: ``done``, ``stopped early (Ctrl-C)``, ``stopped early (operator)``,
    ``failed``; without one ``running`` or ``killed (no stop record: killed or lost power)``."""
    if not isinstance(stop, Mapping):
        return "running" if running else "killed (no stop record: killed or lost power)"
    status, reason = stop.get("status"), str(stop.get("reason", ""))
    if status == "success":
        return "done"
    if status == "aborted":
        return "stopped early (Ctrl-C)" if reason.startswith("interrupted") else "stopped early (operator)"
    return str(status)


def _run_stop(session: Any, k: int, last: int) -> Mapping[str, Any] | None:
    if k == last:
        stop = getattr(session, "stop", None)
        return stop if isinstance(stop, Mapping) else None
    rec = session.runs[k] if k < len(session.runs) else {}
    stop = rec.get("stop") if isinstance(rec, Mapping) else None
    return stop if isinstance(stop, Mapping) else None


def _placed(summary: Any, run: int) -> list[float]:
    """The weights of ``run``'s blocks in the order they were placed (consecutive repeats once)."""
    out: list[float] = []
    for r, w in zip(summary["run"].tolist(), summary["weight_kg"].tolist(), strict=True):
        if r == run and (not out or out[-1] != w):
            out.append(float(w))
    return out


def _choices(record: Mapping[str, Any]) -> tuple[list[str], list[Any]]:
    """The resume questions of a run record, as text, and the weights kept skipped by them."""
    lines, kept = [], []
    choices = record.get("resume_choices")
    for c in choices if isinstance(choices, list) else []:
        if not isinstance(c, Mapping):
            continue
        weight = c.get("weight_kg")
        lines.append(f"{_kg(weight)} was skipped: {c.get('choice', '?')} ({c.get('by', '?')})")
        if c.get("choice") == "keep it skipped":
            kept.append(weight)
    return lines, kept


def _run_line(session: Any, k: int, last: int) -> str:
    record = session.runs[k] if k < len(session.runs) and isinstance(session.runs[k], Mapping) else {}
    started = record.get("started", "?")
    parts = [f"run {k} ({'resumed' if k else 'started'} {started})"]
    asked, kept = _choices(record)
    parts += asked
    placed = _placed(session.summary, k)
    parts.append(f"placed {_kg(placed)}" if placed else "no block completed")
    stop = _run_stop(session, k, last)
    skipped = stop.get("weights_skipped") if stop is not None else None
    new_skips = [w for w in skipped if w not in kept] if isinstance(skipped, list) else []
    if new_skips:
        parts.append(f"skipped by the operator: {_kg(new_skips)}")
    ended = how_run_ended(stop, running=bool(getattr(session, "running", False)) and k == last)
    reason = f" — {stop.get('reason', '')}" if stop is not None and stop.get("status") != "success" else ""
    parts.append(f"ended: {ended}{reason}")
    return "; ".join(parts)


def session_history(session: Any) -> list[str]:
    """The history of a session (a :class:`daq.session_file.Session`) as lines of text: the loading order, then one
    line per run — started or resumed when, the resume questions about skipped weights and their answers, the
    weights placed, those skipped, how it ended (done, stopped early by Ctrl-C or the operator, failed, killed).

    Everything comes from the file's run records, stop records and summary: the lines hold text from the file and
    must be escaped where they are shown. An imported table has no history (empty list).
    """
    if getattr(session, "imported", False):
        return []
    runs = list(session.summary["run"].tolist())
    last = max([len(session.runs) - 1, *runs, 0])
    order = [float(w) for i, w in enumerate(session.summary["weight_kg"].tolist()) if i == 0 or
             w != session.summary["weight_kg"].iloc[i - 1] or runs[i] != runs[i - 1]]  # fmt: skip
    ends = [how_run_ended(_run_stop(session, k, last), running=bool(getattr(session, "running", False)) and k == last)
            for k in range(last + 1)]  # fmt: skip
    ctrl_c = sum(e == "stopped early (Ctrl-C)" for e in ends)
    killed = sum(e.startswith("killed") for e in ends)
    lines = [
        f"loading order: {_kg(order)}" if order else "loading order: no block completed",
        f"runs: {last + 1} ({last} resume(s)); interruptions: {ctrl_c} by Ctrl-C, {killed} killed",
    ]
    return lines + [_run_line(session, k, last) for k in range(last + 1)]
