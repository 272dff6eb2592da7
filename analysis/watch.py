"""The live view of a bench session: a figure and a status line that follow the blocks as they land.

Two panels — R against weight with every repeat (M1…Mn, colour and marker as in every figure) and the mean ± 1 SEM
of the repeats per weight (seed Fig. 9 as it grows, the error-bar convention of every figure), and the
current block's readings against time — and a status line: state, weight, block done/planned, ETA, invalid
readings, blocks taken in compliance. One :class:`LiveState` feeds both, built either from a session file
(:func:`state_from_session`, what ``contactrig watch`` reads from another process) or from the acquisition's own
block records (:class:`LiveView`, ``contactrig acquire --live``).

- :func:`watch` follows a file: reads it with :func:`daq.load_session` whenever it changes (bounded time, a file
  being written is read without its lock and every block checked), redraws, and returns once nobody writes it any
  more (finished, or its writer was killed). ``png`` writes a snapshot (atomically: a viewer never sees half a
  PNG) instead of a window, for SSH and tests.
- :class:`LiveView` is one more writer of the acquisition. It never stops, delays or corrupts the session: the
  drawing runs in a process of its own (spawned on the first block), which owns matplotlib; a block only puts a
  small update (its row and readings) on a bounded queue without ever waiting (a lagging view gets the updates
  merged). Any failure of the view (no display, a closed window, a bug, its process killed or stuck) is reported
  once and turns the view off. :class:`Guarded` gives the same promise to any other optional writer.

matplotlib is imported only when something is drawn (by ``watch``, or in the view's process); snapshots use the Agg
canvas without pyplot (no display needed).
"""

from __future__ import annotations

import math
import os
import queue
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from datetime import datetime
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from analysis.resistance import resistance_unit
from contactrig.core.text import escape_terminal
from daq.records import block_number

__all__ = [
    "BlockRow",
    "Guarded",
    "LiveState",
    "LiveView",
    "NoDisplayError",
    "ViewProcessError",
    "draw_state",
    "render_png",
    "state_from_session",
    "status_line",
    "watch",
]

_NON_INTERACTIVE = {"agg", "pdf", "ps", "svg", "pgf", "cairo", "template", "module://matplotlib_inline.backend_inline"}


class NoDisplayError(RuntimeError):
    """A window was asked for where matplotlib has no interactive backend (no display: SSH, CI)."""


@dataclass(frozen=True)
class BlockRow:
    """One completed block as the view needs it (``started``: seconds since the epoch, NaN when unknown)."""

    block: int
    weight_kg: float
    repeat: int
    mean_ohm: float
    n: int
    n_invalid: int
    compliance: bool
    started: float


@dataclass(frozen=True)
class LiveState:
    """Everything one frame shows: the blocks so far, the last block's readings, and the session's state."""

    name: str
    status: str
    rows: tuple[BlockRow, ...] = ()
    blocks_planned: int | None = None
    current_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    current_ohm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    current_valid: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    note: str = ""

    @property
    def blocks_done(self) -> int:
        return len(self.rows)

    @property
    def compliant_blocks(self) -> list[int]:
        """The numbers (1-based, :func:`daq.records.block_number`) of the blocks taken in compliance."""
        return [block_number(r.block) for r in self.rows if r.compliance]

    @property
    def n_invalid(self) -> int:
        return sum(r.n_invalid for r in self.rows if not r.compliance)

    def eta_s(self, now: float | None = None) -> float | None:
        """Seconds until the plan is done: the median time between block starts × blocks left (None: unknown)."""
        if self.blocks_planned is None or self.status != "running":
            return None
        left = self.blocks_planned - self.blocks_done
        if left <= 0:
            return 0.0
        starts = np.array([r.started for r in self.rows], dtype=float)
        starts = starts[np.isfinite(starts)]
        if starts.size < 2:
            return None
        step = float(np.median(np.diff(np.sort(starts))))
        since_last = max(0.0, (time.time() if now is None else now) - float(starts.max()))
        return max(0.0, left * step - since_last)


