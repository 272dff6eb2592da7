"""Input files a user names (scene files, the height maps a scene names): untrusted, read within stated bounds.

One reader, :func:`read_input_bytes` (:func:`read_text_file` for UTF-8 text), used for every such file:

* **A regular file.** The path is followed through its links and what it ends at must be a regular file: a FIFO,
  a device (``/dev/zero``, ``/dev/urandom``), a socket or a folder is refused unread. It is opened non-blocking, so
  opening a FIFO cannot hang, and checked on the opened descriptor (nothing can be swapped in between).
* **A size limit**, checked on the file's size before reading and again while reading (a file that grows):
  :data:`SCENE_MAX_BYTES` for a scene, :data:`HEIGHT_MAP_MAX_BYTES` for a height map.
* **A time bound** (:data:`READ_TIMEOUT_S`): reading stops with an error when it takes longer (a stalled network
  file system).

Every refusal is a :class:`~contactrig.core.validation.SettingError` naming the key (``scene``,
``[surfaces.liner] path``), the path and what is allowed. Standard library only.
"""

from __future__ import annotations

import os
import stat
import time
from pathlib import Path

from contactrig.core.validation import SettingError

__all__ = [
    "HEIGHT_MAP_MAX_BYTES",
    "HEIGHT_MAP_MAX_SIDE",
    "READ_TIMEOUT_S",
    "SCENE_MAX_BYTES",
    "read_input_bytes",
    "read_text_file",
]

#: Largest scene file, bytes (4 MiB: the packaged scene, every key commented, is ~12 KB).
SCENE_MAX_BYTES = 4 << 20

#: Largest side of a measured height map, points: the largest grid of a generated surface (``n`` ≤ 8192).
HEIGHT_MAP_MAX_SIDE = 8192

#: Largest height-map file, bytes (256 MiB: a 4096 × 4096 map at 16 characters per number).
HEIGHT_MAP_MAX_BYTES = 256 << 20

#: Longest time reading one input file may take, s.
READ_TIMEOUT_S = 30.0

_CHUNK = 1 << 20
_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def _kind(mode: int) -> str:
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def _size_text(n: int) -> str:
    return f"{n / (1 << 20):.4g} MiB" if n >= 1 << 20 else f"{n} bytes"


def _open(key: str, p: Path) -> int:
    try:
        return os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise SettingError(key, str(p), "file not found") from None
    except OSError as exc:
        raise SettingError(key, str(p), f"cannot be read ({exc.strerror or exc})") from None


def read_input_bytes(key: str, path: str | Path, *, max_bytes: int, timeout_s: float = READ_TIMEOUT_S) -> bytes:
    """The bytes of the regular file ``path`` (links followed), at most ``max_bytes`` long, read within
    ``timeout_s`` seconds; anything else is a :class:`SettingError` naming ``key``."""
    p = Path(path)
    allowed = f"expected a regular file of at most {_size_text(max_bytes)}"
    fd = _open(key, p)
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise SettingError(key, str(p), f"{allowed}; this is {_kind(st.st_mode)}")
        if st.st_size > max_bytes:
            raise SettingError(key, str(p), f"{allowed}; this one has {st.st_size} bytes")
        return _read_bounded(key, p, fd, max_bytes, timeout_s, allowed)
    finally:
        os.close(fd)


def _read_bounded(key: str, p: Path, fd: int, max_bytes: int, timeout_s: float, allowed: str) -> bytes:
    deadline = time.monotonic() + timeout_s
    parts: list[bytes] = []
    total = 0
    while True:
        try:
            chunk = os.read(fd, min(_CHUNK, max_bytes + 1 - total))
        except OSError as exc:
            raise SettingError(key, str(p), f"cannot be read ({exc.strerror or exc})") from None
        if not chunk:
            return b"".join(parts)
        parts.append(chunk)
        total += len(chunk)
        if total > max_bytes:
            raise SettingError(key, str(p), f"{allowed}; it grew beyond that while being read")
        if time.monotonic() > deadline:
            raise SettingError(key, str(p), f"reading took longer than {timeout_s:g} s (a stalled file system?)")


def read_text_file(key: str, path: str | Path, *, max_bytes: int = SCENE_MAX_BYTES) -> str:
    """The UTF-8 text of ``path`` (:func:`read_input_bytes`); not UTF-8 is a :class:`SettingError` naming ``key``."""
    raw = read_input_bytes(key, path, max_bytes=max_bytes)
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise SettingError(key, str(path), "not a UTF-8 text file") from None
