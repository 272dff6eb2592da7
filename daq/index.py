"""The sessions index: one row per session file under a folder (``contactrig sessions [DIR]``).

Each file is read with :func:`daq.session_file.load_session` (bounded time, in a child process, checksums
verified), so a damaged file can neither hang nor crash the index: it is listed as ``corrupt`` with the reader's
one-line reason, and nothing raises. HDF5 files that are not contactrig sessions (sweep and database files of
``simulate``/``database``) are left out unless asked for (``include_other``).

Strings in a row (sample, operator, reason) come from the files: they are data, and whoever shows them escapes
them (:func:`format_table` does, for the terminal). Every string of a row is valid Unicode: text that is not (a file
name that is not UTF-8, or such text stored by an older contactrig) has those bytes as visible ``\\xNN`` escapes
(:func:`contactrig.core.text.shown`, said in the row's note for a file name), so one such file never breaks the
index, its JSON or a page.

Times: sessions record their start as local time with its UTC offset. The index sorts by the instant (a session
recorded under another time zone sorts where it happened) and shows each start with its offset
(``2026-11-21 10:15:17 +01:00``; ``start_shown``); ``start_utc`` is the same instant in UTC.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable, Iterable, MutableMapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from contactrig.core.text import escape_terminal, shown
from daq.errors import NewerSchemaError

if TYPE_CHECKING:
    from daq.session_file import Session

__all__ = ["SESSION_SUFFIXES", "SORT_KEYS", "SessionEntry", "format_table", "index_sessions", "session_entry"]

#: File names looked at (case-insensitive suffixes).
SESSION_SUFFIXES = (".h5", ".hdf5", ".nxs")
#: Columns the index can be sorted by.
SORT_KEYS = ("start", "sample", "operator", "status", "path")
_NOT_A_SESSION = "not a contactrig session"


@dataclass(frozen=True)
class SessionEntry:
    """One session file: ``status`` is the session's (success, aborted, failed, running, incomplete) or, for a file
    that cannot be read, ``corrupt`` / ``newer`` (written by a newer contactrig) / ``other`` (an HDF5 file that is
    not a session); ``kind`` is ``simulated``, ``real`` or ``imported`` (empty when unreadable); ``note`` the
    reader's reason for an unreadable file; ``notes`` the session's notes and ``scene`` its scene name (JSON only);
    ``start_time`` as recorded, ``start_shown`` with its UTC offset for display, ``start_utc`` the instant in UTC
    (ISO 8601; empty when the file records none)."""

    path: str
    status: str
    start_time: str = ""
    sample: str = ""
    operator: str = ""
    blocks_done: int | None = None
    blocks_planned: int | None = None
    kind: str = ""
    compliant_blocks: int = 0
    note: str = ""
    notes: str = ""
    scene: str = ""
    start_shown: str = field(init=False, default="")
    start_utc: str = field(init=False, default="")

    def __post_init__(self) -> None:
        shown_at, utc = _times(self.start_time)
        object.__setattr__(self, "start_shown", shown_at)
        object.__setattr__(self, "start_utc", utc)

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _kind(start: dict[str, Any], imported: bool) -> str:
    if imported:
        return "imported"
    return "simulated" if start.get("sim") else "real"


def _planned(start: dict[str, Any], stop: dict[str, Any] | None) -> int | None:
    for source in (stop or {}, start.get("plan") or {}):
        value = source.get("blocks_planned")
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        if isinstance(value, float) and math.isfinite(value):
            return int(value)
    return None


def scene_name(start: dict[str, Any], scene_text: str) -> str:
    from daq.table_provenance import scene_name as name

    return name(start, scene_text)


def _text(value: Any) -> str:
    """A row's text from a file's value: a string (valid Unicode: see the module docstring)."""
    return shown(value if isinstance(value, str) else ("" if value is None else str(value)))


def _times(started: str) -> tuple[str, str]:
    """(shown with its offset, the instant in UTC as ISO 8601) of a recorded start time; a time without an offset
    is shown as recorded, said, and sorted as if in UTC; an unreadable one is shown as it is, with no instant."""
    try:
        t = datetime.fromisoformat(started)
    except (TypeError, ValueError):
        return started, ""
    if t.tzinfo is None:
        return f"{t:%Y-%m-%d %H:%M:%S} (no UTC offset recorded)", t.replace(tzinfo=UTC).isoformat()
    offset = t.strftime("%z")
    return f"{t:%Y-%m-%d %H:%M:%S} {offset[:3]}:{offset[3:5]}", t.astimezone(UTC).isoformat(timespec="microseconds")


def _named(entry: SessionEntry) -> SessionEntry:
    """``entry`` with its path valid Unicode: a file name that is not UTF-8 is shown with visible escapes, said."""
    if shown(entry.path) == entry.path:
        return entry
    said = ("file name is not UTF-8 (shown with \\xNN escapes): the commands open it by its name; rename it to open "
            "it in the console")  # fmt: skip
    note = f"{said}; {entry.note}" if entry.note else said
    return replace(entry, path=shown(entry.path), note=note)


def session_entry(path: str | Path, *, timeout: float | None = None) -> SessionEntry:
    """The index row of one file; never raises for anything the file holds or its name (only KeyboardInterrupt
    goes through); every string in it is valid Unicode."""
    return session_and_entry(path, timeout=timeout)[1]


def session_and_entry(
    path: str | Path, *, timeout: float | None = None, load: Callable[..., Session] | None = None
) -> tuple[Session | None, SessionEntry]:
    """The session read from ``path`` (None when it cannot be read) and its index row (:func:`session_entry`, with
    its path valid Unicode): one bounded read for callers that keep more of the session than the row
    (:mod:`daq.run_index`). ``load``: the reader (default :func:`daq.session_file.load_session`; a caller already
    inside a bounded child passes the reader's work without a second child)."""
    session, entry = _read(path, timeout, load)
    return session, _named(entry)


def _read(
    path: str | Path, timeout: float | None, load: Callable[..., Session] | None
) -> tuple[Session | None, SessionEntry]:
    from daq.session_file import load_session

    p = Path(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            s = (load or load_session)(p, timeout=timeout)
    except NewerSchemaError as exc:
        return None, SessionEntry(str(p), "newer", note=_first_line(exc))
    except Exception as exc:  # untrusted files: any failure is one row, never an exception
        status = "other" if _NOT_A_SESSION in str(exc) else "corrupt"
        return None, SessionEntry(str(p), status, note=_first_line(exc))
    return s, _entry_of(p, s)


def _entry_of(p: Path, s: Session) -> SessionEntry:
    start = s.start if isinstance(s.start, dict) else {}
    session_plan = (start.get("plan") or {}).get("session") or {}
    return SessionEntry(
        path=str(p),
        status=s.status,
        start_time=_text(start.get("started", "")),
        sample=_text(start.get("sample", session_plan.get("sample", ""))),
        operator=_text(start.get("operator", "")),
        notes=_text(start.get("notes", session_plan.get("notes", ""))),
        scene=scene_name(start, _text(getattr(s, "scene_text", ""))),
        blocks_done=len(s.summary),
        blocks_planned=_planned(start, s.stop),
        kind=_kind(start, s.imported),
        compliant_blocks=len(s.compliant_blocks),
        note="" if s.status in ("success", "running") else _first_line(_last_note(s.warnings)),
    )


def _last_note(notes: Sequence[str]) -> str:
    return notes[-1] if notes else ""


def _first_line(value: object) -> str:
    lines = [ln.strip() for ln in shown(value).splitlines() if ln.strip()]
    return lines[0] if lines else ""


def _session_files(folder: Path) -> list[Path]:
    found = []
    for root, dirs, files in os.walk(folder):  # does not follow symbolic links to folders: no loops
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        found += [Path(root) / f for f in sorted(files) if f.lower().endswith(SESSION_SUFFIXES)]
    return found


def index_sessions(
    folder: str | Path,
    *,
    sample: str | None = None,
    sort: str = "start",
    include_other: bool = False,
    timeout: float | None = None,
    cache: MutableMapping[str, Any] | None = None,
) -> list[SessionEntry]:
    """Every session file under ``folder`` (recursively; ``.h5``, ``.hdf5``, ``.nxs``), one :class:`SessionEntry`
    each, sorted by ``sort`` (one of :data:`SORT_KEYS`; unreadable files last). ``sample``: keep the sessions whose
    sample contains it (case-insensitive). A file that is ``folder`` itself is indexed alone. ``cache`` (a dict kept
    by the caller, e.g. the console) keeps each file's row by its size and time of change: a file read once is not
    read again until it changes (a running session's rows are not kept)."""
    from contactrig.core.validation import SettingError, check_choice

    check_choice("--sort", sort, SORT_KEYS)
    root = Path(folder)
    if root.is_file():
        files = [root]
    elif root.is_dir():
        files = _session_files(root)
    else:
        raise SettingError("DIR", str(root), "an existing folder")
    entries = [_cached_entry(f, timeout, cache) for f in files]
    if not include_other:
        entries = [e for e in entries if e.status != "other"]
    if sample is not None:
        needle = sample.casefold()
        entries = [e for e in entries if needle in e.sample.casefold()]
    return sorted(entries, key=lambda e: _sort_key(e, sort))


def _cached_entry(path: Path, timeout: float | None, cache: MutableMapping[str, Any] | None) -> SessionEntry:
    """The row of ``path``, from ``cache`` when the file has not changed (same size, time of change, inode)."""
    if cache is None:
        return session_entry(path, timeout=timeout)
    try:
        st = os.stat(path)
    except OSError:
        return session_entry(path, timeout=timeout)
    stamp = (st.st_size, st.st_mtime_ns, st.st_ino)
    kept = cache.get(str(path))
    if kept is not None and kept[0] == stamp:
        return kept[1]
    entry = session_entry(path, timeout=timeout)
    if entry.status != "running":
        cache[str(path)] = (stamp, entry)
    return entry


def _sort_key(e: SessionEntry, sort: str) -> tuple[int, int, str, str]:
    """Unreadable files last; by start: the instant (UTC), sessions without one after those with one."""
    readable = 1 if e.status in ("corrupt", "newer", "other") else 0
    if sort == "start":
        return readable, 0 if e.start_utc else 1, e.start_utc or e.start_time, e.path
    value = {"sample": e.sample.casefold(), "operator": e.operator.casefold()}.get(
        sort, e.status if sort == "status" else e.path
    )
    return readable, 0, value, e.path


_COLUMNS = ("start", "status", "blocks", "kind", "sample", "operator", "file")


def _row(e: SessionEntry, base: Path | None) -> list[str]:
    done = "" if e.blocks_done is None else str(e.blocks_done)
    planned = "?" if e.blocks_planned is None else str(e.blocks_planned)
    blocks = f"{done}/{planned}" if done else ""
    if e.compliant_blocks:
        blocks += f" ({e.compliant_blocks} compliance)"
    name = e.path
    if base is not None:
        try:
            name = os.path.relpath(e.path, base)
        except ValueError:  # another drive (Windows)
            pass
    status = e.status.upper() if e.status in ("corrupt", "newer") else e.status
    return [e.start_shown, status, blocks, e.kind, e.sample, e.operator, name]


def format_table(
    entries: Iterable[SessionEntry],
    *,
    base: str | Path | None = None,
    notes: bool = True,
    fits: Sequence[str] | None = None,
) -> str:
    """The index as an aligned text table for the terminal (every string escaped: no control character from a
    file reaches the terminal); unreadable files get their reason on the next line when ``notes``; ``fits``: a
    ``fit`` column (one text per entry: the last fit's verdict, :mod:`daq.run_index`) before the file's."""
    items = list(entries)
    rows = [[escape_terminal(c) for c in _row(e, Path(base) if base is not None else None)] for e in items]
    columns: tuple[str, ...] = _COLUMNS
    if fits is not None:
        columns = (*_COLUMNS[:-1], "fit", _COLUMNS[-1])
        rows = [[*r[:-1], escape_terminal(f), r[-1]] for r, f in zip(rows, fits, strict=True)]
    widths = [max([len(h), *(len(r[i]) for r in rows)]) for i, h in enumerate(columns)]
    widths = [min(w, 48) for w in widths[:-1]] + [widths[-1]]

    def line(cells: Sequence[str]) -> str:
        return "  ".join(_fit(c, w) for c, w in zip(cells, widths, strict=True)).rstrip()

    out = [line(columns)]
    for e, r in zip(items, rows, strict=True):
        out.append(line(r))
        if notes and e.note and e.status not in ("success", "running"):
            out.append(f"    {escape_terminal(e.note)}")
    return "\n".join(out)


def _fit(text: str, width: int) -> str:
    return text.ljust(width) if len(text) <= width else text[: width - 1] + "…"
