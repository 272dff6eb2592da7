"""The ``#`` provenance lines of a table that ``contactrig export`` wrote, read back by ``contactrig import``.

An exported summary starts with ``# key:,"value"`` records (:func:`daq.export.session_tables`): where the session
came from, its sample, operator, notes and scene name. :func:`read_provenance` parses them; :func:`session_metadata`
gives what an imported session's start record takes over (so ``contactrig sessions`` lists the same sample,
operator, notes and scene for the original and the re-imported file); :func:`without_statistics` drops the
per-weight statistics columns that the export writes after the repeats (they are derived, not repeats).

What comes back is the text as exported: control characters stay as the visible escapes the export wrote (a note
with a line break reads back with ``\\n``), and the ``'`` that kept a spreadsheet from running a value as a formula
is removed again.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping, Sequence

__all__ = [
    "EXPORTED_BY",
    "METADATA_KEYS",
    "STATISTICS_COLUMNS",
    "provenance_mapping",
    "read_provenance",
    "scene_name",
    "session_metadata",
    "statistics_headers",
    "without_statistics",
]

#: The value of the ``exported by`` record.
EXPORTED_BY = "contactrig export"
#: Provenance key → start-record key of the imported session.
METADATA_KEYS = {"sample": "sample", "operator": "operator", "notes": "notes", "scene": "scene_name"}
#: Per-weight statistics after the repeat columns of an exported summary: ``<name>_<unit>`` (``n`` has no unit).
STATISTICS_COLUMNS = ("mean", "sd", "sem", "n")
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def statistics_headers(unit: str) -> tuple[str, ...]:
    """Headers of the statistics columns in a summary whose values are in ``unit`` (ohm, mohm, uohm)."""
    return tuple(name if name == "n" else f"{name}_{unit}" for name in STATISTICS_COLUMNS)


def _value(text: str) -> str:
    """A text cell as the export wrote it, without the anti-formula ``'``."""
    if text.startswith("'") and text[1:2] and (text[1] in _FORMULA_START or text[1:].lstrip()[:1] in _FORMULA_START):
        return text[1:]
    return text


def read_provenance(text: str) -> dict[str, str]:
    """``key → value`` of the ``# key:,"value"`` records before the header row (``note`` records are joined by
    ``"; "``). A table without them gives ``{}``."""
    out: dict[str, str] = {}
    for line in text.splitlines():
        stripped = line.lstrip()
        if not stripped:
            continue
        if not stripped.startswith("#"):
            break  # the header row: provenance is only above it
        cells = next(csv.reader(io.StringIO(stripped)), [])
        if len(cells) < 2 or not cells[0].endswith(":"):
            continue
        key, value = cells[0][1:-1].strip(), _value(cells[1])
        out[key] = f"{out[key]}; {value}" if key in out and key == "note" else value
    return out


def session_metadata(text: str) -> dict[str, str]:
    """Start-record fields (sample, operator, notes, scene_name) recorded in an exported table's provenance; only
    those present and non-empty, and only when the table says ``contactrig export`` wrote it."""
    prov = read_provenance(text)
    if prov.get("exported by") != EXPORTED_BY:
        return {}
    return {field: prov[key] for key, field in METADATA_KEYS.items() if prov.get(key)}


def without_statistics(rows: Sequence[tuple[int, list[str]]], text: str) -> list[tuple[int, list[str]]]:
    """The (file row, cells) rows of a table without the statistics columns of an exported summary (header row
    first); any other table unchanged."""
    rows = list(rows)
    if not rows or read_provenance(text).get("exported by") != EXPORTED_BY:
        return rows
    header = rows[0][1]
    names = {h for unit in ("ohm", "mohm", "uohm") for h in statistics_headers(unit)}
    keep = [i for i, h in enumerate(header) if h not in names]
    if len(keep) == len(header):
        return rows
    return [(line, [cells[i] for i in keep if i < len(cells)]) for line, cells in rows]


def scene_name(start: Mapping[str, object], scene_text: str = "") -> str:
    """A session's scene name: its start record's ``scene_name``, else ``[scene] name`` of its recorded scene text
    (sessions written before the start record carried it); "" when neither says."""
    name = start.get("scene_name")
    if isinstance(name, str) and name:
        return name
    import tomllib

    try:
        table = tomllib.loads(scene_text).get("scene") if scene_text else None
    except tomllib.TOMLDecodeError:
        return ""
    value = table.get("name") if isinstance(table, dict) else None
    return value if isinstance(value, str) else ""


def provenance_mapping(start: Mapping[str, object], scene_text: str = "") -> dict[str, str]:
    """The metadata records an export writes for a session's start record (inverse of :func:`session_metadata`)."""
    plan = start.get("plan") if isinstance(start.get("plan"), Mapping) else {}
    planned = plan.get("session") if isinstance(plan, Mapping) and isinstance(plan.get("session"), Mapping) else {}
    out = {}
    for key, field in METADATA_KEYS.items():
        value = start.get(field, planned.get(field, "") if isinstance(planned, Mapping) else "")
        out[key] = "" if value is None else str(value)
    out["scene"] = scene_name(start, scene_text)
    return out
