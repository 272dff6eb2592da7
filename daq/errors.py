"""Errors and warnings of bench sessions, each subclassing what the ``contactrig`` dispatcher reports in one line.

``ValueError`` for bad files and settings, ``OSError`` for the file system, ``RuntimeError`` for the session state.
"""

from __future__ import annotations

__all__ = [
    "ChecksumError",
    "FileLockingError",
    "IncompleteSessionWarning",
    "MissingFileError",
    "NewerSchemaError",
    "SessionExistsError",
    "SessionFileError",
    "SessionNoteWarning",
    "SessionStateError",
    "SessionWriteError",
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
