"""Who may write a session file: one advisory lock, and a new session published by rename.

* **The lock.** Every writer of a session file (``acquire``, ``acquire --resume``, ``import``) holds an exclusive
  ``flock`` on the file for as long as it has it open (:func:`lock_exclusive`), taken *before* the file is opened
  for writing, so a refusal changes nothing. It is the lock HDF5 itself uses (HDF5 takes ``flock`` shared for a
  reader, exclusive for a writer, and the writer opens the file without HDF5's own locking), so a program holding
  the file open with h5py/HDF5 — reader or writer — keeps every writer out, and readers see a running session as
  locked and fall back to the lock-free reader. The lock belongs to the file (the inode), so it follows the file
  through the rename below; it ends when the process does (a killed writer leaves no stale lock).
* **Nothing is truncated or replaced in place.** A new session is written to a hidden temporary file in the
  target's folder (``.<name>.<random>.tmp``, the name shortened and hashed where that would pass 255 bytes:
  :func:`temporary_beside`) and appears under its name only once its
  start record is on disk (:func:`publish`): without ``--force`` by a hard link that fails if the name exists
  (no race with a second writer); with ``--force`` by a rename, made while an exclusive lock is held on the file it
  replaces (:func:`claimed`) — a file in use is refused and left as it was. A program that opened the old file
  without locking keeps reading it intact: the rename replaces the folder entry, not the file's bytes.
* **Links.** A symbolic link at the output name is never followed for writing: it is refused without ``--force``
  and, with it, replaced by the new file (the file it points to is untouched) — the rule of every output
  (:mod:`contactrig.core.files`).

Temporary files of writers that were killed (``SIGKILL``, power cut) are removed by the next writer of the same
name (:func:`remove_stale_temporaries`): a temporary file nobody holds locked is stale.
"""

from __future__ import annotations

import contextlib
import errno
import glob
import hashlib
import os
import stat
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from contactrig.core.files import sync_folder
from daq.errors import FileLockingError, SessionExistsError, SessionWriteError, in_use_error

try:
    import fcntl
except ImportError:  # Windows: no flock; HDF5's own locking is all there is
    fcntl = None  # type: ignore[assignment]

__all__ = [
    "claimed",
    "lock_exclusive",
    "publish",
    "remove_stale_temporaries",
    "replaceable",
    "temporary_beside",
]

#: A temporary file younger than this is never taken for a killed writer's (it may not be locked yet), in s.
_FRESH_S = 30.0
_IN_USE = (errno.EAGAIN, errno.EWOULDBLOCK, errno.EACCES)


def lock_exclusive(fd: int, path: Path) -> None:
    """Take the exclusive advisory lock on the open file ``fd`` (never waits); raises :func:`in_use_error` when
    another process holds the file, :class:`FileLockingError` when the file system has no locks (NFS/SMB)."""
    if fcntl is None:
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as exc:
        if exc.errno in _IN_USE:
            raise in_use_error(path) from None
        raise FileLockingError(
            exc.errno or errno.ENOLCK,
            f"the file system holding {path} refuses file locking (typical of NFS/SMB network shares): "
            "write the session to a local disk and copy it to the share afterwards",
        ) from None


def replaceable(path: Path) -> bool:
    """Check that ``path`` may be replaced now (``--force``): absent, a symbolic link (replaced, never followed), or a
    regular file no other process holds open. Returns whether something is there; raises otherwise."""
    with claimed(path) as there:
        return there


@contextmanager
def claimed(path: Path) -> Iterator[bool]:
    """Hold the exclusive lock on the file at ``path`` (not following a link) while the block runs: the moment to
    rename a new file over it. Yields whether something is at ``path``. A folder, a FIFO or device, or a file in
    use is refused with nothing changed."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        yield False
        return
    if stat.S_ISLNK(st.st_mode):
        yield True  # the link itself is replaced; what it points to is never opened
        return
    if stat.S_ISDIR(st.st_mode):
        raise SessionWriteError(errno.EISDIR, f"{path} is a folder, not a file name")
    if not stat.S_ISREG(st.st_mode):
        raise SessionWriteError(errno.EINVAL, f"{path} is not a regular file (a FIFO, socket or device): not replaced")
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except FileNotFoundError:
        yield False
        return
    try:
        lock_exclusive(fd, path)
        yield True
    finally:
        os.close(fd)


def temporary_beside(target: Path) -> Path:
    """A new, empty temporary file in ``target``'s folder (same file system, so it can be renamed over ``target``),
    with the usual permissions; its writer opens it at once and locks it (:func:`lock_exclusive`). A folder that
    cannot take it raises the :class:`OSError` of ``mkstemp``."""
    remove_stale_temporaries(target)
    fd, name = tempfile.mkstemp(prefix=_prefix(target), suffix=".tmp", dir=target.parent)
    try:
        os.fchmod(fd, 0o666 & ~_umask())  # mkstemp makes it private; the session gets the usual permissions
    finally:
        os.close(fd)
    return Path(name)


def _prefix(target: Path) -> str:
    """The start of the temporary file names of ``target``: ``.NAME.``, or for a name too long to take 14 more bytes
    within ``NAME_MAX`` (255 bytes), its first 228 bytes and a hash of the whole, ``.NAME…~HASH.`` — every legal
    name gets a temporary name that fits."""
    raw = os.fsencode(target.name)
    if len(raw) + 14 <= 255:  # "." + name + "." + 8 random + ".tmp"
        return f".{target.name}."
    digest = hashlib.sha256(raw).hexdigest()[:12]
    return f".{os.fsdecode(raw[:228])}~{digest}."


def remove_stale_temporaries(target: Path) -> None:
    """Remove the temporary files killed writers of ``target`` left behind (those no process holds locked)."""
    if fcntl is None:
        return
    try:
        pattern = f"{glob.escape(_prefix(target))}*.tmp"
        names = [p for p in target.parent.glob(pattern) if p.is_file() and not p.is_symlink()]
    except OSError:
        return
    for p in names:
        with contextlib.suppress(OSError):
            if time.time() - p.stat().st_mtime < _FRESH_S:
                continue  # just made: its writer may not have locked it yet
        try:
            fd = os.open(p, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            p.unlink(missing_ok=True)  # still locked by us: no writer can have taken it up meanwhile
        except OSError:
            pass  # a live writer's file
        finally:
            os.close(fd)


def publish(tmp: Path, target: Path, *, force: bool) -> None:
    """Give the written temporary file ``tmp`` its name ``target``: without ``force`` only if the name is free
    (:class:`SessionExistsError` otherwise), with ``force`` over what is there unless it is in use. Either way the
    file at ``target`` is never opened for writing, truncated or followed (a link is replaced)."""
    if not force:
        _link_new(tmp, target)
    else:
        with claimed(target):
            os.replace(tmp, target)
    sync_folder(target.parent)


def _link_new(tmp: Path, target: Path) -> None:
    try:
        os.link(tmp, target)  # atomic, and fails on any existing name — a link, even a dangling one, included
    except FileExistsError:
        raise SessionExistsError(errno.EEXIST, f"{target} exists; use --force to overwrite it") from None
    except OSError as exc:
        if exc.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV):
            raise
        # a file system without hard links (FAT, some network shares): check, then rename
        if os.path.lexists(target):
            raise SessionExistsError(errno.EEXIST, f"{target} exists; use --force to overwrite it") from None
        os.replace(tmp, target)
        return
    tmp.unlink()


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
