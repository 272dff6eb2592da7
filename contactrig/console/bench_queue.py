"""The bench's queue: planned sessions (scene, overrides, file name; a fixed plan each), started one after the other
on their bench address — as soon as the previous session there has ended, or when the operator presses Start (an
item that waits for it) — reordered or cancelled from the console's Queue page.

The queue is the file ``DIR/.contactrig-console-queue.json`` (written atomically, :func:`contactrig.core.files.
write_text_atomic`, at every change), so it survives a console restart. A file that cannot be read is never
overwritten: the queue stays off and says why until it is fixed or removed. A session is started with the console's
own start (:func:`contactrig.console.app._start`, the New-session form's checks, one session per address); a start
refused there (the file exists meanwhile…) stops that address's queue with the reason, shown on the page, until the
operator cancels the item or presses Start again. Nothing starts while the console shuts down.
"""

from __future__ import annotations

import json
import secrets
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["QUEUE_NAME", "BenchQueue", "QueueError"]

#: the queue's file in the console's folder (hidden)
QUEUE_NAME = ".contactrig-console-queue.json"
#: seconds between two looks at the benches
TICK_S = 0.2
_VERSION = 1


class QueueError(ValueError):
    """A queue request refused (one line, shown in the page)."""


@dataclass
class BenchQueue:
    """The queue of ``root``; ``start(form)`` starts a session (returns its run id), ``busy(address)`` says whether a
    session runs on a bench address, ``closing`` stops new starts."""

    root: Path
    start: Callable[[dict[str, Any]], str]
    busy: Callable[[str], bool]
    closing: threading.Event
    items: list[dict[str, Any]] = field(default_factory=list)
    #: the items started from here (this console's lifetime): id, file, run
    started: list[dict[str, Any]] = field(default_factory=list)
    #: why the queue is off (its file unreadable), or ""
    broken: str = ""
    _lock: threading.RLock = field(default_factory=threading.RLock)
    _thread: threading.Thread | None = None

    @property
    def path(self) -> Path:
        return self.root / QUEUE_NAME

    def load(self) -> None:
        """The queue as its file holds it (none: empty); an unreadable file turns the queue off (never rewritten)."""
        try:
            raw = self.path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return
        except OSError as exc:
            self.broken = f"{self.path}: {exc}"
            return
        try:
            data = json.loads(raw)
            items = data["items"]
            if data.get("version") != _VERSION or not isinstance(items, list):
                raise ValueError("not a queue of this contactrig")
            for item in items:
                if not (isinstance(item, dict) and all(isinstance(item.get(k), str) for k in ("id", "address"))
                        and isinstance(item.get("form"), dict)):  # fmt: skip
                    raise ValueError("an item without id, address and form")
        except (ValueError, KeyError, TypeError) as exc:
            self.broken = f"{self.path} cannot be read ({exc}): fix or remove it; the queue is off until then"
            return
        self.items = items

    def _save(self) -> None:
        from contactrig.core.files import write_text_atomic

        text = json.dumps({"version": _VERSION, "items": self.items}, indent=1, ensure_ascii=True)
        write_text_atomic(self.path, text + "\n", force=True)

    def _check(self) -> None:
        if self.broken:
            raise QueueError(self.broken)

    def snapshot(self) -> dict[str, Any]:
        with self._lock:
            return {"items": [dict(i) for i in self.items], "started": list(self.started), "broken": self.broken}

    def add(self, form: dict[str, Any], address: str, wait: bool) -> dict[str, Any]:
        """Append a planned session (``form``: the New-session form, already checked; ``address``: its bench)."""
        with self._lock:
            self._check()
            output = form.get("output")
            if any(i["form"].get("output") == output for i in self.items):
                raise QueueError(f"{output} is queued already: choose another name")
            item = {"id": secrets.token_hex(6), "address": address, "form": form, "wait": bool(wait), "go": False,
                    "error": ""}  # fmt: skip
            self.items.append(item)
            self._save()
            self._run_thread()
            return dict(item)

    def _find(self, item_id: str) -> int:
        for k, item in enumerate(self.items):
            if item["id"] == item_id:
                return k
        raise QueueError(f"queue item {item_id[:20]!r}: not in the queue (started or cancelled meanwhile)")

    def move(self, item_id: str, to: int) -> None:
        """Move an item to position ``to`` (0 = first; a position outside the queue is refused)."""
        with self._lock:
            self._check()
            k = self._find(item_id)
            if not 0 <= to < len(self.items):
                raise QueueError(f"to {to}: expected a position 0 to {len(self.items) - 1}")
            self.items.insert(to, self.items.pop(k))
            self._save()

    def cancel(self, item_id: str) -> None:
        with self._lock:
            self._check()
            del self.items[self._find(item_id)]
            self._save()

    def go(self, item_id: str) -> None:
        """The operator's Start for an item (it starts when it is first for its bench and the bench is free); a start
        that was refused is tried again."""
        with self._lock:
            self._check()
            item = self.items[self._find(item_id)]
            item["go"], item["error"] = True, ""
            self._save()
            self._run_thread()

    def _run_thread(self) -> None:
        if self._thread is None and not self.broken:
            self._thread = threading.Thread(target=self._loop, name="contactrig-queue", daemon=True)
            self._thread.start()

    def begin(self) -> None:
        """Start the queue's thread when the queue holds anything (a console restarted over a queue)."""
        with self._lock:
            if self.items:
                self._run_thread()

    def _loop(self) -> None:
        while not self.closing.wait(TICK_S):
            self.tick()

    def tick(self) -> None:
        """Start the first item of each free bench address when it may start (not waiting for Start, no error)."""
        from contactrig.core.text import bound_error_line

        with self._lock:
            seen: set[str] = set()
            for item in list(self.items):
                address = item["address"]
                if address in seen:
                    continue
                seen.add(address)
                if self.closing.is_set() or item["error"] or (item["wait"] and not item["go"]) or self.busy(address):
                    continue
                try:
                    run = self.start(item["form"])
                except (ValueError, OSError) as exc:
                    item["error"] = bound_error_line(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
                    self._save()
                    continue
                self.items.remove(item)
                self.started.append({"id": item["id"], "file": item["form"].get("output"), "run": run})
                self._save()