# ---- the status line -----------------------------------------------------------------------------------------------
def _clock(seconds: float) -> str:
    s = round(seconds)
    h, rest = divmod(s, 3600)
    return f"{h}:{rest // 60:02d}:{rest % 60:02d}" if h else f"{rest // 60}:{rest % 60:02d}"


def status_line(state: LiveState, now: float | None = None) -> str:
    """``s.h5: RUNNING  10.526 kg repeat 2  block 4/6  ETA 0:12  0 invalid  compliance: none`` — plain text;
    escape it for where it is shown (the file name comes from the user)."""
    planned = "?" if state.blocks_planned is None else str(state.blocks_planned)
    parts = [f"{state.name}: {state.status.upper()}"]
    if state.rows:
        last = state.rows[-1]
        parts.append(f"{last.weight_kg:g} kg repeat {last.repeat}")
        number = block_number(last.block)  # the last block's number, as the live line and the exports call it
        taken = f" ({state.blocks_done} taken)" if state.blocks_done != number else ""
        parts.append(f"block {number}/{planned}{taken}")
    else:
        parts.append(f"no block yet/{planned}")
    eta = state.eta_s(now)
    if state.status == "running":
        parts.append(f"ETA {_clock(eta)}" if eta is not None else "ETA –")
    parts.append(f"{state.n_invalid} invalid")
    comp = state.compliant_blocks
    parts.append(f"COMPLIANCE in block(s) {', '.join(map(str, comp))} (excluded)" if comp else "compliance: none")
    if state.note:
        parts.append(state.note)
    return "  ".join(parts)


# ---- states --------------------------------------------------------------------------------------------------------
def _epoch(text: Any) -> float:
    try:
        return datetime.fromisoformat(str(text).strip()).timestamp()
    except ValueError:
        return math.nan


def _planned(start: Any) -> int | None:
    plan = start.get("plan") if isinstance(start, dict) else None
    value = plan.get("blocks_planned") if isinstance(plan, dict) else None
    return int(value) if isinstance(value, int | float) and not isinstance(value, bool) and value >= 0 else None


def state_from_session(session: Any) -> LiveState:
    """The frame of a loaded :class:`daq.session_file.Session` (running, finished or killed)."""
    s = session.summary
    rows = tuple(
        BlockRow(int(b), float(w), int(r), float(m), int(n), int(ni), bool(c), _epoch(t))
        for b, w, r, m, n, ni, c, t in zip(
            s["block"], s["weight_kg"], s["repeat"], s["mean_ohm"], s["n"], s["n_invalid"], s["compliance"],
            s["started"], strict=True,
        )
    )  # fmt: skip
    state = LiveState(Path(session.path).name, session.status, rows, _planned(session.start),
                      note=_adaptive_note(session))  # fmt: skip
    if rows:
        rd = session.readings
        cur = rd[rd["block"] == rows[-1].block]
        state = replace(
            state,
            current_time_s=cur["time_s"].to_numpy(dtype=float),
            current_ohm=cur["resistance_ohm"].to_numpy(dtype=float),
            current_valid=cur["valid"].to_numpy(dtype=bool),
        )
    return state


def _adaptive_note(session: Any) -> str:
    """An adaptive session's evidence and progress (:func:`analysis.adaptive_session.session_evidence`); a failure
    to compute it is said in the note, never raised (the view goes on)."""
    if not isinstance(session.start, dict) or "adaptive" not in session.start:
        return ""
    try:
        from analysis.adaptive_session import session_evidence

        return session_evidence(session)
    except Exception as exc:
        return f"(evidence not available: {type(exc).__name__}: {exc})"


