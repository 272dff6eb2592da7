"""A session as an xarray Dataset, and as a netCDF-4 file (``contactrig export SESSION --to netcdf``).

:func:`session_dataset` gives the session read by the checking reader (:func:`daq.session_file.load_session`) as
an :class:`xarray.Dataset` with two dimensions:

- ``block`` — one entry per block on disk (coordinate: the 1-based block number every output uses): ``run``,
  ``weight`` [kg], ``repeat``, ``mean_resistance``, ``sd_resistance`` (n − 1), ``sem_resistance`` [ohm],
  ``n_valid``, ``n_invalid``, ``block_started`` (ISO-8601 with its UTC offset) and ``compliance`` (1 = the
  source was in compliance during the block: its mean is NaN and its readings are all invalid);
- ``reading`` — every reading, flagged ones included (never dropped): ``reading_block``, ``reading_index``,
  ``time`` [s] (the instrument's time stamp), ``raw_reading`` (as the instrument returned it, in the session's unit:
  ``V``, or ``ohm`` for an imported table; NaN where it sent +9.9E37, an overflow or no reading),
  ``resistance`` [ohm], ``valid`` (1 = averaged into its block's mean) and ``reading_flag``, a CF flag variable
  (``flag_masks`` 1 ``invalid``, 2 ``no_value`` — overflow or no reading —, 4 ``compliance`` — its block was in
  compliance); its coordinate ``reading`` numbers the readings 0, 1, … in the order of the readings table.

Every numeric variable has a CF ``units`` string (UDUNITS: ``kg``, ``ohm``, ``s``, ``V``, ``1`` for counts and
flags) and a ``long_name``. The global attributes hold the session's metadata as the run index reads it
(:func:`daq.run_index.record_of`): sample, operator, notes, scene name and text, the scene's SHA-256
(``scene_sha256``), the overrides, both ``*IDN?`` replies, every instrument setting read back at the start, the
software versions, start and end time with their UTC offset, status, completeness, seal, schema, blocks done and
planned, the run records, the operator's pauses (schema 5, :mod:`daq.pause`) and (schema 4) the adaptive
records; nested values are JSON text (netCDF attributes are flat). The recorded instrument exchanges (the replay
log) are not part of the Dataset. The attributes QCoDeS's ``qcodes.dataset.load_from_netcdf`` needs (``guid``,
``run_description``, ``snapshot``, ``sample_name`` …) are added by :mod:`analysis.qcodes_netcdf`, without QCoDeS.

The file is written with h5netcdf through xarray (the ``netcdf`` extra: ``pip install 'contactrig[netcdf]'``), so
xarray, netCDF-4 libraries and plain HDF5 readers (dimension scales) all read it. As every output: an existing file
(or symbolic link) is never replaced without ``force``, and the file is written in a staging folder and renamed in
(:func:`contactrig.core.files.replace_together`), so a link at the output path is replaced, never followed.

Nothing here imports xarray until a Dataset is made (``analysis`` imports without it).
"""

from __future__ import annotations

import importlib
import json
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import xarray as xr

    from daq.session_reader import Session

__all__ = ["NETCDF_INSTALL", "NetcdfUnavailable", "default_netcdf_output", "session_dataset", "write_netcdf"]

#: What to install for ``--to netcdf`` (pyproject's ``netcdf`` extra).
NETCDF_INSTALL = "pip install 'contactrig[netcdf]' (xarray>=2024.1, h5netcdf>=1.3)"
#: Bits of ``reading_flag`` (CF ``flag_masks``) and their ``flag_meanings``.
FLAG_INVALID, FLAG_NO_VALUE, FLAG_COMPLIANCE = 1, 2, 4
_FLAG_MEANINGS = "invalid no_value compliance"


class NetcdfUnavailable(RuntimeError):
    """``--to netcdf`` (or :func:`session_dataset`) without xarray and h5netcdf installed."""


def _require(*modules: str) -> list[Any]:
    """The modules, imported; one line naming the extra when one is missing."""
    out = []
    for name in modules:
        try:
            out.append(importlib.import_module(name))
        except ImportError:
            raise NetcdfUnavailable(f"--to netcdf needs {name}, which is not installed: {NETCDF_INSTALL}") from None
    return out


def _load(source: str | Path | Session) -> Session:
    if isinstance(source, (str, Path)):
        from daq.session_file import load_session

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # an incomplete or running session is exported as it stands (status)
            return load_session(source)
    return source


def _json(value: Any) -> str:
    """Nested metadata as JSON text (a netCDF attribute is a string or numbers)."""
    return json.dumps(value, sort_keys=True, ensure_ascii=False, default=str)


