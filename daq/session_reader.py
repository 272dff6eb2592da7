"""The checking reader of session files (:func:`load_session`); the layout is declared in :mod:`daq.session_schema`.

Reading (:func:`load_session`) treats the file as untrusted: it runs in a child process with a deadline
(:mod:`daq.bounded`), checks every member it uses (:class:`_Reader`: type, shape, dtype, JSON type, size) and names
the member at fault in a one-line :class:`SessionFileError`, verifies each block's SHA-256 and then the stop
record's seal, and says when a session is incomplete, running or unsealed. A session being acquired is readable from
another process: the writer holds HDF5's file lock, so the reader opens it without locking and reads again if it
catches the writer mid-flush; every block it reports has passed its checksum.
"""

from __future__ import annotations

import errno
import json
import os
import time
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pandas as pd

from contactrig.core.text import escape_terminal
from daq.errors import (
    ChecksumError,
    IncompleteSessionWarning,
    NewerSchemaError,
    NoStartRecordError,
    SessionFileError,
    SessionNoteWarning,
    errno_of,
    first_line,
    hdf5_error,
)
from daq.records import block_digests, block_number, exchanges_digest
from daq.session_schema import (
    EXCHANGE_FIELDS,
    FORMAT_NAME,
    NEW_SUMMARY_FIELDS,
    READING_FIELDS,
    REQUIRED_STOP_FIELDS,
    SCHEMA_VERSION,
    SEAL_PARTS,
    SEALED_PARTS_SINCE,
    SEALED_SINCE,
    START_FIELDS,
    STOP_FIELDS,
    SUMMARY_FIELDS,
    UPGRADES,
    chain_digest,
    record_seal,
    seal,
    text_of,
)
from instruments.transport import Exchange

__all__ = [
    "Session",
    "exchange_list",
    "load_records",
    "load_session",
    "open_for_reading",
    "read_raw",
    "read_table",
    "readable_rows",
]

@dataclass(frozen=True)
class Session:
    """A session read from disk. ``summary``: one row per block; ``readings``: one row per reading (both in Ω).

    ``complete`` is False when the file has no stop record (killed, power loss, or still being written);
    ``warnings`` lists what the reader found (also issued as Python warnings).
    """

    path: Path
    schema_version: int
    complete: bool
    imported: bool
    start: dict[str, Any]
    stop: dict[str, Any] | None
    runs: list[dict[str, Any]]
    summary: pd.DataFrame = field(repr=False)
    readings: pd.DataFrame = field(repr=False)
    exchanges: pd.DataFrame = field(repr=False)
    scene_text: str = field(repr=False, default="")
    warnings: tuple[str, ...] = ()
    #: the stop record's seal holds: start record, scene text, runs, tables, exchanges and stop record unaltered
    sealed: bool = False
    #: another process is writing the file right now (no stop record yet)
    running: bool = False
    #: False: only the records and block digests were read and checked (:func:`load_records`, the run index's read)
    tables_read: bool = True
    #: an adaptive session's records (schema 5), by summary row: the suggestion that led to that block, the evidence
    #: behind it and what the operator did (``/entry/adaptive``; empty for older files and fixed plans)
    adaptive: dict[int, dict[str, Any]] = field(repr=False, default_factory=dict)

    @property
    def status(self) -> str:
        """``success``, ``aborted``, ``failed``; without a stop record ``running`` (another process is writing it)
        or ``incomplete`` (killed, power loss, lost disk)."""
        if self.stop:
            return str(self.stop["status"])
        return "running" if self.running else "incomplete"

    @property
    def compliance(self) -> np.ndarray:
        """Per summary row: True where the source was in compliance during the block (``summary["compliance"]``).
        Such blocks have a NaN mean and no valid reading: fits and reports leave them out."""
        return self.summary["compliance"].to_numpy(dtype=bool)

    @property
    def compliant_blocks(self) -> list[int]:
        """Block numbers of the blocks taken in compliance."""
        return [int(b) for b in self.summary["block"].to_numpy()[self.compliance]]


def check_readable_schema(path: Path) -> int:
    """The schema of the session file at ``path`` (checked: a contactrig session this version can read)."""
    try:
        h5 = h5py.File(path, "r")
    except OSError as exc:
        raise hdf5_error(path, exc, writing=False) from exc
    with h5:
        return _schema_of(_Reader(h5, path))


#: Largest record or text read from a file (JSON records, the scene text): far above any real one.
_MAX_TEXT_BYTES = 64 << 20
_KIND_NAMES = {"i": "integers", "u": "integers", "f": "numbers", "S": "text", "O": "text", "b": "booleans"}


