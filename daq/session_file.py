"""The HDF5 session file: a versioned, NeXus-lite layout written block by block and read back with checks.

Layout (schema 2; every numeric field has a ``units`` attribute)::

    /                         attrs contactrig_format, contactrig_schema, creator, HDF5_Version, h5py_version,
                              file_time, default="entry"
    /entry                    NXentry; attrs default="summary"; datasets start_time, end_time (ISO-8601 with zone),
                              program_name (attr version)
    /entry/start              NXcollection: ``record`` (JSON: schema, versions, instrument identities, plan,
                              operator, host, times, imported, sim), ``scene_text`` (the full scene)
    /entry/summary            NXdata, signal mean_ohm, axes weight_kg: one row per completed block — block, run,
                              weight_kg, repeat, mean_ohm, sd_ohm, sem_ohm (= mean_ohm_errors), n, n_invalid, count,
                              first_reading, started (ISO-8601), sha256 (readings), first_exchange, n_exchanges,
                              exchanges_sha256, compliance (1 = the source was in compliance during the block: its
                              readings are all marked invalid and its mean, SD and SEM are NaN; new in schema 2)
    /entry/readings           NXdata, signal resistance_ohm: one row per reading — block, index, time_s, reading
                              (as returned, in the readings' unit), resistance_ohm, valid
    /entry/exchanges          NXcollection: every instrument exchange — run, block (−1 outside blocks), kind,
                              message, reply, t_s, error — what replay serves back to the driver
    /entry/runs/run_<k>       NXcollection: ``record`` (JSON) for each run (the first and every --resume)
    /entry/stop               NXcollection: ``record`` (JSON: status, reason, counts, checksums); absent = incomplete

Durability (reference notes, data-and-sessions.md): chunked resizable datasets appended per block, then
``flush()`` and ``os.fsync`` before the next block starts; default ``libver`` (no SWMR), so a file whose writer
was killed still opens and holds every flushed block. The summary row is written last in a block, so a block
cut short by a kill has readings beyond the last summary row, which the reader ignores.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import re
import warnings
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pandas as pd

from contactrig.core import provenance
from daq.errors import (
    ChecksumError,
    FileLockingError,
    IncompleteSessionWarning,
    MissingFileError,
    NewerSchemaError,
    SessionExistsError,
    SessionFileError,
    SessionWriteError,
)
from daq.records import BlockRecord, StopRecord, block_digest, exchanges_digest
from instruments.block import BlockStatistics
from instruments.transport import Exchange

__all__ = [
    "FORMAT_NAME",
    "SCHEMA_VERSION",
    "UPGRADES",
    "Session",
    "SessionFile",
    "exchange_list",
    "load_session",
    "software_versions",
]

FORMAT_NAME = "contactrig-session"
SCHEMA_VERSION = 2


def _upgrade_1(raw: dict[str, Any]) -> dict[str, Any]:
    """Schema 1 → 2: the per-block ``compliance`` flag. Schema 1 never read the compliance bit, so its blocks carry
    no flag (0: not known to have been in compliance)."""
    summary = dict(raw["summary"])
    summary.setdefault("compliance", np.zeros(len(summary["block"]), dtype=np.uint8))
    return {**raw, "summary": summary}


# Upgrade functions, keyed by the schema they read: UPGRADES[k](raw) turns a loaded schema-k structure into a
# schema-(k+1) one, so every older file keeps loading. A file opened to be continued (--resume) is upgraded in place
# (:func:`_upgrade_in_place`).
UPGRADES: dict[int, Callable[[dict[str, Any]], dict[str, Any]]] = {1: _upgrade_1}

_STR = h5py.string_dtype()
_SUMMARY_FIELDS: dict[str, tuple[Any, str]] = {
    "block": ("<i4", ""),
    "run": ("<i4", ""),
    "weight_kg": ("<f8", "kg"),
    "repeat": ("<i4", ""),
    "mean_ohm": ("<f8", "ohm"),
    "sd_ohm": ("<f8", "ohm"),
    "sem_ohm": ("<f8", "ohm"),
    "n": ("<i4", ""),
    "n_invalid": ("<i4", ""),
    "count": ("<i4", ""),
    "first_reading": ("<i8", ""),
    # fixed length (schema 2; schema 1: variable-length): a variable-length string lives in HDF5's global heap,
    # which a later write that fails for lack of space can leave pointing past the end of the file, taking the last
    # complete block's start time with it
    "started": ("S40", "ISO-8601"),
    "sha256": ("S64", ""),
    "first_exchange": ("<i8", ""),
    "n_exchanges": ("<i4", ""),
    "exchanges_sha256": ("S64", ""),
    "compliance": ("u1", "1"),  # a flag: 1 = in compliance (dimensionless)
}
#: Columns added after schema 1, with the schema that added them (absent from older files; see UPGRADES).
_NEW_SUMMARY_FIELDS = {"compliance": 2}
_FIELD_DESCRIPTIONS = {
    "compliance": "1 = the current source was in compliance during this block: readings wrong, excluded (mean NaN)",
}
_READING_FIELDS: dict[str, tuple[Any, str]] = {
    "block": ("<i4", ""),
    "index": ("<i4", ""),
    "time_s": ("<f8", "s"),
    "reading": ("<f8", "V"),  # replaced by the unit of the session's readings on creation
    "resistance_ohm": ("<f8", "ohm"),
    "valid": ("u1", ""),
}
_EXCHANGE_FIELDS: dict[str, tuple[Any, str]] = {
    "run": ("<i4", ""),
    "block": ("<i4", ""),
    "kind": (_STR, ""),
    "message": (_STR, ""),
    "reply": (_STR, ""),
    "t_s": ("<f8", "s"),
    "error": (_STR, ""),
}


def software_versions() -> dict[str, str]:
    """:func:`contactrig.core.provenance.software_versions` plus the HDF5 library version the file was written with."""
    return {**provenance.software_versions(), "h5py": h5py.version.version, "hdf5": h5py.version.hdf5_version}


# ---- opening files, with one clear message per failure ---------------------------------------------------------


def _errno_of(exc: BaseException) -> int | None:
    code = getattr(exc, "errno", None)
    if code:
        return int(code)
    m = re.search(r"errno = (\d+)", str(exc))
    return int(m.group(1)) if m else None


def _explain_open_error(path: Path, exc: BaseException, writing: bool) -> Exception:
    """One clear error for an HDF5 failure (h5py raises OSError, or RuntimeError from flush)."""
    text = str(exc)
    code = _errno_of(exc)
    if "unable to lock file" in text:
        return _locking_error(path, code)
    known = _errno_error(path, code, writing)
    if known is not None:
        return known
    if not writing:
        return SessionFileError(
            f"{path} is not a readable HDF5 session file: truncated or corrupted ({_first_line(text)})"
        )
    return SessionWriteError(code or errno.EIO, f"cannot write {path}: {_first_line(text)}")


def _locking_error(path: Path, code: int | None) -> FileLockingError:
    if code in (errno.EAGAIN, errno.EWOULDBLOCK):
        return FileLockingError(
            errno.EAGAIN,
            f"{path} is open in another process (an acquisition still running?); "
            "close it there first — HDF5 refuses to share a file being written",
        )
    return FileLockingError(
        code or errno.ENOLCK,
        f"the file system holding {path} refuses HDF5 file locking (typical of NFS/SMB network shares): "
        "write the session to a local disk and copy it to the share afterwards",
    )


def _errno_error(path: Path, code: int | None, writing: bool) -> OSError | None:
    """The error for a file-system errno we can explain, or None."""
    if code == errno.ENOENT:
        if writing and not path.parent.is_dir():
            return SessionWriteError(errno.ENOENT, f"the folder {path.parent} does not exist")
        if writing:
            return SessionWriteError(errno.ENOENT, f"cannot create {path} there (no such file or directory)")
        return MissingFileError(errno.ENOENT, f"no such session file: {path}")
    if code in (errno.EACCES, errno.EPERM):
        return SessionWriteError(code, f"no permission to {'write' if writing else 'read'} {path}")
    plain = {
        errno.ENOSPC: f"no space left on the device holding {path}",
        errno.EFBIG: f"the file system refuses to let {path} grow (file too large)",
        errno.EROFS: f"{path} is on a read-only file system",
    }
    if code is not None and code in plain:
        return SessionWriteError(code, plain[code])
    return None


def _first_line(text: str) -> str:
    return text.strip().splitlines()[0] if text.strip() else "unknown error"


def _open_h5(path: Path, mode: str) -> h5py.File:
    try:
        return h5py.File(path, mode)
    except OSError as exc:
        raise _explain_open_error(path, exc, writing=mode != "r") from exc


# ---- writer ------------------------------------------------------------------------------------------------------


def _units(ds: h5py.Dataset, unit: str) -> None:
    if unit:
        ds.attrs["units"] = unit


def _make_table(group: h5py.Group, fields: dict[str, tuple[Any, str]], chunk: int) -> None:
    for name, (dtype, unit) in fields.items():
        _make_column(group, name, dtype, unit, chunk)


def _make_column(group: h5py.Group, name: str, dtype: Any, unit: str, chunk: int, rows: int = 0) -> None:
    """One resizable column of ``rows`` zero rows, with its ``units`` (and description) attributes."""
    ds = group.create_dataset(name, shape=(rows,), maxshape=(None,), dtype=dtype, chunks=(chunk,))
    _units(ds, unit)
    if name in _FIELD_DESCRIPTIONS:
        ds.attrs["description"] = _FIELD_DESCRIPTIONS[name]


def _upgrade_in_place(h5: h5py.File) -> None:
    """Bring an older session file that is being continued to this schema: add the columns it lacks (zero for
    every block it holds: schema 1 never read the compliance bit) and record the new schema."""
    summary = h5["entry/summary"]
    rows = min(summary[name].shape[0] for name in _SUMMARY_FIELDS if name in summary)
    for name, (dtype, unit) in _SUMMARY_FIELDS.items():
        if name not in summary:
            _make_column(summary, name, dtype, unit, 64, rows)
    h5.attrs["contactrig_schema"] = SCHEMA_VERSION


_Columns = dict[str, tuple[Any, np.dtype]]


def _columns(group: h5py.Group, fields: Iterable[str]) -> _Columns:
    """Low-level dataset ids and dtypes of a table's columns, looked up once (h5py lookups cost ~0.05 ms each)."""
    return {name: (group[name].id, group[name].dtype) for name in fields}


