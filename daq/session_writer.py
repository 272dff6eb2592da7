"""The writer of session files (:class:`SessionFile`), block by block; the layout is declared in
:mod:`daq.session_schema`.

Durability (reference notes, data-and-sessions.md): chunked resizable datasets appended per block, then
``flush()`` and ``os.fsync`` before the next block starts; default ``libver`` (no SWMR), so a file whose writer
was killed still opens and holds every flushed block. The summary row is written last in a block, so a block
cut short by a kill has readings beyond the last summary row, which the reader ignores.
"""

from __future__ import annotations

import contextlib
import errno
import io
import json
import os
import stat
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from contactrig.core import provenance
from contactrig.core.files import output_folder
from daq.errors import (
    SessionExistsError,
    SessionWriteError,
    hdf5_error,
)
from daq.records import BlockRecord, StopRecord, block_digests, exchanges_digest
from daq.session_lock import lock_exclusive, publish, replaceable, temporary_beside
from daq.session_reader import check_readable_schema, read_raw, readable_rows
from daq.session_schema import (
    EXCHANGE_FIELDS,
    FIELD_DESCRIPTIONS,
    FORMAT_NAME,
    READING_FIELDS,
    SCHEMA_VERSION,
    STR,
    SUMMARY_FIELDS,
    chain_digest,
    seal,
    software_versions,
)
from instruments.transport import Exchange

__all__ = ["BlockBatch", "SessionFile"]


def _open_h5(path: Path, mode: str) -> h5py.File:
    """Open for writing and hold the writer's lock (:mod:`daq.session_lock`): HDF5 takes its ``flock`` on the file
    as it opens it (before reading or writing a byte; a file another process holds is refused), and the same lock
    is taken again on HDF5's own descriptor, so it holds even where HDF5's locking is switched off
    (``HDF5_USE_FILE_LOCKING=FALSE``). It ends when the file is closed."""
    try:
        h5 = h5py.File(path, mode)
    except OSError as exc:
        raise hdf5_error(path, exc, writing=mode != "r") from exc
    try:
        lock_exclusive(h5.id.get_vfd_handle(), path)
    except BaseException:
        h5.close()
        raise
    return h5


def check_new_session(path: Path, *, force: bool) -> None:
    """Refuse, before anything is written, an output name that is taken (unless ``force``), a folder, something
    other than a regular file or link, or — with ``force`` — a file another process holds."""
    if os.path.lexists(path) and not force:
        raise SessionExistsError(errno.EEXIST, f"{path} exists; use --force to overwrite it")
    if path.is_dir() and not path.is_symlink():
        raise SessionWriteError(errno.EISDIR, f"{path} is a folder, not a file name")
    if force:
        replaceable(path)


def _check_resumable_path(path: Path) -> None:
    """A session is continued in place only under its own name: a symbolic link or anything but a regular file
    is refused (never followed for writing)."""
    try:
        st = os.lstat(path)
    except OSError:
        return  # the open says what is wrong
    if stat.S_ISLNK(st.st_mode):
        raise SessionWriteError(
            errno.ELOOP, f"{path} is a symbolic link: a session is continued only under its own name "
            f"({os.path.realpath(path)})"
        )  # fmt: skip
    if not stat.S_ISREG(st.st_mode):
        raise SessionWriteError(errno.EINVAL, f"{path} is not a regular file: not a session to continue")