class _Reader:
    """Reads the members of an untrusted file with checks; every failure names the file and the member.

    ``member`` is the member being read, so that an unexpected failure can still say where it happened.
    """

    def __init__(self, h5: h5py.File, path: Path) -> None:
        self.h5 = h5
        self.path = path
        self.member = "/"
        self._nodes: dict[str, Any] = {}
        self._rows: dict[str, int] = {}
        try:
            self.max_rows = max(int(os.path.getsize(path)), 1 << 16)  # a row takes at least one byte on disk
        except OSError:
            self.max_rows = 1 << 40

    def fail(self, what: str) -> SessionFileError:
        return SessionFileError(f"{self.path}: /{self.member.lstrip('/')} {what}")

    def has(self, name: str) -> bool:
        self.member = name
        parent, _, leaf = name.rpartition("/")
        node = self.h5 if not parent else self._nodes.get(parent)
        if node is None:
            node = self.h5.get(parent)
            if isinstance(node, h5py.Group):
                self._nodes[parent] = node
        return isinstance(node, h5py.Group) and leaf in node

    def node(self, name: str, kind: type) -> Any:
        self.member = name
        obj = self._nodes.get(name)
        if obj is None:
            obj = self._nodes[name] = self.h5.get(name)  # h5py lookups cost ~0.1 ms each: once per member
        if obj is None:
            raise self.fail("is missing")
        if not isinstance(obj, kind):
            raise self.fail(f"is a {type(obj).__name__.lower()}, not a {kind.__name__.lower()}")
        return obj

    def group(self, name: str) -> h5py.Group:
        return self.node(name, h5py.Group)

    def rows(self, name: str, dtype: Any) -> int:
        """The number of rows of the column ``name``, after checking it is a 1-D column of the right kind."""
        if name in self._rows:
            self.member = name
            return self._rows[name]
        ds = self.node(name, h5py.Dataset)
        if ds.ndim != 1:
            raise self.fail(f"has shape {ds.shape}: expected a column (1-D)")
        want = np.dtype(dtype)
        got = ds.dtype
        is_text = got.kind == "S" or h5py.check_string_dtype(got) is not None
        ok = is_text if want.kind in "SO" else got.kind in ("iu" if want.kind in "iu" else want.kind)
        if not ok:
            found = _KIND_NAMES.get(got.kind, str(got))
            raise self.fail(f"holds {found} ({got}): expected {_KIND_NAMES.get(want.kind, str(want))}")
        if ds.shape[0] > self.max_rows:
            raise self.fail(f"claims {ds.shape[0]} rows, more than the file's {self.max_rows} bytes can hold")
        self._rows[name] = int(ds.shape[0])
        return self._rows[name]

    def column(self, name: str, dtype: Any, n: int) -> np.ndarray:
        self.rows(name, dtype)
        ds = self._nodes[name]
        if np.dtype(dtype).kind in "SO":
            if ds.dtype.kind == "O":
                return np.asarray(ds.asstr()[:n], dtype=object)
            return np.asarray(ds[:n])
        return np.asarray(ds[:n]).astype(np.dtype(dtype))

    def text(self, name: str) -> str:
        """A scalar text dataset (a JSON record, the scene text), UTF-8."""
        ds = self.node(name, h5py.Dataset)
        if ds.shape != () or (ds.dtype.kind != "S" and h5py.check_string_dtype(ds.dtype) is None):
            raise self.fail(f"is {ds.dtype} of shape {ds.shape}: expected one text string")
        if ds.dtype.kind == "S" and ds.dtype.itemsize > _MAX_TEXT_BYTES:
            raise self.fail(f"is {ds.dtype.itemsize} bytes long: too large for a record")
        value = ds[()]
        raw = value if isinstance(value, bytes) else str(value).encode("utf-8", "surrogatepass")
        if len(raw) > _MAX_TEXT_BYTES:
            raise self.fail(f"is {len(raw)} bytes long: too large for a record")
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            raise self.fail("is not UTF-8 text") from None

    def record(self, name: str) -> dict[str, Any]:
        """A JSON record: a scalar text dataset holding a JSON object."""
        text = self.text(name)
        try:
            value = json.loads(text)
        except (json.JSONDecodeError, RecursionError) as exc:
            raise self.fail(f"is not valid JSON ({first_line(str(exc))})") from None
        if not isinstance(value, dict):
            raise self.fail(f"is a JSON {type(value).__name__}, not a record (JSON object)")
        self.member = name
        return value

    def attr(self, name: str, where: str = "/") -> Any:
        """A short scalar attribute (None when absent); a huge or array-valued one is refused unread."""
        self.member = f"{where.rstrip('/')}/@{name}"
        obj = self.h5[where]
        if name not in obj.attrs:
            return None
        aid = obj.attrs.get_id(name)
        if aid.shape not in ((), (1,)) or aid.get_storage_size() > 4096:
            raise self.fail(f"has shape {aid.shape} and {aid.get_storage_size()} bytes: expected a short value")
        value = obj.attrs[name]
        if isinstance(value, np.ndarray):
            value = value.reshape(-1)[0]
        return value.decode("utf-8", "replace") if isinstance(value, bytes) else value