# ---- drawing -------------------------------------------------------------------------------------------------------
def _plain(text: str) -> str:
    """Text for matplotlib: escaped for the terminal's sake and with ``$`` escaped, so no mathtext is parsed."""
    return escape_terminal(text).replace("$", r"\$")


#: Up to this many repeats get a legend entry each (M1…Mn); more share one entry.
_LEGEND_REPEATS = 12


def _draw_weights(ax: Any, state: LiveState) -> None:
    from analysis.figure_style import MEASURED_COLOUR, repeat_style

    ok = [r for r in state.rows if not r.compliance and math.isfinite(r.mean_ohm)]
    k, unit = resistance_unit([r.mean_ohm for r in ok] or [1e-3])
    w = np.array([r.weight_kg for r in ok])
    v = np.array([r.mean_ohm for r in ok]) * k
    repeats = sorted({r.repeat for r in ok})
    for j, rep in enumerate(repeats):
        sel = np.array([r.repeat == rep for r in ok])
        # M1…Mn by position, as Fig. 9 names a session's repeats (analysis.figures.repeat_names)
        label = f"M{j + 1}" if len(repeats) <= _LEGEND_REPEATS else (f"repeats M1…M{len(repeats)}" if j == 0 else None)
        ax.plot(w[sel], v[sel], "-", **repeat_style(j), lw=0.8, ms=3, alpha=0.85, label=label)
    weights = sorted(set(w.tolist()))
    means, sems = [], []
    for x in weights:
        at = v[w == x]
        means.append(float(np.mean(at)))
        sems.append(float(np.std(at, ddof=1) / math.sqrt(at.size)) if at.size > 1 else 0.0)
    if weights:
        ax.errorbar(weights, means, yerr=sems, fmt="s-", color=MEASURED_COLOUR, capsize=3, label="mean ± 1 SEM",
                    zorder=3)  # fmt: skip
    bad = [r.weight_kg for r in state.rows if r.compliance]
    if bad:
        ax.plot(bad, [0.0] * len(bad), "x", color="#d62728", ms=8, mew=2, label="compliance (excluded)")
    ax.set(xlabel="weight W [kg]", ylabel=f"resistance R [{unit}]", title="R against weight")
    ax.set_ylim(bottom=0)
    if ok or bad:
        ax.legend(fontsize=7.5, ncols=2 if len(repeats) > 6 else 1)


def _draw_current(ax: Any, state: LiveState) -> None:
    t, r, valid = state.current_time_s, state.current_ohm, state.current_valid
    k, unit = resistance_unit(r[valid] if valid.any() else [1e-3])
    if t.size != r.size or valid.size != r.size:  # unknown reading times (or a malformed frame): by index
        t, valid = np.arange(r.size, dtype=float), np.resize(valid, r.size).astype(bool)
    t = np.where(np.isfinite(t), t, np.arange(t.size, dtype=float))
    some_invalid = bool((~valid).any())
    ax.plot(t[valid], r[valid] * k, ".-", color="#1f77b4", lw=0.6, ms=4, label="valid" if some_invalid else "_valid")
    if some_invalid:
        ax.plot(t[~valid], np.zeros(int((~valid).sum())), "x", color="#d62728", label="invalid")
        ax.legend(fontsize=7.5)
    last = state.rows[-1] if state.rows else None
    title = f"block {block_number(last.block)}: {last.weight_kg:g} kg, repeat {last.repeat}" if last else "no block yet"
    ax.set(xlabel="time t [s]", ylabel=f"resistance R [{unit}]", title=_plain(title))
    ax.ticklabel_format(axis="y", useOffset=False)


def draw_state(fig: Any, state: LiveState, now: float | None = None) -> None:
    """Draw ``state`` on the matplotlib figure ``fig`` (cleared first): two panels and the status line."""
    fig.clear()
    left, right = fig.subplots(1, 2)
    _draw_weights(left, state)
    _draw_current(right, state)
    fig.suptitle(_plain(status_line(state, now)), fontsize=8.0)


