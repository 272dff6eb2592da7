"""Errors and warnings of bench sessions, each subclassing what the ``contactrig`` dispatcher reports in one line.

``ValueError`` for bad files and settings, ``OSError`` for the file system, ``RuntimeError`` for the session state.
"""

from __future__ import annotations

import errno
import re
from pathlib import Path

__all__ = [
    "ChecksumError",
    "FileLockingError",
    "IncompleteSessionWarning",
    "MissingFileError",
    "NewerSchemaError",
    "NoStartRecordError",
    "SessionExistsError",
    "SessionFileError",
    "SessionNoteWarning",
    "SessionStateError",
    "SessionWriteError",
    "errno_of",
    "first_line",
    "hdf5_error",
    "in_use_error",
]


class SessionFileError(ValueError):
    """A session file cannot be read: not HDF5, truncated, corrupted, or not a contactrig session."""


class ChecksumError(SessionFileError):
    """Recorded data do not match the SHA-256 stored with them: the file was altered or damaged.

    ``position`` is the row of the failing block in the summary (None when the whole file is at fault).
    """

    def __init__(self, message: str, position: int | None = None) -> None:
        super().__init__(message)
        self.position = position

    def __reduce__(self) -> tuple[type, tuple[str, int | None]]:  # crosses the process boundary of daq.bounded
        return (type(self), (str(self), self.position))


class NoStartRecordError(SessionFileError):
    """The file has no start record: its acquisition was stopped before it began (files of older versions)."""


class NewerSchemaError(SessionFileError):
    """The file was written with a newer session schema than this contactrig understands."""


class _OneLine(OSError):
    """An OSError built as ``Error(errno, message)`` that reads as its message alone (no ``[Errno N]`` prefix):
    the message already says what failed and what to do; ``errno`` stays available to code."""

    def __str__(self) -> str:
        return str(self.strerror) if self.strerror else super().__str__()


class MissingFileError(_OneLine, FileNotFoundError):
    """A file the user named does not exist (a session to read or resume, a table to import)."""


class SessionExistsError(_OneLine, FileExistsError):
    """The output file exists; it is never overwritten without ``--force`` (or continued without ``--resume``)."""


class SessionWriteError(_OneLine):
    """Writing the session file failed (unwritable path, full disk, lost network drive)."""


class FileLockingError(_OneLine):
    """HDF5 could not lock the file: in use by another process, or on a file system without locking (NFS/SMB)."""


class SessionStateError(RuntimeError):
    """The session cannot do what was asked in its current state (resume a complete session, replay an import…)."""


class SessionNoteWarning(UserWarning):
    """A note :func:`daq.load_session` has about a session (aborted, unsealed, altered…); the same text, unescaped,
    is in ``Session.warnings``, so callers that keep those need not collect these too."""


class IncompleteSessionWarning(SessionNoteWarning):
    """The session has no stop record: it was killed, lost power, or is still being written."""


# ---- HDF5 failures, one clear message each (writers and readers of session files) --------------------------------


def errno_of(exc: BaseException) -> int | None:
    """The errno of an OSError, or the one HDF5 quotes in its message (``errno = N``); None when there is none."""
    code = getattr(exc, "errno", None)
    if code:
        return int(code)
    m = re.search(r"errno = (\d+)", str(exc))
    return int(m.group(1)) if m else None


def hdf5_error(path: Path, exc: BaseException, writing: bool) -> Exception:
    """One clear error for an HDF5 failure (h5py raises OSError, or RuntimeError from flush)."""
    text = str(exc)
    code = errno_of(exc)
    if "unable to lock file" in text:
        return _locking_error(path, code)
    known = _errno_error(path, code, writing)
    if known is not None:
        return known
    if not writing:
        return SessionFileError(
            f"{path} is not a readable HDF5 session file: truncated or corrupted ({first_line(text)})"
        )
    return SessionWriteError(code or errno.EIO, f"cannot write {path}: {first_line(text)}")


def in_use_error(path: Path) -> FileLockingError:
    """The one refusal for a session file another process holds open (writer or reader)."""
    return FileLockingError(
        errno.EAGAIN,
        f"{path} is open in another process (an acquisition writing it, or a program reading it); nothing was "
        "changed: close it there first, or write to another file",
    )


def _locking_error(path: Path, code: int | None) -> FileLockingError:
    if code in (errno.EAGAIN, errno.EWOULDBLOCK):
        return in_use_error(path)
    return FileLockingError(
        code or errno.ENOLCK,
        f"the file system holding {path} refuses HDF5 file locking (typical of NFS/SMB network shares): "
        "write the session to a local disk and copy it to the share afterwards",
    )


def _errno_error(path: Path, code: int | None, writing: bool) -> OSError | None:
    """The error for a file-system errno we can explain, or None."""
    if code == errno.ENOENT:
        if writing and not path.parent.is_dir():
            return SessionWriteError(errno.ENOENT, f"the folder {path.parent} does not exist")
        if writing:
            return SessionWriteError(errno.ENOENT, f"cannot create {path} there (no such file or directory)")
        return MissingFileError(errno.ENOENT, f"no such session file: {path}")
    if code in (errno.EACCES, errno.EPERM):
        return SessionWriteError(code, f"no permission to {'write' if writing else 'read'} {path}")
    plain = {
        errno.ENOSPC: f"no space left on the device holding {path}",
        errno.EFBIG: f"the file system refuses to let {path} grow (file too large)",
        errno.EROFS: f"{path} is on a read-only file system",
    }
    if code is not None and code in plain:
        return SessionWriteError(code, plain[code])
    return None


def first_line(text: str) -> str:
    """The first non-empty line of an error text (HDF5 messages run over many lines)."""
    return text.strip().splitlines()[0] if text.strip() else "unknown error"
