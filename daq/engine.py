"""The acquisition engine: carries out a plan's steps on an instrument link and hands records to writers.

What to do (the plan's steps, :mod:`daq.plan`), who does it (this engine, on an :class:`~daq.link.InstrumentLink`)
and what is kept (writers: the HDF5 file, the live display, replay's in-memory collector) are separate, after
Bluesky, kept synchronous. Acquisition and replay run this same engine; only the link and the writers differ.

A pause (:mod:`daq.pause`: the console's Pause, with a reason) is taken at a block boundary: the block under way is
finished and on disk, the source idle; the pause record goes to the writers that keep it (a ``pause`` method: the
file's run record, the console) when it begins and again when it ends.

Exit guarantees (every path — success, error, Ctrl-C): the link is closed in ``finally`` (``SOUR:SWE:ABOR``, the
source idle) and the stop record is written after it. Each block is handed to the writers — flushed and fsynced
to disk — before the next block starts. Ctrl-C once stops after the current block; twice stops now (the block
under way is discarded, its readings were never complete); while a block is being written, even a second Ctrl-C
waits until the block is on disk.
"""

from __future__ import annotations

import math
import signal
import threading
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

import numpy as np

from contactrig.core.provenance import now_iso
from daq.link import InstrumentLink
from daq.pause import PauseControl, pause_record
from daq.plan import Measure, PlaceWeight
from daq.records import BlockRecord, StopRecord, StopStatus, block_number
from instruments.block import Block
from instruments.transport import Exchange

__all__ = [
    "AcquisitionEngine",
    "Interrupts",
    "OperatorQuit",
    "Prompter",
    "RunOutcome",
    "Writer",
    "answer_yes",
    "format_mean_ohm",
    "format_ohm",
]

Decision = Literal["go", "skip", "quit"]
Prompter = Callable[[PlaceWeight], Decision]


def answer_yes(step: PlaceWeight) -> Decision:
    """The unattended operator (``--yes``): every weight is taken as placed."""
    return "go"


class OperatorQuit(Exception):
    """The operator chose to stop (``q``) or no operator input is available."""


class Writer(Protocol):
    """A consumer of session records."""

    def start(self, start: dict[str, Any], scene_text: str) -> None: ...

    def exchanges(self, exchanges: Sequence[Exchange], block: int) -> None: ...

    def block(self, rec: BlockRecord) -> None: ...

    def stop(self, stop: StopRecord) -> None: ...


class Interrupts:
    """SIGINT policy while a session runs: first Ctrl-C → stop after the block, second → stop now.

    Outside a block (prompt, set-up) any Ctrl-C stops at once; while a block is being written, interrupts are
    deferred until it is on disk. Installed only in the main thread (signal handlers cannot be set elsewhere).
    """

    def __init__(self, notify: Callable[[str], None] | None = None) -> None:
        self.count = 0
        self.phase: Literal["idle", "instrument", "writing"] = "idle"
        self.deferred = False
        self._notify = notify or (lambda msg: None)
        self._previous: Any = None
        self._installed = False

    @property
    def stop_requested(self) -> bool:
        return self.count > 0

    def _handler(self, signum: int, frame: Any) -> None:
        self.count += 1
        if self.phase == "idle":
            self._stop_now()
        if self.count == 1:
            self._notify("Ctrl-C: stopping after this block (press Ctrl-C again to stop now)")
            return
        if self.phase == "instrument":
            self._stop_now()
        self.deferred = True

    def _stop_now(self) -> None:
        # From here the run only winds down (source idle, stop record written): a further Ctrl-C is counted, never
        # raised, so it cannot cut the stop record short. The phase changes before the raise, not after.
        self.phase = "writing"
        raise KeyboardInterrupt

    def enter(self, phase: Literal["idle", "instrument", "writing"]) -> None:
        self.phase = phase
        if phase != "writing" and self.deferred:
            self.deferred = False
            raise KeyboardInterrupt

    def __enter__(self) -> Interrupts:
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self._handler)
            self._installed = True
            if getattr(self._previous, "stop_requested", False):
                # a Ctrl-C before the run began whose KeyboardInterrupt was swallowed on its way (the handler of
                # ``contactrig`` keeps the request): stop before the first block
                self.count = 1
        return self

    def __exit__(self, *exc: object) -> None:
        if self._installed:
            signal.signal(signal.SIGINT, self._previous)
            self._installed = False