def _new_figure() -> Any:
    import matplotlib
    from matplotlib.figure import Figure

    from analysis.figure_style import RC

    matplotlib.rcParams.update(RC)
    return Figure(figsize=(10.0, 4.2), layout="constrained")


def render_png(state: LiveState, path: str | Path, *, force: bool = True, fig: Any = None) -> Path:
    """Draw ``state`` to the PNG ``path`` atomically (Agg, no pyplot, no display); returns the path."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from contactrig.core.files import atomic_write

    fig = fig if fig is not None else _new_figure()
    FigureCanvasAgg(fig)
    draw_state(fig, state)
    from analysis.snapshot import SNAPSHOT_METADATA

    with atomic_write(path, force=force) as tmp:
        fig.savefig(tmp, format="png", dpi=90, metadata=SNAPSHOT_METADATA)  # marked: a later run may rewrite it
    return Path(path)


class _Window:
    """A pyplot window (the only place pyplot is used). Raises :class:`NoDisplayError` without a display."""

    def __init__(self) -> None:
        import matplotlib
        import matplotlib.pyplot as plt  # picks a GUI backend when there is a display, else Agg

        if str(matplotlib.get_backend()).lower() in _NON_INTERACTIVE:
            raise NoDisplayError(
                f"no display for a window (matplotlib backend {matplotlib.get_backend()}): use --png PATH for a "
                "snapshot file instead"
            )
        from analysis.figure_style import RC

        matplotlib.rcParams.update(RC)
        self.plt = plt
        self.fig = plt.figure(figsize=(10.0, 4.2), layout="constrained")
        if self.fig.canvas.manager is not None:
            self.fig.canvas.manager.set_window_title("contactrig watch")
        plt.show(block=False)

    @property
    def open(self) -> bool:
        return bool(self.plt.fignum_exists(self.fig.number))

    def draw(self, state: LiveState) -> None:
        if not self.open:
            raise RuntimeError("the window was closed")
        draw_state(self.fig, state)
        self.fig.canvas.draw_idle()
        self.fig.canvas.flush_events()

    def wait(self, seconds: float) -> None:
        self.plt.pause(seconds)

    def show_until_closed(self) -> None:
        if self.open:
            self.plt.show(block=True)


# ---- following a file ----------------------------------------------------------------------------------------------
def _load_state(path: Path, previous: LiveState | None) -> LiveState:
    """The file's state; a read failure while a writer is busy keeps the previous frame with a note."""
    import warnings

    from daq.session_file import load_session

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return state_from_session(load_session(path))
    except Exception as exc:
        if previous is None or previous.status != "running":
            raise
        return replace(previous, note=f"(last read failed: {str(exc).splitlines()[0] if str(exc) else exc})")


def watch(
    path: str | Path,
    *,
    png: str | Path | None = None,
    every: float = 2.0,
    force: bool = False,
    once: bool = False,
    stream: TextIO | None = None,
    max_seconds: float | None = None,
    keep_open: bool = True,
) -> LiveState:
    """Follow the session file ``path`` until nobody writes it (or ``once``, or ``max_seconds``); returns the last
    frame. ``png``: rewrite that snapshot at most every ``every`` seconds instead of a window (an existing file is
    refused unless ``force`` or it is a snapshot an earlier run wrote: :mod:`analysis.snapshot`); a window stays
    open on the finished session until closed (``keep_open``). The status line goes to ``stream`` (default stderr)
    whenever it changes. Without a display (and no ``png``) the status text is all there is: it goes to ``stream``
    (default stdout), with a note on stderr."""
    from analysis.snapshot import check_snapshot_path

    p = Path(path)
    if png is not None:
        check_snapshot_path(png, force=force)
    state = _load_state(p, None)  # a missing or unreadable file is the command's error, before any window opens
    window = None if png is not None else _window_or_headless()
    headless = png is None and window is None
    out = stream if stream is not None else sys.stdout if headless else sys.stderr
    deadline = None if max_seconds is None else time.monotonic() + max_seconds
    fig = _new_figure() if png is not None else None
    shown = ""
    while True:
        if png is not None:
            render_png(state, png, force=True, fig=fig)
        elif window is not None:
            window.draw(state)
        line = escape_terminal(status_line(state))
        if line != shown:
            print(line, file=out, flush=True)
            shown = line
        if once or state.status != "running" or (deadline is not None and time.monotonic() >= deadline):
            break
        _pause(window, every)
        if window is not None and not window.open:
            return state  # closed by the operator: that is the request to stop
        # read again even when the file has not changed: a writer that was killed changes nothing in the file,
        # only whether anybody holds it (running → incomplete)
        state = _load_state(p, state)
    if window is not None and keep_open:
        window.show_until_closed()
    return state


