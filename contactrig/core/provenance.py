"""Provenance: what made a file — software versions, host, operator, time — and the one JSON encoder for records.

Every file contactrig writes (session, contact database, rig sweep, report) records these through this module, so
the version lookup and the JSON conversion of numpy values exist once.
"""

from __future__ import annotations

import json
import socket
import sys
from datetime import datetime
from typing import Any

import numpy as np

__all__ = [
    "host_name",
    "json_default",
    "json_finite",
    "login_name",
    "now_iso",
    "package_version",
    "software_version",
    "software_versions",
    "to_json",
]


def package_version(name: str) -> str:
    """The installed version of distribution ``name`` (read from metadata; nothing is imported), or "not installed"."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(name)
    except PackageNotFoundError:
        return "not installed"


def software_version() -> str:
    """contactrig's own version ("0+unknown" when run from a source tree that was never installed)."""
    v = package_version("contactrig")
    return "0+unknown" if v == "not installed" else v


def software_versions() -> dict[str, str]:
    """Versions of contactrig, Python, numpy, h5py and pyvisa, from package metadata (nothing heavy is imported)."""
    return {
        "contactrig": package_version("contactrig"),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "h5py": package_version("h5py"),
        "pyvisa": package_version("pyvisa"),
        "pyvisa-sim": package_version("pyvisa-sim"),
    }


def host_name() -> str:
    """This computer's network name."""
    return socket.gethostname()


def login_name() -> str:
    """The operator's login name, recorded when the scene (or ``--operator``) names nobody; "unknown" if none."""
    import getpass

    try:
        return getpass.getuser()
    except Exception:  # no login name in some containers
        return "unknown"


def now_iso() -> str:
    """The current local time as ISO-8601 with its UTC offset, e.g. ``2026-11-21T10:15:17.123+01:00``."""
    return datetime.now().astimezone().isoformat(timespec="milliseconds")


def json_default(obj: Any) -> Any:
    """``json.dumps(default=...)`` for numpy scalars and arrays; anything else unknown is written as its ``str``."""
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return str(obj)


def json_finite(value: Any) -> Any:
    """``value`` (plain JSON values: dicts, lists, numbers, text) with every NaN or infinite float as None: JSON
    (RFC 8259) has no NaN, and SQLite's JSON functions and browsers refuse it."""
    if isinstance(value, float):
        return value if value == value and abs(value) != float("inf") else None
    if isinstance(value, dict):
        return {k: json_finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [json_finite(v) for v in value]
    return value


def to_json(value: Any, **kwargs: Any) -> str:
    """``json.dumps`` with :func:`json_default` (the one encoder every record and provenance goes through)."""
    return json.dumps(value, default=json_default, **kwargs)