def _append(columns: _Columns, values: dict[str, Any]) -> None:
    """Append the same number of rows to each named column.

    Uses h5py's low-level calls (extend, select the new rows, write): the high-level lookups and slicing cost
    ~0.1 ms per call, which over the ~25 columns of a block were most of the per-block overhead.
    """
    for name, data in values.items():
        dsid, dtype = columns[name]
        arr = np.ascontiguousarray(np.asarray(data, dtype=dtype))
        n_new = arr.shape[0]
        if not n_new:
            continue
        old = dsid.get_space().shape[0]
        dsid.set_extent((old + n_new,))
        fspace = dsid.get_space()
        fspace.select_hyperslab((old,), (n_new,))
        dsid.write(h5py.h5s.create_simple((n_new,)), fspace, arr)


def _json_dataset(group: h5py.Group, name: str, record: dict[str, Any]) -> None:
    if name in group:
        del group[name]
    group.create_dataset(name, data=provenance.to_json(record, sort_keys=True, allow_nan=True), dtype=_STR)


class SessionFile:
    """Writer of one session file. Create with :meth:`create` or :meth:`open_for_resume`; use as a context manager.

    Every ``append_block`` ends with ``flush`` and ``os.fsync`` (``fsync=False`` skips the latter and leaves the
    syncing to the OS: faster, but a power cut may lose the last blocks): the block is on disk before the
    acquisition moves on.
    """

    def __init__(self, h5: h5py.File, path: Path, *, fsync: bool = True) -> None:
        self._h5 = h5
        self.path = path
        self.fsync = fsync
        self._entry = h5["entry"]
        self.run = 0
        self._readings = _columns(self._entry["readings"], _READING_FIELDS)
        self._summary = _columns(self._entry["summary"], _SUMMARY_FIELDS)
        self._exchanges = _columns(self._entry["exchanges"], _EXCHANGE_FIELDS)
        self.n_blocks_at_close = 0
        self._block_hashes: list[str] = []

    # -- creation ---------------------------------------------------------------------------------------------------
    @classmethod
    def create(
        cls, path: str | Path, *, reading_unit: str = "V", force: bool = False, fsync: bool = True
    ) -> SessionFile:
        """Create a new session file at ``path`` (refuses an existing file unless ``force``); ``reading_unit`` is
        the unit of the readings as the instruments return them (``V``, ``OHMS``/``ohm``)."""
        p = Path(path)
        if p.exists() and not force:
            raise SessionExistsError(errno.EEXIST, f"{p} exists; use --force to overwrite it")
        if p.is_dir():
            raise SessionWriteError(errno.EISDIR, f"{p} is a folder, not a file name")
        h5 = _open_h5(p, "w")
        try:
            cls._layout(h5, reading_unit)
            h5.flush()
        except (OSError, RuntimeError) as exc:
            h5.close()
            raise _explain_open_error(p, exc, writing=True) from exc
        return cls(h5, p, fsync=fsync)

    @staticmethod
    def _layout(h5: h5py.File, reading_unit: str) -> None:
        versions = software_versions()
        h5.attrs["contactrig_format"] = FORMAT_NAME
        h5.attrs["contactrig_schema"] = SCHEMA_VERSION
        h5.attrs["creator"] = f"contactrig {versions['contactrig']}"
        h5.attrs["HDF5_Version"] = versions["hdf5"]
        h5.attrs["h5py_version"] = versions["h5py"]
        h5.attrs["file_time"] = provenance.now_iso()
        h5.attrs["default"] = "entry"
        h5.attrs["NX_class"] = "NXroot"
        entry = h5.create_group("entry")
        entry.attrs["NX_class"] = "NXentry"
        entry.attrs["default"] = "summary"
        prog = entry.create_dataset("program_name", data="contactrig", dtype=_STR)
        prog.attrs["version"] = versions["contactrig"]

        summary = entry.create_group("summary")
        summary.attrs["NX_class"] = "NXdata"
        summary.attrs["signal"] = "mean_ohm"
        summary.attrs["axes"] = ["weight_kg"]
        summary.attrs["weight_kg_indices"] = 0
        _make_table(summary, _SUMMARY_FIELDS, 64)
        summary["mean_ohm_errors"] = summary["sem_ohm"]  # hard link: NeXus error bars on the signal

        readings = entry.create_group("readings")
        readings.attrs["NX_class"] = "NXdata"
        readings.attrs["signal"] = "resistance_ohm"
        readings.attrs["axes"] = ["."]
        fields = dict(_READING_FIELDS)
        fields["reading"] = ("<f8", {"OHMS": "ohm", "OHM": "ohm"}.get(reading_unit.upper(), reading_unit))
        _make_table(readings, fields, 4096)

        exchanges = entry.create_group("exchanges")
        exchanges.attrs["NX_class"] = "NXcollection"
        _make_table(exchanges, _EXCHANGE_FIELDS, 1024)

        for name in ("start", "runs"):
            g = entry.create_group(name)
            g.attrs["NX_class"] = "NXcollection"

    @classmethod
    def open_for_resume(cls, path: str | Path, *, fsync: bool = True, keep_blocks: int | None = None) -> SessionFile:
        """Open an existing session to append more blocks; its stop record (if any) is moved to its run record.

        ``keep_blocks``: the number of blocks :func:`load_session` verified; rows beyond it (a block cut short by
        a kill or a failed write) are cut off before new blocks are appended.
        """
        p = Path(path)
        schema = _check_readable_schema(p)
        h5 = _open_h5(p, "a")
        try:
            if schema < SCHEMA_VERSION:
                _upgrade_in_place(h5)
            writer = cls(h5, p, fsync=fsync)
            runs = h5["entry/runs"]
            writer.run = len(runs)
            keep_exchanges = None
            if "stop" in writer._entry:
                keep_exchanges = json.loads(writer._entry["stop/record"][()]).get("exchanges_in_file")
                last = runs[f"run_{writer.run - 1}"]
                rec = json.loads(last["record"][()])
                rec["stop"] = json.loads(writer._entry["stop/record"][()])
                _json_dataset(last, "record", rec)
                del writer._entry["stop"]
                if "end_time" in writer._entry:
                    del writer._entry["end_time"]
            writer._drop_partial_rows(keep_blocks, keep_exchanges)
            writer._block_hashes = [d.decode() for d in writer._entry["summary/sha256"][:]]
            writer._sync()
        except BaseException:
            h5.close()
            raise
        return writer

    def _drop_partial_rows(self, keep_blocks: int | None = None, keep_exchanges: int | None = None) -> None:
        """Cut readings and exchanges a kill left beyond the last complete block (no summary row vouches for them).

        ``keep_exchanges``: the exchange count of the stop record, if there is one; else the exchanges up to the
        end of the last complete block are kept.
        """
        summary = self._entry["summary"]
        n_blocks = min(summary[name].shape[0] for name in _SUMMARY_FIELDS)
        if keep_blocks is not None:
            n_blocks = min(n_blocks, keep_blocks)
        for name in _SUMMARY_FIELDS:
            if summary[name].shape[0] != n_blocks:
                summary[name].resize((min(summary[name].shape[0], n_blocks),))
        n_readings = int(summary["first_reading"][-1] + summary["count"][-1]) if n_blocks else 0
        for name in _READING_FIELDS:
            ds = self._entry["readings"][name]
            if ds.shape[0] > n_readings:
                ds.resize((n_readings,))
        group = self._entry["exchanges"]
        n_ex = min(group[name].shape[0] for name in _EXCHANGE_FIELDS)
        if keep_exchanges is None:
            keep_exchanges = (
                int(summary["first_exchange"][n_blocks - 1] + summary["n_exchanges"][n_blocks - 1]) if n_blocks else 0
            )
        n_ok = _readable_rows(group, _EXCHANGE_FIELDS, min(n_ex, keep_exchanges))
        for name in _EXCHANGE_FIELDS:
            if group[name].shape[0] > n_ok:
                group[name].resize((n_ok,))

    # -- records ------------------------------------------------------------------------------------------------------
    def write_start(self, start: dict[str, Any], scene_text: str) -> None:
        """Write the session's start record (the first run only) and the run record of this run."""
        try:
            group = self._entry["start"]
            if "record" not in group:  # a resumed session keeps its first start record; each run has its own
                _json_dataset(group, "record", start)
                group.create_dataset("scene_text", data=scene_text, dtype=_STR)
                self._entry.create_dataset("start_time", data=start.get("started", provenance.now_iso()), dtype=_STR)
                for key in ("operator", "host", "started"):
                    group.attrs[key] = str(start.get(key, ""))
                group.attrs["schema_version"] = SCHEMA_VERSION
            self.write_run(start)
        except (OSError, RuntimeError) as exc:
            raise _explain_open_error(self.path, exc, writing=True) from exc

    def write_run(self, run_record: dict[str, Any]) -> None:
        g = self._entry["runs"].require_group(f"run_{self.run}")
        g.attrs["NX_class"] = "NXcollection"
        _json_dataset(g, "record", run_record)
        self._sync()

    @property
    def n_blocks(self) -> int:
        return int(self._summary["block"][0].get_space().shape[0])

    @property
    def n_exchanges(self) -> int:
        return int(self._exchanges["run"][0].get_space().shape[0])

    @property
    def n_readings(self) -> int:
        return int(self._readings["block"][0].get_space().shape[0])

    def append_block(self, rec: BlockRecord) -> None:
        """Append one completed block: readings and exchanges, flush, then its summary row, flush and fsync.

        First checks that the file can grow by what the block needs (:meth:`_check_room`): a write that fails half
        way can damage HDF5's global heap, where the exchanges of the blocks already on file keep their strings."""
        n = int(rec.reading.size)
        first = self.n_readings
        first_exchange = self.n_exchanges
        self._check_room(rec)
        try:
            _append(
                self._readings,
                {
                    "block": np.full(n, rec.block, dtype=np.int32),
                    "index": np.arange(n, dtype=np.int32),
                    "time_s": rec.time_s,
                    "reading": rec.reading,
                    "resistance_ohm": rec.resistance_ohm,
                    "valid": np.asarray(rec.valid, dtype=np.uint8),
                },
            )
            if rec.exchanges:
                self.append_exchanges(rec.exchanges, block=rec.block, sync=False)
            # the readings reach the disk before the summary row that vouches for them: a write that fails (full
            # disk) or a kill leaves at most readings without a summary row, which readers ignore
            self._h5.flush()
            st = rec.stats
            _append(
                self._summary,
                {
                    "block": [rec.block],
                    "run": [rec.run],
                    "weight_kg": [rec.weight_kg],
                    "repeat": [rec.repeat],
                    "mean_ohm": [st.mean],
                    "sd_ohm": [st.sd],
                    "sem_ohm": [st.sem],
                    "n": [st.n],
                    "n_invalid": [st.n_invalid],
                    "count": [n],
                    "first_reading": [first],
                    "started": [rec.started.encode("ascii", "replace")],
                    "sha256": [rec.sha256.encode()],
                    "first_exchange": [first_exchange],
                    "n_exchanges": [len(rec.exchanges)],
                    "exchanges_sha256": [rec.exchanges_sha256.encode()],
                    "compliance": [1 if rec.compliance else 0],
                },
            )
            self._sync()
        except (OSError, RuntimeError) as exc:
            raise _explain_open_error(self.path, exc, writing=True) from exc
        self._block_hashes.append(rec.sha256)

    def _check_room(self, rec: BlockRecord) -> None:
        """Refuse (before anything is written) a block the file cannot take: the process' file-size limit
        (RLIMIT_FSIZE) or the free space of the file system, against twice the block's bytes plus 1 MiB for HDF5's
        chunks and metadata. Raises :class:`SessionWriteError` (EFBIG or ENOSPC)."""
        needed = 2 * (int(rec.reading.size) * 33 + sum(len(e.message) + len(e.reply or "") + 64 for e in rec.exchanges))
        needed += 1 << 20
        size = self.path.stat().st_size if self.path.exists() else 0
        limit = _file_size_limit()
        if limit is not None and size + needed > limit:
            raise SessionWriteError(errno.EFBIG, f"the file system refuses to let {self.path} grow (file too large)")
        try:
            st = os.statvfs(self.path.parent)
        except (OSError, AttributeError):  # no statvfs (Windows): HDF5's own error will have to do
            return
        if st.f_bavail * st.f_frsize < needed:
            raise SessionWriteError(errno.ENOSPC, f"no space left on the device holding {self.path}")

    def append_exchanges(self, exchanges: Iterable[Exchange], *, block: int = -1, sync: bool = True) -> None:
        """Record instrument exchanges of this run (``block`` −1: outside any block, e.g. identify, close)."""
        ex = list(exchanges)
        if not ex:
            return
        try:
            _append(
                self._exchanges,
                {
                    "run": np.full(len(ex), self.run, dtype=np.int32),
                    "block": np.full(len(ex), block, dtype=np.int32),
                    "kind": [e.kind for e in ex],
                    "message": [e.message for e in ex],
                    "reply": [e.reply or "" for e in ex],
                    "t_s": np.array([e.t_s for e in ex], dtype=np.float64),
                    "error": [e.error or "" for e in ex],
                },
            )
            if sync:
                self._sync()
        except (OSError, RuntimeError) as exc:
            raise _explain_open_error(self.path, exc, writing=True) from exc

    def write_stop(self, stop: StopRecord) -> None:
        """Write the stop record, with the SHA-256 over all block digests; the session is then complete."""
        record = {
            "status": stop.status,
            "reason": stop.reason,
            "stopped": stop.stopped,
            "blocks_planned": stop.blocks_planned,
            "blocks_done": stop.blocks_done,
            "blocks_in_file": self.n_blocks,
            "readings_in_file": self.n_readings,
            "readings_done": stop.readings_done,
            "exchanges_in_file": self.n_exchanges,
            "weights_skipped": list(stop.weights_skipped),
            "run": self.run,
            "sha256_blocks": _chain_digest(self._block_hashes),
        }
        try:
            g = self._entry.require_group("stop")
            g.attrs["NX_class"] = "NXcollection"
            g.attrs["status"] = stop.status
            g.attrs["reason"] = stop.reason
            _json_dataset(g, "record", record)
            if "end_time" in self._entry:
                del self._entry["end_time"]
            self._entry.create_dataset("end_time", data=stop.stopped, dtype=_STR)
            self._sync()
        except (OSError, RuntimeError) as exc:
            raise _explain_open_error(self.path, exc, writing=True) from exc

    # -- durability ---------------------------------------------------------------------------------------------
    def _sync(self) -> None:
        self._h5.flush()
        if self.fsync:
            try:
                fd = self._h5.id.get_vfd_handle()
            except Exception:  # a driver without a file descriptor (file-like objects in tests)
                return
            os.fsync(fd)

    def close(self) -> None:
        """Flush, fsync and close (safe to call twice); ``n_blocks_at_close`` keeps the final count."""
        if not self._h5.id.valid:
            return
        self.n_blocks_at_close = self.n_blocks
        try:
            try:
                self._sync()
            finally:
                self._h5.close()
        except (OSError, RuntimeError) as exc:
            raise _explain_open_error(self.path, exc, writing=True) from exc

    def __enter__(self) -> SessionFile:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _file_size_limit() -> int | None:
    """The process' file-size limit in bytes (RLIMIT_FSIZE), or None when there is none (or no such notion)."""
    try:
        import resource
    except ImportError:  # Windows
        return None
    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    return None if soft == resource.RLIM_INFINITY else int(soft)


