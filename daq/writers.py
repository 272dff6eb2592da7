"""Consumers of session records: the HDF5 file, the live display, and an in-memory collector (replay, tests)."""

from __future__ import annotations

import errno
import shutil
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from daq.engine import format_live_line
from daq.errors import SessionWriteError
from daq.records import BlockRecord, StopRecord, block_number
from daq.session_file import SessionFile
from instruments.transport import Exchange

__all__ = ["FileWriter", "LiveDisplay", "MemoryWriter"]


class FileWriter:
    """Writes records to a :class:`~daq.session_file.SessionFile`; each block is flushed and fsynced.

    If a block cannot be written (full disk, lost drive), its data are saved to a rescue ``.npz`` next to the
    session (or in a private temporary folder; see :func:`_rescue`) and the error says where; blocks already on
    file stay there.
    """

    def __init__(self, session_file: SessionFile) -> None:
        self.file = session_file
        #: set after a failed write: nothing more goes into the file, so what is already there stays readable
        self.failed = False
        self._run_record: dict[str, Any] = {}

    def start(self, start: dict[str, Any], scene_text: str) -> None:
        self.file.write_start(start, scene_text)
        self._run_record = dict(start)

    def pause(self, pauses: list[dict[str, Any]]) -> None:
        """This run's pause records (:mod:`daq.pause`) into its run record, on disk before the session waits."""
        if not self.failed:
            self.file.write_run({**self._run_record, "pauses": pauses})

    def exchanges(self, exchanges: Sequence[Exchange], block: int) -> None:
        if self.failed:
            return
        try:
            self.file.append_exchanges(exchanges, block=block)
        except OSError:
            self.failed = True
            raise

    def block(self, rec: BlockRecord) -> None:
        if self.failed:
            raise SessionWriteError(errno.EIO, f"{self.file.path} failed earlier; {_rescue(rec, self.file.path)}")
        try:
            self.file.append_block(rec)
        except OSError as exc:  # SessionWriteError / FileLockingError from the session file
            self.failed = True
            raise SessionWriteError(exc.errno or errno.EIO, f"{exc}; {_rescue(rec, self.file.path)}") from exc

    def stop(self, stop: StopRecord) -> None:
        if self.failed:
            return  # no stop record: readers will say the session is incomplete, which it is
        self.file.write_stop(stop)


def _rescue(rec: BlockRecord, path: Path) -> str:
    """Save a block the session file could not take, and say where it went.

    Next to the session (``<stem>.block<N>.rescue.npz``), or — when that folder refuses it (the full disk itself) —
    in a private folder of our own (``mkdtemp``: mode 0700, unpredictable name) under the system's temporary folder.
    The file is created exclusively and never through a symbolic link (``O_CREAT | O_EXCL | O_NOFOLLOW``): an
    existing name gets a numbered sibling, a pre-placed symlink is never followed nor overwritten.
    """
    errors = []
    for folder in (path.parent, None):
        try:
            target = _rescue_into(rec, path, folder)
        except OSError as exc:
            errors.append(f"{folder or 'a private temporary folder'}: {exc.strerror or exc}")
            continue
        return f"block {block_number(rec.block)} was saved to {target}; every earlier block is safe in the session file"
    return f"block {block_number(rec.block)} could not be rescued either ({'; '.join(errors)})"


def _rescue_into(rec: BlockRecord, path: Path, folder: Path | None) -> Path:
    import os

    where = folder if folder is not None else Path(tempfile.mkdtemp(prefix="contactrig-rescue-"))
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_BINARY", 0)
    for k in range(100):
        target = where / f"{path.stem}.block{block_number(rec.block)}{f'.{k}' if k else ''}.rescue.npz"
        try:
            fd = os.open(target, flags, 0o600)
        except FileExistsError:  # also a symlink planted under this name: never followed
            continue
        try:
            with os.fdopen(fd, "wb") as fh:
                np.savez(
                    fh,
                    weight_kg=rec.weight_kg,
                    repeat=rec.repeat,
                    reading=rec.reading,
                    time_s=rec.time_s,
                    resistance_ohm=rec.resistance_ohm,
                    valid=rec.valid,
                    started=rec.started,
                    unit=rec.unit,
                )
                fh.flush()
                os.fsync(fh.fileno())
        except OSError:
            target.unlink(missing_ok=True)
            raise
        return target
    raise FileExistsError(errno.EEXIST, f"{where} holds 100 rescue files of block {block_number(rec.block)} already")


