"""A session run from the console: the acquisition child process (:mod:`contactrig.console.child`) and its state.

A reader thread takes the child's events as they come and folds them into :class:`RunState`; pages read a copy of
that state (``snapshot``), never the pipe, so no browser — slow, closed or crashed — can hold the acquisition up.
The operator's answers go to the child's stdin; "stop after this block" and "stop now" are the first and second
SIGINT to the child, which runs ``acquire`` with the terminal's Ctrl-C policy.

Every question of the child carries an id (:mod:`contactrig.console.child`); an answer names the question it answers
and is passed on only while that very question is asked, once: a late, duplicate or foreign answer (a second tab, a
double click, a slow network) is refused, so it can never answer the next weight's question. The child's stdin is
also its lifeline: when the console process ends by any path (even SIGKILL) the pipe closes and the child stops as
the terminal's first Ctrl-C stops it (source idle, stop record written).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Any

__all__ = ["RunState", "SessionRun"]

#: state lines kept (acquire's plan and notes); older ones are dropped
MAX_LINES = 200
#: answered questions remembered (to say "already answered" rather than "not asked")
MAX_ANSWERED = 1000


@dataclass
class RunState:
    """What the page shows of one run: identity, plan, the question to the operator, blocks, stop and end."""

    id: str
    file: str
    address: str
    controller: str
    sim: bool
    resume: bool
    blocks_planned: int = 0
    #: blocks on file before this run (a resumed session)
    blocks_before: int = 0
    #: weights in the plan (the operator places each of them once)
    weights_left: int = 0
    #: the sample (from the scene or the recorded start record): past sessions of it can be overlaid
    sample: str = ""
    phase: str = "starting"  # starting, prompt, resume_choice, measuring, stopping, ended
    prompt: dict[str, Any] | None = None
    lines: list[str] = field(default_factory=list)
    blocks: list[dict[str, Any]] = field(default_factory=list)
    stop: dict[str, Any] | None = None
    end: dict[str, Any] | None = None
    stop_requests: int = 0
    started_at: float = field(default_factory=time.monotonic)
    block_times: list[float] = field(default_factory=list)
    version: int = 0
    #: an adaptive session: its budget [min] (None: a fixed plan), the design's last state (the analysis's JSON, as
    #: the child sent it after each block, with each suggestion and at the end) and, once ended, its stop decision
    #: and reason
    budget_min: float | None = None
    adaptive: dict[str, Any] | None = None
    adaptive_stop: dict[str, Any] | None = None
    #: this run's pause records (:mod:`daq.pause`, as the file holds them) and the operator's Pause not yet taken
    #: (the block under way ends first)
    pauses: list[dict[str, Any]] = field(default_factory=list)
    pause_request: dict[str, Any] | None = None

    def public(self) -> dict[str, Any]:
        """The JSON the pages get (strings from files inside are data: pages show them with textContent)."""
        eta = _eta_s(self.block_times, self.blocks, self.blocks_planned - self.blocks_before - len(self.blocks))
        blocks = [{k: v for k, v in b.items() if k != "readings_ohm"} for b in self.blocks[:-1]] + self.blocks[-1:]
        return {
            "id": self.id, "file": self.file, "address": self.address, "controller": self.controller,
            "sim": self.sim, "resume": self.resume, "phase": self.phase, "prompt": self.prompt,
            "lines": self.lines[-MAX_LINES:], "blocks": blocks, "blocks_planned": self.blocks_planned,
            "blocks_before": self.blocks_before, "stop": self.stop, "end": self.end,
            "stop_requests": self.stop_requests, "eta_s": eta, "weights_left": self.weights_left,
            "sample": self.sample, "budget_min": self.budget_min, "adaptive": self.adaptive,
            "adaptive_stop": self.adaptive_stop, "pauses": self.pauses, "pause_request": self.pause_request,
            "version": self.version,
        }  # fmt: skip


def _eta_s(times: list[float], blocks: list[dict[str, Any]], left: int) -> float | None:
    """Seconds of measuring left: the blocks still to take × the median time between two blocks at the same weight
    (the operator's time to place a weight is not in it: the page says how many weights are still to place);
    None before two blocks at one weight."""
    if left <= 0:
        return 0.0
    steps = sorted(b - a for a, b, wa, wb in zip(times, times[1:], blocks, blocks[1:], strict=False)
                   if wa.get("weight_kg") == wb.get("weight_kg"))  # fmt: skip
    if not steps:
        return None
    return steps[len(steps) // 2] * left


class SessionRun:
    """One acquisition child process and the state its events build."""

    def __init__(self, state: RunState, request: dict[str, Any], cwd: str) -> None:
        self.state = state
        #: question id → what it asked and how it was answered (for the refusal of a late or duplicate answer)
        self._answered: dict[str, str] = {}
        self._lock = threading.Lock()
        self._changed = threading.Condition(self._lock)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "contactrig.console.child"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, cwd=cwd, text=True, encoding="utf-8",
            start_new_session=True,  # its own process group: a Ctrl-C at the console's terminal is the console's
        )  # fmt: skip
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        self._reader = threading.Thread(target=self._read, name=f"console-run-{state.id}", daemon=True)
        self._reader.start()

    # -- events from the child -----------------------------------------------------------------------------------
    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            try:
                event = json.loads(line)
            except json.JSONDecodeError:
                continue
            if isinstance(event, dict):
                self._apply(event)
        code = self.proc.wait()
        with self._lock:
            if self.state.end is None:
                self.state.end = {"code": code, "error": f"the acquisition process ended with exit code {code}"}
            self.state.phase, self.state.prompt = "ended", None
            self._bump()

    def _apply(self, event: dict[str, Any]) -> None:
        kind = event.get("event")
        with self._lock:
            s = self.state
            if kind == "line":
                s.lines.append(str(event.get("text", "")))
                del s.lines[:-MAX_LINES]
            elif kind == "block":
                s.blocks.append(event)
                s.block_times.append(time.monotonic())
                s.phase = "stopping" if s.stop_requests else "measuring"
            elif kind in ("prompt", "resume_choice"):
                s.phase, s.prompt = str(kind), event
                if kind == "prompt":
                    s.weights_left = max(s.weights_left - 1, 0)
            elif kind == "pause":
                _pause_event(s, event)
            elif kind in ("suggest", "evidence", "adaptive"):
                _adaptive_event(s, str(kind), event)
            elif kind == "stop":
                s.stop = event
                s.blocks_planned = int(event.get("blocks_planned") or s.blocks_planned)
            elif kind == "end":
                s.end, s.phase, s.prompt = event, "ended", None
            elif kind == "start" and s.phase == "starting":
                s.phase = "measuring"
            self._bump()

    def _bump(self) -> None:
        self.state.version += 1
        self._changed.notify_all()

    # -- the operator --------------------------------------------------------------------------------------------
    def answer(self, prompt_id: str, answer: dict[str, Any]) -> str | None:
        """Answer the question ``prompt_id`` (a weight: ``{"decision": …}``; on resume: ``{"measure": …}``) if it is
        the one asked now and not answered yet; None when passed on, else why it was refused (one line)."""
        with self._lock:
            asked = self.state.prompt
            if prompt_id in self._answered:
                return f"{self._answered[prompt_id]}: this answer came late or twice and was not used"
            if asked is None or asked.get("id") != prompt_id:
                now = "nothing is asked now" if asked is None else f"the question now is: {_question(asked)}"
                return f"this answer names a question that is not asked ({now}): it was not used"
            wanted = "decision" if asked.get("event") in ("prompt", "suggest") else "measure"
            if wanted not in answer:
                return f"{_question(asked)} needs {wanted!r}: the answer was not used"
            refused = _fits(asked, answer)
            if refused is not None:
                return f"{_question(asked)}: {refused}: the answer was not used"
            if self.proc.stdin is None or self.proc.poll() is not None:
                return "the acquisition process has ended: the answer was not used"
            try:
                self.proc.stdin.write(json.dumps({"id": prompt_id, **answer}) + "\n")
                self.proc.stdin.flush()
            except (OSError, ValueError):
                return "the acquisition process has ended: the answer was not used"
            how = answer.get("decision", "measure it now" if answer.get("measure") else "keep it skipped")
            self._answered[prompt_id] = f"{_question(asked)} was already answered ({how})"
            if len(self._answered) > MAX_ANSWERED:
                del self._answered[next(iter(self._answered))]
            self.state.prompt = None
            self.state.phase = "measuring"
            self._bump()
        return None

    def pause(self, reason: Any, who: Any) -> str | None:
        """The operator's Pause (``reason``, ``who``: one-line texts): the session pauses after the block under way
        (:mod:`daq.pause`). None when passed on, else why not (one line)."""
        from contactrig.core.validation import SettingError
        from daq.pause import checked_text

        try:
            message = {"control": "pause", "reason": checked_text("reason", reason), "who": checked_text("who", who)}
        except SettingError as exc:
            return str(exc)
        with self._lock:
            if self.state.phase in ("ended", "stopping") or self.state.stop_requests:
                return "the session is stopping or has ended: nothing to pause"
            if self.state.phase == "paused":
                return "the session is paused already"
            refused = self._send(message)
            if refused is None:
                self.state.pause_request = {"reason": message["reason"], "who": message["who"]}
                self._bump()
            return refused

    def resume(self, who: Any) -> str | None:
        """The operator's Resume: the session goes on with its next block (or a Pause not yet taken is dropped)."""
        from contactrig.core.validation import SettingError
        from daq.pause import checked_text

        try:
            message = {"control": "resume", "who": checked_text("who", who)}
        except SettingError as exc:
            return str(exc)
        with self._lock:
            if self.state.phase != "paused" and self.state.pause_request is None:
                return "the session is not paused"
            refused = self._send(message)
            if refused is None:
                self.state.pause_request = None
                self._bump()
            return refused

    def _send(self, message: dict[str, Any]) -> str | None:
        """One line to the child (the lock held); None when written."""
        if self.proc.stdin is None or self.proc.poll() is not None:
            return "the acquisition process has ended"
        try:
            self.proc.stdin.write(json.dumps(message) + "\n")
            self.proc.stdin.flush()
        except (OSError, ValueError):
            return "the acquisition process has ended"
        return None

    def request_stop(self) -> int:
        """One SIGINT to the child: the first stops after the block under way, the second stops now."""
        with self._lock:
            if self.state.phase == "ended":
                return self.state.stop_requests
            self.state.stop_requests += 1
            self.state.phase = "stopping"
            self._bump()
            count = self.state.stop_requests
        try:
            os.kill(self.proc.pid, signal.SIGINT)
        except ProcessLookupError:
            pass
        return count

    # -- readers -------------------------------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self.state.phase != "ended"

    def snapshot(self) -> dict[str, Any]:
        with self._lock:
            return json.loads(json.dumps(self.state.public()))

    def wait_change(self, version: int, timeout: float) -> int:
        """Block (a worker thread, never the acquisition) until the state's version passes ``version``."""
        with self._lock:
            self._changed.wait_for(lambda: self.state.version != version, timeout=timeout)
            return self.state.version

    def close(self) -> None:
        """The console is shutting down: stop the run as one Ctrl-C does (after the block, unless a stop was asked
        already), wait for it to end, then close the pipes. The child's stdin stays open until then: its closing is
        the child's sign that the console is gone."""
        if self.proc.poll() is None and self.state.stop_requests == 0:
            self.request_stop()
        self.proc.wait()
        self._reader.join(timeout=5)  # its last events read
        for pipe in (self.proc.stdin, self.proc.stdout):
            if pipe is not None:
                try:
                    pipe.close()
                except OSError:
                    pass


def _pause_event(s: RunState, event: dict[str, Any]) -> None:
    """The run's pause records, when a pause begins (phase ``paused``) and when it ends."""
    s.pauses = [p for p in event.get("pauses") or [] if isinstance(p, dict)]
    if s.pauses and "resumed" not in s.pauses[-1]:
        s.pause_request, s.phase = None, "paused"
    elif s.phase == "paused":
        s.phase = "stopping" if s.stop_requests else "measuring"


def _adaptive_event(s: RunState, kind: str, event: dict[str, Any]) -> None:
    """An adaptive session's events: its state after a block (``evidence``), its next placement (``suggest``: the
    state apart, the question as asked), its last state once it has ended (``adaptive``, with the stop decision)."""
    if isinstance(event.get("adaptive"), dict):
        s.adaptive = event["adaptive"]
    if kind == "suggest":
        s.phase, s.prompt = "prompt", {k: v for k, v in event.items() if k != "adaptive"}
    elif kind == "adaptive":
        s.adaptive_stop = {"decision": event.get("decision"), "stop_reason": event.get("stop_reason")}


def _fits(asked: dict[str, Any], answer: dict[str, Any]) -> str | None:
    """Why a decision does not answer the question asked (None: it does): a weight's question takes go, skip or quit;
    an adaptive session's suggestion go (take it), place (another of the allowed weights, ``weight_kg``) or quit."""
    decision = answer.get("decision")
    if "decision" not in answer:
        return None
    if asked.get("event") == "prompt":
        return None if decision in ("go", "skip", "quit") else f"{decision!r} is not one of go, skip, quit"
    if decision in ("go", "quit"):
        return None
    if decision != "place":
        return f"{decision!r} is not one of go (take the suggestion), place (another weight), quit"
    allowed = [float(w) for w in asked.get("allowed_kg") or []]
    weight = answer.get("weight_kg")
    if isinstance(weight, (int, float)) and not isinstance(weight, bool) and any(
            abs(w - weight) <= 1e-6 * abs(w) for w in allowed):  # fmt: skip
        return None
    return f"weight_kg {weight!r} is not one of the allowed weights ({', '.join(f'{w:g}' for w in allowed)} kg)"


def _question(asked: dict[str, Any]) -> str:
    """The question in words: ``place 5.44 kg``, ``5.44 kg was skipped: measure it now?`` or an adaptive session's
    suggestion (``suggested: re-seat 5 kg …``)."""
    if asked.get("event") == "resume_choice":
        return f"'{asked.get('weight_kg')} kg was skipped: measure it now?'"
    if asked.get("event") == "suggest":
        return f"'suggested: {(asked.get('suggestion') or {}).get('text', asked.get('weight_kg'))}'"
    return f"'place {asked.get('weight_kg')} kg'"
