"""HDF5 file of a rig load sweep (``contactrig simulate -o sim.h5``): arrays with units, warnings, provenance.

The sweep itself is computed by :func:`sims.rig.sweep` (physics, no file I/O); ``daq`` owns every data file.

Layout (every array carries a ``units`` attribute)::

    /                       attrs: format = "contactrig-sweep", format_version = 1, software_version, scene_name
    /scene_text             the scene file's exact text
    /provenance_json        provenance dict as JSON (scene text, database provenance, rig settings, version)
    /warnings               variable-length strings
    /models/<name>/<field>  weight_kg [kg], contact_area_m2 [m^2], min_separation_m [m], force_n [N],
                            peak_pressure_pa [Pa], contact_width_m [m], n_nodes [1], converged [1]

The file is written to a temporary name and renamed, so a crash never leaves a half-written sweep.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from contactrig.core.provenance import json_default

if TYPE_CHECKING:
    from sims.rig.sweep import SweepResult

__all__ = ["FORMAT", "load_sweep", "save_sweep"]

FORMAT = "contactrig-sweep"
FORMAT_VERSION = 1


def save_sweep(result: SweepResult, path: str | os.PathLike[str]) -> Path:
    """Write ``result`` to the HDF5 file ``path`` (replaced atomically); returns the path."""
    import h5py

    from sims.rig.sweep import ModelSweep

    path = Path(path)
    tmp = path.with_name(path.name + ".partial")
    str_dtype = h5py.string_dtype()
    with h5py.File(tmp, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["format_version"] = FORMAT_VERSION
        f.attrs["software_version"] = str(result.provenance.get("software_version", ""))
        f.attrs["scene_name"] = str(result.provenance.get("scene_name", ""))
        f.create_dataset("scene_text", data=str(result.provenance.get("scene_text", "")), dtype=str_dtype)
        f.create_dataset(
            "provenance_json",
            data=json.dumps(result.provenance, default=json_default, sort_keys=True),
            dtype=str_dtype,
        )
        f.create_dataset("warnings", data=np.array(result.warnings, dtype=object), dtype=str_dtype)
        models = f.create_group("models")
        for name, m in result.models.items():
            g = models.create_group(name)
            for attr, unit in ModelSweep.UNITS.items():
                d = g.create_dataset(attr, data=np.asarray(getattr(m, attr)))
                d.attrs["units"] = unit
        f.flush()
    os.replace(tmp, path)
    return path


def load_sweep(path: str | os.PathLike[str]) -> SweepResult:
    """Read a sweep written by :func:`save_sweep`; a file of another kind is a ``ValueError`` naming it."""
    import h5py

    from sims.rig.sweep import ModelSweep, SweepResult

    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except FileNotFoundError:
        raise FileNotFoundError(f"sweep file not found: {path}") from None
    except OSError as exc:
        raise ValueError(f"{path} is not a readable HDF5 file ({exc})") from None
    with f:
        if f.attrs.get("format") != FORMAT:
            raise ValueError(f"{path} is not a contactrig sweep file (format attribute {f.attrs.get('format')!r})")
        provenance = json.loads(_text(f["provenance_json"][()]))
        warnings = [_text(w) for w in f["warnings"][()]]
        models = {}
        for name, g in f["models"].items():
            arrays = {attr: np.asarray(g[attr][()]) for attr in ModelSweep.UNITS}
            arrays["converged"] = arrays["converged"].astype(bool)
            models[name] = ModelSweep(name=name, **arrays)
    return SweepResult(models=models, warnings=warnings, provenance=provenance)


def _text(value: Any) -> str:
    return value.decode("utf-8") if isinstance(value, bytes) else str(value)
