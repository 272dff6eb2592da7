"""Fingerprints: what a derived result was computed from, so results of different scenes are never mixed silently.

A fingerprint is a plain dict (JSON-ready) recorded in every derived file (sweep, contact database, report)::

    {"schema": 1,
     "tables": {"rig": {"sha256": "…", "values": {"clearance_m": 2e-05, …}}, "materials": {…}, …},
     "scene_sha256": "…", "software_version": "0.3.1"}

``tables`` holds the simulation-relevant scene tables *as the solvers used them* (defaults filled in, typed), each
canonicalised (JSON with sorted keys, exact float repr) and hashed; ``values`` flattens each table to dotted keys so a
difference can be named (``[rig] clearance_m``). Keys that do not change what a result means when two results are
compared are left out (:data:`IGNORED`: the weights a sweep was run at, the list of models built, values derived from
others). :func:`differences` compares two fingerprints and says what differs, in words; tables recorded by only one
side are not compared. Which tables a result has, and how they are read from a configuration or a provenance record,
is the business of the layers that own those (``daq.sweep_file``); this module only canonicalises, hashes and compares.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from typing import Any

from contactrig.core.provenance import json_default
from contactrig.core.validation import scene_key

__all__ = ["IGNORED", "SCHEMA", "canonical", "differences", "fingerprint", "has_tables", "sha256_text"]

SCHEMA = 1

#: Per table, keys left out of the fingerprint (dotted; ``*`` matches one level, a key also drops what is under it):
#: they do not change what a simulated curve means, or are derived from keys that are compared.
IGNORED: dict[str, tuple[str, ...]] = {
    "rig": ("weights_kg",),  # a sweep is interpolated onto the measured weights; out-of-range is refused there
    "database": ("models",),  # which curves were built, not how
    "materials": ("E_star_pa", "H_pa"),  # derived from the per-body values, which are compared
    "surfaces": ("*.mccool",),  # summit statistics a database computes from the surface settings
}


def _ignored(table: str, key: str) -> bool:
    parts = key.split(".")
    for pattern in IGNORED.get(table, ()):
        pat = pattern.split(".")
        if len(parts) >= len(pat) and all(p in ("*", k) for p, k in zip(pat, parts, strict=False)):
            return True
    return False


def sha256_text(text: str) -> str:
    """Hex SHA-256 of ``text`` (UTF-8)."""
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def canonical(value: Any) -> Any:
    """``value`` as plain JSON types (tuples → lists, numpy → Python), so equal settings compare and hash equal."""
    return json.loads(json.dumps(value, default=json_default, sort_keys=True))


def _flatten(value: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(value, Mapping):
        out: dict[str, Any] = {}
        for k in sorted(value):
            out.update(_flatten(value[k], f"{prefix}.{k}" if prefix else str(k)))
        return out
    return {prefix: value}


def fingerprint(
    tables: Mapping[str, Any], *, scene_text: str | None = None, software_version: str | None = None
) -> dict[str, Any]:
    """The fingerprint of a result computed from ``tables`` (table name → settings mapping; None entries skipped)."""
    out_tables: dict[str, Any] = {}
    for name in sorted(tables):
        value = tables[name]
        if value is None:
            continue
        flat = {k: v for k, v in _flatten(canonical(value)).items() if not _ignored(name, k)}
        out_tables[name] = {"sha256": sha256_text(json.dumps(flat, sort_keys=True)), "values": flat}
    fp: dict[str, Any] = {"schema": SCHEMA, "tables": out_tables}
    if scene_text is not None:
        fp["scene_sha256"] = sha256_text(scene_text)
    if software_version is not None:
        fp["software_version"] = software_version
    return fp


def has_tables(fp: Mapping[str, Any] | None) -> bool:
    """Whether ``fp`` records at least one table (a result without one cannot be checked)."""
    return bool(fp) and bool((fp or {}).get("tables"))


def _show(value: Any) -> str:
    if value is None:
        return "(not set)"
    if isinstance(value, float) and math.isfinite(value):
        return f"{value:g}"
    if isinstance(value, list) and all(isinstance(v, (int, float)) for v in value):
        return "[" + ", ".join(f"{v:g}" for v in value) + "]"
    return repr(value) if isinstance(value, str) else str(value)


def _key(table: str, key: str) -> str:
    # "surfaces" + "liner.sq_m" → "[surfaces.liner] sq_m"; "rig" + "clearance_m" → "[rig] clearance_m"
    return scene_key(f"{table}.{key}")


def differences(a: Mapping[str, Any], b: Mapping[str, Any], labels: tuple[str, str] = ("a", "b")) -> list[str]:
    """What differs between fingerprints ``a`` and ``b``, one phrase per key, e.g. ``"[rig] clearance_m differs:
    session 2e-05, simulation 2.5e-05"`` (``labels`` name the two sides). Tables only one side records are skipped."""
    ta, tb = a.get("tables") or {}, b.get("tables") or {}
    out = []
    for name in sorted(set(ta) & set(tb)):
        if ta[name].get("sha256") == tb[name].get("sha256"):
            continue
        va, vb = ta[name].get("values") or {}, tb[name].get("values") or {}
        keys = sorted(k for k in set(va) | set(vb) if va.get(k) != vb.get(k))
        for k in keys or ["(table)"]:
            out.append(f"{_key(name, k)} differs: {labels[0]} {_show(va.get(k))}, {labels[1]} {_show(vb.get(k))}")
    return out