def _schema_of(reader: _Reader) -> int:
    path = reader.path
    if reader.attr("contactrig_format") != FORMAT_NAME:
        raise SessionFileError(f"{path} is an HDF5 file but not a contactrig session (no contactrig_format attribute)")
    value = reader.attr("contactrig_schema")
    if value is None:
        value = 0
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise SessionFileError(f"{path}: /@contactrig_schema is {str(value)[:40]!r}: expected a schema number")
    schema = int(value)
    if schema > SCHEMA_VERSION:
        creator = str(reader.attr("creator") or "a newer contactrig")[:80]
        raise NewerSchemaError(
            f"{path} uses session schema {schema}, written by {creator}; this contactrig reads schemas up to "
            f"{SCHEMA_VERSION}: upgrade contactrig to read it"
        )
    if schema < SCHEMA_VERSION and not all(k in UPGRADES for k in range(schema, SCHEMA_VERSION)):
        raise SessionFileError(f"{path} uses session schema {schema}, for which there is no upgrade path")
    return schema


def _read_column(ds: h5py.Dataset, n: int) -> np.ndarray:
    return ds.asstr()[:n] if ds.dtype.kind == "O" else ds[:n]


def read_table(group: h5py.Group, fields: Iterable[str], n: int) -> dict[str, np.ndarray]:
    return {name: _read_column(group[name], n) for name in fields}


def readable_rows(group: h5py.Group, fields: Iterable[str], n: int) -> int:
    """The longest prefix (≤ n rows) of every column that can be read.

    A writer that died in the middle of a flush (full disk, power loss) can leave the index of its last rows
    pointing past the end of the file; the rows before them are intact.
    """
    names = list(fields)

    def ok(k: int) -> bool:
        try:
            for name in names:
                _read_column(group[name], k)
        except (OSError, ValueError, RuntimeError):
            return False
        return True

    if ok(n):
        return n
    lo, hi = 0, n  # ok(lo) holds (0 rows always read), ok(hi) does not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if ok(mid):
            lo = mid
        else:
            hi = mid
    return lo


def _table_rows(reader: _Reader, group: str, fields: Mapping[str, tuple[Any, str]]) -> int:
    """The rows every column of a table has (checked: 1-D, right kind, not absurdly long)."""
    return min(reader.rows(f"{group}/{name}", dtype) for name, (dtype, _) in fields.items())


def _read_columns(reader: _Reader, group: str, fields: Mapping[str, tuple[Any, str]], n: int) -> dict[str, np.ndarray]:
    return {name: reader.column(f"{group}/{name}", dtype, n) for name, (dtype, _) in fields.items()}


def _stop_record(reader: _Reader) -> tuple[dict[str, Any] | None, str]:
    """The stop record (None when absent or unreadable) and a note when it is there but unreadable."""
    if not reader.has("entry/stop/record"):
        return None, ""
    try:
        text = reader.text("entry/stop/record")
        stop = json.loads(text)
    except (json.JSONDecodeError, OSError, RuntimeError) as exc:  # the writer died writing it
        return None, f"the stop record is unreadable ({first_line(str(exc))}), so the session counts as incomplete"
    if not isinstance(stop, dict):
        raise reader.fail(f"is a JSON {type(stop).__name__}, not a record (JSON object)")
    _check_fields(reader, stop, STOP_FIELDS)
    return stop, ""




def _check_fields(reader: _Reader, record: Mapping[str, Any], fields: Mapping[str, tuple[type, ...]]) -> None:
    for key, types in fields.items():
        if key not in record:
            if key in REQUIRED_STOP_FIELDS and fields is STOP_FIELDS:
                raise reader.fail(f"lacks the field {key!r}")
            continue
        value = record[key]
        if not isinstance(value, types) or (bool not in types and isinstance(value, bool)):
            raise reader.fail(f"field {key!r} is a JSON {type(value).__name__}: expected {types[0].__name__}")
    if fields is STOP_FIELDS and record["status"] not in ("success", "aborted", "failed"):
        raise reader.fail(f"field 'status' is {str(record['status'])[:40]!r}: expected success, aborted or failed")


def _summary_rows(reader: _Reader, stop: dict[str, Any] | None) -> tuple[dict[str, np.ndarray], list[str]]:
    """The summary table (older schemas lack the newer columns) and the names of its columns."""
    present = [name for name in SUMMARY_FIELDS if reader.has(f"entry/summary/{name}")]
    missing = [name for name in SUMMARY_FIELDS if name not in present and name not in NEW_SUMMARY_FIELDS]
    if missing:
        reader.member = f"entry/summary/{missing[0]}"
        raise reader.fail("is missing")
    fields = {name: SUMMARY_FIELDS[name] for name in present}
    n_blocks = _table_rows(reader, "entry/summary", fields)
    if stop is None:  # a writer that died mid-flush can leave the last summary row unreadable
        n_blocks = readable_rows(reader.h5["entry/summary"], present, n_blocks)
    summary = _read_columns(reader, "entry/summary", fields, n_blocks)
    _check_offsets(reader, summary)
    return summary, present


