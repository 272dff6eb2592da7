"""The console's acquisition process: :func:`daq.acquire.acquire` itself, run in a child process of the console.

The console starts ``python -m contactrig.console.child`` in a process group of its own and talks to it over two
pipes, one JSON object per line: the child's stdout carries events (the plan, each record, the question to the
operator), its stdin the operator's answers. It runs ``acquire`` in its main thread, so acquire's own Ctrl-C
policy (:class:`daq.engine.Interrupts`) is installed: the console's "stop after this block" is one SIGINT to this
process, "stop now" a second one — the terminal's first and second Ctrl-C, with the same guarantees (source idle,
stop record written).

The acquisition never waits on the browser: the records go to the console as one more writer, guarded
(:class:`analysis.watch.Guarded`: a failure of the pipe turns it off, the acquisition goes on); only the prompter
waits, for the operator, as the terminal's does.

Every question carries a fresh random id and only an answer naming it is taken (the console checks this too; here it
is the last guard): an answer meant for an earlier question can never answer the next weight's.

The console must never leave a child measuring on its own. Its stdin is the lifeline: a thread reads it, and when it
closes (the console process ended by any path, SIGKILL included: the kernel closes the pipe) the child stops as the
terminal's first Ctrl-C stops it — after the block under way, source idle, stop record written; a question waiting
for an answer ends the run at once (``OperatorQuit``).
"""

from __future__ import annotations

import json
import math
import os
import queue
import secrets
import signal
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from typing import Any, TextIO

from contactrig.console.view import block_row, strict_json
from daq.engine import Decision, OperatorQuit
from daq.pause import PauseControl
from daq.plan import PlaceWeight
from daq.records import BlockRecord, StopRecord

__all__ = ["ConsoleWriter", "main", "pipe_adaptive", "pipe_prompter", "pipe_resume_chooser"]

#: readings of a block sent to the console (the plot of the current block); more are counted, not sent
MAX_READINGS_SENT = 2000


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


class _Channel:
    """Events out (one JSON line each, flushed), answers in (one JSON line each, read by a thread that also notices
    the console going away)."""

    def __init__(self, out: TextIO, inp: Iterator[bytes]) -> None:
        self.out, self.inp = out, inp
        #: the console went away (its end of the pipe closed): events are dropped, questions end the run
        self.gone = False
        self._answers: queue.Queue[dict[str, Any] | None] = queue.Queue()
        self._asking = False
        #: the operator's Pause and Resume (``{"control": "pause", "reason", "who"}``, ``{"control": "resume",
        #: "who"}``), taken by the engine at the next block boundary
        self.pause = PauseControl()

    def watch(self) -> None:
        """Read answers from here on in a thread; the end of stdin (the console gone) stops the run."""
        threading.Thread(target=self._read, name="console-lifeline", daemon=True).start()

    def _read(self) -> None:
        for line in self.inp:
            try:
                answer = json.loads(line)
            except (json.JSONDecodeError, UnicodeDecodeError):
                continue
            if isinstance(answer, dict) and "control" in answer:
                self._control(answer)
            elif isinstance(answer, dict):
                self._answers.put(answer)
        self.gone = True
        self._answers.put(None)  # a question waiting ends the run (OperatorQuit)
        if not self._asking:  # measuring: as the terminal's first Ctrl-C (after the block, source idle)
            os.kill(os.getpid(), signal.SIGINT)

    def _control(self, message: dict[str, Any]) -> None:
        """A Pause or Resume (checked by the console already; one it would have refused is dropped here)."""
        from contactrig.core.validation import SettingError

        try:
            if message["control"] == "pause":
                self.pause.request(message.get("reason"), message.get("who"))  # type: ignore[arg-type]
            elif message["control"] == "resume":
                self.pause.resume(message.get("who"))  # type: ignore[arg-type]
        except SettingError:
            pass

    def send(self, event: dict[str, Any]) -> None:
        """Send one event; never raises for a console that went away (the acquisition must go on)."""
        if self.gone:
            return
        try:
            self.out.write(json.dumps(event, allow_nan=False) + "\n")
            self.out.flush()
        except (OSError, ValueError):  # EPIPE, or the stream closed
            self.gone = True

    def ask(self, event: dict[str, Any]) -> dict[str, Any]:
        """Send a question (with a fresh id) and wait for the answer that names it; the console gone →
        ``OperatorQuit``. An answer naming another question is dropped."""
        asked = {**event, "id": secrets.token_hex(8)}
        self._asking = True
        try:
            self.send(asked)
            while True:
                if self.gone:
                    raise OperatorQuit("the console that asked the operator went away: stopped at the prompt")
                try:
                    answer = self._answers.get(timeout=0.5)  # a timeout: a Ctrl-C (SIGINT) is handled meanwhile
                except queue.Empty:
                    continue
                if answer is not None and answer.get("id") == asked["id"]:
                    return answer
        finally:
            self._asking = False


