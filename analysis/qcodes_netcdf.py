"""The global attributes that make a session's netCDF file (:mod:`analysis.session_dataset`) a QCoDeS dataset.

QCoDeS opens an exported run with ``qcodes.dataset.load_from_netcdf(path)``, which reads (QCoDeS 0.58.0,
``qcodes/dataset/data_set_in_memory.py``, ``DataSetInMem._load_from_netcdf``) the global attributes ``guid``,
``captured_run_id``, ``captured_counter``, ``ds_name``, ``exp_name``, ``sample_name``, ``run_description`` (its
``RunDescriber`` as JSON), ``snapshot`` (JSON), ``run_timestamp_raw`` and ``completed_timestamp_raw`` (UTC epoch
seconds; −1 for none), ``parent_dataset_links`` (JSON list) and ``export_info`` (JSON); every other attribute
becomes the run's metadata. Its data cache then takes every data variable with the index of each of its dimensions
as its setpoints (``_from_xarray_dataset_to_qcodes_raw_data``), so every dimension needs a coordinate.

The attributes are written here by hand, in the format QCoDeS itself writes
(``qcodes/dataset/exporters/export_to_xarray.py``, ``_add_metadata_to_xarray``; the ``RunDescriber`` of storage
version 3, ``qcodes/dataset/descriptions/versioning/rundescribertypes.py``): contactrig never imports QCoDeS.

- ``guid`` — QCoDeS's format (``qcodes/dataset/guids.py``: ``8-4-4-4-12`` lower-case hex digits; its fields are a
  sample code, a location, a work station and the time in ms since the epoch): the first 16 hex digits of the
  session's content id (SHA-256 of its first start record, :func:`daq.run_index.content_id`) as sample code,
  location and work station, and the session's start in ms since the epoch (UTC) as the time field, so
  ``qcodes.dataset.guids.parse_guid`` gives the start; the same session (a copy, a renamed or resumed file) always
  exports the same guid. A start without a UTC offset (not an instant) gives the next 16 digits of the content id
  instead.
- ``exp_name`` — the scene's name (``contactrig`` when it has none); ``ds_name`` — the session file's name without
  its suffix; ``sample_name`` — the session's sample; ``captured_run_id`` and ``captured_counter`` — 1 (a session
  is one run; the guid tells sessions apart).
- ``run_description`` — every coordinate an independent parameter and every data variable a dependent one whose
  setpoints are its dimensions' coordinates (``paramtype`` ``text`` for strings, ``numeric`` otherwise; ``label``
  its ``long_name``, ``unit`` its ``units``), with the shapes.
- ``snapshot`` — a QCoDeS station snapshot: the source and the voltmeter as instruments with their ``IDN``
  parameter (vendor, model, serial, firmware) and the address (none where no ``*IDN?`` reply is recorded, as in
  an imported table), and a ``contactrig`` section with the scene, the
  overrides, every setting read back at the start, and the software versions.
"""

from __future__ import annotations

import json
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["QCODES_ATTRIBUTES", "QCODES_CHECKED", "epoch_seconds", "qcodes_attributes", "qcodes_guid"]

#: The QCoDeS version whose netCDF loader this was written against and checked with.
QCODES_CHECKED = "0.58.0"
#: The global attributes :func:`qcodes_attributes` adds.
QCODES_ATTRIBUTES = (
    "ds_name", "exp_name", "sample_name", "guid", "captured_run_id", "captured_counter", "run_timestamp_raw",
    "completed_timestamp_raw", "run_description", "snapshot", "parent_dataset_links", "export_info",
)  # fmt: skip


def epoch_seconds(text: str) -> float | None:
    """An ISO-8601 instant with its UTC offset as seconds since 1970-01-01T00:00:00Z; None when it is empty,
    unparsable or has no offset (a local time is not an instant)."""
    try:
        t = datetime.fromisoformat(text)
    except (TypeError, ValueError):
        return None
    return None if t.tzinfo is None else t.timestamp()


def qcodes_guid(content_id: str, start_s: float | None) -> str:
    """A guid in QCoDeS's format from the session's content id (``sha256:<64 hex digits>``) and its start
    [s since the epoch, UTC]: sample code, location and work station from the first 16 hex digits of the content
    id, the time field the start in ms (the next 16 digits of the content id when the start is None)."""
    digits = content_id.rsplit(":", 1)[-1].lower()
    if len(digits) < 32 or any(c not in "0123456789abcdef" for c in digits):
        raise ValueError(f"content id {content_id!r}: expected hex digits (at least 32)")
    time = f"{round(start_s * 1000):016x}" if start_s is not None and start_s >= 0 else digits[16:32]
    return f"{digits[:8]}-{digits[8:12]}-{digits[12:16]}-{time[:4]}-{time[4:16]}"


