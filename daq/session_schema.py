"""The one declaration of the HDF5 session file: layout, columns with their units, records, upgrades and seal.

Layout (schema 5; every numeric field has a ``units`` attribute)::

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
    /entry/stop               NXcollection: ``record`` (JSON: status, reason, counts, checksums, and — schema 3 —
                              ``seal``: SHA-256 of start record, scene text, run records, summary, readings,
                              exchanges and the stop record itself); absent = incomplete. Schema 4: an
                              adaptive session (``acquire --adaptive``) has ``adaptive`` in its start record (the
                              sequential design's settings) and in its stop record (every suggestion, the evidence
                              behind it and what the operator did, and the stop decision: :mod:`analysis.sequential`).
                              Schema 5: a run record holds ``pauses``, the operator's pauses at block boundaries
                              (reason, who, UTC times with offset, the block after which: :mod:`daq.pause`)
    /entry/adaptive           NXcollection (schema 5, an adaptive session only): ``block_<j>`` (JSON), the record of the
                              suggestion that led to summary row j — the suggestion, the evidence behind it and what the
                              operator did — written with that block, before its summary row, and flushed with it: a
                              killed session keeps every suggestion of its blocks (the stop record repeats them all). In
                              an adaptive session a summary row's ``repeat`` is its seating's number at that weight:
                              consecutive rows of one weight and repeat are blocks repeated at one seating

The writer (:mod:`daq.session_writer`) creates every table from these declarations and the reader
(:mod:`daq.session_reader`) checks every member against them; the seal (:func:`seal`) is computed by the one and
checked by the other from the same list of parts (:data:`SEAL_PARTS`).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterable, Mapping
from typing import Any

import h5py
import numpy as np

from contactrig.core import provenance

__all__ = [
    "EXCHANGE_FIELDS",
    "FORMAT_NAME",
    "READING_FIELDS",
    "SCHEMA_VERSION",
    "SEAL_PARTS",
    "START_FIELDS",
    "STOP_FIELDS",
    "SUMMARY_FIELDS",
    "UPGRADES",
    "chain_digest",
    "record_seal",
    "seal",
    "software_versions",
    "text_of",
]

FORMAT_NAME = "contactrig-session"
SCHEMA_VERSION = 5


def _upgrade_1(raw: dict[str, Any]) -> dict[str, Any]:
    """Schema 1 → 2: the per-block ``compliance`` flag. Schema 1 never read the compliance bit, so its blocks carry
    no flag (0: not known to have been in compliance)."""
    summary = dict(raw["summary"])
    summary.setdefault("compliance", np.zeros(len(summary["block"]), dtype=np.uint8))
    return {**raw, "summary": summary}


def _upgrade_2(raw: dict[str, Any]) -> dict[str, Any]:
    """Schema 2 → 3: the stop record's seal (SHA-256 over start record, scene text, runs, tables, exchanges and stop
    record). Nothing to convert: a schema-2 file has no seal and is reported as unsealed."""
    return raw


def _upgrade_3(raw: dict[str, Any]) -> dict[str, Any]:
    """Schema 3 → 4: the ``adaptive`` records of an adaptive session (start and stop record). Nothing to convert: a
    schema-3 file is a fixed-plan session, without them."""
    return raw


def _upgrade_4(raw: dict[str, Any]) -> dict[str, Any]:
    """Schema 4 → 5: the ``pauses`` of a run record (:mod:`daq.pause`), and each suggestion of an adaptive session
    also as its block's own record (``/entry/adaptive``). Nothing to convert: a schema-4 session was never paused, and
    has its suggestions in its stop record only (``raw["adaptive"]`` empty)."""
    return {**raw, "adaptive": dict(raw.get("adaptive") or {})}


# Upgrade functions, keyed by the schema they read: UPGRADES[k](raw) turns a loaded schema-k structure into a
# schema-(k+1) one, so every older file keeps loading. A file opened to be continued (--resume) is upgraded in place
# (:func:`_upgrade_in_place`).
UPGRADES: dict[int, Callable[[dict[str, Any]], dict[str, Any]]] = {
    1: _upgrade_1, 2: _upgrade_2, 3: _upgrade_3, 4: _upgrade_4,
}  # fmt: skip

STR = h5py.string_dtype()
SUMMARY_FIELDS: dict[str, tuple[Any, str]] = {
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
NEW_SUMMARY_FIELDS = {"compliance": 2}
FIELD_DESCRIPTIONS = {
    "compliance": "1 = the current source was in compliance during this block: readings wrong, excluded (mean NaN)",
}
READING_FIELDS: dict[str, tuple[Any, str]] = {
    "block": ("<i4", ""),
    "index": ("<i4", ""),
    "time_s": ("<f8", "s"),
    "reading": ("<f8", "V"),  # replaced by the unit of the session's readings on creation
    "resistance_ohm": ("<f8", "ohm"),
    "valid": ("u1", ""),
}
EXCHANGE_FIELDS: dict[str, tuple[Any, str]] = {
    "run": ("<i4", ""),
    "block": ("<i4", ""),
    "kind": (STR, ""),
    "message": (STR, ""),
    "reply": (STR, ""),
    "t_s": ("<f8", "s"),
    "error": (STR, ""),
}


def software_versions() -> dict[str, str]:
    """:func:`contactrig.core.provenance.software_versions` plus the HDF5 library version the file was written with."""
    return {**provenance.software_versions(), "h5py": h5py.version.version, "hdf5": h5py.version.hdf5_version}


#: Fields of the records that readers rely on, with their JSON types (absent is allowed, except
#: REQUIRED_STOP_FIELDS in the stop record).
STOP_FIELDS: dict[str, tuple[type, ...]] = {
    "status": (str,),
    "reason": (str,),
    "blocks_in_file": (int,),
    "readings_in_file": (int,),
    "exchanges_in_file": (int,),
    "blocks_planned": (int,),
    "blocks_done": (int,),
    "sha256_blocks": (str,),
    "seal": (dict,),
    "weights_skipped": (list,),
    "adaptive": (dict,),  # schema 4: suggestions, evidence, operator's actions, stop decision
}
START_FIELDS: dict[str, tuple[type, ...]] = {
    "imported": (bool,),
    "sim": (bool,),
    "plan": (dict,),
    "instrument": (dict,),
    "operator": (str,),
    "sample": (str,),
    "host": (str,),
    "started": (str,),
    "adaptive": (dict,),  # schema 4: the sequential design's settings
}
REQUIRED_STOP_FIELDS = {"status", "reason", "blocks_in_file", "sha256_blocks"}


# ---- the seal: what a completed session's stop record vouches for ------------------------------------------------

SEALED_SINCE = 3
#: The parts of a session the stop record's seal covers, and how a message names each.
SEAL_PARTS = {
    "start": "the start record",
    "scene_text": "the scene text",
    "runs": "the run records",
    "summary": "the summary table",
    "readings": "the readings",
    "exchanges": "the recorded instrument exchanges",
    "stop": "the stop record",
    "adaptive": "the records of the suggestions",
}
#: Parts added to the seal after schema 3, with the schema that added them (an older file's seal lacks them).
SEALED_PARTS_SINCE = {"adaptive": 5}


def canonical(value: Any) -> bytes:
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=True, allow_nan=True).encode()


def table_digest(table: Mapping[str, np.ndarray], fields: Mapping[str, tuple[Any, str]]) -> str:
    h = hashlib.sha256()
    for name in sorted(table):
        dtype = np.dtype(fields[name][0]) if name in fields and fields[name][0] is not STR else None
        values = table[name]
        if dtype is None or dtype.kind == "S":
            data = "\x1e".join(text_of(v) for v in values).encode("utf-8", "surrogatepass")
        else:
            data = np.ascontiguousarray(values, dtype=dtype.newbyteorder("<")).tobytes()
        h.update(f"{name}\x1f{len(values)}\x1f{len(data)}\x1f".encode())
        h.update(data)
    return h.hexdigest()


def seal(raw: Mapping[str, Any], stop: Mapping[str, Any]) -> dict[str, str]:
    """SHA-256 of every part the analysis and replay use (``stop``: the stop record without its seal)."""
    sha = lambda data: hashlib.sha256(data).hexdigest()  # noqa: E731
    return {
        "start": sha(canonical(raw["start"])),
        "scene_text": sha(str(raw["scene_text"]).encode("utf-8", "surrogatepass")),
        "runs": sha(canonical(raw["runs"])),
        "summary": table_digest(raw["summary"], SUMMARY_FIELDS),
        "readings": table_digest(raw["readings"], READING_FIELDS),
        "exchanges": table_digest(raw["exchanges"], EXCHANGE_FIELDS),
        "stop": sha(canonical({k: v for k, v in stop.items() if k != "seal"})),
        "adaptive": sha(canonical(raw.get("adaptive") or {})),
    }


def record_seal(raw: Mapping[str, Any], stop: Mapping[str, Any]) -> dict[str, str]:
    """The parts of :func:`seal` that are records (start, scene text, runs, stop), computed without the tables."""
    return {k: v for k, v in seal({**raw, "summary": {}, "readings": {}, "exchanges": {}}, stop).items()
            if k in ("start", "scene_text", "runs", "stop")}  # fmt: skip


def chain_digest(hashes: Iterable[str]) -> str:
    h = hashlib.sha256()
    for d in hashes:
        h.update(d.encode())
    return h.hexdigest()


def text_of(value: Any) -> str:
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)