def _chain_digest(hashes: Iterable[str]) -> str:
    h = hashlib.sha256()
    for d in hashes:
        h.update(d.encode())
    return h.hexdigest()


# ---- reader ------------------------------------------------------------------------------------------------------


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

    @property
    def status(self) -> str:
        """``success``, ``aborted``, ``failed``, or ``incomplete`` (no stop record)."""
        return str(self.stop["status"]) if self.stop else "incomplete"

    @property
    def compliance(self) -> np.ndarray:
        """Per summary row: True where the source was in compliance during the block (``summary["compliance"]``).
        Such blocks have a NaN mean and no valid reading: fits and reports leave them out."""
        return self.summary["compliance"].to_numpy(dtype=bool)

    @property
    def compliant_blocks(self) -> list[int]:
        """Block numbers of the blocks taken in compliance."""
        return [int(b) for b in self.summary.loc[self.compliance, "block"]]


def _check_readable_schema(path: Path) -> int:
    with _open_h5(path, "r") as h5:
        return _schema_of(h5, path)


def _schema_of(h5: h5py.File, path: Path) -> int:
    if h5.attrs.get("contactrig_format") != FORMAT_NAME:
        raise SessionFileError(f"{path} is an HDF5 file but not a contactrig session (no contactrig_format attribute)")
    schema = int(h5.attrs.get("contactrig_schema", 0))
    if schema > SCHEMA_VERSION:
        creator = h5.attrs.get("creator", "a newer contactrig")
        raise NewerSchemaError(
            f"{path} uses session schema {schema}, written by {creator}; this contactrig reads schemas up to "
            f"{SCHEMA_VERSION}: upgrade contactrig to read it"
        )
    if schema < SCHEMA_VERSION and not all(k in UPGRADES for k in range(schema, SCHEMA_VERSION)):
        raise SessionFileError(f"{path} uses session schema {schema}, for which there is no upgrade path")
    return schema