def _paramspec(ds: xr.Dataset, name: str) -> dict[str, Any]:
    """QCoDeS's ``ParamSpecBase`` dict of a variable: name, paramtype, label, unit."""
    var = ds[name]
    kind = "text" if var.dtype.kind in "OSU" else "numeric"
    return {"name": name, "paramtype": kind, "label": str(var.attrs.get("long_name", "")),
            "unit": str(var.attrs.get("units", ""))}  # fmt: skip


def _run_description(ds: xr.Dataset) -> str:
    """The ``RunDescriber`` (storage version 3) as JSON: coordinates independent, every data variable depending on
    its dimensions' coordinates, in both the old (``interdependencies``: ``ParamSpec`` list) and the new
    (``interdependencies_``) form QCoDeS writes, and the shapes."""
    coords = [str(c) for c in ds.coords]
    dependents = {str(v): [str(d) for d in ds[v].dims] for v in ds.data_vars}
    params = {name: _paramspec(ds, name) for name in [*coords, *dependents]}
    paramspecs = [{**params[n], "inferred_from": [], "depends_on": dependents.get(n, [])} for n in params]
    return json.dumps({
        "version": 3,
        "interdependencies": {"paramspecs": paramspecs},
        "interdependencies_": {"parameters": params, "dependencies": dependents, "inferences": {}, "standalones": []},
        "shapes": {v: list(ds[v].shape) for v in dependents},
    })  # fmt: skip


def _idn(reply: str) -> dict[str, str | None]:
    """An ``*IDN?`` reply as QCoDeS's ``IDN`` parameter value (``Instrument.get_idn``: comma-separated, missing
    fields None)."""
    parts: list[str | None] = [p.strip() for p in reply.split(",", 3)] if reply else []
    parts += [None] * (4 - len(parts))
    return dict(zip(("vendor", "model", "serial", "firmware"), parts, strict=True))


def _snapshot(attrs: dict[str, Any], start_s: float | None) -> str:
    """A QCoDeS station snapshot of the session (see the module docstring) as JSON."""
    settings = json.loads(attrs.get("instrument_settings") or "{}")
    address = (settings.get("instrument") or {}).get("address")
    ts = datetime.fromisoformat(attrs["start_time"]).strftime("%Y-%m-%d %H:%M:%S") if start_s is not None else None
    instruments = {}
    for role, key, what in (("source", "instrument_source_idn", "Keithley 6221 current source"),
                            ("voltmeter", "instrument_voltmeter_idn", "Keithley 2182A nanovoltmeter")):  # fmt: skip
        reply = str(attrs.get(key, ""))
        if not reply:
            continue  # not recorded (an imported table): no instrument
        instruments[role] = {
            "__class__": f"contactrig: {what}", "name": role, "functions": {}, "submodules": {},
            "parameters": {"IDN": {"__class__": "qcodes.parameters.Parameter", "full_name": f"{role}_IDN",
                                   "name": "IDN", "label": "IDN", "unit": "", "value": _idn(reply),
                                   "raw_value": reply, "ts": ts}},
            **({"address": address} if address and role == "source" else {}),
        }  # fmt: skip
    contactrig = {
        "scene_name": attrs.get("scene_name", ""), "scene_sha256": attrs.get("scene_sha256", ""),
        "overrides": json.loads(attrs.get("overrides") or "{}"), "settings": settings,
        "software": json.loads(attrs.get("software") or "{}"), "content_id": attrs.get("content_id", ""),
    }  # fmt: skip
    station = {"instruments": instruments, "parameters": {}, "components": {}, "config": None}
    return json.dumps({"station": station, "contactrig": contactrig}, sort_keys=True, default=str)


def qcodes_attributes(ds: xr.Dataset) -> dict[str, Any]:
    """The attributes QCoDeS's ``load_from_netcdf`` needs, from the Dataset that
    :func:`analysis.session_dataset.session_dataset` builds: its variables, coordinates and the session attributes
    ``content_id``, ``start_time``, ``end_time``, ``sample``, ``scene_name``, ``session_file``, the ``*IDN?``
    replies, ``instrument_settings``, ``overrides`` and ``software``."""
    attrs = dict(ds.attrs)
    start_s = epoch_seconds(str(attrs.get("start_time", "")))
    end_s = epoch_seconds(str(attrs.get("end_time", "")))
    return {
        "ds_name": Path(str(attrs.get("session_file", ""))).stem or "session",
        "exp_name": str(attrs.get("scene_name") or "contactrig"),
        "sample_name": str(attrs.get("sample", "")),
        "guid": qcodes_guid(str(attrs["content_id"]), start_s),
        "captured_run_id": 1,
        "captured_counter": 1,
        "run_timestamp_raw": -1.0 if start_s is None else start_s,  # QCoDeS's sentinel for None
        "completed_timestamp_raw": -1.0 if end_s is None else end_s,
        "run_description": _run_description(ds),
        "snapshot": _snapshot(attrs, start_s),
        "parent_dataset_links": "[]",
        "export_info": json.dumps({"export_paths": {}}),
    }