class ConsoleWriter:
    """A :class:`daq.engine.Writer` that sends each record's summary to the console (a few µs a block)."""

    def __init__(self, channel: _Channel) -> None:
        self.channel = channel

    def start(self, start: dict[str, Any], scene_text: str) -> None:
        self.channel.send({"event": "start", "run": start.get("run"), "started": start.get("started")})

    def exchanges(self, exchanges: Sequence[Any], block: int) -> None:
        return None

    def block(self, rec: BlockRecord) -> None:
        st = rec.stats
        readings = [_finite(float(x)) for x in rec.resistance_ohm[:MAX_READINGS_SENT]]
        # the page's row: the 1-based number and the terminal's formatting
        row = block_row(rec.block, rec.run, rec.weight_kg, rec.repeat, st.mean, st.sem, st.n, st.n_invalid,
                        rec.compliance)  # fmt: skip
        self.channel.send({"event": "block", **row, "readings_ohm": readings, "started": rec.started})

    def pause(self, pauses: list[dict[str, Any]]) -> None:
        """This run's pause records (:mod:`daq.pause`), when a pause begins and when it ends."""
        self.channel.send({"event": "pause", "pauses": pauses})

    def stop(self, stop: StopRecord) -> None:
        self.channel.send({
            "event": "stop", "status": stop.status, "reason": stop.reason, "stopped": stop.stopped,
            "blocks_done": stop.blocks_done, "blocks_planned": stop.blocks_planned,
            "weights_skipped": list(stop.weights_skipped),
        })  # fmt: skip


def pipe_prompter(channel: _Channel) -> Callable[[PlaceWeight], Decision]:
    """The operator's Continue / Skip / Stop from the console (the confirmation of Skip is asked in the page)."""

    def prompt(step: PlaceWeight) -> Decision:
        answer = channel.ask({
            "event": "prompt", "weight_kg": step.weight_kg, "weight_index": step.weight_index,
            "repeats_left": step.repeats_left,
        })  # fmt: skip
        decision = answer.get("decision")
        return decision if decision in ("go", "skip", "quit") else "quit"

    return prompt


def pipe_resume_chooser(channel: _Channel) -> Callable[[float], bool]:
    """On resume: measure a weight an earlier run skipped now (True), or keep it skipped."""

    def choose(weight_kg: float) -> bool:
        return bool(channel.ask({"event": "resume_choice", "weight_kg": weight_kg}).get("measure", False))

    return choose


def pipe_adaptive(
    channel: _Channel, budget_min: float, *, simulated: bool, noise_from: str | None = None
) -> tuple[Callable[[Any], Any], Callable[[], None]]:
    """An adaptive session from the console (``acquire --adaptive --budget-min N [--noise-from SESSION.h5]``): the
    factory ``acquire(adaptive=…)`` takes (:func:`analysis.adaptive_session.adaptive_source`, the operator asked
    over the pipe) and a function that sends the session's last state once it has ended.

    After every block the design's state goes to the page (``evidence``); before each placement the question
    ``suggest`` carries the suggestion, the allowed weights and the state the
    design reports (:meth:`analysis.sequential.SequentialDesign.report`, with its evidence line; strict JSON, an
    event that could not be sent would end the channel): the page shows it, nothing is computed here. The answer
    (:func:`_chosen`) as at the terminal: take it, place another allowed weight, or stop."""
    from analysis.adaptive_session import adaptive_source, evidence_line

    held: list[Any] = []  # the session's AdaptiveSteps, once acquire has made them

    def state_of(state: Any) -> dict[str, Any]:
        out = dict(strict_json(state))
        out["evidence_line"] = evidence_line(held[0].design) if held else ""
        return out

    def choose(placement: Any, state: Any, allowed: Sequence[float]) -> float | None:
        while True:
            answer = channel.ask({
                "event": "suggest", "weight_kg": placement.weight_kg, "suggestion": strict_json(placement.as_dict()),
                "allowed_kg": [float(w) for w in allowed], "adaptive": state_of(state),
            })  # fmt: skip
            chosen = _chosen(answer, float(placement.weight_kg), allowed)
            if not isinstance(chosen, str):  # "again": not an answer to this question
                return chosen

    make = adaptive_source(budget_min, simulated=simulated, choose=choose, noise_from=noise_from)

    def factory(plan: Any) -> Any:
        steps = make(plan)
        held.append(steps)
        _report_after_blocks(steps, channel, state_of)
        return steps

    def final() -> None:
        if not held:
            return
        steps = held[0]
        try:
            last = steps.last if steps.last is not None else steps.design.report()
            state = state_of(last)
        except Exception as exc:  # the page says so; the session and its file are not touched
            state = {"error": f"{type(exc).__name__}: {exc}"}
        channel.send({"event": "adaptive", "adaptive": state, "decision": strict_json(steps.decision),
                      "stop_reason": steps.stop_reason})  # fmt: skip

    return factory, final


