"""The run index: a rebuildable SQLite cache over the sealed session files of a folder tree, searchable.

The session files are the record; the index is a cache of what they say, kept in ``DIR/.contactrig-index.sqlite``
(standard library :mod:`sqlite3`, WAL mode, ``PRAGMA user_version`` with numbered upgrades). Deleting it loses
nothing: the next listing reads the files again. What operators add afterwards (tags, remarks) lives in an
append-only sidecar per folder, ``.contactrig-notes.jsonl`` (one JSON object a line, with who wrote it and when),
never in the sealed session; the index reads the sidecars, so tags and remarks survive a rebuild.

Refresh: every session file under DIR is ``stat``-ed; a file whose size, time of modification, time of change and
inode are those the index holds is not read again. Every other file is read in bounded child processes (many
files to a child, a deadline for them all; a child that crashes or hangs costs its batch, read again one file to a
child), two at a time by default. A sealed, finished session is read by its records
(:func:`daq.session_reader.load_records`: start record, scene, runs and stop record against the seal, the block
digests against the stop record, the tables' columns present: ~1/3 of a whole read; ``checked: records``); every
other file is read whole and verified (:func:`daq.session_reader.load_session`'s work; ``checked: whole``), and its
verdict and reason count. The values in the tables are verified whenever a session is loaded (fit, report, export,
replay, ``contactrig sessions FILE``). A file renamed or moved inside the tree (same inode, size and time of
modification) keeps its row without a read; a copy elsewhere is recognised by its content id (the SHA-256 of its
first start record), and tags and remarks follow the content id. A damaged file is a row with status ``corrupt``
and the reader's reason, never dropped, never fatal. A running session is read again at every refresh.

Concurrency: reads happen outside any transaction; the changes are written in one ``BEGIN IMMEDIATE`` transaction
(SQLite serialises writers; ``busy_timeout`` 30 s), and a row is written only when the file still has the stamp it
was read with; the sessions themselves are never written by the index. A read-only folder, an index path that is a
symbolic link, or an index from a newer contactrig: the folder is scanned into memory instead, and the result says so.

Network shares: SQLite's WAL needs memory shared on one computer and its locks are unreliable over NFS and SMB, and
``O_APPEND`` is not atomic between NFS clients. So on a folder on a network share
(:func:`daq.filesystem.network_share`), or on any folder when :data:`INDEX_DIR_ENV` is set, nothing SQLite is kept
on the share: the index lives on this computer (:func:`index_location`: ``<cache>/<16 hex digits of the SHA-256 of
host and resolved folder>.sqlite``, cache ``$CONTACTRIG_INDEX_DIR`` or ``$XDG_CACHE_HOME/contactrig/index``,
created 0700; a note says where and why), each computer its own, rebuilt from the files like any index; and each
computer appends tags, remarks and fit verdicts to a sidecar of its own (``.contactrig-notes.<host>.jsonl``,
``.contactrig-fits.<host>.jsonl``). Every reader reads the plain sidecar and every computer's, merged in time order,
on every folder (a folder copied from a share keeps its marks). On a local folder nothing changes: the index beside
the sessions, the plain sidecars.

Fit verdicts: ``contactrig fit`` appends the verdict of each fit of a session (whether the data discriminate
between the models, the best model, the verdict sentence, who, when, and the analysis version: contactrig's) to
``.contactrig-fits.jsonl`` in the session's folder (:func:`record_fit`; append-only like the notes, never in the
sealed session). The index reads those files too; each row's ``fit`` is the last fit of its content id, marked
``stale`` when it was made with another analysis version than the one running.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import os
import re
import sqlite3
import stat
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from datetime import UTC, date, datetime, timedelta
from pathlib import Path
from typing import TYPE_CHECKING, Any

from contactrig.core.text import shown
from daq.filesystem import network_share
from daq.index import SESSION_SUFFIXES, SORT_KEYS, SessionEntry, session_and_entry

if TYPE_CHECKING:
    from daq.session_file import Session

__all__ = [
    "DETAIL_KEYS",
    "FIELD_HELP",
    "FITS_NAME",
    "FIT_VERDICTS",
    "INDEX_DIR_ENV",
    "INDEX_NAME",
    "SCHEMA_VERSION",
    "SIDECAR_NAME",
    "WHERE_KEYS",
    "Refresh",
    "add_mark",
    "content_id",
    "entry_of",
    "fits_in",
    "index_location",
    "last_fit",
    "marks_in",
    "parse_where",
    "query",
    "read_fits",
    "record_fit",
    "record_of",
    "refresh",
    "session_record",
]

#: The index file inside the folder it indexes (hidden).
INDEX_NAME = ".contactrig-index.sqlite"
#: The append-only file of tags and remarks inside each folder (hidden).
SIDECAR_NAME = ".contactrig-notes.jsonl"
#: The append-only file of fit verdicts inside each folder (hidden), written by ``contactrig fit``.
FITS_NAME = ".contactrig-fits.jsonl"
#: Environment variable: a folder on this computer where the index of every folder is kept (set: every folder is
#: treated as one on a network share, sidecars included; unset: only those on a share, in the user's cache).
INDEX_DIR_ENV = "CONTACTRIG_INDEX_DIR"
#: A sidecar's name: the plain one, or a computer's own on a network share (``.contactrig-notes.<host>.jsonl``).
_SIDECAR = re.compile(r"\.contactrig-(notes|fits)(?:\.([A-Za-z0-9._-]+))?\.jsonl")
#: A fit's verdict: the data discriminate between the models, or they do not (``contactrig fit``'s statement).
FIT_VERDICTS = ("discriminates", "undecided")
#: ``PRAGMA user_version`` of the index this contactrig writes; :data:`_UPGRADES` takes an older one there.
SCHEMA_VERSION = 2
#: Statuses of files that are not readable sessions (listed last).
UNREADABLE = ("corrupt", "newer", "other")
#: ``--where`` keys: key → (operators allowed, what it matches).
WHERE_KEYS: dict[str, tuple[str, str]] = {
    "sample": ("=~", "the sample (= equal, ~ contains; case-insensitive)"),
    "operator": ("=~", "the operator"),
    "scene": ("=~", "the scene name"),
    "status": ("=", "success, aborted, failed, running, incomplete, corrupt, newer"),
    "serial": ("=", "the serial number of either instrument (from *IDN?)"),
    "tag": ("=", "a tag added with `contactrig sessions FILE --tag`"),
    "verdict": ("=", "the last fit's: discriminates, undecided, stale (made with another analysis version), none"),
    "text": ("~", "words in the notes or remarks (full text, all words)"),
    "start": ("<>", "start date or instant, UTC (start>=2026-01-01, start<=2026-01-31)"),
}
#: A record's detail, kept apart from its listing in the index (``query(detail=False)`` leaves it out).
DETAIL_KEYS = ("overrides", "instruments", "settings", "software")
FIELD_HELP = (
    "any value recorded at the start, by its dotted name as `contactrig sessions diff` shows it, under "
    + ", ".join(DETAIL_KEYS)
    + " (settings.delta.nplc=2, settings.delta.nplc>=1, instruments.voltmeter~2182A, software.h5py=3.16.0): "
    "= equal (a number as a number, text case-insensitive, true/false, null), ~ contains, >=/<= numbers"
)
_VERDICT_VALUES = (*FIT_VERDICTS, "stale", "none")
_STATUSES = ("success", "aborted", "failed", "running", "incomplete", "corrupt", "newer", "other")
_WHERE = re.compile(r"^\s*([a-z]+)\s*(>=|<=|=|~)\s*(.*?)\s*$", re.S)
_FIELD = re.compile(r"^\s*((?:" + "|".join(DETAIL_KEYS) + r")(?:\.[^.=~<>\"]+)*)\s*(>=|<=|=|~)\s*(.*?)\s*$", re.S)

_SCHEMA_V1 = """
CREATE TABLE sessions (
    path TEXT PRIMARY KEY, size INTEGER, mtime_ns INTEGER, ctime_ns INTEGER, inode INTEGER,
    content_id TEXT NOT NULL, status TEXT NOT NULL, start_utc TEXT NOT NULL, sample TEXT NOT NULL,
    operator TEXT NOT NULL, scene TEXT NOT NULL, serials TEXT NOT NULL, record TEXT NOT NULL);
