"""Snapshot PNGs of the live view (``contactrig watch --png``, ``acquire --live PNG``): marked as ours, so that a
later run rewrites its own snapshot without ``--force``, and still refuses any other file.

A snapshot is rewritten by design every few seconds: replacing the snapshot an earlier run left is not an
overwrite of a result. What makes a file "ours" is a PNG text chunk (:data:`SNAPSHOT_METADATA`, written by
:func:`analysis.watch.render_png`): a regular file — never a symbolic link, which is not followed even to read it —
whose first chunks hold ``contactrig-snapshot = live view``. Anything else at the name (a figure, a PNG from
another program, a link, a folder) is refused unless ``--force``, as by every command
(:func:`contactrig.core.files.check_new_file`).
"""

from __future__ import annotations

import os
import stat
import struct
from pathlib import Path

from contactrig.core.files import check_new_file

__all__ = ["SNAPSHOT_METADATA", "check_snapshot_path", "is_own_snapshot", "png_text"]

#: The PNG text chunk every live-view snapshot carries (matplotlib ``savefig(metadata=…)``).
SNAPSHOT_METADATA = {"contactrig-snapshot": "live view"}
_PNG = b"\x89PNG\r\n\x1a\n"
#: Bytes read to find the marker: text chunks come before the image data, far within this.
_HEAD_BYTES = 1 << 16


def png_text(data: bytes) -> dict[str, str]:
    """The ``tEXt`` chunks before the image data of the PNG bytes ``data`` (keyword → text, Latin-1)."""
    if not data.startswith(_PNG):
        return {}
    out: dict[str, str] = {}
    pos = len(_PNG)
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos : pos + 8])
        body = data[pos + 8 : pos + 8 + length]
        if kind in (b"IDAT", b"IEND") or len(body) < length:
            break
        if kind == b"tEXt":
            key, _, value = body.partition(b"\0")
            out[key.decode("latin-1")] = value.decode("latin-1")
        pos += 12 + length
    return out


def is_own_snapshot(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` is a regular file (not a link: never followed) that is a live-view snapshot."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError:
        return False
    with os.fdopen(fd, "rb") as f:
        if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
            return False
        head = f.read(_HEAD_BYTES)
    text = png_text(head)
    return all(text.get(k) == v for k, v in SNAPSHOT_METADATA.items())


def check_snapshot_path(path: str | os.PathLike[str], *, force: bool = False) -> Path:
    """``path`` checked as a snapshot to write: a snapshot of ours is rewritten, anything else there is refused
    unless ``force`` (:func:`contactrig.core.files.check_new_file`, which also creates a missing folder)."""
    return check_new_file(path, force=force or is_own_snapshot(path))