def _window_or_headless() -> _Window | None:
    """A window, or None (said on stderr) where there is no display: the status text is then the output."""
    try:
        return _Window()
    except NoDisplayError as exc:
        print(f"contactrig watch: {exc}; printing the status only", file=sys.stderr, flush=True)
        return None


def _pause(window: _Window | None, seconds: float) -> None:
    if window is not None:
        window.wait(seconds)
    else:
        time.sleep(seconds)


# ---- inside the acquisition ----------------------------------------------------------------------------------------
class ViewProcessError(RuntimeError):
    """The view's process ended without saying why (killed, crashed) or did not draw its last frame in time."""


def _reason(exc: BaseException) -> str:
    """``Type: first line of the message`` — how a failure of the view is reported."""
    return f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}".rstrip(": ")


class _OffOnce:
    """Reports a failure once and remembers that the view is off."""

    def __init__(self, what: str, stream: TextIO | None) -> None:
        self.what = what
        self.stream = stream
        self.off = False
        self.reason = ""

    def fail(self, exc: BaseException) -> None:
        self.report(_reason(exc))

    def report(self, reason: str) -> None:
        if self.off:
            return
        self.off = True
        self.reason = reason
        try:
            print(
                f"{self.what} off: {escape_terminal(self.reason)} — the acquisition goes on",
                file=self.stream if self.stream is not None else sys.stderr,
                flush=True,
            )
        except Exception:  # a closed stream: nothing more to say
            pass


class Guarded:
    """Wraps an optional writer: its first exception is reported once and turns it off; the acquisition and the
    other writers never see it. (The session file itself is never wrapped: its failures must stop the session.)"""

    def __init__(self, writer: Any, what: str = "live view", stream: TextIO | None = None) -> None:
        self.writer = writer
        self._state = _OffOnce(what, stream)

    @property
    def off(self) -> bool:
        return self._state.off

    def _call(self, name: str, *args: Any) -> None:
        if self._state.off:
            return
        try:
            getattr(self.writer, name)(*args)
        except Exception as exc:
            self._state.fail(exc)

    def start(self, start: dict[str, Any], scene_text: str) -> None:
        self._call("start", start, scene_text)

    def exchanges(self, exchanges: Sequence[Any], block: int) -> None:
        self._call("exchanges", exchanges, block)

    def block(self, rec: Any) -> None:
        self._call("block", rec)

    def pause(self, pauses: list[dict[str, Any]]) -> None:
        """A pause's records (:mod:`daq.pause`), to a writer that keeps them."""
        if callable(getattr(self.writer, "pause", None)):
            self._call("pause", pauses)

    def stop(self, stop: Any) -> None:
        self._call("stop", stop)


# -- the view's process: owns matplotlib, takes small updates, draws -------------------------------------------------
_Readings = tuple[np.ndarray, np.ndarray, np.ndarray]  # time_s, resistance_ohm, valid of the last block