def _read_column(ds: h5py.Dataset, n: int) -> np.ndarray:
    return ds.asstr()[:n] if ds.dtype.kind == "O" else ds[:n]


def _read_table(group: h5py.Group, fields: Iterable[str], n: int) -> dict[str, np.ndarray]:
    return {name: _read_column(group[name], n) for name in fields}


def _readable_rows(group: h5py.Group, fields: Iterable[str], n: int) -> int:
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


def _read_raw(h5: h5py.File, path: Path) -> dict[str, Any]:
    entry = h5["entry"]
    stop = None
    stop_note = ""
    if "stop" in entry and "record" in entry["stop"]:
        try:
            stop = json.loads(entry["stop/record"][()])
        except (json.JSONDecodeError, OSError, UnicodeDecodeError) as exc:  # the writer died writing it
            stop_note = f"the stop record is unreadable ({_first_line(str(exc))}), so the session counts as incomplete"
    summary_group = entry["summary"]
    present = [name for name in _SUMMARY_FIELDS if name in summary_group]  # older schemas lack the newer columns
    n_blocks = min(summary_group[name].shape[0] for name in present)
    if stop is None:  # a writer that died mid-flush can leave the last summary row unreadable
        n_blocks = _readable_rows(summary_group, present, n_blocks)
    summary = _read_table(summary_group, present, n_blocks)
    n_readings = int(summary["first_reading"][-1] + summary["count"][-1]) if n_blocks else 0
    readings_group = entry["readings"]
    on_file = available = min(readings_group[name].shape[0] for name in _READING_FIELDS)
    has_stop = stop is not None
    if not has_stop:
        available = _readable_rows(readings_group, _READING_FIELDS, min(on_file, n_readings))
    dropped = 0
    if available < n_readings:
        if has_stop:
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
    readings = _read_table(readings_group, _READING_FIELDS, n_readings)
    exchanges_group = entry["exchanges"]
    n_ex_on_file = min(exchanges_group[name].shape[0] for name in _EXCHANGE_FIELDS)
    if stop is not None and "exchanges_in_file" in stop:
        n_ex = min(n_ex_on_file, int(stop["exchanges_in_file"]))
    else:
        # incomplete: rows after the last complete block's exchanges were never vouched for (a kill or a
        # failed write leaves them half-written or zero-filled)
        n_ex = int(summary["first_exchange"][-1] + summary["n_exchanges"][-1]) if n_blocks else 0
        n_ex = _readable_rows(exchanges_group, _EXCHANGE_FIELDS, min(n_ex, n_ex_on_file))
    exchanges = _read_table(exchanges_group, _EXCHANGE_FIELDS, n_ex)
    start = json.loads(entry["start/record"][()]) if "record" in entry["start"] else None
    scene_text = entry["start/scene_text"].asstr()[()] if "scene_text" in entry["start"] else ""
    runs = []
    for k in range(len(entry["runs"])):
        g = entry["runs"].get(f"run_{k}")
        if g is not None and "record" in g:
            runs.append(json.loads(g["record"][()]))
    return {
        "summary": summary,
        "readings": readings,
        "exchanges": exchanges,
        "start": start,
        "scene_text": scene_text,
        "stop": stop,
        "runs": runs,
        "trailing_readings": max(on_file - n_readings, 0),
        "dropped_blocks": dropped,
        "stop_note": stop_note,
        "unreadable_exchanges": n_ex_on_file - n_ex,
        "reading_unit": readings_group["reading"].attrs.get("units", ""),
    }


