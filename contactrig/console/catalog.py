"""The console's sessions index: :mod:`daq.run_index` (the one index, as ``contactrig sessions --where``), refreshed
in a background thread so that a page never waits for a scan of the folder.

A page asks :meth:`Catalog.rows` (the index as it is, ``query(refresh=False)``, one page of rows) and :meth:`kick`
(a refresh wanted); the refresh thread runs :func:`daq.run_index.refresh` one at a time (kicks while one runs ask for
one more after it, never for several) and counts ``generation`` up after each, so a page polls until the generation
changes and draws again. Tags and remarks are added with
:func:`daq.run_index.add_mark`; a session's own marks are read back from its folder's sidecars by its content id
(:func:`daq.run_index.marks_in`), so the session page shows a new mark at once; two sessions are compared with
:func:`daq.session_diff.session_diff`. Nothing here indexes, searches or compares on its own.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["PAGE_ROWS", "Catalog"]

#: rows on one index page (the newest first); more matching: the page has the next page's button
PAGE_ROWS = 500


@dataclass
class Catalog:
    """The run index of ``root`` for the console, with its refresh thread (started by the first :meth:`kick`)."""

    root: Path
    #: set when the console goes down: the thread ends after the refresh under way
    closed: threading.Event
    generation: int = 0
    #: the last refresh's notes (read-only folder, damaged index rebuilt…) or its error, one line each
    notes: list[str] = field(default_factory=list)
    _wanted: threading.Event = field(default_factory=threading.Event)
    _busy: bool = False
    _thread: threading.Thread | None = None
    _lock: threading.Lock = field(default_factory=threading.Lock)

    @property
    def indexing(self) -> bool:
        """A refresh is under way or wanted."""
        return self._busy or self._wanted.is_set()

    def state(self) -> tuple[int, bool]:
        """``(generation, indexing)`` read together, under the lock: a page that reads them *before* its rows gets
        rows at least as new as what they claim (read after the rows, a refresh that ended meanwhile would claim its
        rows for rows read before it had written them, and the page would stop polling on a stale table)."""
        with self._lock:
            return self.generation, self._busy or self._wanted.is_set()

    def kick(self) -> None:
        """Ask for a refresh: now, or after the one under way (which may have missed a change made meanwhile)."""
        with self._lock:
            if self.closed.is_set():
                return
            self._wanted.set()
            if self._thread is None:
                self._thread = threading.Thread(target=self._loop, name="contactrig-index", daemon=True)
                self._thread.start()

    def _loop(self) -> None:
        from daq import run_index

        while not self.closed.is_set():
            if not self._wanted.wait(timeout=0.5):
                continue
            with self._lock:
                self._busy = True
                self._wanted.clear()
            try:
                self.notes = run_index.refresh(self.root).notes
            except Exception as exc:  # never fatal to the console: the page shows it
                self.notes = [f"index refresh failed: {_one_line(exc)}"]
            finally:
                with self._lock:
                    self._busy = False
                    self.generation += 1

    def rows(
        self, where: Sequence[str], sort: str, *, descending: bool = True, offset: int = 0
    ) -> tuple[list[dict[str, Any]], int]:
        """One page of the index's rows meeting every ``--where`` text (``SettingError`` for a bad one): at most
        :data:`PAGE_ROWS` from ``offset`` on, paths relative to the folder, each with the last fit's verdict (``fit``)
        and without the detail (:data:`daq.run_index.DETAIL_KEYS`: the session page and the diff read it); and how
        many sessions matched in all."""
        from daq.run_index import query

        rows, result = query(
            self.root, where, sort=sort, refresh=False, limit=PAGE_ROWS, descending=descending, detail=False,
            offset=offset,
        )  # fmt: skip
        base = str(self.root) + "/"
        for r in rows:  # inside the folder, as the index keeps them: the prefix off (not a Path per row)
            r["path"] = r["path"][len(base) :] if r["path"].startswith(base) else self.relative(r["path"])
        if result.index is None:  # scanned into memory (read-only folder…): the query did the refresh itself
            self.notes = result.notes
        return rows, result.matched

    def relative(self, path: str) -> str:
        try:
            return Path(path).relative_to(self.root).as_posix()
        except ValueError:
            return path

    def add_mark(self, path: Path, kind: str, text: str, who: str) -> dict[str, str]:
        """A tag or remark on the session ``path`` (:func:`daq.run_index.add_mark`), then a refresh of the index."""
        from contactrig.core.validation import SettingError
        from daq.run_index import add_mark

        if kind not in ("tag", "remark"):
            raise SettingError("kind", kind, "tag or remark")
        clean = who.strip()
        if not clean or len(clean) > 64 or any(ord(c) < 32 for c in clean) or not _utf8(clean):
            raise SettingError("who", who, "the name of who writes it, 1 to 64 characters on one line")
        if not _utf8(text):
            raise SettingError(f"--{kind}", text, "text (Unicode without lone surrogates)")
        mark = add_mark(path, kind, text, who=clean)
        self.kick()
        return mark

    @staticmethod
    def marks_of(path: Path, start: dict[str, Any]) -> list[dict[str, str]]:
        """The tags and remarks of one session (first run's start record ``start``) in its folder's sidecars."""
        from daq.run_index import content_id, marks_in

        cid = content_id(start)
        return [{k: m[k] for k in ("kind", "text", "who", "at")} for m in marks_in(path.parent)
                if m["content_id"] == cid]  # fmt: skip

    def diff(self, a: Path, b: Path) -> dict[str, Any]:
        """:func:`daq.session_diff.session_diff` of two sessions, paths relative to the folder."""
        from daq.session_diff import session_diff

        d = session_diff(a, b, timeout=60)
        d["a"], d["b"] = self.relative(str(a)), self.relative(str(b))
        return d


def _utf8(text: str) -> bool:
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _one_line(exc: BaseException) -> str:
    from contactrig.core.text import bound_error_line

    return bound_error_line(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