def _reading_units(start: dict[str, Any]) -> str:
    """The readings' unit as a UDUNITS string: ``V``, ``ohm`` (instrument ``OHMS`` or an imported table), or ``1``
    where the session names none."""
    from daq.export import reading_unit

    return reading_unit(start) or "1"  # the plan's unit is V or OHMS (instruments.delta), read as "ohm"


def _metadata(session: Session) -> dict[str, Any]:
    """Global attributes: the session's metadata as the run index describes it (:func:`daq.run_index.record_of`)."""
    from contactrig.core.provenance import software_versions
    from daq.index import session_and_entry
    from daq.pause import pauses_of
    from daq.run_index import record_of

    session_, entry = session_and_entry(session.path, load=lambda *_a, **_k: session)
    rec = record_of(Path(session.path), session_, entry)
    start, stop = session.start, session.stop or {}
    attrs: dict[str, Any] = {
        "Conventions": "CF-1.10",
        "title": f"contactrig session {rec['scene'] or ''}: {rec['sample'] or ''}".strip(),
        "source": f"contactrig session file {Path(session.path).name} (schema {session.schema_version})",
        "history": f"exported by contactrig {software_versions().get('contactrig', '')} (contactrig export --to "
        "netcdf)",
        "references": "Raffai, Marsalek & Necasova, Numerical modelling of dry friction of piston rings in internal "
        "combustion engines (electrical contact resistance against load)",
        "session_file": str(session.path),
        "schema_version": int(session.schema_version),
        "status": str(session.status),
        "complete": int(session.complete),
        "sealed": int(session.sealed),
        "kind": rec["kind"],
        "sample": rec["sample"],
        "operator": rec["operator"],
        "notes": rec["notes"],
        "scene_name": rec["scene"],
        "scene_sha256": rec["scene_sha256"],
        "scene_text": session.scene_text,
        "content_id": rec["content_id"],
        "start_time": rec["start_time"],
        "start_time_utc": rec["start_utc"],
        "end_time": rec["end_time"],
        "stop_reason": str(stop.get("reason", "")),
        "blocks_done": int(rec["blocks_done"]),
        "blocks_planned": -1 if rec["blocks_planned"] is None else int(rec["blocks_planned"]),
        "overrides": _json(rec["overrides"]),
        "instrument_source_idn": rec["instruments"].get("source", ""),
        "instrument_voltmeter_idn": rec["instruments"].get("voltmeter", ""),
        "instrument_settings": _json(rec["settings"]),
        "software_version": rec["software_version"],
        "software": _json(rec["software"]),
        "host": str(start.get("host", "")),
        "runs": _json(session.runs),
        "pauses": _json(pauses_of(session.runs)),
        "plan": _json(start.get("plan", {})),
    }
    for where, record in (("start", start), ("stop", stop)):
        if "adaptive" in record:  # schema 4: the sequential design's settings; its suggestions and stop decision
            attrs[f"adaptive_{where}"] = _json(record["adaptive"])
    return attrs


def _var(dims: str, values: Any, units: str | None, long_name: str, **extra: Any) -> tuple[str, Any, dict]:
    attrs = {"long_name": long_name, **({"units": units} if units is not None else {}), **extra}
    return (dims, values, attrs)


