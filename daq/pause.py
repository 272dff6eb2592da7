"""A pause of a running session at a block boundary, with a reason (the console's Pause and Resume, issue 29).

The operator asks for a pause (:meth:`PauseControl.request`: reason, who) from another thread (the console's
lifeline reader). The engine (:class:`daq.engine.AcquisitionEngine`) takes the request at the next block boundary —
the block under way is finished and on disk first, and the source is idle there (every block ends with the
driver's ``SOUR:SWE:ABOR``; nothing is armed between blocks) — hands a pause record to its writers and waits
(:meth:`PauseControl.wait`) until :meth:`PauseControl.resume`; the next block is armed as every block is. A pause
asked for and resumed before the boundary is reached is dropped (nothing to record). A Ctrl-C (or the console's
Stop) while paused stops the session as at any idle moment: source idle, stop record written.

The pause record (:func:`pause_record`) goes into the run record of its run (``/entry/runs/run_<k>/record``,
key ``pauses``, a list: rewritten when the pause begins and when it ends), so it is on disk while the session
waits, covered by the seal once the session stops, and read by every reader as part of :attr:`Session.runs`.
Keys: ``reason``, ``who``, ``paused`` (ISO-8601 with the UTC offset), ``after_block`` (1-based number of the last
block done before it, 0: none yet), and once resumed ``resumed`` and ``resumed_by``. Added in schema 5.
"""

from __future__ import annotations

import threading
from typing import Any

from contactrig.core.provenance import now_iso
from contactrig.core.validation import SettingError

__all__ = ["MAX_REASON", "PauseControl", "checked_text", "pause_record", "pauses_of"]

#: longest reason or name taken (characters)
MAX_REASON = 500


def checked_text(name: str, value: Any) -> str:
    """``value`` as a pause's reason or name (``name``): a non-empty one-line text of at most :data:`MAX_REASON`
    characters, stripped; else a one-line :class:`SettingError` naming it."""
    if isinstance(value, str) and ("\n" in value or "\r" in value):
        raise SettingError(name, value[:60], "one line of text")
    if not isinstance(value, str) or not value.strip() or len(value) > MAX_REASON:
        raise SettingError(name, str(value)[:60], f"a non-empty text of at most {MAX_REASON} characters")
    return value.strip()


def pause_record(reason: str, who: str, after_block: int) -> dict[str, Any]:
    """The record of a pause that begins now (``after_block``: 1-based number of the last block done, 0: none)."""
    return {"reason": reason, "who": who, "paused": now_iso(), "after_block": int(after_block)}


def pauses_of(runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Every pause record of a session's run records (:attr:`daq.session_file.Session.runs`), each with its
    ``run``; none in a file written before schema 5."""
    out = []
    for k, run in enumerate(runs):
        for p in (run.get("pauses") or []) if isinstance(run, dict) else []:
            if isinstance(p, dict):
                out.append({**p, "run": k})
    return out


class PauseControl:
    """Pause and resume requests for one running session (thread-safe)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._request: dict[str, str] | None = None
        self._resumed = threading.Event()
        self._resumed_by = ""
        #: the engine waits in a pause now
        self.paused = False

    def request(self, reason: str, who: str) -> None:
        """Pause at the next block boundary (``reason`` and ``who``: one-line texts, checked)."""
        reason, who = checked_text("reason", reason), checked_text("who", who)
        with self._lock:
            self._request = {"reason": reason, "who": who}
            self._resumed.clear()

    def resume(self, who: str) -> None:
        """End the pause (or drop a request not yet taken)."""
        who = checked_text("who", who)
        with self._lock:
            self._request = None
            self._resumed_by = who
            self._resumed.set()

    def take(self) -> dict[str, str] | None:
        """The request waiting for a block boundary (the engine, at one), or None."""
        with self._lock:
            request, self._request = self._request, None
            if request is not None:
                self._resumed.clear()
                self.paused = True
            return request

    def wait(self, poll_s: float = 0.2) -> str:
        """Wait for :meth:`resume` (in short waits: a Ctrl-C is handled meanwhile); who resumed."""
        while not self._resumed.wait(poll_s):
            pass
        with self._lock:
            self.paused = False
            return self._resumed_by