def _verify(raw: dict[str, Any], path: Path) -> None:
    s, r = raw["summary"], raw["readings"]
    hashes = []
    for i in range(len(s["block"])):
        a = int(s["first_reading"][i])
        b = a + int(s["count"][i])
        if not np.all(r["block"][a:b] == s["block"][i]):
            raise ChecksumError(
                f"{path}: block {int(s['block'][i])} has readings of another block — file corrupted", position=i
            )
        stats = BlockStatistics(
            float(s["mean_ohm"][i]),
            float(s["sd_ohm"][i]),
            float(s["sem_ohm"][i]),
            int(s["n"][i]),
            int(s["n_invalid"][i]),
        )
        digest = block_digest(
            int(s["block"][i]),
            float(s["weight_kg"][i]),
            int(s["repeat"][i]),
            r["reading"][a:b],
            r["time_s"][a:b],
            r["resistance_ohm"][a:b],
            r["valid"][a:b],
            stats,
            bool(s["compliance"][i]) if "compliance" in s else False,
        )
        stored = s["sha256"][i].decode() if isinstance(s["sha256"][i], bytes) else str(s["sha256"][i])
        if digest != stored:
            raise ChecksumError(
                f"{path}: SHA-256 mismatch in block {int(s['block'][i])} (weight {float(s['weight_kg'][i]):g} kg, "
                f"repeat {int(s['repeat'][i])}): the file was altered or damaged",
                position=i,
            )
        hashes.append(stored)
        e0 = int(s["first_exchange"][i])
        e1 = e0 + int(s["n_exchanges"][i])
        ex = raw["exchanges"]
        if e1 > len(ex["kind"]) or exchanges_digest(exchange_list(ex, e0, e1)) != _text(s["exchanges_sha256"][i]):
            raise ChecksumError(
                f"{path}: the recorded instrument exchanges of block {int(s['block'][i])} are damaged (SHA-256): "
                "the block cannot be replayed",
                position=i,
            )
    stop = raw["stop"]
    if stop is not None:
        if stop.get("blocks_in_file") != len(hashes):
            raise ChecksumError(
                f"{path}: the stop record counts {stop.get('blocks_in_file')} blocks but the file holds {len(hashes)}"
            )
        if stop.get("sha256_blocks") != _chain_digest(hashes):
            raise ChecksumError(f"{path}: the SHA-256 over all blocks does not match the stop record")