def session_dataset(source: str | Path | Session) -> xr.Dataset:
    """The session at ``source`` (a path, or a :class:`~daq.session_file.Session` already read) as an
    :class:`xarray.Dataset`: dimensions ``block`` and ``reading``, CF ``units`` on every numeric variable, flagged
    readings kept with their flags, the session's metadata as global attributes (see the module docstring)."""
    from analysis.qcodes_netcdf import qcodes_attributes
    from daq.records import block_number

    (xr,) = _require("xarray")
    session = _load(source)
    s, r = session.summary, session.readings
    blocks = np.asarray([block_number(b) for b in s["block"].to_numpy(dtype=np.int64)], dtype=np.int32)
    compliance = s["compliance"].to_numpy(dtype=bool)
    reading_blocks = r["block"].to_numpy(dtype=np.int64)
    in_compliance = np.isin(reading_blocks, s["block"].to_numpy(dtype=np.int64)[compliance])
    valid = r["valid"].to_numpy(dtype=bool)
    raw = r["reading"].to_numpy(dtype=float)
    flag = (
        np.where(valid, 0, FLAG_INVALID)
        | np.where(np.isfinite(raw), 0, FLAG_NO_VALUE)
        | np.where(in_compliance, FLAG_COMPLIANCE, 0)
    ).astype(np.uint8)
    ohm = "ohm"
    start = session.start if isinstance(session.start, dict) else {}
    data = {
        "run": _var("block", s["run"].to_numpy(dtype=np.int32), "1", "run of the block (0: first, k: k-th --resume)"),
        "weight": _var("block", s["weight_kg"].to_numpy(dtype=float), "kg", "weight placed on the piston"),
        "repeat": _var("block", s["repeat"].to_numpy(dtype=np.int32), "1", "repeat of this weight (1-based)"),
        "mean_resistance": _var("block", s["mean_ohm"].to_numpy(dtype=float), ohm,
                                "mean resistance of the block's valid readings (NaN: none, or in compliance)"),
        "sd_resistance": _var("block", s["sd_ohm"].to_numpy(dtype=float), ohm,
                              "standard deviation (n - 1) of the block's valid readings"),
        "sem_resistance": _var("block", s["sem_ohm"].to_numpy(dtype=float), ohm,
                               "standard error of the block mean (sd / sqrt(n_valid))"),
        "n_valid": _var("block", s["n"].to_numpy(dtype=np.int32), "1", "valid readings in the block"),
        "n_invalid": _var("block", s["n_invalid"].to_numpy(dtype=np.int32), "1", "invalid readings in the block"),
        "block_started": _var("block", np.asarray([str(t) for t in s["started"]], dtype=object), None,
                              "start of the block (ISO-8601 with its UTC offset)"),
        "compliance": _var("block", compliance.astype(np.uint8), "1",
                           "the current source was in compliance during the block (readings excluded)",
                           flag_values=np.asarray([0, 1], dtype=np.uint8),
                           flag_meanings="not_in_compliance in_compliance"),
        "reading_block": _var("reading", np.asarray([block_number(b) for b in reading_blocks], dtype=np.int32), "1",
                              "block number of the reading (1-based, the coordinate of dimension block)"),
        "reading_index": _var("reading", r["index"].to_numpy(dtype=np.int32), "1",
                              "position of the reading in its block (0-based)"),
        "time": _var("reading", r["time_s"].to_numpy(dtype=float), "s",
                     "time stamp of the reading, as the instrument returned it"),
        "raw_reading": _var("reading", raw, _reading_units(start),
                        "reading as the instrument returned it (NaN: +9.9E37, overflow or no reading)"),
        "resistance": _var("reading", r["resistance_ohm"].to_numpy(dtype=float), ohm, "resistance of the reading"),
        "valid": _var("reading", valid.astype(np.uint8), "1", "1 = the reading is averaged into its block's mean",
                      flag_values=np.asarray([0, 1], dtype=np.uint8), flag_meanings="invalid valid"),
        "reading_flag": _var("reading", flag, "1", "quality flags of the reading (0: good)",
                             flag_masks=np.asarray([FLAG_INVALID, FLAG_NO_VALUE, FLAG_COMPLIANCE], dtype=np.uint8),
                             flag_meanings=_FLAG_MEANINGS),
    }  # fmt: skip
    coords = {
        "block": ("block", blocks, {"long_name": "block number (1-based)", "units": "1"}),
        "reading": ("reading", np.arange(len(r), dtype=np.int32),
                    {"long_name": "reading number in the session (0-based, in the order of the readings table)",
                     "units": "1"}),
    }  # fmt: skip
    ds = xr.Dataset(data, coords=coords, attrs=_metadata(session))
    ds["mean_resistance"].attrs["ancillary_variables"] = "sd_resistance sem_resistance n_valid compliance"
    ds["resistance"].attrs["ancillary_variables"] = "valid reading_flag"
    ds.attrs.update(qcodes_attributes(ds))  # loadable by QCoDeS's load_from_netcdf (analysis.qcodes_netcdf)
    return ds


def default_netcdf_output(source: str | Path) -> Path:
    """``SESSION.h5`` → ``SESSION.nc`` beside it."""
    return Path(source).with_suffix(".nc")


def write_netcdf(source: str | Path, output: str | Path | None = None, *, force: bool = False) -> Path:
    """Write the session at ``source`` as a netCDF-4 file (``output``, default ``SESSION.nc`` beside it) with
    h5netcdf through xarray; the output is checked before the session is read, never replaced without ``force``,
    and renamed into place when complete. Returns its path."""
    from contactrig.core.files import refuse_existing, replace_together

    _require("xarray", "h5netcdf")  # the one-line error before anything else
    out = Path(output) if output is not None else default_netcdf_output(source)
    (path,) = refuse_existing([out], force=force, inputs=[source])  # --force must not eat the session
    ds = session_dataset(source)
    with replace_together(path.parent, [path], force=force) as stage:
        ds.to_netcdf(stage / path.name, engine="h5netcdf")
    return path