@dataclass(frozen=True)
class BlockBatch:
    """Many blocks taken at once (an imported table): per block ``block``, ``weight_kg`` (kg), ``repeat`` and
    ``count`` (readings); per reading ``reading`` (as measured), ``time_s`` (s), ``resistance_ohm`` (Ω), ``valid``."""

    block: np.ndarray
    weight_kg: np.ndarray
    repeat: np.ndarray
    count: np.ndarray
    reading: np.ndarray
    time_s: np.ndarray
    resistance_ohm: np.ndarray
    valid: np.ndarray
    started: str

    def statistics(self) -> dict[str, np.ndarray]:
        """Per block over its valid readings (as :func:`instruments.block.block_statistics`): mean_ohm, sd_ohm
        (n − 1), sem_ohm (Ω; NaN where undefined), n, n_invalid."""
        count = np.asarray(self.count, dtype=np.int64)
        owner = np.repeat(np.arange(count.size), count)
        good = np.asarray(self.valid, dtype=bool)
        x = np.where(good, self.resistance_ohm, 0.0)
        n = np.bincount(owner, weights=good, minlength=count.size).astype(np.int64)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.bincount(owner, weights=x, minlength=count.size) / n
            dev = np.where(good, self.resistance_ohm - mean[owner], 0.0)
            var = np.bincount(owner, weights=dev * dev, minlength=count.size) / (n - 1)
            sd = np.where(n > 1, np.sqrt(var), np.nan)
            sem = np.where(n > 1, sd / np.sqrt(n), np.nan)
        mean = np.where(n > 0, mean, np.nan)
        return {"mean_ohm": mean, "sd_ohm": sd, "sem_ohm": sem, "n": n.astype(np.int32),
                "n_invalid": (count - n).astype(np.int32)}  # fmt: skip


def _indices(count: np.ndarray) -> np.ndarray:
    """0, 1, … within each block of ``count`` readings."""
    count = np.asarray(count, dtype=np.int64)
    starts = np.repeat(np.concatenate(([0], np.cumsum(count)[:-1])), count)
    return (np.arange(int(count.sum())) - starts).astype(np.int32)


def _exchange_bytes(exchanges: Iterable[Exchange]) -> int:
    return sum(len(e.message) + len(e.reply or "") + len(e.error or "") + 64 for e in exchanges)


def _require_room(path: Path, file: Path | None, needed: int, margin: int = 1 << 20) -> None:
    """Refuse, before HDF5 writes a byte, what the file cannot take: ``needed`` bytes plus ``margin`` (default 1 MiB,
    for HDF5's chunks and metadata) against the process' file-size limit (RLIMIT_FSIZE) and the free space of the
    file system. Raises :class:`SessionWriteError` (EFBIG or ENOSPC). A write HDF5 starts and cannot finish leaves
    its caches in a state only :meth:`SessionFile._failed` can end; the check makes that the rare case (a disk
    filled by another program meanwhile)."""
    needed += margin
    try:
        size = file.stat().st_size if file is not None else 0
    except OSError:
        size = 0
    limit = _file_size_limit()
    if limit is not None and size + needed > limit:
        raise SessionWriteError(errno.EFBIG, f"the file system refuses to let {path} grow (file too large)")
    try:
        st = os.statvfs(path.parent)
    except (OSError, AttributeError):  # no statvfs (Windows): HDF5's own error will have to do
        return
    if st.f_bavail * st.f_frsize < needed:
        raise SessionWriteError(errno.ENOSPC, f"no space left on the device holding {path}")


def _start_records(entry: h5py.Group, start: dict[str, Any], scene_text: str, run: int) -> None:
    """The start record and scene (the first run only: a resumed session keeps its first start record) and the run
    record of run ``run``."""
    group = entry["start"]
    if "record" not in group:
        _json_dataset(group, "record", start)
        group.create_dataset("scene_text", data=scene_text, dtype=STR)
        entry.create_dataset("start_time", data=start.get("started", provenance.now_iso()), dtype=STR)
        for key in ("operator", "host", "started"):
            group.attrs[key] = str(start.get(key, ""))
        group.attrs["schema_version"] = SCHEMA_VERSION
    _run_record(entry, start, run)


def _run_record(entry: h5py.Group, record: dict[str, Any], run: int) -> None:
    g = entry["runs"].require_group(f"run_{run}")
    g.attrs["NX_class"] = "NXcollection"
    _json_dataset(g, "record", record)


def _write_image(path: Path, image: bytes) -> None:
    """Write ``image`` as the whole content of the file ``path`` (ours, not yet published) and fsync it."""
    fd = os.open(path, os.O_WRONLY | os.O_TRUNC | getattr(os, "O_NOFOLLOW", 0))
    try:
        view = memoryview(image)
        while view:
            view = view[os.write(fd, view) :]
        os.fsync(fd)
    finally:
        os.close(fd)