class MemoryWriter:
    """Keeps every record in memory."""

    def __init__(self) -> None:
        self.start_record: dict[str, Any] | None = None
        self.blocks: list[BlockRecord] = []
        self.exchange_log: list[tuple[int, Exchange]] = []
        self.stop_record: StopRecord | None = None

    def start(self, start: dict[str, Any], scene_text: str) -> None:
        self.start_record = start

    def exchanges(self, exchanges: Sequence[Exchange], block: int) -> None:
        self.exchange_log.extend((block, e) for e in exchanges)

    def block(self, rec: BlockRecord) -> None:
        self.blocks.append(rec)

    def stop(self, stop: StopRecord) -> None:
        self.stop_record = stop


class LiveDisplay:
    """Progress bar (tqdm) with the live line — weight, mean R, SEM — on a terminal; one plain line per block
    otherwise (logs, pipes, tests).

    The bar's ETA (:attr:`eta_s`) counts block time only: the time spent waiting for the operator (the prompt, run
    inside :meth:`paused`) is left out of each block's duration, so a long pause to change weights does not inflate
    the estimate; tqdm's own remaining-time field (which would include it) is not shown. ``clock``: seconds (tests).
    """

    #: the bar without tqdm's own remaining time: the postfix carries the block-time ETA
    BAR_FORMAT = "{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]"

    def __init__(
        self,
        total: int,
        done: int = 0,
        stream: TextIO | None = None,
        quiet: bool = False,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.total = total
        self.index = done
        self.stream = stream if stream is not None else sys.stderr
        self.quiet = quiet
        self._clock = clock
        self._mark = clock()  # end of the last block (or the start)
        self._waited = 0.0  # time spent waiting for the operator since then
        self.block_times_s: list[float] = []
        self._bar: Any = None
        if not quiet and _isatty(self.stream):
            from tqdm import tqdm

            width = shutil.get_terminal_size((100, 24)).columns  # a pty reporting 0 columns would hide the bar
            self._bar = tqdm(
                total=total, initial=done, unit="block", file=self.stream, ncols=width, bar_format=self.BAR_FORMAT
            )

    @property
    def eta_s(self) -> float | None:
        """Time still needed (s): the median block time (operator waits left out) × blocks left; None before the
        first block."""
        if not self.block_times_s:
            return None
        return statistics.median(self.block_times_s[-20:]) * max(self.total - self.index, 0)

    def message(self, text: str) -> None:
        if self.quiet:
            return
        if self._bar is not None:
            self._bar.write(text, file=self.stream)
        else:
            print(text, file=self.stream, flush=True)

    @contextmanager
    def paused(self) -> Iterator[None]:
        """Clear the bar while the operator is asked something; draw it again afterwards. The time spent here is
        not block time (see :attr:`eta_s`)."""
        t0 = self._clock()
        if self._bar is not None:
            self._bar.clear()
        try:
            yield
        finally:
            self._waited += max(self._clock() - t0, 0.0)
            if self._bar is not None:
                self._bar.refresh()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def start(self, start: dict[str, Any], scene_text: str) -> None:
        pass

    def exchanges(self, exchanges: Sequence[Exchange], block: int) -> None:
        pass

    def block(self, rec: BlockRecord) -> None:
        now = self._clock()
        self.block_times_s.append(max(now - self._mark - self._waited, 0.0))
        self._mark, self._waited = now, 0.0
        self.index += 1
        line = format_live_line(rec, self.index, self.total)
        if self._bar is not None:
            eta = self.eta_s
            self._bar.update(1)
            self._bar.set_postfix_str(f"{line.split('  ', 1)[1]}  ETA {_duration(eta or 0.0)} (blocks)", refresh=True)
        elif not self.quiet:
            print(line, file=self.stream, flush=True)

    def stop(self, stop: StopRecord) -> None:
        self.close()
        hint = "" if stop.status == "success" else f" — {stop.blocks_done} block(s) on file; --resume continues"
        self.message(f"session {stop.status}: {stop.reason}{hint}")


def _duration(seconds: float) -> str:
    """``1 h 02 min``, ``3 min 05 s``, ``42 s``."""
    s = round(seconds)
    if s >= 3600:
        return f"{s // 3600} h {s % 3600 // 60:02d} min"
    if s >= 60:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s} s"


def _isatty(stream: TextIO) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False