@dataclass(frozen=True)
class _Spec:
    """What the view's process is to draw and where: ``draw`` (tests) if given, else the PNG ``png`` through
    ``render`` (:func:`render_png` as the acquiring process knew it), else a window."""

    name: str
    blocks_planned: int | None
    every: float
    png: Path | None = None
    draw: Callable[[LiveState], None] | None = None
    render: Callable[..., Any] | None = None


@dataclass(frozen=True)
class _Update:
    """The blocks since the previous update, the last block's readings (None: unchanged) and the session's state;
    ``final``: the session has ended, draw this and end."""

    rows: tuple[BlockRow, ...]
    current: _Readings | None
    status: str
    final: bool = False


def _apply(state: LiveState, update: _Update) -> LiveState:
    state = replace(state, rows=(*state.rows, *update.rows), status=update.status)
    if update.current is not None:
        t, r, valid = update.current
        state = replace(state, current_time_s=t, current_ohm=r, current_valid=valid)
    return state


def _get(updates: Any, timeout: float) -> _Update | None:
    try:
        return updates.get(timeout=timeout) if timeout > 0 else updates.get_nowait()
    except queue.Empty:
        return None


class _Painter:
    """The drawing side, in the view's process: opens the window (:class:`NoDisplayError` without a display) or
    prepares the figure, waits for updates (keeping a window responsive) and draws frames."""

    def __init__(self, spec: _Spec) -> None:
        self.spec = spec
        self.window = _Window() if spec.draw is None and spec.png is None else None
        self.fig = _new_figure() if spec.draw is None and spec.png is not None else None

    def take(self, updates: Any) -> list[_Update]:
        """The updates waiting, after at most ~0.2 s (empty: none came)."""
        if self.window is None:
            first = _get(updates, 0.2)
        else:
            first = _get(updates, 0.0)
            if first is None:
                self.window.wait(0.1)
                if not self.window.open:
                    raise RuntimeError("the window was closed")
        taken = [first] if first is not None else []
        while taken and not taken[-1].final and (more := _get(updates, 0.0)) is not None:
            taken.append(more)
        return taken

    def draw(self, state: LiveState) -> None:
        if self.spec.draw is not None:
            self.spec.draw(state)
        elif self.window is not None:
            self.window.draw(state)
        elif self.spec.render is not None:
            self.spec.render(state, self.spec.png, force=True, fig=self.fig)


def _follow(spec: _Spec, updates: Any, frames: Any) -> None:
    """Draw the updates as they come, at most every ``spec.every`` s and the final one always; return after the
    final one or once the acquiring process is gone."""
    import multiprocessing

    painter = _Painter(spec)
    parent = multiprocessing.parent_process()
    state = LiveState(spec.name, "running", blocks_planned=spec.blocks_planned)
    drawn, dirty = -math.inf, False
    while True:
        taken = painter.take(updates)
        for update in taken:
            state, dirty = _apply(state, update), True
        final = bool(taken) and taken[-1].final
        if dirty and (final or time.monotonic() - drawn >= spec.every):
            painter.draw(state)
            frames.value += 1
            drawn, dirty = time.monotonic(), False
        if final or (not taken and parent is not None and not parent.is_alive()):
            return


def _view_main(spec: _Spec, updates: Any, failures: Any, frames: Any) -> None:
    """The view's process. Its first failure is sent on ``failures`` (one line) and ends it; Ctrl-C is ignored (it
    is the acquisition's business: the first one stops the session after the block, whose end is still drawn)."""
    import signal
    import warnings

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _follow(spec, updates, frames)
    except BaseException as exc:
        try:
            failures.send(_reason(exc))
        except Exception:  # the acquiring process is gone: nobody to tell
            pass
    finally:
        failures.close()


def _ended(code: int | None) -> str:
    import signal

    if code is not None and code < 0 and -code in signal.valid_signals():
        how = f"killed by {signal.Signals(-code).name}"
    else:
        how = f"exit code {code}"
    return f"{ViewProcessError.__name__}: the view process ended unexpectedly ({how})"