def _text(value: Any) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


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
    return {**raw, "summary": s, "readings": r, "exchanges": e}


def load_session(path: str | Path, *, verify: bool = True) -> Session:
    """Read a session file, check its schema and checksums, and say if it is incomplete.

    Raises :class:`~daq.errors.NewerSchemaError` for files from a newer contactrig, :class:`SessionFileError`
    for truncated or corrupted files and :class:`ChecksumError` when data do not match their SHA-256.
    An incomplete session (no stop record) loads with ``complete=False`` and an :class:`IncompleteSessionWarning`.
    """
    p = Path(path)
    schema, raw = _read_file(p)
    for k in range(schema, SCHEMA_VERSION):
        raw = UPGRADES[k](raw)
    notes: list[str] = []
    if verify:
        raw, notes = _verified(raw, p)
    if raw["start"] is None:
        raise SessionFileError(f"{p} has no start record: the acquisition died before it began; no data to read")
    notes += _notes(raw, p)
    for note in notes:
        warnings.warn(note, IncompleteSessionWarning if raw["stop"] is None else UserWarning, stacklevel=2)
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
    )


def _read_file(p: Path) -> tuple[int, dict[str, Any]]:
    """The file's schema and raw tables; any failure to read them is one :class:`SessionFileError`."""
    h5 = _open_h5(p, "r")
    try:
        schema = _schema_of(h5, p)
        try:
            raw = _read_raw(h5, p)
        except (KeyError, OSError, ValueError, json.JSONDecodeError) as exc:
            if isinstance(exc, SessionFileError):
                raise
            raise SessionFileError(f"{p} is damaged: {_first_line(str(exc))}") from exc
    finally:
        h5.close()
    return schema, raw