def _check_offsets(reader: _Reader, s: Mapping[str, np.ndarray]) -> None:
    """Each block's readings follow the previous block's; exchange ranges are in order and non-negative."""
    count, first = s["count"].astype(np.int64), s["first_reading"].astype(np.int64)
    expected = np.concatenate(([0], np.cumsum(count)[:-1])) if count.size else count
    bad = np.flatnonzero((count < 0) | (first != expected))
    if bad.size:
        reader.member = "entry/summary/first_reading"
        raise reader.fail(f"and count disagree at row {int(bad[0])}: the summary does not match the readings")
    fe, ne = s["first_exchange"].astype(np.int64), s["n_exchanges"].astype(np.int64)
    bad = np.flatnonzero((fe < 0) | (ne < 0) | np.concatenate((np.diff(fe) < 0, [False]))[: fe.size])
    if bad.size:
        reader.member = "entry/summary/first_exchange"
        raise reader.fail(f"is out of order at row {int(bad[0])}")


def read_raw(h5: h5py.File, path: Path, stop_override: dict[str, Any] | None = None) -> dict[str, Any]:
    """The session's tables and records, checked member by member (``stop_override``: the stop record about to be
    written, when the writer computes its seal)."""
    reader = h5 if isinstance(h5, _Reader) else _Reader(h5, path)
    reader.group("entry")
    stop, stop_note = (stop_override, "") if stop_override is not None else _stop_record(reader)
    summary, _ = _summary_rows(reader, stop)
    n_blocks = len(summary["block"])
    n_readings = int(summary["first_reading"][-1] + summary["count"][-1]) if n_blocks else 0
    on_file = available = _table_rows(reader, "entry/readings", READING_FIELDS)
    if stop is None:
        available = readable_rows(reader.h5["entry/readings"], READING_FIELDS, min(on_file, n_readings))
    dropped = 0
    if available < n_readings:
        if stop is not None:
            raise SessionFileError(
                f"{path}: readings are missing ({available} on file, the summary needs {n_readings})"
            )
        # incomplete session: a summary row whose readings never reached the disk does not make a block
        ends = summary["first_reading"] + summary["count"]
        keep = int(np.count_nonzero(ends <= available))
        dropped = n_blocks - keep
        n_blocks = keep
        summary = {k: v[:keep] for k, v in summary.items()}
        n_readings = int(summary["first_reading"][-1] + summary["count"][-1]) if n_blocks else 0
    readings = _read_columns(reader, "entry/readings", READING_FIELDS, n_readings)
    exchanges, n_ex_on_file = _read_exchanges(reader, summary, stop)
    start, scene_text = _start_and_scene(reader)
    unit = reader.attr("units", "entry/readings/reading")
    return {
        "summary": summary,
        "readings": readings,
        "exchanges": exchanges,
        "start": start,
        "scene_text": scene_text,
        "stop": stop,
        "runs": _run_records(reader),
        "adaptive": _adaptive_records(reader, n_blocks),
        "trailing_readings": max(on_file - n_readings, 0),
        "dropped_blocks": dropped,
        "stop_note": stop_note,
        "unreadable_exchanges": n_ex_on_file - len(exchanges["kind"]),
        "reading_unit": unit if isinstance(unit, str) else "",
    }


def _read_exchanges(
    reader: _Reader, summary: Mapping[str, np.ndarray], stop: dict[str, Any] | None
) -> tuple[dict[str, np.ndarray], int]:
    n_ex_on_file = _table_rows(reader, "entry/exchanges", EXCHANGE_FIELDS)
    n_blocks = len(summary["block"])
    if stop is not None and "exchanges_in_file" in stop:
        n_ex = min(n_ex_on_file, max(int(stop["exchanges_in_file"]), 0))
    else:
        # incomplete: rows after the last complete block's exchanges were never vouched for (a kill or a
        # failed write leaves them half-written or zero-filled)
        n_ex = int(summary["first_exchange"][-1] + summary["n_exchanges"][-1]) if n_blocks else 0
        n_ex = readable_rows(reader.h5["entry/exchanges"], EXCHANGE_FIELDS, min(n_ex, n_ex_on_file))
    return _read_columns(reader, "entry/exchanges", EXCHANGE_FIELDS, n_ex), n_ex_on_file


def _start_and_scene(reader: _Reader) -> tuple[dict[str, Any] | None, str]:
    reader.group("entry/start")
    start = reader.record("entry/start/record") if reader.has("entry/start/record") else None
    if start is not None:
        _check_fields(reader, start, START_FIELDS)
    scene_text = reader.text("entry/start/scene_text") if reader.has("entry/start/scene_text") else ""
    if start is not None and not reader.has("entry/start/scene_text"):
        raise reader.fail("is missing: the session's scene was not recorded")
    return start, scene_text


def _run_records(reader: _Reader) -> list[dict[str, Any]]:
    runs_group = reader.group("entry/runs")
    runs = []
    for k in range(min(len(runs_group), 100_000)):
        name = f"entry/runs/run_{k}"
        if reader.has(name) and reader.has(f"{name}/record"):
            runs.append(reader.record(f"{name}/record"))
    return runs


