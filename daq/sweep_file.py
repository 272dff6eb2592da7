"""HDF5 file of a rig load sweep (``contactrig simulate -o sim.h5``): arrays with units, warnings, provenance.

The sweep itself is computed by :func:`sims.rig.sweep` (physics, no file I/O); ``daq`` owns every data file.

Layout (every array carries a ``units`` attribute)::

    /                       attrs: format = "contactrig-sweep", format_version = 1, software_version, scene_name
    /scene_text             the scene file's exact text
    /provenance_json        provenance dict as JSON (scene text, database provenance, rig settings, version)
    /warnings               variable-length strings (the solver's warnings, as ``SweepResult.warnings``)
    /validity_warnings      variable-length strings: where a model is used outside its validity
                            (:func:`validity_warnings`: plasticity index > 1 with an elastic-only model, nominal
                            pressure above the softer body's hardness)
    /fingerprint_json       what the sweep was computed from (:func:`sweep_fingerprint`,
                            :mod:`contactrig.core.fingerprint`): hashed scene tables as the solver used them
    /models/<name>/<field>  weight_kg [kg], contact_area_m2 [m^2], min_separation_m [m], force_n [N],
                            peak_pressure_pa [Pa], contact_width_m [m], n_nodes [1], converged [1]

The file is written to a temporary file in the same folder and renamed (:func:`contactrig.core.files.atomic_write`),
so a crash never leaves a half-written sweep or a temporary file; an existing file is replaced only with ``force``.

Fingerprints of a configuration (:func:`config_fingerprint`) and of a result's provenance
(:func:`sweep_fingerprint`, :func:`database_fingerprint`) are built from the same tables, so a session's scene and a
simulation can be compared key by key (``analysis.pipeline`` refuses a mismatch).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from contactrig.core.files import atomic_write
from contactrig.core.fingerprint import fingerprint, has_tables
from contactrig.core.provenance import json_default
from daq import file_seal

if TYPE_CHECKING:
    from sims.config import SimConfig
    from sims.rig.sweep import SweepResult

__all__ = [
    "FORMAT",
    "config_fingerprint",
    "database_fingerprint",
    "load_sweep",
    "plasticity_warnings",
    "save_sweep",
    "sweep_fingerprint",
    "validity_warnings",
]

FORMAT = "contactrig-sweep"
FORMAT_VERSION = 1


def save_sweep(result: SweepResult, path: str | os.PathLike[str], *, force: bool = False) -> Path:
    """Write ``result`` to the HDF5 file ``path`` atomically; an existing file is refused unless ``force``."""
    with atomic_write(path, force=force) as tmp:
        _write(result, tmp)
    return Path(path)


def _write(result: SweepResult, tmp: Path) -> None:
    import h5py

    from sims.rig.sweep import ModelSweep

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
        validity = validity_warnings(result)
        f.create_dataset("validity_warnings", data=np.array(validity, dtype=object), dtype=str_dtype)
        fp = sweep_fingerprint(result.provenance)
        f.create_dataset("fingerprint_json", data=json.dumps(fp, sort_keys=True), dtype=str_dtype)
        models = f.create_group("models")
        for name, m in result.models.items():
            g = models.create_group(name)
            for attr, unit in ModelSweep.UNITS.items():
                d = g.create_dataset(attr, data=np.asarray(getattr(m, attr)))
                d.attrs["units"] = unit
        file_seal.seal(f)  # last: the loader reports any member changed, added or removed after this
        f.flush()


def load_sweep(path: str | os.PathLike[str], *, timeout: float | None = None) -> SweepResult:
    """Read a sweep written by :func:`save_sweep`; a file of another kind, or a damaged one, is a ``ValueError``
    naming it (and the member at fault), a missing one ``FileNotFoundError``.

    Read in a child process within ``timeout`` seconds (:mod:`daq.bounded`: a damaged HDF5 file can neither hang
    nor crash the caller). A sealed file's seal is checked (:mod:`daq.file_seal`); ``provenance["sealed"]`` says
    whether it had one, and an unsealed file says so in ``provenance["file_notes"]``.
    """
    from daq.bounded import call_bounded

    p = Path(path)
    return call_bounded(_read_sweep, (p,), path=p, what="sweep file", timeout=timeout)


def _read_sweep(path: Path) -> SweepResult:
    """The work of :func:`load_sweep` (in the child process), every member checked."""
    import h5py

    from daq import file_seal
    from sims.rig.sweep import ModelSweep, SweepResult

    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise _SweepError(f"{path} is not a readable HDF5 file ({_first(exc)})") from None
    with f:
        where = "/"
        try:
            if _attr_text(f, "format") != FORMAT:
                raise _SweepError(
                    f"{path} is not a contactrig sweep file (format attribute {_attr_text(f, 'format')!r})"
                )
            sealed = file_seal.check(f, str(path), "sweep file")
            where = "/provenance_json"
            provenance = _json_object(_scalar_text(f, "provenance_json", path), path, where)
            where = "/warnings"
            warnings = _text_list(f, "warnings", path)
            if "fingerprint_json" in f and "fingerprint" not in provenance:
                where = "/fingerprint_json"
                provenance["fingerprint"] = _json_object(_scalar_text(f, "fingerprint_json", path), path, where)
            where = "/models"
            models = {}
            for name, g in _group(f, "models", path).items():
                where = f"/models/{name}"
                arrays = {attr: _numeric_column(g, attr, path) for attr in ModelSweep.UNITS}
                arrays["converged"] = arrays["converged"].astype(bool)
                models[name] = ModelSweep(name=name, **arrays)
        except ValueError:
            raise
        except Exception as exc:  # untrusted content: one line naming the member, never a traceback
            raise _SweepError(f"{path}: {where} is unreadable ({type(exc).__name__}: {_first(exc)})") from None
    provenance["sealed"] = sealed
    if not sealed:
        provenance["file_notes"] = [f"{path} is UNSEALED (written before sweep files were sealed): not verified"]
    return SweepResult(models=models, warnings=warnings, provenance=provenance)


class _SweepError(ValueError):
    """A sweep file that cannot be read (crosses the process boundary of :mod:`daq.bounded`)."""


def _first(exc: BaseException) -> str:
    lines = [ln for ln in str(exc).splitlines() if ln.strip()]
    return lines[0].strip() if lines else type(exc).__name__


def _attr_text(f: Any, name: str) -> str | None:
    if name not in f.attrs:
        return None
    aid = f.attrs.get_id(name)
    if aid.shape not in ((), (1,)) or aid.get_storage_size() > 4096:
        return "<not a short text>"
    value = f.attrs[name]
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)


def _member(f: Any, name: str, path: Path, kind: str) -> Any:
    import h5py

    obj = f.get(name)
    want = h5py.Group if kind == "group" else h5py.Dataset
    if not isinstance(obj, want):
        raise _SweepError(f"{path}: /{name} is {'missing' if obj is None else 'not a ' + kind}")
    return obj


def _group(f: Any, name: str, path: Path) -> Any:
    return _member(f, name, path, "group")


def _scalar_text(f: Any, name: str, path: Path) -> str:
    import h5py

    ds = _member(f, name, path, "dataset")
    if ds.shape != () or (ds.dtype.kind != "S" and h5py.check_string_dtype(ds.dtype) is None):
        raise _SweepError(f"{path}: /{name} is {ds.dtype} of shape {ds.shape}: expected one text string")
    return _text(ds[()])


def _json_object(text: str, path: Path, where: str) -> dict[str, Any]:
    try:
        value = json.loads(text)
    except (json.JSONDecodeError, RecursionError):
        raise _SweepError(f"{path}: {where} is not valid JSON") from None
    if not isinstance(value, dict):
        raise _SweepError(f"{path}: {where} is a JSON {type(value).__name__}, not a record (JSON object)")
    return value


def _text_list(f: Any, name: str, path: Path) -> list[str]:
    import h5py

    ds = _member(f, name, path, "dataset")
    if ds.ndim != 1 or (ds.dtype.kind != "S" and h5py.check_string_dtype(ds.dtype) is None):
        raise _SweepError(f"{path}: /{name} is {ds.dtype} of shape {ds.shape}: expected a list of texts")
    return [_text(w) for w in ds[()]]


def _numeric_column(g: Any, name: str, path: Path) -> np.ndarray:
    ds = _member(g, name, path, "dataset")
    if ds.ndim != 1 or ds.dtype.kind not in "biuf":
        raise _SweepError(f"{path}: {ds.name} is {ds.dtype} of shape {ds.shape}: expected a column of numbers")
    return np.asarray(ds[()])


def _text(value: Any) -> str:
    return value.decode("utf-8") if isinstance(value, bytes) else str(value)


# ---- fingerprints: the same tables from a configuration and from a result's provenance ----------------------------
def _database_settings(settings: Any) -> dict[str, Any]:
    return {k: getattr(settings, k) for k in ("n_separations", "h_min_sigma", "h_max_sigma", "gt_heights")}


def config_fingerprint(config: SimConfig) -> dict[str, Any]:
    """The fingerprint of what a simulation of ``config`` would be computed from (materials, surfaces, database
    settings, rig settings, and the press's sphere for a press scene; :mod:`contactrig.core.fingerprint`)."""
    from contactrig.core.provenance import software_version

    tables = {
        "materials": config.materials.as_dict(),
        "surfaces": {"liner": config.liner.as_dict(), "piston": config.piston.as_dict()},
        "database": _database_settings(config.database),
        "rig": config.rig.as_dict(),
    }
    if config.press is not None:  # a press scene: the sphere and its mesh matter; its load sweep, like the rig's, not
        tables["press"] = {k: v for k, v in config.press.as_dict().items() if k != "weights_kg"}
    return fingerprint(tables, scene_text=config.text, software_version=software_version())


def database_fingerprint(provenance: dict[str, Any], rig: dict[str, Any] | None = None) -> dict[str, Any]:
    """The fingerprint of a contact database from its provenance (materials, surfaces, settings), plus the rig
    settings of a sweep built on it (``rig``)."""
    prov = provenance or {}
    tables = {
        "materials": prov.get("materials"),
        "surfaces": prov.get("surfaces"),
        "database": prov.get("settings"),
        "rig": rig,
    }
    text = prov.get("scene_text")
    return fingerprint(
        tables,
        scene_text=text if isinstance(text, str) else None,
        software_version=str(prov.get("software_version", "")) or None,
    )


def sweep_fingerprint(provenance: dict[str, Any]) -> dict[str, Any]:
    """The fingerprint of a sweep: the one recorded with it (``provenance["fingerprint"]``, from a file), else built
    from its provenance (rig settings and the database's provenance). A result whose provenance records none of
    these has a fingerprint without tables (it cannot be checked)."""
    prov = provenance or {}
    recorded = prov.get("fingerprint")
    if isinstance(recorded, dict) and has_tables(recorded):
        return recorded
    db = prov.get("database") if isinstance(prov.get("database"), dict) else {}
    fp = database_fingerprint(db or {}, prov.get("rig_settings"))
    if isinstance(prov.get("scene_text"), str):
        from contactrig.core.fingerprint import sha256_text

        fp["scene_sha256"] = sha256_text(prov["scene_text"])
    if prov.get("software_version"):
        fp["software_version"] = str(prov["software_version"])
    return fp


def plasticity_warnings(models: list[str], database_provenance: dict[str, Any]) -> list[str]:
    """One warning per model registered ``elastic_only`` when the database's plasticity index ψ exceeds 1."""
    from sims.models import get_model, model_label

    psi = _number((database_provenance or {}).get("plasticity_index"))
    if psi is None or psi <= 1:
        return []
    out = []
    for name in models:
        try:
            elastic = get_model(name).elastic_only
        except KeyError:
            elastic = False
        if elastic:
            out.append(
                f"{model_label(name)}: plasticity index ψ = {psi:.3g} > 1 but the model is elastic only: most summits "
                "deform plastically, which it ignores (its area is too small, its pressure too high)"
            )
    return out


def validity_warnings(result: SweepResult) -> list[str]:
    """Where the sweep's models are used outside their validity, in words (one string per model and cause):

    * plasticity index ψ > 1 (the database's ``plasticity_index``) with a model registered ``elastic_only``
      (:class:`sims.models.ContactModel`): most summits deform plastically, which the model ignores;
    * peak nominal contact pressure above the hardness of the softer body (``materials.H_pa``): the nominal
      pressure cannot exceed the hardness (full plastic contact), so the model is outside its range there.
    """
    from sims.models import model_label

    prov = getattr(result, "provenance", None) or {}
    db = prov.get("database") if isinstance(prov.get("database"), dict) else {}
    hardness = _number(((db or {}).get("materials") or {}).get("H_pa"))
    out = plasticity_warnings(list(result.models), db or {})
    for name, m in result.models.items():
        p = np.asarray(getattr(m, "peak_pressure_pa", []), dtype=float).reshape(-1)
        if hardness is not None and p.size and np.nanmax(p) > hardness:
            i = int(np.nanargmax(p))
            out.append(
                f"{model_label(name)}: peak nominal contact pressure {p[i] / 1e6:.4g} MPa at {m.weight_kg[i]:g} kg "
                f"exceeds the softer body's hardness H = {hardness / 1e6:.4g} MPa: beyond full plastic contact, "
                "outside the model's range"
            )
    return out


def _number(value: Any) -> float | None:
    if isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value):
        return float(value)
    return None