def _verified(raw: dict[str, Any], p: Path) -> tuple[dict[str, Any], list[str]]:
    """``raw`` after its checksums are checked; an incomplete session's half-written last block is left out."""
    try:
        _verify(raw, p)
    except ChecksumError as exc:
        n = len(raw["summary"]["block"])
        if raw["stop"] is not None or exc.position != n - 1:
            raise
        # an incomplete session whose writer died while writing its last block: that block is not complete
        note = f"{p}: the last block was cut short when the writer died and is left out ({exc})"
        return _drop_last_block(raw), [note]
    return raw, []


def _notes(raw: dict[str, Any], p: Path) -> list[str]:
    """What the reader found: rows left out, an unreadable or missing stop record, a session that did not succeed."""
    notes = []
    if raw["unreadable_exchanges"]:
        notes.append(
            f"{p}: {raw['unreadable_exchanges']} instrument exchanges after the last complete block (an unfinished "
            "block or run) are left out"
        )
    if raw["stop_note"]:
        notes.append(f"{p}: {raw['stop_note']}")
    if raw["dropped_blocks"]:
        notes.append(f"{p}: {raw['dropped_blocks']} block(s) whose readings never reached the disk are left out")
    if raw["stop"] is None:
        trailing = raw["trailing_readings"]
        notes.append(
            f"{p} is an INCOMPLETE session: it has no stop record (the acquisition was killed, lost power or its "
            f"disk, or is still running); {len(raw['summary']['block'])} complete blocks were read"
            + (f", {trailing} readings of an unfinished block ignored" if trailing else "")
            + "; `contactrig acquire --resume` continues it"
        )
    elif raw["stop"]["status"] != "success":
        notes.append(f"{p}: session {raw['stop']['status']}: {raw['stop']['reason']}")
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
            "started": [_text(t) for t in s["started"]],
            "sha256": [_text(d) for d in s["sha256"]],
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