def _adaptive_records(reader: _Reader, n_blocks: int) -> dict[int, dict[str, Any]]:
    """The records of an adaptive session's suggestions (schema 5), by the summary row of the block each led to;
    a record beyond the last complete block (its block cut short by a kill) is no block's and is left out."""
    if not reader.has("entry/adaptive"):
        return {}
    group = reader.group("entry/adaptive")
    rows = sorted(int(name[6:]) for name in group if name.startswith("block_") and name[6:].isdigit())
    return {j: reader.record(f"entry/adaptive/block_{j}") for j in rows if j < n_blocks}


def _check_seal(raw: Mapping[str, Any], path: Path, schema: int) -> bool:
    """True when the session is sealed and the seal holds; False when it has no seal; raises when it does not hold."""
    stop = raw["stop"]
    if stop is None or "seal" not in stop:
        if stop is not None and schema >= SEALED_SINCE:
            raise ChecksumError(f"{path}: the stop record has no seal, but schema {schema} files are sealed: altered")
        return False
    if schema < SEALED_SINCE:
        raise ChecksumError(f"{path}: claims schema {schema}, which had no seal, yet carries one: the file was altered")
    recorded = stop["seal"]
    actual = seal(raw, stop)
    for part, name in SEAL_PARTS.items():
        if schema < SEALED_PARTS_SINCE.get(part, SEALED_SINCE):  # an older file's seal lacks the newer parts
            continue
        if recorded.get(part) != actual[part]:
            raise ChecksumError(
                f"{path}: {name} changed after the session was sealed (SHA-256 in the stop record): the file was "
                "altered or damaged and is not analysed"
            )
    return True


def _verify(raw: dict[str, Any], path: Path) -> None:
    """Every block's readings, summary and exchanges against their SHA-256, then the stop record's counts; the first
    block at fault is named (``ChecksumError.position``: its row). Vectorised (:func:`block_digests`): a table of
    60 000 blocks is checked in well under a second."""
    s, r = raw["summary"], raw["readings"]
    k = len(s["block"])
    count = np.asarray(s["count"], dtype=np.int64)
    owner = np.repeat(np.asarray(s["block"], dtype=np.int64), count)
    wrong = np.flatnonzero(np.asarray(r["block"][: owner.size], dtype=np.int64) != owner)
    if wrong.size:
        i = int(np.searchsorted(np.cumsum(count), wrong[0], side="right"))
        raise ChecksumError(
            f"{path}: block {block_number(s['block'][i])} has readings of another block — file corrupted", position=i
        )
    digests = block_digests(s, r)
    stored = [text_of(d) for d in s["sha256"]]
    for i in range(k):
        if digests[i] != stored[i]:
            raise ChecksumError(
                f"{path}: SHA-256 mismatch in block {block_number(s['block'][i])} (weight "
                f"{float(s['weight_kg'][i]):g} kg, repeat {int(s['repeat'][i])}): the file was altered or damaged",
                position=i,
            )
        if not _exchanges_hold(raw["exchanges"], s, i):
            raise ChecksumError(
                f"{path}: the recorded instrument exchanges of block {block_number(s['block'][i])} are damaged "
                "(SHA-256): the block cannot be replayed",
                position=i,
            )
    stop = raw["stop"]
    if stop is not None:
        if stop.get("blocks_in_file") != k:
            raise ChecksumError(
                f"{path}: the stop record counts {stop.get('blocks_in_file')} blocks but the file holds {k}"
            )
        if stop.get("sha256_blocks") != chain_digest(stored):
            raise ChecksumError(f"{path}: the SHA-256 over all blocks does not match the stop record")


_NO_EXCHANGES = exchanges_digest([])


def _exchanges_hold(ex: Mapping[str, Any], s: Mapping[str, np.ndarray], i: int) -> bool:
    """Block ``i``'s recorded exchanges match their SHA-256 (a block without exchanges: the digest of none)."""
    e0 = int(s["first_exchange"][i])
    e1 = e0 + int(s["n_exchanges"][i])
    if e1 > len(ex["kind"]):
        return False
    actual = _NO_EXCHANGES if e1 == e0 else exchanges_digest(exchange_list(ex, e0, e1))
    return actual == text_of(s["exchanges_sha256"][i])


def exchange_list(ex: Mapping[str, Any], a: int = 0, b: int | None = None) -> list[Exchange]:
    """Rows a … b−1 (default: all) of the exchange columns (kind, message, reply, t_s, error: arrays, or the
    columns of ``Session.exchanges``) as :class:`Exchange` (reply None for writes and failed exchanges)."""
    out = []
    for kind, message, reply, t_s, error in zip(
        ex["kind"][a:b], ex["message"][a:b], ex["reply"][a:b], ex["t_s"][a:b], ex["error"][a:b], strict=True
    ):
        err = str(error) or None
        out.append(Exchange(str(kind), str(message), None if kind == "write" or err else str(reply), float(t_s), err))
    return out