CREATE INDEX sessions_content ON sessions(content_id);
CREATE INDEX sessions_start ON sessions(start_utc);
CREATE TABLE sidecars (path TEXT PRIMARY KEY, size INTEGER, mtime_ns INTEGER);
CREATE TABLE marks (sidecar TEXT NOT NULL, line INTEGER NOT NULL, content_id TEXT NOT NULL, kind TEXT NOT NULL,
    text TEXT NOT NULL, who TEXT NOT NULL, at TEXT NOT NULL, file TEXT NOT NULL, PRIMARY KEY (sidecar, line));
CREATE INDEX marks_content ON marks(content_id);
CREATE VIRTUAL TABLE notes_text USING fts5(path UNINDEXED, body);
CREATE VIRTUAL TABLE remarks_text USING fts5(content_id UNINDEXED, body);
"""
_SCHEMA_V2 = """
CREATE TABLE fits (sidecar TEXT NOT NULL, line INTEGER NOT NULL, content_id TEXT NOT NULL, verdict TEXT NOT NULL,
    best TEXT NOT NULL, statement TEXT NOT NULL, analysis_version TEXT NOT NULL, who TEXT NOT NULL, at TEXT NOT NULL,
    file TEXT NOT NULL, PRIMARY KEY (sidecar, line));