def _cut_off(h5: h5py.File) -> None:
    """Point HDF5's file descriptor at the null device: whatever HDF5 still writes (closing flushes its caches) goes
    nowhere, and succeeds. The lock on the file ends with its descriptor."""
    with contextlib.suppress(Exception):
        fd = h5.id.get_vfd_handle()
        null = os.open(os.devnull, os.O_RDWR)
        try:
            os.dup2(null, fd, inheritable=False)
        finally:
            os.close(null)


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
    if name in FIELD_DESCRIPTIONS:
        ds.attrs["description"] = FIELD_DESCRIPTIONS[name]


def _upgrade_in_place(h5: h5py.File) -> None:
    """Bring an older session file that is being continued to this schema: add the columns it lacks (zero for
    every block it holds: schema 1 never read the compliance bit) and record the new schema."""
    summary = h5["entry/summary"]
    rows = min(summary[name].shape[0] for name in SUMMARY_FIELDS if name in summary)
    for name, (dtype, unit) in SUMMARY_FIELDS.items():
        if name not in summary:
            _make_column(summary, name, dtype, unit, 64, rows)
    h5.attrs["contactrig_schema"] = SCHEMA_VERSION


_Columns = dict[str, tuple[Any, np.dtype]]


def _columns(group: h5py.Group, fields: Iterable[str]) -> _Columns:
    """Low-level dataset ids and dtypes of a table's columns, looked up once (h5py lookups cost ~0.05 ms each);
    columns an older schema lacks are left out (added by :func:`_upgrade_in_place` before anything is appended)."""
    return {name: (group[name].id, group[name].dtype) for name in fields if name in group}


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
    group.create_dataset(name, data=provenance.to_json(record, sort_keys=True, allow_nan=True), dtype=STR)