def _drop_last_block(raw: dict[str, Any]) -> dict[str, Any]:
    s = {k: v[:-1] for k, v in raw["summary"].items()}
    n_readings = int(s["first_reading"][-1] + s["count"][-1]) if len(s["block"]) else 0
    r = {k: v[:n_readings] for k, v in raw["readings"].items()}
    n_ex = int(s["first_exchange"][-1] + s["n_exchanges"][-1]) if len(s["block"]) else 0
    e = {k: v[:n_ex] for k, v in raw["exchanges"].items()}
    a = {j: v for j, v in raw.get("adaptive", {}).items() if j < len(s["block"])}
    return {**raw, "summary": s, "readings": r, "exchanges": e, "adaptive": a}


def load_session(path: str | Path, *, verify: bool = True, timeout: float | None = None) -> Session:
    """Read a session file, check its schema, checksums and seal, and say if it is incomplete or running.

    The file is read in a child process within ``timeout`` seconds (default: 10 s for files up to 50 MB; see
    :mod:`daq.bounded`), so a damaged file can neither hang nor crash the caller. Raises
    :class:`~daq.errors.NewerSchemaError` for files from a newer contactrig, :class:`SessionFileError` for truncated,
    corrupted or malformed files (naming the member) and :class:`ChecksumError` when data do not match their SHA-256
    or a sealed part was altered. An incomplete session (no stop record) loads with ``complete=False`` and an
    :class:`IncompleteSessionWarning`; one another process is still writing has ``status == "running"``.
    """
    from daq.bounded import call_bounded

    p = Path(path)
    session = call_bounded(_load, (p, verify), path=p, what="session file", timeout=timeout)
    for note in session.warnings:  # file text inside: shown escaped wherever Python prints a warning
        category = IncompleteSessionWarning if session.stop is None else SessionNoteWarning
        warnings.warn(escape_terminal(note), category, stacklevel=2)
    return session


def _load(p: Path, verify: bool, attempts: int = 3) -> Session:
    """The work of :func:`load_session` (in the child process): read, check, upgrade, verify. A file another process
    is writing is read again when a read catches it mid-write (at most ``attempts`` times)."""
    for attempt in range(attempts):
        # a read that catches a live writer between two of its steps is tried again (a file nobody writes, never)
        schema, raw, running = _read_file(p, attempts=_LIVE_READ_ATTEMPTS)
        try:
            try:
                # a running session's blocks are all complete: one that fails its checksum was read mid-write,
                # so read again (only the last attempt treats it as a block cut short by a dead writer)
                return _checked(p, schema, raw, running, verify, strict=running and attempt < attempts - 1)
            except (ValueError, TypeError, KeyError, IndexError, AttributeError) as exc:
                if isinstance(exc, SessionFileError):
                    raise
                # values of the right type and shape that still make no sense together: one line, never a traceback
                what = f"{type(exc).__name__}: {first_line(str(exc))}"
                raise SessionFileError(f"{p}: inconsistent content ({what})") from None
        except SessionFileError:
            if not running or attempt == attempts - 1:
                raise
        time.sleep(0.05)
    raise AssertionError("unreachable")  # pragma: no cover


def _checked(
    p: Path, schema: int, raw: dict[str, Any], running: bool, verify: bool, *, strict: bool = False
) -> Session:
    """``raw`` checked and turned into a :class:`Session`; ``strict``: no block may be dropped as cut short."""
    notes: list[str] = []
    if verify:  # the blocks' own checksums first (their messages name the block), then the seal over the rest
        raw, notes = _verified(raw, p, may_drop_last=not strict)
    sealed = _check_seal(raw, p, schema) if verify else False
    for k in range(schema, SCHEMA_VERSION):
        raw = UPGRADES[k](raw)
    if raw["start"] is None:
        raise NoStartRecordError(f"{p} has no start record: the acquisition died before it began; no data to read")
    notes += _notes(raw, p, sealed=sealed, schema=schema, running=running)
    summary, readings, exchanges = _frames(raw)
    return Session(
        path=p,
        schema_version=schema,
        complete=raw["stop"] is not None,
        imported=bool(raw["start"].get("imported", False)),
        start=raw["start"],
        stop=raw["stop"],
        runs=raw["runs"],
        summary=summary,
        readings=readings,
        exchanges=exchanges,
        scene_text=raw["scene_text"],
        warnings=tuple(notes),
        sealed=sealed,
        running=running and raw["stop"] is None,
        adaptive=dict(raw.get("adaptive") or {}),
    )


_COUNT_FIELDS = ("block", "compliance", "n_invalid", "sha256")
_NOT_READ = pd.DataFrame()  # the tables load_records does not read (one empty frame for all: ~0.3 ms a frame)


