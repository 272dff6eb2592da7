"""The contact database's HDF5 file (``contactrig database -o``): the I/O edge of :mod:`sims.database`.

Layout: root attributes ``format`` = "contactrig-contact-database", ``format_version`` = 1 and ``provenance`` (JSON:
scene name and text, materials, surface statistics, software version); one group per model with datasets
``separation_m`` (units "m"), ``pressure_pa`` ("Pa") and ``area_fraction`` ("1"), and the model's parameters as the
group's JSON attribute ``parameters``; root attribute ``validity_warnings`` (JSON list: elastic-only models built with
a plasticity index > 1) and ``fingerprint`` (JSON: hashed materials, surfaces and database
settings the curves were built from, :func:`daq.sweep_file.database_fingerprint`). Written to a temporary file in the
same folder, then renamed (:func:`contactrig.core.files.atomic_write`: nothing is left behind on failure); an existing
file is replaced only with ``force``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from contactrig.core.files import atomic_write
from contactrig.core.provenance import to_json
from contactrig.core.validation import SettingError
from daq import file_seal
from sims.database import ContactCurve, ContactDatabase

__all__ = ["FORMAT", "load_database", "save_database"]

FORMAT = "contactrig-contact-database"
_UNITS = {"separation_m": "m", "pressure_pa": "Pa", "area_fraction": "1"}


def save_database(db: ContactDatabase, path: str | Path, *, force: bool = False) -> Path:
    """Write ``db`` to HDF5 at ``path`` (layout in the module docstring) atomically; an existing file is refused
    unless ``force``. Returns the path."""
    from daq.sweep_file import database_fingerprint, plasticity_warnings

    with atomic_write(path, force=force) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["format_version"] = 1
        f.attrs["provenance"] = to_json(db.provenance)
        f.attrs["fingerprint"] = to_json(database_fingerprint(db.provenance), sort_keys=True)
        f.attrs["validity_warnings"] = to_json(plasticity_warnings(list(db.curves), db.provenance))
        for name, curve in db.curves.items():
            g = f.create_group(name)
            for key, unit in _UNITS.items():
                g.create_dataset(key, data=np.asarray(getattr(curve, key))).attrs["units"] = unit
            g.attrs["parameters"] = to_json(curve.parameters)
        file_seal.seal(f)  # last: the loader reports any member changed, added or removed after this
    return Path(path)


def load_database(path: str | Path, *, timeout: float | None = None) -> ContactDatabase:
    """Read a database written by :func:`save_database`; a missing, foreign or damaged file is a
    :class:`SettingError` naming it (and the member at fault).

    Read in a child process within ``timeout`` seconds (:mod:`daq.bounded`: a damaged HDF5 file can neither hang
    nor crash the caller). A sealed file's seal is checked (:mod:`daq.file_seal`); ``provenance["sealed"]`` says
    whether it had one, and an unsealed file says so in ``provenance["file_notes"]``.
    """
    from daq.bounded import call_bounded
    from daq.errors import SessionFileError

    p = Path(path)
    if not p.exists():
        raise SettingError("database", str(p), "file not found")
    try:
        curves, prov = call_bounded(_read_database, (p,), path=p, what="contact database", timeout=timeout)
    except (SessionFileError, OSError) as exc:
        raise SettingError("database", str(p), str(exc).replace(f"{p}: ", "").replace(str(p), "the file")) from None
    listed = [m for m in prov.get("models", []) if m in curves]
    order = listed + [m for m in curves if m not in listed]
    return ContactDatabase({m: curves[m] for m in order}, prov)


def _read_database(p: Path) -> tuple[dict[str, ContactCurve], dict[str, Any]]:
    """The work of :func:`load_database` (in the child process), every member checked."""
    from daq import file_seal
    from daq.errors import SessionFileError

    try:
        f = h5py.File(p, "r")
    except OSError as exc:
        raise SessionFileError(f"not a readable HDF5 file ({_first(exc)})") from None
    where = "/"
    with f:
        try:
            if _short_attr(f, "format") != FORMAT:
                raise SessionFileError("not a contactrig contact database")
            sealed = file_seal.check(f, str(p), "contact database")
            where = "/@provenance"
            prov = _json_attr(f, "provenance")
            curves = {}
            for name in f:
                where = f"/{name}"
                curves[name] = _curve(f[name], name)
        except SessionFileError:
            raise
        except Exception as exc:  # untrusted content (SettingError too): one line naming the member
            raise SessionFileError(f"{where} is unreadable or invalid ({_first(exc)})") from None
    prov["sealed"] = sealed
    if not sealed:
        prov["file_notes"] = [f"{p} is UNSEALED (written before database files were sealed): not verified"]
    return curves, prov


def _first(exc: BaseException) -> str:
    lines = [ln for ln in str(exc).splitlines() if ln.strip()]
    return lines[0].strip() if lines else type(exc).__name__


def _short_attr(obj: Any, name: str) -> Any:
    from daq.errors import SessionFileError

    if name not in obj.attrs:
        return None
    aid = obj.attrs.get_id(name)
    if aid.shape not in ((), (1,)) or aid.get_storage_size() > (16 << 20):
        raise SessionFileError(f"{obj.name.rstrip('/')}/@{name} is not a single value")
    value = obj.attrs[name]
    return value.decode("utf-8") if isinstance(value, bytes) else value


def _json_attr(obj: Any, name: str) -> dict[str, Any]:
    from daq.errors import SessionFileError

    text = _short_attr(obj, name)
    value = json.loads(text) if isinstance(text, str) else {} if text is None else None
    if not isinstance(value, dict):
        raise SessionFileError(f"{obj.name.rstrip('/')}/@{name} is not a JSON record")
    return value


def _curve(g: Any, name: str) -> ContactCurve:
    from daq.errors import SessionFileError

    if not isinstance(g, h5py.Group):
        raise SessionFileError(f"/{name} is not a model group")
    arrays = []
    for key in _UNITS:
        ds = g.get(key)
        if not isinstance(ds, h5py.Dataset) or ds.ndim != 1 or ds.dtype.kind not in "iuf":
            raise SessionFileError(f"/{name}/{key} is missing or not a column of numbers")
        arrays.append(np.asarray(ds[()], dtype=float))
    h, pressure, area = arrays
    return ContactCurve(name, h, pressure, area, _json_attr(g, "parameters"))