def _report_after_blocks(steps: Any, channel: _Channel, state_of: Callable[[Any], dict[str, Any]]) -> None:
    """After every block the steps ingest (their writer method, wrapped for this instance), the design's state to the
    page (an ``evidence`` event). ``report()`` is deterministic (its generator seeded by the block count): the
    suggestions, and their replay, are not changed by it."""
    ingest = steps.block

    def block(rec: Any) -> None:
        ingest(rec)
        try:
            state = state_of(steps.design.report())
        except Exception as exc:  # the page says so; the acquisition goes on
            state = {"error": f"{type(exc).__name__}: {exc}"}
        channel.send({"event": "evidence", "adaptive": state})

    setattr(steps, "block", block)  # noqa: B010 (a method of the instance, not of the class)


def _chosen(answer: dict[str, Any], suggested_kg: float, allowed: Sequence[float]) -> float | str | None:
    """The weight [kg] an answer to a suggestion places: ``go`` the suggested one (Enter at the terminal), ``place``
    with ``weight_kg`` one of the allowed (a weight typed), ``quit`` None (``q``: stop); anything else ``"again"``
    (the question is asked anew, as the terminal asks again)."""
    decision = answer.get("decision")
    if decision == "go":
        return suggested_kg
    if decision == "quit":
        return None
    weight = answer.get("weight_kg")
    if decision == "place" and isinstance(weight, (int, float)) and not isinstance(weight, bool):
        hit = [w for w in allowed if math.isclose(w, float(weight), rel_tol=1e-6)]
        if hit:
            return float(hit[0])
    return "again"


class _Lines:
    """A text stream whose lines (acquire's plan, its live line, its notes) become ``line`` events."""

    def __init__(self, channel: _Channel) -> None:
        self.channel, self.buffer = channel, ""

    def write(self, text: str) -> int:
        self.buffer += text
        *lines, self.buffer = self.buffer.split("\n")
        for line in lines:
            if line.strip():
                self.channel.send({"event": "line", "text": line.strip("\r")})
        return len(text)

    def flush(self) -> None:
        return None

    def isatty(self) -> bool:
        return False


def run(request: dict[str, Any], channel: _Channel) -> int:
    """One ``acquire`` as ``request`` says (scene, output, sim, sim_speed, resume, overrides, adaptive: its
    ``budget_min`` and ``noise_from``); returns the exit
    code of ``contactrig acquire`` (0 done, 1 stopped early, 2 error)."""
    from analysis.simulated_session import DEFAULT_SIM_SPEED, SimulatedRigBench
    from analysis.watch import Guarded
    from daq.acquire import acquire
    from daq.link import VisaBench

    speed = request.get("sim_speed") or DEFAULT_SIM_SPEED
    bench = SimulatedRigBench(float(speed)) if request.get("sim") else VisaBench()  # the plan's VISA library
    adaptive: Callable[[Any], Any] | None = None
    final: Callable[[], None] | None = None
    if isinstance(request.get("adaptive"), dict):  # the steps ask the operator themselves (no weight prompt)
        adaptive, final = pipe_adaptive(channel, float(request["adaptive"]["budget_min"]),
                                        simulated=bool(request.get("sim")),
                                        noise_from=request["adaptive"].get("noise_from"))  # fmt: skip
    try:
        result = acquire(
            request.get("scene"), request["output"], bench=bench, resume=bool(request.get("resume")),
            prompter=None if adaptive is not None else pipe_prompter(channel), adaptive=adaptive,
            resume_chooser=pipe_resume_chooser(channel), stream=_Lines(channel),  # type: ignore[arg-type]
            extra_writers=[Guarded(ConsoleWriter(channel), "console")],
            overrides=request.get("overrides") or None, allow_change=bool(request.get("allow_change")),
            pause=channel.pause,
        )  # fmt: skip
    except KeyboardInterrupt:
        channel.send({"event": "end", "code": 1, "error": "interrupted before the session began"})
        return 1
    except Exception as exc:  # the one-line error, as the CLI prints it
        channel.send({"event": "end", "code": 2, "error": f"{type(exc).__name__}: {exc}"})
        return 2
    finally:
        if final is not None:
            final()
    code = 0 if result.status == "success" else 1 if result.status == "aborted" else 2
    channel.send({"event": "end", "code": code, "status": result.status, "reason": result.reason})
    return code


def _lines(fd: int) -> Iterator[bytes]:
    """The lines read from ``fd`` with ``os.read`` (no Python file object: a fork while the lifeline thread waits in
    a read must not inherit a held lock, as a forked bounded reader closing ``sys.stdin`` would)."""
    buffer = b""
    while chunk := os.read(fd, 1 << 16):
        buffer += chunk
        *lines, buffer = buffer.split(b"\n")
        yield from lines
    if buffer:
        yield buffer


def main() -> int:
    """Read the request (first line of stdin) and run it; events go to the real stdout only."""
    out = sys.stdout
    sys.stdout = sys.stderr  # nothing else may write into the event pipe
    sys.argv = ["contactrig console"]  # the start record's "command": where the session was started from
    answers = _lines(sys.stdin.fileno())
    sys.stdin = open(os.devnull, encoding="utf-8")  # nothing else reads the console's pipe
    channel = _Channel(out, answers)
    request = json.loads(next(answers, b"{}"))
    channel.watch()
    return run(request, channel)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
