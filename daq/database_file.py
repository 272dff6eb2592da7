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

import h5py
import numpy as np

from contactrig.core.files import atomic_write
from contactrig.core.provenance import to_json
from contactrig.core.validation import SettingError
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
    return Path(path)


def load_database(path: str | Path) -> ContactDatabase:
    """Read a database written by :func:`save_database`."""
    p = Path(path)
    if not p.exists():
        raise SettingError("database", str(p), "file not found")
    try:
        f = h5py.File(p, "r")
    except OSError as exc:
        raise SettingError("database", str(p), f"not a readable HDF5 file ({exc})") from None
    with f:
        if f.attrs.get("format") != FORMAT:
            raise SettingError("database", str(p), "not a contactrig contact database")
        prov = json.loads(f.attrs.get("provenance", "{}"))
        curves = {}
        for name in f:
            g = f[name]
            h, pressure, area = (np.asarray(g[key][()], dtype=float) for key in _UNITS)
            curves[name] = ContactCurve(name, h, pressure, area, json.loads(g.attrs.get("parameters", "{}")))
    listed = [m for m in prov.get("models", []) if m in curves]
    order = listed + [m for m in curves if m not in listed]
    return ContactDatabase({m: curves[m] for m in order}, prov)