def load_records(p: Path) -> Session | None:
    """A sealed, finished session's records and block counts, without its readings and exchanges: the run index's
    read (a third of the HDF5 members; about a third of a whole read's time). Run it where :func:`load_session`
    runs its work: inside a bounded child (:mod:`daq.bounded`).

    Checked: the start record, scene text, run records and stop record against the stop record's seal, the
    summary's block digests against the stop record (their count and their SHA-256 chain), and that every column
    of the three tables is there; the values in the tables are checked against their SHA-256 whenever the session
    is loaded (:func:`load_session`). ``summary`` has the columns ``block``, ``compliance`` and ``n_invalid``;
    ``readings`` and ``exchanges`` are empty; ``sealed`` and ``tables_read`` are False. None when this read does
    not apply or finds anything wrong (no stop record or seal, an older schema, a file a writer holds, any damage):
    the caller reads the whole file with :func:`load_session`, whose verdict and reason count."""
    try:
        h5, running = open_for_reading(p)
    except Exception:  # the whole read says why
        return None
    try:
        if running:
            return None
        reader = _Reader(h5, p)
        if _schema_of(reader) != SCHEMA_VERSION or not reader.has("entry/stop/record"):
            return None
        stop = reader.record("entry/stop/record")
        _check_fields(reader, stop, STOP_FIELDS)
        tables = (("entry/summary", SUMMARY_FIELDS), ("entry/readings", READING_FIELDS),
                  ("entry/exchanges", EXCHANGE_FIELDS))  # fmt: skip
        if any(not set(columns) <= set(reader.group(group)) for group, columns in tables):
            return None  # a column missing: the full read names it
        fields = {k: SUMMARY_FIELDS[k] for k in _COUNT_FIELDS}
        n = _table_rows(reader, "entry/summary", fields)
        s = _read_columns(reader, "entry/summary", fields, n)
        start, scene_text = _start_and_scene(reader)
        runs = _run_records(reader)
    except Exception:  # untrusted content: the full read names what is wrong
        return None
    finally:
        h5.close()
    recorded = stop.get("seal")
    raw: dict[str, Any] = {"start": start, "scene_text": scene_text, "runs": runs}
    digests = [text_of(d) for d in s["sha256"]]
    if (
        start is None
        or not isinstance(recorded, dict)
        or stop.get("blocks_in_file") != n
        or stop.get("sha256_blocks") != chain_digest(digests)
        or any(recorded.get(k) != v for k, v in record_seal(raw, stop).items())
    ):
        return None
    raw.update(stop=stop, summary=s, unreadable_exchanges=0, stop_note="", dropped_blocks=0)
    summary = pd.DataFrame({
        "block": s["block"].astype(np.int64), "compliance": np.asarray(s["compliance"], dtype=bool),
        "n_invalid": s["n_invalid"].astype(np.int64),
    })  # fmt: skip
    return Session(
        path=p, schema_version=SCHEMA_VERSION, complete=True, imported=bool(start.get("imported", False)),
        start=start, stop=stop, runs=runs, summary=summary, readings=_NOT_READ, exchanges=_NOT_READ,
        scene_text=scene_text, warnings=tuple(_notes(raw, p, sealed=True, schema=SCHEMA_VERSION, running=False)),
        tables_read=False,
    )  # fmt: skip


def open_for_reading(p: Path) -> tuple[h5py.File, bool]:
    """Open read-only; a file locked by a live writer is opened without locking (True: it is being written)."""
    try:
        return h5py.File(p, "r"), False
    except OSError as exc:
        text = str(exc)
        if "unable to lock file" not in text or errno_of(exc) not in (errno.EAGAIN, errno.EWOULDBLOCK):
            raise hdf5_error(p, exc, writing=False) from exc
    # another process holds the HDF5 write lock: an acquisition (or --resume) is writing this file. Reading it
    # without the lock is safe for us: every block we report is checked against its SHA-256, a row being written
    # is left out as an unfinished block, and any inconsistency seen mid-write is retried (_read_file). The open
    # itself can catch the writer extending the file (HDF5: "truncated file", the end recorded before the data
    # lands): a flush takes milliseconds, so the open is tried again for up to a second before it counts.
    for attempt in range(_LIVE_OPEN_ATTEMPTS):
        try:
            return h5py.File(p, "r", locking=False), True
        except OSError as exc:
            if attempt == _LIVE_OPEN_ATTEMPTS - 1:
                raise hdf5_error(p, exc, writing=False) from exc
        time.sleep(0.05)
    raise AssertionError("unreachable")  # pragma: no cover


_LIVE_OPEN_ATTEMPTS = 20  # × 50 ms: a file a live writer is extending
_LIVE_READ_ATTEMPTS = 10  # × 50 ms: a file a live writer is between two steps of


def _read_file(p: Path, attempts: int = 1) -> tuple[int, dict[str, Any], bool]:
    """The file's schema, raw tables and whether a writer holds it; any failure to read them is one
    :class:`SessionFileError` naming the member. A file being written is read again if a read catches it mid-write."""
    for attempt in range(attempts):
        h5, running = open_for_reading(p)
        try:
            return (*_read_open_file(h5, p), running)
        except SessionFileError:
            if not running or attempt == attempts - 1:
                raise
        finally:
            h5.close()
        time.sleep(0.05)
    raise AssertionError("unreachable")  # pragma: no cover