@dataclass
class RunOutcome:
    """What a run did: the stop record, the blocks it completed, and the exception that ended it (if any)."""

    stop: StopRecord
    blocks: list[BlockRecord] = field(default_factory=list)
    error: BaseException | None = None
    interrupted: bool = False


@dataclass
class _RunState:
    """What a run has done so far; ``current`` is the block under way (None between blocks)."""

    done: list[BlockRecord] = field(default_factory=list)
    skipped: list[float] = field(default_factory=list)
    status: StopStatus = "success"
    reason: str = ""
    error: BaseException | None = None
    interrupted: bool = False
    current: Measure | None = None
    skip_weight: int | None = None
    pauses: list[dict[str, Any]] = field(default_factory=list)


class AcquisitionEngine:
    """Runs plan steps on ``link`` for ``run`` number ``run`` and hands every record to ``writers``.

    ``settings`` are the instrument pair's block settings (e.g. :class:`instruments.delta.DeltaSettings`), the
    same for every block. ``blocks_planned`` and ``blocks_before`` (already on file, for ``--resume``) only feed
    the counts of the stop record; ``skipped_before`` are weights skipped in an earlier run and kept skipped on
    ``--resume`` (the stop record lists them with this run's skips). ``pause``: the operator's pause requests,
    taken at block boundaries (:mod:`daq.pause`).
    """

    def __init__(
        self,
        link: InstrumentLink,
        settings: object,
        writers: Sequence[Writer],
        *,
        run: int = 0,
        prompter: Prompter = answer_yes,
        interrupts: Interrupts | None = None,
        blocks_planned: int = 0,
        blocks_before: int = 0,
        readings_before: int = 0,
        skipped_before: Sequence[float] = (),
        pause: PauseControl | None = None,
    ) -> None:
        self.link = link
        self.pause = pause
        self.settings = settings
        self.writers = list(writers)
        self.run_number = run
        self.prompter = prompter
        self.interrupts = interrupts or Interrupts()
        self.blocks_planned = blocks_planned
        self.blocks_before = blocks_before
        self.readings_before = readings_before
        self.skipped_before = tuple(float(w) for w in skipped_before)
        self._steps: object = None

    def _emit_exchanges(self, block: int) -> None:
        ex = self.link.take_exchanges()
        if ex:
            for w in self.writers:
                w.exchanges(ex, block)

    def start(self, start: dict[str, Any], scene_text: str) -> None:
        """Hand the start record (and the set-up exchanges so far) to the writers."""
        for w in self.writers:
            w.start(start, scene_text)
        self._emit_exchanges(-1)

    def run(self, steps: Iterable[PlaceWeight | Measure]) -> RunOutcome:
        """Carry out ``steps``; close the link; write the stop record. Never raises: see ``RunOutcome.error``."""
        state = _RunState(skipped=list(self.skipped_before))
        self._steps = steps
        try:
            self._carry_out(steps, state)
        except KeyboardInterrupt:
            state.interrupted = True
            state.status = "aborted"
            state.reason = _interrupt_reason(state, self.interrupts.count)
        except OperatorQuit as exc:
            state.status, state.reason = "aborted", str(exc)
        except Exception as exc:
            state.status, state.error = "failed", exc
            state.reason = f"{type(exc).__name__}{_where(state.current)}: {exc}"
        finally:
            stop = self._finish(state)
        return RunOutcome(stop=stop, blocks=state.done, error=state.error, interrupted=state.interrupted)

    def _carry_out(self, steps: Iterable[PlaceWeight | Measure], state: _RunState) -> None:
        """The steps in order; a first Ctrl-C ends the run before the next step."""
        intr = self.interrupts
        for step in steps:
            intr.enter("idle")
            if self._stopping(state):
                return
            self._pause_point(state)
            if self._stopping(state):  # a Ctrl-C while the pause record was written
                return
            if isinstance(step, PlaceWeight):
                self._place(step, state)
            elif step.weight_index != state.skip_weight:
                self._measure(step, state)
        intr.enter("idle")
        intr.phase = "writing"  # the plan is done: from here only the stop record is written
        state.reason = (
            f"all {self.blocks_planned} planned blocks done"
            if not state.skipped
            else f"plan done; weights skipped by the operator: {', '.join(f'{w:g} kg' for w in state.skipped)}"
        )
        # steps that decide themselves when to end (an adaptive session, analysis.sequential) say why
        state.reason = str(getattr(steps, "stop_reason", "") or state.reason)

    def _stopping(self, state: _RunState) -> bool:
        """Whether a Ctrl-C asked the run to stop (then the stop's reason is set and the run winds down)."""
        if not self.interrupts.stop_requested:
            return False
        self.interrupts.phase = "writing"  # winding down: a second Ctrl-C now must not hit the stop record
        state.status, state.reason = "aborted", _after_block_reason(state.done)
        state.interrupted = True
        return True

    def _pause_point(self, state: _RunState) -> None:
        """A block boundary: when the operator asked for a pause, record it and wait for the resume. The source is
        idle here (the driver ends every block with it idle, and nothing is armed between blocks); a Ctrl-C while
        waiting stops the run as at any idle moment. The pause record is written as a block is: a Ctrl-C meanwhile
        waits until it is on disk (then the run stops instead of waiting), so it never cuts the run record short."""
        request = self.pause.take() if self.pause is not None else None
        if request is None or self.pause is None:
            return
        intr = self.interrupts
        last = block_number(state.done[-1].block) if state.done else 0
        record = pause_record(request["reason"], request["who"], last)
        state.pauses.append(record)
        intr.enter("writing")
        self._tell_pauses(state)
        intr.enter("idle")  # a second Ctrl-C during the write stops here
        if intr.stop_requested:
            return
        who = self.pause.wait()
        intr.enter("writing")
        record.update(resumed=now_iso(), resumed_by=who)
        self._tell_pauses(state)
        intr.enter("idle")

    def _tell_pauses(self, state: _RunState) -> None:
        """This run's pause records to every writer that keeps them (a ``pause`` method)."""
        for w in self.writers:
            tell = getattr(w, "pause", None)
            if callable(tell):
                tell([dict(p) for p in state.pauses])

    def _place(self, step: PlaceWeight, state: _RunState) -> None:
        """Ask the operator to place the weight: go on, skip its blocks, or stop."""
        decision = self.prompter(step)
        if decision == "quit":
            raise OperatorQuit(f"operator stopped the session at weight {step.weight_kg:g} kg")
        if decision == "skip":
            state.skipped.append(step.weight_kg)
            state.skip_weight = step.weight_index
            return
        state.skip_weight = None
        self.link.place_weight(step.weight_kg)

    def _measure(self, step: Measure, state: _RunState) -> None:
        """One block: run it on the instruments, then hand it to every writer before anything else happens."""
        intr = self.interrupts
        state.current = step
        started = now_iso()
        # the contact this block measures: its own, or that of the seating it repeats at (the weight not lifted)
        self.link.prepare_block(step.block if step.seating_block is None else step.seating_block)
        intr.enter("instrument")
        block = self.link.run_block(self.settings)
        intr.enter("writing")
        rec = self._record(step, block, started)
        for w in self.writers:
            w.block(rec)
        state.done.append(rec)
        state.current = None
        intr.enter("idle")

    def _finish(self, state: _RunState) -> StopRecord:
        """Close the link, then write the stop record; neither may be cut short by another Ctrl-C."""
        self.interrupts.phase = "writing"
        close_error = self._close(state.current)
        if close_error is not None and state.error is None:
            state.status, state.error = "failed", close_error
            state.reason = f"closing the instrument failed: {close_error}"
        stop = StopRecord(
            status=state.status,
            reason=state.reason,
            stopped=now_iso(),
            blocks_planned=self.blocks_planned,
            blocks_done=self.blocks_before + len(state.done),
            readings_done=self.readings_before + sum(int(r.reading.size) for r in state.done),
            weights_skipped=tuple(state.skipped),
            adaptive=self.adaptive_record(),
        )
        stop_error = None
        for w in self.writers:
            try:
                w.stop(stop)
            except Exception as exc:  # a full disk must not hide the original error
                stop_error = stop_error or exc
        self.interrupts.phase = "idle"
        if stop_error is not None and state.error is None:
            state.error = stop_error
        return stop

    def adaptive_record(self) -> dict[str, Any] | None:
        """The record of the steps, when they keep one (an adaptive session's suggestions), for the stop record."""
        record = getattr(self._steps, "record", None)
        if not callable(record):
            return None
        try:
            return dict(record())
        except Exception as exc:  # the stop record is written whatever: it says the record failed
            return {"error": f"{type(exc).__name__}: {exc}"}

    def _close(self, current: Measure | None) -> BaseException | None:
        err = None
        try:
            self.link.close()
        except Exception as exc:
            err = exc
        # exchanges of a block that did not complete stay tagged with its number (no summary row refers to them)
        try:
            self._emit_exchanges(current.block if current is not None else -1)
        except Exception as exc:  # e.g. a full disk: must not hide how the run ended
            err = err or exc
        return err

    def _record(self, step: Measure, block: Block, started: str) -> BlockRecord:
        ex = self.link.take_exchanges()
        resistance = np.asarray(block.resistance_ohm(), dtype=np.float64)
        return BlockRecord(
            block=step.block,
            run=self.run_number,
            weight_kg=float(step.weight_kg),
            repeat=int(step.repeat),
            unit=str(block.unit),
            reading=np.asarray(block.readings, dtype=np.float64),
            time_s=np.asarray(block.timestamps_s, dtype=np.float64),
            resistance_ohm=resistance,
            valid=np.isfinite(resistance),
            started=started,
            exchanges=tuple(ex),
            compliance=bool(getattr(block, "compliance", False)),  # pairs without a compliance flag: never
            adaptive=step.adaptive,
        )