_VIEW_NICENESS = 10  # the view's process runs this much nicer than the acquisition: short of CPUs, the view waits


def _give_way(pid: int | None) -> None:
    """Lower the priority of the view's process (POSIX; elsewhere, and if refused, it keeps the same priority)."""
    if sys.platform == "win32" or pid is None:
        return
    try:
        os.setpriority(os.PRIO_PROCESS, pid, min(19, os.getpriority(os.PRIO_PROCESS, 0) + _VIEW_NICENESS))
    except OSError:
        pass


class _ViewProcess:
    """The acquiring process's end of the view's process (spawned, daemon): a bounded queue of updates that is never
    waited on (an update that does not fit is merged into the next one), a pipe on which the view reports its one
    failure, and a shared frame counter."""

    def __init__(self, spec: _Spec) -> None:
        import multiprocessing

        ctx = multiprocessing.get_context("spawn")
        self.updates = ctx.Queue(maxsize=2)
        self.updates.cancel_join_thread()  # never wait at exit for updates a dead or stuck view will not take
        self._failures, failures_w = ctx.Pipe(duplex=False)
        self._frames = ctx.RawValue("q", 0)
        self.process = ctx.Process(
            target=_view_main, args=(spec, self.updates, failures_w, self._frames), name="contactrig-live-view",
            daemon=True,
        )  # fmt: skip
        try:
            self.process.start()
        finally:
            failures_w.close()  # the view holds the write end: the pipe reads EOF once it is gone
        _give_way(self.process.pid)
        self._rows: list[BlockRow] = []
        self._current: _Readings | None = None

    @property
    def frames(self) -> int:
        return int(self._frames.value)

    def post(self, rows: Sequence[BlockRow], current: _Readings | None, status: str, *, final: bool = False) -> bool:
        """Queue an update if there is room (never waits); else keep it to merge into the next one. True: queued."""
        self._rows.extend(rows)
        if current is not None:
            self._current = current
        try:
            self.updates.put_nowait(_Update(tuple(self._rows), self._current, status, final))
        except queue.Full:
            return False
        self._rows.clear()
        self._current = None
        return True

    def _said(self) -> str | None:
        try:
            return str(self._failures.recv()) if self._failures.poll(0) else None
        except (EOFError, OSError):  # ended without a word
            return None

    def failure(self) -> str | None:
        """Why the view has stopped (its own report, or how its process ended); None while it runs."""
        said = self._said()
        if said is not None or self.process.is_alive():
            return said
        return self._said() or _ended(self.process.exitcode)

    def finish(self, status: str, timeout: float) -> str | None:
        """Hand over the final update and wait at most ``timeout`` s for the view to draw it and end; its failure, if
        any."""
        deadline = time.monotonic() + timeout
        while not self.post((), None, status, final=True):
            failed = self.failure()
            if failed is not None:
                return failed
            if time.monotonic() >= deadline:
                return f"{ViewProcessError.__name__}: the last frame was not drawn within {timeout:g} s"
            time.sleep(0.01)
        self.process.join(max(0.0, deadline - time.monotonic()))
        if self.process.is_alive():
            return f"{ViewProcessError.__name__}: the last frame was not drawn within {timeout:g} s"
        return self._said() or (None if self.process.exitcode == 0 else _ended(self.process.exitcode))

    def close(self) -> None:
        """End the view's process if it still runs (terminate, then kill) and release the queue and the pipe."""
        p = self.process
        for end in (p.terminate, p.kill):
            if not p.is_alive():
                break
            end()
            p.join(2.0)
        self.updates.close()
        self._failures.close()