CREATE INDEX fits_content ON fits(content_id, at);
CREATE INDEX sessions_sample ON sessions(sample COLLATE NOCASE);
CREATE INDEX sessions_operator ON sessions(operator COLLATE NOCASE);
CREATE INDEX sessions_scene ON sessions(scene COLLATE NOCASE);
CREATE INDEX sessions_status ON sessions(status);
CREATE INDEX marks_kind_text ON marks(kind, text);
ALTER TABLE sessions ADD COLUMN detail TEXT NOT NULL DEFAULT '{}';
DELETE FROM sessions;
DELETE FROM notes_text;
"""
#: Numbered upgrades: ``_UPGRADES[k]`` takes an index of version k to k + 1 (2: fits, indexes on the columns searched,
#: a row's detail apart from its listing; its rows are read again from the files).
_UPGRADES: dict[int, str] = {0: _SCHEMA_V1, 1: _SCHEMA_V2}


@dataclass
class Refresh:
    """What a refresh did: files ``read``, ``kept`` (unchanged), ``moved`` (renamed, row kept), ``removed``; ``index``
    the index file (None: scanned into memory, ``notes`` say why)."""

    index: Path | None
    read: int = 0
    kept: int = 0
    moved: int = 0
    removed: int = 0
    notes: list[str] = field(default_factory=list)
    #: (:func:`query`) the sessions that met the conditions, before ``offset`` and ``limit``
    matched: int = 0


# --- one file ------------------------------------------------------------------------------------------------------


def content_id(start: dict[str, Any]) -> str:
    """The content id of a session: SHA-256 of its first start record (canonical JSON): the same for a copy, a
    renamed file and a resumed session, different for every session started."""
    text = json.dumps(start, sort_keys=True, ensure_ascii=True, default=str, allow_nan=True)
    return "sha256:" + hashlib.sha256(text.encode()).hexdigest()


def _bytes_id(path: Path) -> str:
    """The content id of an unreadable file: SHA-256 of its bytes (of its first and last 8 MiB beyond 16 MiB)."""
    h = hashlib.sha256()
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return "bytes:unreadable:" + hashlib.sha256(str(path).encode()).hexdigest()
    with os.fdopen(fd, "rb") as f:
        st = os.fstat(f.fileno())
        if not stat.S_ISREG(st.st_mode):
            return "bytes:not-a-file:" + hashlib.sha256(str(path).encode()).hexdigest()
        if st.st_size <= 16 << 20:
            h.update(f.read())
        else:
            h.update(f.read(8 << 20))
            f.seek(-(8 << 20), os.SEEK_END)
            h.update(f.read())
            h.update(str(st.st_size).encode())
    return "bytes:" + h.hexdigest()


def _utc(text: str, assume_utc: bool = False) -> str:
    """An ISO-8601 instant with its UTC offset, as UTC (``2026-01-01T10:00:00.000000+00:00``); "" when unparsable,
    out of range (9999-12-31T23:00-05:00 is past year 9999 in UTC) or without an offset (an instant without one
    cannot be ordered against others; ``assume_utc``: taken as UTC)."""
    try:
        t = datetime.fromisoformat(text)
        if t.tzinfo is None and not assume_utc:
            return ""
        return (t if t.tzinfo is not None else t.replace(tzinfo=UTC)).astimezone(UTC).isoformat(timespec="microseconds")
    except (TypeError, ValueError, OverflowError):
        return ""


def _instant_key(text: str) -> str:
    """A sort key of an ISO-8601 instant: the instant in UTC (no offset: taken as UTC; unparsable or out of range:
    "", first). The one order of marks and fits: in SQL as ``instant(at)`` (:func:`_functions`) and in
    :func:`marks_in`, :func:`fits_in` and :func:`last_fit`."""
    return _utc(text, assume_utc=True)


def _serial(idn: str) -> str:
    """The serial number in an ``*IDN?`` reply (maker, model, serial, firmware)."""
    parts = [p.strip() for p in idn.split(",")]
    return parts[2] if len(parts) >= 4 else ""


def session_record(path: str | Path, *, timeout: float | None = None) -> dict[str, Any]:
    """Everything the index holds about one file, read once with the bounded reader; never raises for what the file
    holds. Keys: those of :class:`daq.index.SessionEntry` plus ``content_id``, ``start_utc``, ``end_time``,
    ``scene_sha256``, ``overrides``, ``instruments`` (``*IDN?`` of source and voltmeter), ``serials``,
    ``settings`` (the pinned state read back at the start, the delta and instrument settings of the plan),
    ``invalid_readings``, ``software`` (versions), ``software_version``, ``fit`` (None here; the index gives
    the last fit recorded with :func:`record_fit`) and ``checked`` (``whole``: every block's SHA-256 and the whole
    seal; ``records``: :func:`daq.session_reader.load_records`; "": unreadable)."""
    p = Path(path)
    session, entry = session_and_entry(p, timeout=timeout)
    return record_of(p, session, entry)


def record_of(p: Path, session: Session | None, entry: SessionEntry) -> dict[str, Any]:
    """:func:`session_record` of a session already read (None: unreadable) and its index row."""
    from contactrig.core.fingerprint import sha256_text

    record: dict[str, Any] = {
        **entry.as_dict(), "content_id": "", "start_utc": _utc(entry.start_time), "end_time": "",
        "scene_sha256": "", "overrides": {}, "instruments": {}, "serials": [], "settings": {},
        "invalid_readings": 0, "software": {}, "software_version": "", "fit": None, "checked": "",
    }  # fmt: skip
    if session is None:
        record["content_id"] = _bytes_id(p)
        return record
    start = session.start if isinstance(session.start, dict) else {}
    first = session.runs[0] if session.runs and isinstance(session.runs[0], dict) else start
    instrument, plan, software = (_mapping(start.get(k)) for k in ("instrument", "plan", "software"))
    idns = {k: str(instrument[k]) for k in ("source", "voltmeter") if isinstance(instrument.get(k), str)}
    stop = session.stop or {}
    invalid = session.summary["n_invalid"].sum() if "n_invalid" in session.summary else 0
    record.update(
        content_id=content_id(first),
        end_time=str(stop.get("stopped", "")),
        scene_sha256=sha256_text(session.scene_text) if session.scene_text else "",
        overrides=_mapping(start.get("overrides")),
        instruments=idns,
        serials=sorted({s for s in (_serial(v) for v in idns.values()) if s}),
        settings={
            "pinned_state": instrument.get("pinned_state") or {},
            "delta": plan.get("delta") or {},
            "instrument": plan.get("instrument") or {},
        },
        invalid_readings=int(invalid),
        software={str(k): str(v) for k, v in software.items()},
        software_version=str(software.get("contactrig", "")),
        checked="whole" if session.tables_read else "records",
    )
    return json.loads(json.dumps(record, default=str))  # plain JSON values (numpy scalars, non-finite floats)


def _mapping(value: Any) -> dict[str, Any]:
    return value if isinstance(value, dict) else {}



#: Files read by one bounded child in a row (the fork is paid once per batch, not once per file).
BATCH = 48


def _load_here(path: Path, *, timeout: float | None = None) -> Session:
    """The bounded reader's own work, run inside a child that :func:`_read_batch` already bounds: a sealed,
    finished session's records (:func:`daq.session_reader.load_records`: records and block digests against the
    seal, a few HDF5 members), any other file read whole and verified (as :func:`daq.session_reader.load_session`
    does in its child), whose verdict and reason count."""
    from daq.bounded import check_regular_file
    from daq.session_reader import _load, load_records

    check_regular_file(path, "session file")
    return load_records(path) or _load(path, True)


def _records_here(paths: list[Path]) -> list[dict[str, Any]]:
    return [record_of(p, *session_and_entry(p, load=_load_here)) for p in paths]


def _read_batch(paths: list[Path], timeout: float | None) -> list[dict[str, Any]]:
    """:func:`session_record` of each of ``paths``, read one after the other in one bounded child process (deadline:
    that of all their bytes); a batch that hangs or crashes the HDF5 library is read again file by file, each in its
    own child, so the bad file is found and listed with its reason."""
    from daq.bounded import call_bounded, timeout_for
    from daq.errors import SessionFileError

    sizes = [s[0] for s in (_stamp(p) for p in paths) if s is not None]
    limit = timeout_for(sum(sizes)) + 0.05 * len(paths)
    try:
        return call_bounded(_records_here, (paths,), path=paths[0], what="session file", timeout=limit)
    except (SessionFileError, OSError):
        return [session_record(p, timeout=timeout) for p in paths]


def _read_all(paths: list[Path], jobs: int, timeout: float | None) -> list[dict[str, Any]]:
    """Records of ``paths`` in order, ``jobs`` bounded children at once (threads waiting on them)."""
    if not paths:
        return []
    # What the readers run, imported here once: a forked child inherits it; a child that imports it itself pays
    # ~0.4 s of CPU (h5py, pandas) a batch, twice what reading the batch's files costs (measured: 15.7 against 5.5 ms
    # of the readers' CPU a file).
    from contactrig.core import fingerprint  # noqa: F401
    from daq import bounded, session_file, session_reader, table_provenance  # noqa: F401

    size = max(1, min(BATCH, -(-len(paths) // max(1, jobs))))
    batches = [paths[i : i + size] for i in range(0, len(paths), size)]
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        return [r for batch in pool.map(lambda b: _read_batch(b, timeout), batches) for r in batch]


def entry_of(record: dict[str, Any]) -> SessionEntry:
    """The :class:`daq.index.SessionEntry` of an index record (for :func:`daq.index.format_table`)."""
    names = {f.name for f in dataclasses.fields(SessionEntry) if f.init}
    return SessionEntry(**{k: v for k, v in record.items() if k in names})


# --- the index file ------------------------------------------------------------------------------------------------


def _is_link(path: Path) -> bool:
    return path.is_symlink()


def _shared(folder: Path) -> str:
    """Why ``folder`` is treated as one on a network share ("": it is not; see the module's "Network shares")."""
    if os.environ.get(INDEX_DIR_ENV):
        return f"{folder} is treated as shared ({INDEX_DIR_ENV} is set)"
    kind = network_share(folder)
    return f"{folder} is on a network share ({kind})" if kind else ""


def _cache_dir() -> Path:
    """Where this computer keeps the indexes of shared folders: ``$CONTACTRIG_INDEX_DIR``, else
    ``$XDG_CACHE_HOME/contactrig/index`` (default ``~/.cache``; on Windows ``%LOCALAPPDATA%``)."""
    chosen = os.environ.get(INDEX_DIR_ENV)
    if chosen:
        return Path(chosen)
    base = os.environ.get("LOCALAPPDATA" if os.name == "nt" else "XDG_CACHE_HOME", "")
    return (Path(base) if os.path.isabs(base) else Path.home() / ".cache") / "contactrig" / "index"


def index_location(folder: str | Path) -> tuple[Path, str]:
    """Where the index of ``folder`` is kept, and why when it is not ``folder/`` :data:`INDEX_NAME` (a folder on a
    network share, or :data:`INDEX_DIR_ENV` set: a file of this computer's cache named by the SHA-256 of the host
    name and the resolved folder, so computers sharing a home folder do not share a file)."""
    from contactrig.core.provenance import host_name

    root = Path(folder)
    why = _shared(root)
    if not why:
        return root / INDEX_NAME, ""
    key = f"{host_name()}\n{os.path.realpath(root)}".encode("utf-8", "surrogateescape")
    return _cache_dir() / f"{hashlib.sha256(key).hexdigest()[:16]}.sqlite", why


def _cache_problem(cache: Path) -> str:
    """Why the cache folder cannot hold an index ("": it can; created, 0700, if absent)."""
    if not cache.is_absolute():
        return f"the index folder {cache} is not an absolute path"
    if cache.is_symlink():
        return f"the index folder {cache} is a symbolic link: not followed"
    try:
        os.makedirs(cache, mode=0o700, exist_ok=True)
    except OSError as exc:
        return f"the index folder {cache} cannot be created ({exc.strerror or exc})"
    if cache.is_symlink() or not cache.is_dir() or not os.access(cache, os.W_OK):
        return f"the index folder {cache} is not a writable folder"
    return ""


@contextlib.contextmanager
def _connect(root: Path, notes: list[str]) -> Iterator[tuple[sqlite3.Connection, Path | None]]:
    """The index of ``root`` (created or upgraded), or an in-memory one with a note saying why."""
    index, shared = index_location(root)
    con = None
    where: Path | None = None
    why = _cache_problem(index.parent) if shared else ""
    if why:
        why = f"{shared}: {why}"
    elif any(_is_link(Path(f"{index}{s}")) for s in ("", "-wal", "-shm", "-journal")):
        why = f"{index} (or its -wal/-shm) is a symbolic link: not followed"
    elif not shared and not os.access(root, os.W_OK):
        why = f"{root} is read-only: the index cannot be kept there"
    else:
        try:
            fd = os.open(index, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o644)
            os.close(fd)
            con = _open(str(index))
            where = index
        except _NewerIndex:
            why = f"{index} was written by a newer contactrig (schema {_version_of(index)}): left as it is"
        except (sqlite3.DatabaseError, OSError) as exc:
            why = f"{index} cannot be used ({exc})"
            if isinstance(exc, sqlite3.DatabaseError) and not isinstance(exc, sqlite3.OperationalError):
                with contextlib.suppress(OSError, sqlite3.Error):  # a damaged cache: rebuilt from the files
                    for suffix in ("-wal", "-shm", ""):
                        with contextlib.suppress(FileNotFoundError):
                            os.unlink(f"{index}{suffix}")
                    con, where, why = _open(str(index)), index, ""
                    notes.append(f"{index} was damaged: rebuilt from the session files")
    if con is None:
        notes.append(f"{why}; the folder was scanned instead")
        con = _open(":memory:")
    elif shared:
        notes.insert(0, f"{shared}: its index is kept on this computer, {index}")
    try:
        yield con, where
    finally:
        con.close()


class _NewerIndex(Exception):
    pass


def _version_of(index: Path) -> int:
    try:
        with contextlib.closing(sqlite3.connect(f"file:{index}?mode=ro", uri=True)) as c:
            return int(c.execute("PRAGMA user_version").fetchone()[0])
    except sqlite3.Error:
        return -1


def _functions(con: sqlite3.Connection) -> sqlite3.Connection:
    """``instant(at)``: :func:`_instant_key` in SQL, so that SQLite orders marks and fits exactly as Python does
    (SQLite's own ``julianday`` reads fewer ISO-8601 forms and only milliseconds)."""
    con.create_function("instant", 1, _instant_key, deterministic=True)
    return con


def _open(name: str) -> sqlite3.Connection:
    con = _functions(sqlite3.connect(name, timeout=30.0, isolation_level=None))
    con.execute("PRAGMA busy_timeout = 30000")
    if name != ":memory:":
        con.execute("PRAGMA journal_mode = WAL")
        con.execute("PRAGMA synchronous = NORMAL")
    version = int(con.execute("PRAGMA user_version").fetchone()[0])
    if version > SCHEMA_VERSION:
        con.close()
        raise _NewerIndex
    if version < SCHEMA_VERSION:
        con.execute("BEGIN IMMEDIATE")
        try:
            version = int(con.execute("PRAGMA user_version").fetchone()[0])  # another process may have done it
            for k in range(version, SCHEMA_VERSION):
                for statement in _UPGRADES[k].split(";"):
                    if statement.strip():
                        con.execute(statement)
                con.execute(f"PRAGMA user_version = {k + 1}")
            con.execute("COMMIT")
        except BaseException:
            con.execute("ROLLBACK")
            raise
    return con


# --- refresh -------------------------------------------------------------------------------------------------------


def _walk(root: Path) -> tuple[list[Path], list[Path]]:
    """Session files and sidecars under ``root`` (as :func:`daq.index.index_sessions`: hidden folders skipped,
    symbolic links to folders not followed)."""
    sessions, sidecars = [], []
    for top, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for f in sorted(files):
            if f.lower().endswith(SESSION_SUFFIXES):
                sessions.append(Path(top) / f)
            elif _SIDECAR.fullmatch(f):
                sidecars.append(Path(top) / f)
    return sessions, sidecars


def _stamp(path: Path) -> tuple[int, int, int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino


_Stamp = tuple[int, int, int, int]
#: A file modified less than this before a refresh began is read again at the next one: a change within the
#: file system's time resolution would leave size and times as they were (git's "racily clean" entries).
_SETTLE_NS = 2_000_000_000


def _row(path: str, stamp: _Stamp | None, rec: dict[str, Any], settled_ns: int) -> tuple[Any, ...]:
    from contactrig.core.provenance import json_finite

    trusted = stamp is not None and stamp[1] < settled_ns and rec["status"] != "running"
    size, mtime, ctime, ino = stamp if stamp is not None and trusted else (None,) * 4
    return (
        path, size, mtime, ctime, ino, rec["content_id"], rec["status"], rec["start_utc"], rec["sample"],
        rec["operator"], rec["scene"], " ".join(rec["serials"]),
        json.dumps({k: v for k, v in rec.items() if k not in DETAIL_KEYS}),
        # the detail strict JSON (no NaN): SQLite's JSON functions read it for --where on a recorded value
        json.dumps(json_finite({k: rec[k] for k in DETAIL_KEYS if k in rec}), allow_nan=False),
    )  # fmt: skip


def _write_session(con: sqlite3.Connection, row: tuple[Any, ...], notes_text: str) -> None:
    con.execute("INSERT OR REPLACE INTO sessions VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?)", row)
    con.execute("DELETE FROM notes_text WHERE path = ?", (row[0],))
    if notes_text:
        con.execute("INSERT INTO notes_text (path, body) VALUES (?, ?)", (row[0], notes_text))


def _delete_session(con: sqlite3.Connection, path: str) -> None:
    con.execute("DELETE FROM sessions WHERE path = ?", (path,))
    con.execute("DELETE FROM notes_text WHERE path = ?", (path,))


def _changes(
    known: dict[str, Any], on_disk: dict[str, _Stamp | None]
) -> tuple[list[str], list[str], list[tuple[str, str]], list[tuple[None, str]]]:
    """Paths gone, paths changed, moves (old, new: same size, time of modification and inode) and paths to read."""
    gone = [p for p in known if p not in on_disk]
    changed = [p for p, s in on_disk.items() if s is None or known.get(p) != s]
    by_file = {(known[p][0], known[p][1], known[p][3]): p for p in gone if known[p][0] is not None}
    moves: list[tuple[str, str]] = []
    to_read: list[tuple[None, str]] = []
    for p in changed:
        s = on_disk[p]
        old = by_file.pop((s[0], s[1], s[3]), None) if s is not None and p not in known else None
        if old is not None:
            moves.append((old, p))
        else:
            to_read.append((None, p))
    return gone, changed, moves, to_read


def _key(rel: str) -> str:
    """The index's key of a relative path: the path itself, or for a file name that is not UTF-8 (SQLite keeps only
    Unicode text) the name with its undecodable bytes as ``\\xNN``, as it is shown (:func:`contactrig.core.text.shown`);
    such a file is still read by its real name."""
    return shown(rel)


def _refresh(con: sqlite3.Connection, root: Path, result: Refresh, jobs: int, timeout: float | None) -> None:
    """Bring the index ``con`` of ``root`` up to date; paths are kept relative to ``root`` (the index still holds
    when the folder is moved or mounted elsewhere)."""
    settled = time.time_ns() - _SETTLE_NS
    files, sidecars = _walk(root)
    known = {
        r[0]: (r[1], r[2], r[3], r[4])
        for r in con.execute("SELECT path, size, mtime_ns, ctime_ns, inode FROM sessions")
    }
    real = {_key(rel): rel for rel in (os.path.relpath(f, root) for f in files)}
    on_disk = {k: _stamp(root / rel) for k, rel in real.items()}
    gone, changed, moves, to_read = _changes(known, on_disk)
    records = _read_all([root / real[p] for _, p in to_read], jobs, timeout)
    moved_from = {old for old, _ in moves}
    con.execute("BEGIN IMMEDIATE")
    try:
        for p in gone:
            if not os.path.lexists(root / p) and p not in moved_from:
                _delete_session(con, p)
                result.removed += 1
        for old, new in moves:
            kept = con.execute("SELECT record, status, detail FROM sessions WHERE path = ?", (old,)).fetchone()
            if kept is None or kept[1] in UNREADABLE or os.path.lexists(root / old):  # (its reason names the path)
                rec = session_record(root / real[new], timeout=timeout)
                result.read += 1
            else:
                rec = {**json.loads(kept[0]), **json.loads(kept[2])}
                result.moved += 1
            if kept is not None and not os.path.lexists(root / old):
                _delete_session(con, old)
            _write_session(con, _row(new, on_disk[new], rec, settled), rec["notes"])
        for (_, p), rec in zip(to_read, records, strict=True):
            same = _stamp(root / real[p]) == on_disk[p]  # else it changed while read: listed, read again next time
            _write_session(con, _row(p, on_disk[p] if same else None, rec, settled), rec["notes"])
            result.read += 1
        result.kept = len(on_disk) - len(changed)
        _refresh_sidecars(con, root, sidecars)
        con.execute("COMMIT")
    except BaseException:
        con.execute("ROLLBACK")
        raise


def _refresh_sidecars(con: sqlite3.Connection, root: Path, sidecars: Sequence[Path]) -> None:
    """Reload every sidecar that changed (they are small; a line is never rewritten, only added)."""
    known = {r[0]: (r[1], r[2]) for r in con.execute("SELECT path, size, mtime_ns FROM sidecars")}
    present = {os.path.relpath(s, root): s for s in sidecars}
    changed = {p for p in known if p not in present}
    for p in changed:
        con.execute("DELETE FROM sidecars WHERE path = ?", (p,))
    for p, full in present.items():
        s = _stamp(full)
        if s is None or known.get(p) == (s[0], s[1]):
            continue
        changed.add(p)
        con.execute("INSERT OR REPLACE INTO sidecars VALUES (?,?,?)", (p, s[0], s[1]))
    for p in changed:
        if _kind(os.path.basename(p)) == "fits":
            con.execute("DELETE FROM fits WHERE sidecar = ?", (p,))
            con.executemany(
                "INSERT INTO fits VALUES (?,?,?,?,?,?,?,?,?,?)",
                [(p, i, *(f[k] for k in _FIT_KEYS)) for i, f in enumerate(read_fits(root / p))],
            )
            continue
        con.execute("DELETE FROM marks WHERE sidecar = ?", (p,))
        rows = [(p, i, m["content_id"], m["kind"], m["text"], m["who"], m["at"], m["file"])
                for i, m in enumerate(read_marks(root / p))]  # fmt: skip
        con.executemany("INSERT INTO marks VALUES (?,?,?,?,?,?,?,?)", rows)
    if changed:
        con.execute("DELETE FROM remarks_text")
        con.execute(
            "INSERT INTO remarks_text (content_id, body) SELECT content_id, text FROM marks WHERE kind = 'remark'"
        )


def _root(folder: str | Path) -> Path:
    from contactrig.core.validation import SettingError

    root = Path(folder)
    if not root.is_dir():
        raise SettingError("DIR", str(root), "an existing folder")
    return root


def refresh(folder: str | Path, *, jobs: int = 2, timeout: float | None = None) -> Refresh:
    """Bring the index of ``folder`` up to date with its files (reads only what changed; ``jobs`` reads at once)."""
    notes: list[str] = []
    root = _root(folder)
    with _connect(root, notes) as (con, where):
        result = Refresh(where, notes=notes)
        _refresh(con, root, result, jobs, timeout)
    return result


# --- tags and remarks ----------------------------------------------------------------------------------------------

_MARK_KINDS = {"tag": 64, "remark": 4000}  # kind → longest text allowed (characters)


def _read_lines(sidecar: Path, keys: Sequence[str]) -> list[dict[str, str]]:
    """The JSON objects of one append-only sidecar that have every one of ``keys`` as text, in order (symbolic
    links not followed); a line that is not one (a write cut short, an edit by hand) is skipped."""
    try:
        fd = os.open(sidecar, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as f:
            if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
                return []
            raw = f.read(64 << 20)
    except OSError:
        return []
    out = []
    for line in raw.split(b"\n"):
        try:
            obj = json.loads(line)
        except (ValueError, UnicodeDecodeError, RecursionError):
            continue
        if isinstance(obj, dict) and all(isinstance(obj.get(k), str) for k in keys):
            out.append({k: obj[k] for k in keys})
    return out


def _kind(name: str) -> str:
    """``notes`` or ``fits`` for a sidecar's file name ("" for any other name)."""
    m = _SIDECAR.fullmatch(name)
    return m.group(1) if m else ""


def _own_sidecar(folder: Path, name: str) -> Path:
    """The sidecar ``name`` (:data:`SIDECAR_NAME`, :data:`FITS_NAME`) this computer appends to in ``folder``: the
    plain one, or on a network share its own, ``.contactrig-notes.<host>.jsonl`` (host name as [A-Za-z0-9._-])."""
    if not _shared(folder):
        return folder / name
    from contactrig.core.provenance import host_name

    host = re.sub(r"[^A-Za-z0-9._-]", "_", host_name())[:64].strip(".") or "unknown"
    return folder / f"{name.removesuffix('.jsonl')}.{host}.jsonl"


def _merged(folder: Path, kind: str, read: Callable[[Path], list[dict[str, str]]]) -> list[dict[str, str]]:
    """What ``read`` finds in the plain sidecar of ``kind`` and every computer's own in ``folder``, in time order
    (as the index orders them: by the instant ``at`` in UTC, whatever its offset, then by file name and line)."""
    try:
        names = sorted(n for n in os.listdir(folder) if _kind(n) == kind)
    except OSError:
        return []
    lines = [(_instant_key(m["at"]), n, i, m) for n in names for i, m in enumerate(read(folder / n))]
    return [m for *_, m in sorted(lines, key=lambda t: t[:3])]


def _append_line(sidecar: Path, obj: dict[str, str]) -> None:
    """One line appended to a sidecar (created if absent; a symbolic link is refused, never followed): one write
    of one line with O_APPEND, so the lines of concurrent writers never interleave; synced to disk."""
    line = (json.dumps(obj, ensure_ascii=True) + "\n").encode()
    fd = os.open(sidecar, os.O_WRONLY | os.O_APPEND | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o644)
    try:
        os.write(fd, line)
        os.fsync(fd)
    finally:
        os.close(fd)


def read_marks(sidecar: Path) -> list[dict[str, str]]:
    """The tags and remarks of one sidecar, in order; a line that is not one complete mark (a write cut short, an
    edit by hand) is skipped."""
    keys = ("content_id", "kind", "text", "who", "at", "file")
    return [m for m in _read_lines(sidecar, keys) if m["kind"] in _MARK_KINDS]


def marks_in(folder: str | Path) -> list[dict[str, str]]:
    """The tags and remarks of ``folder``'s sidecars (the plain one and every computer's), in time order."""
    return _merged(Path(folder), "notes", read_marks)


def add_mark(file: str | Path, kind: str, text: str, *, who: str | None = None) -> dict[str, str]:
    """Append a tag or remark on the session ``file`` to the sidecar of its folder (the session is not touched) and
    return it. The session is recognised by its content id: the mark follows a copy or a move."""
    from contactrig.core.provenance import login_name, now_iso
    from contactrig.core.validation import SettingError

    option = f"--{kind}"
    limit = _MARK_KINDS[kind]
    clean = text.strip()
    if not clean or len(clean) > limit or any(ord(c) < 32 for c in clean) or (kind == "tag" and " " in clean):
        what = "one word" if kind == "tag" else "one line of text"
        raise SettingError(option, text, f"{what}, 1 to {limit} characters, no control characters")
    p = Path(file)
    if not p.is_file() or not p.name.lower().endswith(SESSION_SUFFIXES):
        raise SettingError("FILE", str(p), f"an existing session file ({', '.join(SESSION_SUFFIXES)})")
    rec = session_record(p)
    if rec["status"] == "other":
        raise SettingError("FILE", str(p), "a contactrig session file (this HDF5 file is not one)")
    mark = {"content_id": rec["content_id"], "kind": kind, "text": clean, "who": who or login_name(),
            "at": now_iso(), "file": p.name}  # fmt: skip
    _append_line(_own_sidecar(p.parent, SIDECAR_NAME), mark)
    return mark


# --- fit verdicts --------------------------------------------------------------------------------------------------

_FIT_KEYS = ("content_id", "verdict", "best", "statement", "analysis_version", "who", "at", "file")


def read_fits(sidecar: Path) -> list[dict[str, str]]:
    """The fit verdicts of one fits sidecar (:data:`FITS_NAME`), in order; an incomplete line is skipped."""
    return [f for f in _read_lines(sidecar, _FIT_KEYS) if f["verdict"] in FIT_VERDICTS]


def record_fit(
    file: str | Path, *, discriminates: bool, best: str, statement: str, who: str | None = None
) -> dict[str, str]:
    """Append the verdict of a fit of the session ``file`` (``discriminates``: the data discriminate between the
    models; ``best``: the best model; ``statement``: the verdict in words) to :data:`FITS_NAME` in its folder,
    with who, when and the analysis version (contactrig's), and return it. The session is not touched; it is
    recognised by its content id (the verdict follows a copy or a move)."""
    from contactrig.core.provenance import login_name, now_iso, software_version
    from contactrig.core.validation import SettingError

    p = Path(file)
    rec = session_record(p)
    if rec["status"] in UNREADABLE:
        raise SettingError("FILE", str(p), "a readable contactrig session file")
    fit = {"content_id": rec["content_id"], "verdict": FIT_VERDICTS[0] if discriminates else FIT_VERDICTS[1],
           "best": best, "statement": statement, "analysis_version": software_version(), "who": who or login_name(),
           "at": now_iso(), "file": p.name}  # fmt: skip
    _append_line(_own_sidecar(p.parent, FITS_NAME), fit)
    return fit


def fits_in(folder: str | Path) -> list[dict[str, str]]:
    """The fit verdicts of ``folder``'s fits sidecars (the plain one and every computer's), in time order."""
    return _merged(Path(folder), "fits", read_fits)


def last_fit(file: str | Path, cid: str) -> dict[str, str] | None:
    """The last fit of the session of content id ``cid`` recorded in the fits files of ``file``'s folder (None:
    never fitted there; a tie in time: the later file name, then line, as the index)."""
    fits = [f for f in fits_in(Path(file).parent) if f["content_id"] == cid]
    return fits[-1] if fits else None


def _last_fits(con: sqlite3.Connection) -> dict[str, dict[str, Any]]:
    """The last fit of each content id (by the instant, UTC: a later fit written at another UTC offset, e.g. after a
    change to daylight saving time, is the later one; then by file and line), ``stale`` when made with another
    analysis version than this contactrig's."""
    from contactrig.core.provenance import software_version

    now = ""  # read from the package's metadata when there is a fit (a few ms: not for every listing)
    out: dict[str, dict[str, Any]] = {}
    for row in con.execute(f"SELECT {', '.join(_FIT_KEYS)} FROM fits ORDER BY instant(at), sidecar, line"):
        fit = dict(zip(_FIT_KEYS, row, strict=True))
        now = now or software_version()
        fit["stale"] = fit["analysis_version"] != now
        out[fit.pop("content_id")] = fit
    return out


# --- search --------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Condition:
    """One ``--where`` condition: ``key`` (:data:`WHERE_KEYS`), ``op`` (= ~ >= <=) and ``value``."""

    key: str
    op: str
    value: str


def parse_where(text: str) -> Condition:
    """``KEY=VALUE``, ``KEY~VALUE``, ``start>=DATE`` or ``start<=DATE``; SettingError naming ``--where`` otherwise."""
    from contactrig.core.validation import SettingError

    allowed = (
        "KEY=VALUE, KEY~TEXT or start>=/<=DATE with KEY one of " + ", ".join(WHERE_KEYS)
        + ", or a recorded value's dotted name under " + ", ".join(DETAIL_KEYS) + " (settings.delta.nplc=2)"
    )  # fmt: skip
    f = _FIELD.match(text)
    if f is not None and f.group(3):
        name, op, value = f.groups()
        if op in (">=", "<=") and _number(value) is None:
            raise SettingError("--where", text, f"{name}{op}NUMBER (>= and <= compare numbers)")
        return Condition(name.strip(), op, value)
    m = _WHERE.match(text)
    if m is None or m.group(1) not in WHERE_KEYS or not m.group(3):
        raise SettingError("--where", text, allowed)
    key, op, value = m.groups()
    ops = WHERE_KEYS[key][0]
    if (op in "=~" and op not in ops) or (op in (">=", "<=") and ops != "<>") or (ops == "<>" and op in "=~"):
        raise SettingError("--where", text, f"{key}: {WHERE_KEYS[key][1]}")
    if key == "start":
        _instant(value, op, text)
    if key == "status" and value not in _STATUSES:
        raise SettingError("--where", text, "status=" + "|".join(_STATUSES))
    if key == "verdict" and value not in _VERDICT_VALUES:
        raise SettingError("--where", text, "verdict=" + "|".join(_VERDICT_VALUES))
    if key == "text" and not _words(value):
        raise SettingError("--where", text, "text~WORDS with at least one word")
    return Condition(key, op, value)


def _instant(value: str, op: str, text: str) -> str:
    """The UTC bound of a ``start`` condition: a date covers its whole day (UTC); an instant needs its offset."""
    from contactrig.core.validation import SettingError

    try:
        day = date.fromisoformat(value)
    except ValueError:
        bound = _utc(value)
        if not bound:
            raise SettingError("--where", text, "a date (2026-01-31) or an instant with its offset") from None
        return bound
    try:
        t = datetime(day.year, day.month, day.day, tzinfo=UTC) + (timedelta(days=1) if op == "<=" else timedelta())
    except OverflowError:  # start<=9999-12-31: before the day after, which no datetime holds; sorts after any instant
        return "9999-12-32"
    return t.isoformat(timespec="milliseconds")


def _number(text: str) -> float | None:
    """``text`` as a finite number, or None."""
    try:
        x = float(text)
    except ValueError:
        return None
    return x if x == x and abs(x) != float("inf") else None


def _json_path(name: str) -> str:
    """The SQLite JSON path of a recorded value's dotted name. The overrides are one flat table whose keys hold
    dots themselves (``session.notes``, as a scene's dotted keys): ``overrides.session.notes`` is
    ``$."overrides"."session.notes"``; the other roots nest one level a dot."""
    root, _, rest = name.partition(".")
    parts = [root.strip()] + ([rest.strip()] if root.strip() == "overrides" and rest else
                              [part.strip() for part in rest.split(".")] if rest else [])  # fmt: skip
    return "$" + "".join(f'."{part}"' for part in parts)


def _recorded(con: sqlite3.Connection, name: str) -> bool:
    """Whether any session of the index records the value ``name`` (dotted, under :data:`DETAIL_KEYS`)."""
    row = con.execute("SELECT 1 FROM sessions WHERE (CASE WHEN json_valid(detail) THEN json_type(detail, ?) END) "
                      "IS NOT NULL LIMIT 1", [_json_path(name)])  # fmt: skip
    return row.fetchone() is not None


def _field_sql(c: Condition) -> tuple[str, list[Any]]:
    """A condition on a recorded value (:data:`DETAIL_KEYS`): SQLite's JSON functions on the row's detail (a
    detail that is not strict JSON, as an index written before non-finite numbers were made null, matches nothing
    rather than failing the search)."""
    sql, params = _field_test(c)
    return f"(CASE WHEN json_valid(s.detail) THEN {sql} END)", params


def _field_test(c: Condition) -> tuple[str, list[Any]]:
    path = _json_path(c.key)
    value, kind = "json_extract(s.detail, ?)", "json_type(s.detail, ?)"
    x = _number(c.value)
    if c.op in (">=", "<="):
        return f"({kind} IN ('integer', 'real') AND {value} {c.op} ?)", [path, path, x]
    if c.op == "~":
        return f"instr(lower(CAST({value} AS TEXT)), lower(?)) > 0", [path, c.value]
    low = c.value.lower()
    if low in ("true", "false", "null"):
        return f"{kind} = ?", [path, low]
    if x is not None:  # a number equal as a number (1 = 1.0), or text recorded as that very text (SCPI's "1")
        return (f"(({kind} IN ('integer', 'real') AND {value} = ?) OR ({kind} = 'text' AND {value} = ?))",
                [path, path, x, path, path, c.value])  # fmt: skip
    return f"({kind} = 'text' AND {value} = ? COLLATE NOCASE)", [path, path, c.value]


def _words(text: str) -> list[str]:
    return re.findall(r"\w+", text)


def _sql(c: Condition) -> tuple[str, list[Any]]:
    if c.key in ("sample", "operator", "scene"):
        if c.op == "=":
            return f"s.{c.key} = ? COLLATE NOCASE", [c.value]
        return f"instr(lower(s.{c.key}), lower(?)) > 0", [c.value]
    if c.key == "status":
        return "s.status = ?", [c.value]
    if c.key == "serial":
        return "(' ' || s.serials || ' ') LIKE ?", [f"% {c.value} %"]
    if c.key == "verdict":
        last = ("(SELECT f.{} FROM fits f WHERE f.content_id = s.content_id "
                "ORDER BY instant(f.at) DESC, f.sidecar DESC, f.line DESC LIMIT 1)")  # fmt: skip
        if c.value == "none":
            return "NOT EXISTS (SELECT 1 FROM fits f WHERE f.content_id = s.content_id)", []
        if c.value == "stale":
            from contactrig.core.provenance import software_version

            return f"{last.format('analysis_version')} != ?", [software_version()]
        return f"{last.format('verdict')} = ?", [c.value]
    if c.key == "tag":
        return "s.content_id IN (SELECT content_id FROM marks WHERE kind = 'tag' AND text = ?)", [c.value]
    if c.key == "text":
        match = " ".join('"' + w + '"' for w in _words(c.value))
        return (
            "(s.path IN (SELECT path FROM notes_text WHERE notes_text MATCH ?) OR s.content_id IN "
            "(SELECT content_id FROM remarks_text WHERE remarks_text MATCH ?))",
            [match, match],
        )
    bound = _instant(c.value, c.op, c.value)
    return ("s.start_utc != '' AND s.start_utc >= ?" if c.op == ">=" else "s.start_utc != '' AND s.start_utc < ?"), [
        bound
    ]


_ORDER = {
    "start": "s.start_utc = '', s.start_utc, s.path",  # a start without its UTC offset: after the others
    "sample": "lower(s.sample), s.path",
    "operator": "lower(s.operator), s.path",
    "status": "s.status, s.path",
    "path": "s.path",
}


def _select(
    con: sqlite3.Connection,
    root: Path,
    conditions: Iterable[Condition],
    sort: str,
    include_other: bool,
    limit: int | None = None,
    descending: bool = False,
    detail: bool = True,
    offset: int = 0,
) -> tuple[list[dict[str, Any]], int]:
    clauses, params = ["1"], []
    for c in conditions:
        sql, p = _field_sql(c) if c.key.split(".")[0] in DETAIL_KEYS else _sql(c)
        clauses.append(sql)
        params += p
    if not include_other:
        clauses.append("s.status != 'other'")
    unreadable = "(s.status IN ('corrupt', 'newer', 'other'))"
    order = _ORDER[sort]
    if descending:  # newest (last) first; a start without its offset and unreadable files still last
        order = ", ".join(t if t.endswith("= ''") else f"{t} DESC" for t in order.split(", "))
    more = "s.detail" if detail else "''"
    offset = max(0, offset)
    rows = con.execute(
        f"SELECT s.record, s.path, {more} FROM sessions s WHERE {' AND '.join(clauses)} ORDER BY {unreadable}, {order} "
        "LIMIT ? OFFSET ?",
        [*params, -1 if limit is None else max(0, limit), offset],
    ).fetchall()
    matched = offset + len(rows)
    if (limit is not None and len(rows) >= limit) or (offset and not rows):  # cut: count them
        matched = con.execute(f"SELECT count(*) FROM sessions s WHERE {' AND '.join(clauses)}", params).fetchone()[0]
    marks: dict[str, dict[str, list[dict[str, str]]]] = {}
    order = "ORDER BY instant(at), sidecar, line"  # the instant, UTC, as _merged
    for cid, kind, text, who, at in con.execute(f"SELECT content_id, kind, text, who, at FROM marks {order}"):
        marks.setdefault(cid, {"tag": [], "remark": []})[kind].append({"text": text, "who": who, "at": at})
    fits = _last_fits(con)
    base = "" if str(root) == "." else str(root) + os.sep  # as str(root / path), without a Path per row
    # the rows' JSON decoded in one call (one C-level parse of the list, not a loads per row: half the time)
    out: list[dict[str, Any]] = json.loads("[" + ",".join(r[0] for r in rows) + "]")
    details = json.loads("[" + ",".join(r[2] for r in rows) + "]") if detail else None
    for k, (rec, (_, path, _)) in enumerate(zip(out, rows, strict=True)):
        if details is not None:
            rec.update(details[k])
        rec["path"] = base + path
        cid = rec["content_id"]
        m = marks.get(cid)
        rec["tags"], rec["remarks"] = (m["tag"], m["remark"]) if m is not None else ([], [])
        rec["fit"] = fits.get(cid)
    return out, matched


def query(
    folder: str | Path,
    where: Sequence[Condition | str] = (),
    *,
    sort: str = "start",
    include_other: bool = False,
    jobs: int = 2,
    timeout: float | None = None,
    refresh: bool = True,
    limit: int | None = None,
    descending: bool = False,
    detail: bool = True,
    offset: int = 0,
) -> tuple[list[dict[str, Any]], Refresh]:
    """The sessions under ``folder`` that meet every condition of ``where`` (``--where`` texts or
    :class:`Condition`), each a :func:`session_record` plus ``tags`` and ``remarks`` (each with ``who`` and
    ``at``), sorted by ``sort`` (:data:`daq.index.SORT_KEYS`; start: by the UTC instant; unreadable files last),
    after a refresh of the index (``refresh=False``: the index as it is, e.g. for a page that refreshes in the
    background; ``limit``: at most that many rows, e.g. one page; ``descending``: the sort reversed, e.g. the newest
    first, unreadable files still last; ``detail=False``: without :data:`DETAIL_KEYS`, the listing only, faster;
    ``offset``: that many matching rows skipped first, e.g. a later page); the :class:`Refresh` says what was read,
    any note and how many sessions ``matched`` (before ``offset`` and ``limit``). The console can call this as it is."""
    from contactrig.core.validation import check_choice

    check_choice("--sort", sort, SORT_KEYS)
    conditions = [c if isinstance(c, Condition) else parse_where(c) for c in where]
    root = _root(folder)
    notes: list[str] = []
    with _connect(root, notes) as (con, where_):
        result = Refresh(where_, notes=notes)
        if refresh or where_ is None:
            _refresh(con, root, result, jobs, timeout)
        rows, result.matched = _select(con, root, conditions, sort, include_other, limit, descending, detail, offset)
        if not result.matched:  # a misspelt name matches nothing: say so rather than list nothing silently
            for c in conditions:
                if c.key.split(".")[0] in DETAIL_KEYS and not _recorded(con, c.key):
                    notes.append(f"no session here records {c.key} (names as `contactrig sessions diff` shows them)")
        return rows, result


#: A row as :func:`indexed_rows` and :func:`fresh_scan` give it: path, content id, status, has a reason, tags, the
#: last fit (verdict, best model, when; "" none).
_Row = tuple[str, str, str, bool, tuple[str, ...], str]


def indexed_rows(folder: str | Path) -> list[_Row]:
    """(path, content id, status, has a reason, tags, last fit) of every row of ``folder``'s index as it is,
    unrefreshed (for checks that the index equals a fresh scan)."""
    index = index_location(folder)[0]
    with contextlib.closing(_functions(sqlite3.connect(f"file:{index}?mode=ro", uri=True))) as con:
        return _rows_of(con)


def _rows_of(con: sqlite3.Connection) -> list[_Row]:
    tags: dict[str, list[str]] = {}
    for cid, text in con.execute("SELECT content_id, text FROM marks WHERE kind = 'tag'"):
        tags.setdefault(cid, []).append(text)
    fits = {cid: f"{f['verdict']} {f['best']} {f['at']}" for cid, f in _last_fits(con).items()}
    out = []
    for path, cid, status, record in con.execute("SELECT path, content_id, status, record FROM sessions"):
        row = (path, cid, status, bool(json.loads(record)["note"]), tuple(sorted(tags.get(cid, []))), fits.get(cid, ""))
        out.append(row)
    return sorted(out)


def fresh_scan(folder: str | Path) -> list[_Row]:
    """What :func:`indexed_rows` would hold for an index built now from nothing (in memory; nothing is written)."""
    root = _root(folder)
    with contextlib.closing(_open(":memory:")) as con:
        _refresh(con, root, Refresh(None), 2, None)
        return _rows_of(con)