class SessionFile:
    """Writer of one session file. Create with :meth:`create` or :meth:`open_for_resume`; use as a context manager.

    Every ``append_block`` ends with ``flush`` and ``os.fsync`` (``fsync=False`` skips the latter and leaves the
    syncing to the OS: faster, but a power cut may lose the last blocks): the block is on disk before the
    acquisition moves on.
    """

    def __init__(self, h5: h5py.File, path: Path, *, fsync: bool = True) -> None:
        self._h5 = h5
        #: the session's name (messages, rescue files); the data are in :attr:`file` (a temporary file until published)
        self.path = path
        self.file = path
        self.fsync = fsync
        self.run = 0
        self._bind()
        self.n_blocks_at_close = 0
        self._block_hashes: list[str] = []
        #: ``force`` of the pending publication (None: the file is under its name already)
        self._publish_force: bool | None = None
        #: publish as soon as the start record is on disk (False: the caller calls :meth:`publish`)
        self.publish_on_start = True
        self._created = False
        self._schema_on_open = SCHEMA_VERSION
        #: a write failed and the file was cut off from the disk (:meth:`_failed`)
        self._broken = False

    def _bind(self) -> None:
        """Look up the groups and columns of the open file once."""
        self._entry = self._h5["entry"]
        self._readings = _columns(self._entry["readings"], READING_FIELDS)
        self._summary = _columns(self._entry["summary"], SUMMARY_FIELDS)
        self._exchanges = _columns(self._entry["exchanges"], EXCHANGE_FIELDS)

    # -- creation ---------------------------------------------------------------------------------------------------
    @classmethod
    def create(
        cls, path: str | Path, *, reading_unit: str = "V", force: bool = False, fsync: bool = True
    ) -> SessionFile:
        """A new session for ``path`` (refuses an existing file unless ``force``, and one in use always);
        ``reading_unit`` is the unit of the readings as the instruments return them (``V``, ``OHMS``/``ohm``).

        The file is written as a locked temporary file beside ``path`` and takes its name only at :meth:`publish` —
        called by :meth:`write_start` once the start record is on disk (unless ``publish_on_start`` is set False):
        until then ``path``, and whatever is there, is untouched (:mod:`daq.session_lock`)."""
        p = Path(path)
        check_new_session(p, force=force)
        image = cls._layout_image(reading_unit)
        output_folder(p.parent)  # created when missing, as by every command that writes (contactrig.core.files)
        try:
            tmp = temporary_beside(p)
        except OSError as exc:  # the folder refuses it: the messages of any failed write (missing, no permission…)
            raise hdf5_error(p, exc, writing=True) from exc
        try:
            _require_room(p, None, len(image))
            _write_image(tmp, image)
        except BaseException as exc:
            tmp.unlink(missing_ok=True)
            if isinstance(exc, OSError) and not isinstance(exc, SessionWriteError):
                raise hdf5_error(p, exc, writing=True) from exc
            raise
        try:
            h5 = _open_h5(tmp, "r+")
            writer = cls(h5, p, fsync=fsync)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        writer.file = tmp
        writer._publish_force = force
        writer._created = True
        return writer

    @classmethod
    def _layout_image(cls, reading_unit: str) -> bytes:
        """The empty session (:meth:`_layout`) as the bytes of an HDF5 file, built in memory: the file on disk is
        written with plain writes (a full disk is a plain error) and HDF5 only ever opens a complete file."""
        with h5py.File(f"contactrig-layout-{os.getpid()}-{id(cls)}", "w", driver="core", backing_store=False) as h5:
            cls._layout(h5, reading_unit)
            h5.flush()
            return bytes(h5.id.get_file_image())

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
        prog = entry.create_dataset("program_name", data="contactrig", dtype=STR)
        prog.attrs["version"] = versions["contactrig"]

        summary = entry.create_group("summary")
        summary.attrs["NX_class"] = "NXdata"
        summary.attrs["signal"] = "mean_ohm"
        summary.attrs["axes"] = ["weight_kg"]
        summary.attrs["weight_kg_indices"] = 0
        _make_table(summary, SUMMARY_FIELDS, 64)
        summary["mean_ohm_errors"] = summary["sem_ohm"]  # hard link: NeXus error bars on the signal

        readings = entry.create_group("readings")
        readings.attrs["NX_class"] = "NXdata"
        readings.attrs["signal"] = "resistance_ohm"
        readings.attrs["axes"] = ["."]
        fields = dict(READING_FIELDS)
        fields["reading"] = ("<f8", {"OHMS": "ohm", "OHM": "ohm"}.get(reading_unit.upper(), reading_unit))
        _make_table(readings, fields, 4096)

        exchanges = entry.create_group("exchanges")
        exchanges.attrs["NX_class"] = "NXcollection"
        _make_table(exchanges, EXCHANGE_FIELDS, 1024)

        for name in ("start", "runs"):
            g = entry.create_group(name)
            g.attrs["NX_class"] = "NXcollection"

    @classmethod
    def open_existing(cls, path: str | Path, *, fsync: bool = True) -> SessionFile:
        """Open an existing session to continue it (``--resume``), after taking its lock: a file another process
        holds (writer or reader), a symbolic link, or anything but a regular file is refused with nothing changed.
        Nothing is written yet (:meth:`begin_resume` does the changes)."""
        p = Path(path)
        _check_resumable_path(p)
        schema = check_readable_schema(p)
        h5 = _open_h5(p, "a")
        try:
            writer = cls(h5, p, fsync=fsync)
        except BaseException:
            h5.close()
            raise
        writer._schema_on_open = schema
        return writer

    @classmethod
    def open_for_resume(cls, path: str | Path, *, fsync: bool = True, keep_blocks: int | None = None) -> SessionFile:
        """:meth:`open_existing` then :meth:`begin_resume`."""
        writer = cls.open_existing(path, fsync=fsync)
        try:
            writer.begin_resume(keep_blocks)
        except BaseException:
            writer.close()
            raise
        return writer

    def begin_resume(self, keep_blocks: int | None = None) -> None:
        """Prepare an opened session for more blocks: upgrade an older schema in place, move its stop record (if
        any) to its run record, cut rows no summary row vouches for.

        ``keep_blocks``: the number of blocks :func:`load_session` verified; rows beyond it (a block cut short by
        a kill or a failed write) are cut off before new blocks are appended.
        """
        h5 = self._h5
        if self._schema_on_open < SCHEMA_VERSION:
            _upgrade_in_place(h5)
            self._summary = _columns(self._entry["summary"], SUMMARY_FIELDS)
        runs = h5["entry/runs"]
        self.run = len(runs)
        keep_exchanges = None
        if "stop" in self._entry:
            keep_exchanges = json.loads(self._entry["stop/record"][()]).get("exchanges_in_file")
            last = runs[f"run_{self.run - 1}"]
            rec = json.loads(last["record"][()])
            rec["stop"] = json.loads(self._entry["stop/record"][()])
            _json_dataset(last, "record", rec)
            del self._entry["stop"]
            if "end_time" in self._entry:
                del self._entry["end_time"]
        self._drop_partial_rows(keep_blocks, keep_exchanges)
        self._block_hashes = [d.decode() for d in self._entry["summary/sha256"][:]]
        self._sync()

    def _drop_partial_rows(self, keep_blocks: int | None = None, keep_exchanges: int | None = None) -> None:
        """Cut readings and exchanges a kill left beyond the last complete block (no summary row vouches for them).

        ``keep_exchanges``: the exchange count of the stop record, if there is one; else the exchanges up to the
        end of the last complete block are kept.
        """
        summary = self._entry["summary"]
        n_blocks = min(summary[name].shape[0] for name in SUMMARY_FIELDS)
        if keep_blocks is not None:
            n_blocks = min(n_blocks, keep_blocks)
        for name in SUMMARY_FIELDS:
            if summary[name].shape[0] != n_blocks:
                summary[name].resize((min(summary[name].shape[0], n_blocks),))
        n_readings = int(summary["first_reading"][-1] + summary["count"][-1]) if n_blocks else 0
        for name in READING_FIELDS:
            ds = self._entry["readings"][name]
            if ds.shape[0] > n_readings:
                ds.resize((n_readings,))
        group = self._entry["exchanges"]
        n_ex = min(group[name].shape[0] for name in EXCHANGE_FIELDS)
        if keep_exchanges is None:
            keep_exchanges = (
                int(summary["first_exchange"][n_blocks - 1] + summary["n_exchanges"][n_blocks - 1]) if n_blocks else 0
            )
        n_ok = readable_rows(group, EXCHANGE_FIELDS, min(n_ex, keep_exchanges))
        for name in EXCHANGE_FIELDS:
            if group[name].shape[0] > n_ok:
                group[name].resize((n_ok,))

    # -- records ------------------------------------------------------------------------------------------------------
    def write_start(self, start: dict[str, Any], scene_text: str) -> None:
        """Write the session's start record (the first run only) and the run record of this run.

        A new session's first records are added to its file image in memory and the file rewritten with plain
        writes (:meth:`_rewrite`): HDF5 never meets a failing write while it creates them."""
        _require_room(self.path, self.file, 2 * (len(scene_text) + len(provenance.to_json(start))))
        if not self.published and self.n_blocks == 0 and self.n_exchanges == 0:
            self._rewrite(lambda h5: _start_records(h5["entry"], start, scene_text, self.run))
        else:
            try:
                _start_records(self._entry, start, scene_text, self.run)
                self._sync()
            except (OSError, RuntimeError) as exc:
                raise self._failed(exc) from exc
        if self.publish_on_start:
            self.publish()

    def _rewrite(self, edit: Callable[[h5py.File], None]) -> None:
        """Apply ``edit`` to the (unpublished, healthy) file's image in memory, write the result to a second
        temporary file with plain writes and rename it over the first: a write that fails leaves the first as it was."""
        self._h5.close()
        image = io.BytesIO(self.file.read_bytes())
        with h5py.File(image, "r+") as h5:
            edit(h5)
        try:
            new = temporary_beside(self.path)
        except OSError as exc:
            self._reopen()
            raise hdf5_error(self.path, exc, writing=True) from exc
        try:
            _write_image(new, image.getvalue())
            os.replace(new, self.file)
        except OSError as exc:
            new.unlink(missing_ok=True)
            self._reopen()
            raise hdf5_error(self.path, exc, writing=True) from exc
        self._reopen()

    def _reopen(self) -> None:
        self._h5 = _open_h5(self.file, "r+")
        self._bind()

    @property
    def published(self) -> bool:
        """The file is under its name (:attr:`path`); False while it is a temporary file beside it."""
        return self._publish_force is None

    def publish(self) -> None:
        """Give the new file its name, once what it holds is on disk (flush, fsync): without ``force`` only if the
        name is still free, with ``force`` over the old file unless another process holds it (refused, with the old
        file left as it was). A link at the name is replaced, never followed (:func:`daq.session_lock.publish`)."""
        if self._publish_force is None:
            return
        try:
            self._h5.flush()
            fd = self._h5.id.get_vfd_handle()
            os.fsync(fd)
        except (OSError, RuntimeError) as exc:
            raise self._failed(exc) from exc
        publish(self.file, self.path, force=self._publish_force)
        self.file = self.path
        self._publish_force = None

    def write_run(self, run_record: dict[str, Any]) -> None:
        """(Re)write the run record of this run."""
        try:
            _run_record(self._entry, run_record, self.run)
            self._sync()
        except (OSError, RuntimeError) as exc:
            raise self._failed(exc) from exc

    @property
    def n_blocks(self) -> int:
        return int(self._summary["block"][0].get_space().shape[0])

    @property
    def n_exchanges(self) -> int:
        return int(self._exchanges["run"][0].get_space().shape[0])

    @property
    def n_readings(self) -> int:
        return int(self._readings["block"][0].get_space().shape[0])

    def append_blocks(self, batch: BlockBatch) -> None:
        """Append many completed blocks at once — a table is one measurement: every column written in one call,
        then one flush and fsync (a 60 000-block table in well under a second, instead of 60 000 separately fsynced
        blocks). Same rows, statistics and SHA-256 as :meth:`append_block` would write; no instrument exchanges."""
        k = len(batch.block)
        if not k:
            return
        _require_room(self.path, self.file, 2 * (batch.resistance_ohm.size * 33 + k * 320))
        first = self.n_readings + np.concatenate(([0], np.cumsum(batch.count)[:-1])).astype(np.int64)
        summary = {
            "block": batch.block, "run": np.full(k, self.run, dtype=np.int32), "weight_kg": batch.weight_kg,
            "repeat": batch.repeat, **batch.statistics(), "count": batch.count, "first_reading": first,
            "started": np.full(k, batch.started.encode("ascii", "replace"), dtype="S40"),
            "first_exchange": np.full(k, self.n_exchanges, dtype=np.int64), "n_exchanges": np.zeros(k, np.int32),
            "exchanges_sha256": np.full(k, exchanges_digest([]).encode(), dtype="S64"),
            "compliance": np.zeros(k, dtype=np.uint8),
        }  # fmt: skip
        readings = {
            "block": np.repeat(batch.block, batch.count), "index": _indices(batch.count),
            "time_s": batch.time_s, "reading": batch.reading, "resistance_ohm": batch.resistance_ohm,
            "valid": batch.valid.astype(np.uint8),
        }  # fmt: skip
        relative = {**summary, "first_reading": first - self.n_readings}
        digests = block_digests(relative, readings)
        summary["sha256"] = np.array([d.encode() for d in digests], dtype="S64")
        try:
            _append(self._readings, readings)
            self._h5.flush()
            _append(self._summary, summary)
            self._sync()
        except (OSError, RuntimeError) as exc:
            raise self._failed(exc) from exc
        self._block_hashes.extend(digests)

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
            if rec.adaptive is not None:  # the suggestion that led to this block: flushed with it (schema 5)
                group = self._entry.require_group("adaptive")
                group.attrs["NX_class"] = "NXcollection"
                _json_dataset(group, f"block_{self.n_blocks}", rec.adaptive)
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
            raise self._failed(exc) from exc
        self._block_hashes.append(rec.sha256)

    def _check_room(self, rec: BlockRecord) -> None:
        """Refuse (before anything is written) a block the file cannot take (:func:`_require_room`), against twice
        the block's bytes plus 1 MiB for HDF5's chunks and metadata."""
        note = len(provenance.to_json(rec.adaptive)) if rec.adaptive is not None else 0
        _require_room(self.path, self.file, 2 * (int(rec.reading.size) * 33 + _exchange_bytes(rec.exchanges) + note))

    def append_exchanges(self, exchanges: Iterable[Exchange], *, block: int = -1, sync: bool = True) -> None:
        """Record instrument exchanges of this run (``block`` −1: outside any block, e.g. identify, close)."""
        ex = list(exchanges)
        if not ex:
            return
        _require_room(self.path, self.file, 2 * _exchange_bytes(ex))
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
            raise self._failed(exc) from exc

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
            "sha256_blocks": chain_digest(self._block_hashes),
        }
        if stop.adaptive is not None:
            record["adaptive"] = stop.adaptive
        _require_room(self.path, self.file, 0, margin=64 << 10)  # the stop record: a few kB
        try:
            self._h5.flush()
            # the seal: SHA-256 of everything readers use, computed from what the file holds (read back through the
            # reader itself), so that any later change to the file is reported as such
            record["seal"] = seal(read_raw(self._h5, self.path, stop_override=record), record)
            g = self._entry.require_group("stop")
            g.attrs["NX_class"] = "NXcollection"
            g.attrs["status"] = stop.status
            g.attrs["reason"] = stop.reason
            _json_dataset(g, "record", record)
            if "end_time" in self._entry:
                del self._entry["end_time"]
            self._entry.create_dataset("end_time", data=stop.stopped, dtype=STR)
            self._sync()
        except (OSError, RuntimeError) as exc:
            raise self._failed(exc) from exc

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
        """Flush, fsync and close (safe to call twice); ``n_blocks_at_close`` keeps the final count. A file never
        published is removed first (its name was never given: nothing appears, nothing is replaced)."""
        self._drop_unpublished()
        if not self._h5.id.valid:
            return
        with contextlib.suppress(Exception):
            self.n_blocks_at_close = self.n_blocks
        if self._broken:
            self._close_broken()
            return
        try:
            self._sync()
            self._h5.close()
        except (OSError, RuntimeError) as exc:
            error = self._failed(exc)
            self._close_broken()
            raise error from exc

    def _failed(self, exc: BaseException) -> Exception:
        """A write HDF5 could not do (full disk, file-size limit, lost drive): the file is cut off from the disk at
        once — HDF5's descriptor is pointed at the null device — so that nothing more lands in it (what was flushed
        before stays readable, as after a kill) and closing it cannot fail again: HDF5 closing a file whose writes
        fail can crash the process (SIGSEGV at exit). Returns the one-line error to raise."""
        if not self._broken and self._h5.id.valid:
            self._broken = True
            _cut_off(self._h5)
        return hdf5_error(self.path, exc, writing=True)

    def _close_broken(self) -> None:
        """Close a file cut off by :meth:`_failed`: its handles first, then the file; errors are the first one's."""
        self._readings = self._summary = self._exchanges = {}
        with contextlib.suppress(Exception):
            self._h5.close()

    def discard(self) -> None:
        """Close without keeping anything (the run failed before its first block): a file this writer created is
        removed — while its lock is still held, so it is ours to the last moment — and nothing more is written to
        it; a resumed file is closed as it is. Never raises: the error that ended the run is on its way."""
        new_and_named = self._created and self.published
        if self._publish_force is None and not new_and_named:
            with contextlib.suppress(OSError, RuntimeError):
                self.close()
            return
        if new_and_named:
            Path(self.path).unlink(missing_ok=True)
        self._drop_unpublished()
        if self._h5.id.valid:
            self._failed(RuntimeError("discarded"))
            self._close_broken()

    def _drop_unpublished(self) -> None:
        if self._publish_force is not None:
            Path(self.file).unlink(missing_ok=True)
            self._publish_force = None
            self.file = self.path
            self._created = False  # the name was never given: there is nothing of ours under it

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