class LiveView:
    """The live view as a writer of the acquisition (``contactrig acquire --live``).

    The drawing runs in a process of its own (spawned on the first block, a daemon, ended with the session), which
    owns matplotlib: ``png`` a snapshot file rewritten at most every ``every`` seconds, None a window redrawn at
    most as often; ``draw`` replaces the drawing (tests: a picklable function, called in that process). A block
    costs the acquisition a small update (the block's row and readings) put on a bounded queue without waiting —
    when the view lags, updates are merged, never waited for. Any failure (no display, a closed window, a bug, a
    killed or stuck view process) is reported once on ``stream`` and turns the view off (:attr:`off`,
    :attr:`reason`); at the end the view gets at most ``stop_timeout`` seconds to draw its last frame, after the
    session file is sealed.
    """

    def __init__(
        self,
        png: str | Path | None = None,
        *,
        every: float = 1.0,
        stream: TextIO | None = None,
        name: str = "",
        force: bool = False,
        draw: Callable[[LiveState], None] | None = None,
        stop_timeout: float = 10.0,
    ) -> None:
        self.png = Path(png) if png is not None else None
        self.every = every
        self.force = force
        self.stop_timeout = stop_timeout
        self._guard = _OffOnce("live view", stream)
        self._state = LiveState(name or (self.png.name if self.png else "session"), "running")
        self._draw = draw
        self._view: _ViewProcess | None = None

    @property
    def off(self) -> bool:
        return self._guard.off

    @property
    def reason(self) -> str:
        return self._guard.reason

    @property
    def state(self) -> LiveState:
        """The state as the acquisition handed it over (what the view is drawing, or will)."""
        return self._state

    @property
    def frames(self) -> int:
        """Frames drawn by the view's process so far."""
        return self._view.frames if self._view is not None else 0

    @property
    def process(self) -> Any:
        """The view's :class:`multiprocessing.Process` (None before the first block)."""
        return self._view.process if self._view is not None else None

    # -- the writer interface ------------------------------------------------------------------------------------
    def start(self, start: dict[str, Any], scene_text: str) -> None:
        try:
            self._state = replace(self._state, blocks_planned=_planned(start))
            if self._draw is None and self.png is not None:
                from analysis.snapshot import check_snapshot_path

                check_snapshot_path(self.png, force=self.force)  # refused before any block, in the acquiring process
        except Exception as exc:
            self._guard.fail(exc)

    def exchanges(self, exchanges: Sequence[Any], block: int) -> None:
        pass

    def block(self, rec: Any) -> None:
        if self.off:
            return
        try:
            st = rec.stats
            row = BlockRow(
                int(rec.block), float(rec.weight_kg), int(rec.repeat), float(st.mean), int(st.n), int(st.n_invalid),
                bool(rec.compliance), _epoch(rec.started),
            )  # fmt: skip
            current = (
                np.asarray(rec.time_s, dtype=float),
                np.asarray(rec.resistance_ohm, dtype=float),
                np.asarray(rec.valid, dtype=bool),
            )
            self._state = replace(
                self._state, rows=(*self._state.rows, row), current_time_s=current[0], current_ohm=current[1],
                current_valid=current[2],
            )  # fmt: skip
            view = self._view if self._view is not None else self._spawn()
            view.post((row,), current, self._state.status)
            failed = view.failure()
            if failed is not None:
                self._guard.report(failed)
        except Exception as exc:
            self._guard.fail(exc)

    def stop(self, stop: Any) -> None:
        try:
            self._state = replace(self._state, status=str(stop.status))
            if self._view is not None and not self.off:
                failed = self._view.finish(self._state.status, self.stop_timeout)
                if failed is not None:
                    self._guard.report(failed)
        except Exception as exc:
            self._guard.fail(exc)
        finally:
            if self._view is not None:
                self._view.close()

    def _spawn(self) -> _ViewProcess:
        png = self.png if self._draw is None else None
        # render_png as this module holds it now (a test may have replaced it); pickled by name for the view
        spec = _Spec(self._state.name, self._state.blocks_planned, self.every, png, self._draw, render_png)
        self._view = _ViewProcess(spec)
        return self._view