def _where(current: Measure | None) -> str:
    if current is None:
        return ""
    return f" in the block at {current.weight_kg:g} kg, repeat {current.repeat} (block {block_number(current.block)})"


def _interrupt_reason(state: _RunState, count: int) -> str:
    current = state.current
    if current is not None:
        return (
            f"interrupted (Ctrl-C twice) during the block at {current.weight_kg:g} kg, repeat "
            f"{current.repeat} (block {block_number(current.block)}); that block was discarded, every completed one "
            "is kept"
        )
    if count >= 1 and state.done:
        return _after_block_reason(state.done)
    return "interrupted (Ctrl-C)"


def _after_block_reason(done: list[BlockRecord]) -> str:
    if not done:
        return "interrupted (Ctrl-C) before the first block completed"
    last = done[-1]
    return (
        f"interrupted (Ctrl-C): stopped after the block at {last.weight_kg:g} kg, repeat {last.repeat} "
        f"(block {block_number(last.block)})"
    )


def format_live_line(rec: BlockRecord, index: int, total: int) -> str:
    """``block 3/48  5.44 kg  repeat 3  R = 8.0913 mΩ ± 12.3 µΩ (SEM, n = 100)`` — the live line: the block's number
    (:func:`daq.records.block_number`) of ``total`` planned; ``index``, the blocks taken so far, is added when it
    differs (a skipped weight, a resumed session). A block taken in compliance says so and shows no value."""
    number = block_number(rec.block)
    where = f"block {number}/{total}" + (f" ({index} taken)" if index != number else "")
    st = rec.stats
    if rec.compliance:
        value = f"COMPLIANCE: source could not drive the current, block excluded ({rec.reading.size} readings)"
        return f"{where}  {rec.weight_kg:g} kg  repeat {rec.repeat}  {value}"
    if st.n == 0:
        value = "no valid readings"
    else:
        sem = "" if math.isnan(st.sem) else f" ± {format_ohm(st.sem)}"
        value = f"R = {format_mean_ohm(st.mean)}{sem} (SEM, n = {st.n})"
    invalid = f", {st.n_invalid} invalid" if st.n_invalid else ""
    return f"{where}  {rec.weight_kg:g} kg  repeat {rec.repeat}  {value}{invalid}"


def format_mean_ohm(x: float) -> str:
    """A block's mean resistance [Ω] as the live line prints it: mΩ with four decimals (``8.0913 mΩ``)."""
    return f"{x * 1e3:.4f} mΩ"


def format_ohm(x: float) -> str:
    """A resistance [Ω] with an SI prefix chosen so that three significant digits show (e.g. ``5.12 nΩ``): the
    live line's SEM, and the console's (one rule for the terminal and the page)."""
    for factor, unit in ((1.0, "Ω"), (1e-3, "mΩ"), (1e-6, "µΩ"), (1e-9, "nΩ")):
        if abs(x) >= factor:
            return f"{x / factor:.3g} {unit}"
    return f"{x / 1e-12:.3g} pΩ"
