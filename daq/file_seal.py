"""The seal of a sweep or contact-database file: SHA-256 of every member, stored in the file, checked on reading.

A writer calls :func:`seal` on the open file as its last step (after every dataset and attribute is written); it
stores, in the root attribute ``content_sha256``, a JSON object mapping every member (``/scene_text``,
``/models/hertz/force_n``, ``/@format`` for a root attribute…) to the SHA-256 of its type, shape and content. A
reader calls :func:`check`: True when the seal holds, False when the file has none (written before files were
sealed: the reader says "unsealed"), and :class:`~daq.errors.SessionFileError` naming the first member that was
added, removed or changed after sealing. A checksum, not a signature: it catches damage and careless edits, not a
forger who recomputes it.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

import h5py
import numpy as np

from daq.errors import ChecksumError

__all__ = ["SEAL_ATTRIBUTE", "check", "member_digests", "seal"]

SEAL_ATTRIBUTE = "content_sha256"


def _value_bytes(value: Any) -> bytes:
    arr = np.asarray(value)
    if arr.dtype.kind in "OSU":
        items = [v.decode("utf-8", "surrogateescape") if isinstance(v, bytes) else str(v) for v in arr.reshape(-1)]
        return "\x1e".join(items).encode("utf-8", "surrogatepass")
    if arr.dtype.kind in "biufc":
        return np.ascontiguousarray(arr, dtype=arr.dtype.newbyteorder("<")).tobytes()
    return repr(arr.tolist()).encode()


def _digest(kind: str, value: Any) -> str:
    arr = np.asarray(value)
    h = hashlib.sha256(f"{kind}\x1f{arr.dtype.kind}\x1f{arr.shape}\x1f".encode())
    h.update(_value_bytes(value))
    return h.hexdigest()


def member_digests(f: h5py.File) -> dict[str, str]:
    """SHA-256 of every dataset and attribute of ``f`` (the seal attribute itself aside), keyed by member path."""
    out: dict[str, str] = {}

    def attrs(path: str, obj: Any) -> None:
        for name in sorted(obj.attrs):
            if path == "/" and name == SEAL_ATTRIBUTE:
                continue
            out[f"{path.rstrip('/')}/@{name}"] = _digest("attr", obj.attrs[name])

    def visit(name: str, obj: Any) -> None:
        path = f"/{name}"
        if isinstance(obj, h5py.Dataset):
            value = obj.asstr()[()] if h5py.check_string_dtype(obj.dtype) is not None else obj[()]
            out[path] = _digest("dataset", value)
        else:
            out[path] = _digest("group", 0)
        attrs(path, obj)

    attrs("/", f)
    f.visititems(visit)
    return dict(sorted(out.items()))


def seal(f: h5py.File) -> None:
    """Store the seal of ``f`` (open for writing; call it last, after every member is written)."""
    f.attrs[SEAL_ATTRIBUTE] = json.dumps(member_digests(f), sort_keys=True)


def check(f: h5py.File, label: str, what: str) -> bool:
    """True when ``f``'s seal holds, False when it has none; raises :class:`ChecksumError` naming the first member
    added, removed or changed since it was sealed (``label``: the file, as messages name it)."""
    if SEAL_ATTRIBUTE not in f.attrs:
        return False
    raw = f.attrs[SEAL_ATTRIBUTE]
    try:
        recorded = json.loads(raw.decode() if isinstance(raw, bytes) else str(raw))
    except (json.JSONDecodeError, UnicodeDecodeError):
        recorded = None
    if not isinstance(recorded, dict):
        raise ChecksumError(f"{label}: /@{SEAL_ATTRIBUTE} (the seal) is damaged: the {what} was altered or damaged")
    actual = member_digests(f)
    for member in sorted(set(recorded) | set(actual)):
        if member not in actual:
            change = "was removed"
        elif member not in recorded:
            change = "was added"
        elif recorded[member] != actual[member]:
            change = "changed"
        else:
            continue
        raise ChecksumError(f"{label}: {member} {change} after the {what} was sealed (SHA-256): the file was altered")
    return True