def _read_open_file(h5: h5py.File, p: Path) -> tuple[int, dict[str, Any]]:
    reader = _Reader(h5, p)
    try:
        schema = _schema_of(reader)
        raw = read_raw(reader, p)
    except SessionFileError:
        raise
    except Exception as exc:  # untrusted content: one line naming the member, never a traceback
        raise reader.fail(f"is unreadable ({type(exc).__name__}: {first_line(str(exc))})") from None
    return schema, raw


def _verified(raw: dict[str, Any], p: Path, *, may_drop_last: bool = True) -> tuple[dict[str, Any], list[str]]:
    """``raw`` after its checksums are checked; an incomplete session's half-written last block is left out."""
    try:
        _verify(raw, p)
    except ChecksumError as exc:
        n = len(raw["summary"]["block"])
        if raw["stop"] is not None or exc.position != n - 1 or not may_drop_last:
            raise
        # an incomplete session whose writer died while writing its last block: that block is not complete
        note = f"{p}: the last block was cut short when the writer died and is left out ({exc})"
        return _drop_last_block(raw), [note]
    return raw, []


def _notes(raw: dict[str, Any], p: Path, *, sealed: bool, schema: int, running: bool) -> list[str]:
    """What the reader found: rows left out, an unreadable or missing stop record, a session that did not succeed,
    a session without a seal."""
    notes = []
    if raw["unreadable_exchanges"] and not running:
        notes.append(
            f"{p}: {raw['unreadable_exchanges']} instrument exchanges after the last complete block (an unfinished "
            "block or run) are left out"
        )
    if raw["stop_note"]:
        notes.append(f"{p}: {raw['stop_note']}")
    if raw["dropped_blocks"]:
        notes.append(f"{p}: {raw['dropped_blocks']} block(s) whose readings never reached the disk are left out")
    stop = raw["stop"]
    if stop is None and running:
        notes.append(
            f"{p} is a RUNNING session (another process is writing it; unsealed until it stops): "
            f"{len(raw['summary']['block'])} complete blocks read so far"
        )
    elif stop is None:
        trailing = raw["trailing_readings"]
        notes.append(
            f"{p} is an INCOMPLETE, UNSEALED session: it has no stop record (the acquisition was killed, lost power "
            f"or its disk); {len(raw['summary']['block'])} complete blocks were read"
            + (f", {trailing} readings of an unfinished block ignored" if trailing else "")
            + "; `contactrig acquire --resume` continues it"
        )
    else:
        if running:
            notes.append(f"{p} is open for writing in another process (being resumed?): it may change")
        if not sealed:
            notes.append(
                f"{p} is UNSEALED (schema {schema}, written before sessions were sealed): its readings are checked "
                "against their SHA-256, but its start record, scene text and instrument exchanges cannot be"
            )
        if stop["status"] != "success":
            notes.append(f"{p}: session {stop['status']}: {stop['reason']}")
    return notes


def _frames(raw: dict[str, Any]) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    s, r = raw["summary"], raw["readings"]
    summary = pd.DataFrame(
        {
            "block": s["block"].astype(np.int64),
            "run": s["run"].astype(np.int64),
            "weight_kg": s["weight_kg"],
            "repeat": s["repeat"].astype(np.int64),
            "mean_ohm": s["mean_ohm"],
            "sd_ohm": s["sd_ohm"],
            "sem_ohm": s["sem_ohm"],
            "n": s["n"].astype(np.int64),
            "n_invalid": s["n_invalid"].astype(np.int64),
            "started": [text_of(t) for t in s["started"]],
            "sha256": [text_of(d) for d in s["sha256"]],
            "first_exchange": s["first_exchange"].astype(np.int64),
            "n_exchanges": s["n_exchanges"].astype(np.int64),
            "compliance": np.asarray(s.get("compliance", np.zeros(len(s["block"]))), dtype=bool),
        }
    )
    counts = s["count"].astype(np.int64)
    readings = pd.DataFrame(
        {
            "block": r["block"].astype(np.int64),
            "weight_kg": np.repeat(s["weight_kg"], counts),
            "repeat": np.repeat(s["repeat"].astype(np.int64), counts),
            "index": r["index"].astype(np.int64),
            "time_s": r["time_s"],
            "reading": r["reading"],
            "resistance_ohm": r["resistance_ohm"],
            "valid": r["valid"].astype(bool),
        }
    )
    e = raw["exchanges"]
    exchanges = pd.DataFrame(
        {
            "run": e["run"].astype(np.int64),
            "block": e["block"].astype(np.int64),
            "kind": e["kind"],
            "message": e["message"],
            "reply": e["reply"],
            "t_s": e["t_s"],
            "error": e["error"],
        }
    )
    return summary, readings, exchanges
