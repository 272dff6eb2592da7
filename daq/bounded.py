"""Reading untrusted data files in bounded time: the HDF5 open and parse run in a child process with a deadline.

Why a child process: a damaged HDF5 file (zeroed pages, a corrupt B-tree or object header) can make the HDF5 C
library loop forever, or crash the process; neither can be stopped from a thread, and no cheap pre-validation of
the HDF5 structure covers every case the library may trip over. A forked child costs a few milliseconds (it
inherits the imported modules), reads the file, and hands back the parsed, checked result (pickled through a
pipe); the parent waits at most ``timeout`` seconds and then kills it. A crash of the child (SIGSEGV inside the
library) becomes a one-line error too. The child ignores SIGINT (it is the parent that decides what a Ctrl-C means)
and never outlives the parent, even one killed with SIGKILL: :mod:`contactrig.core.child_process`.

Before any of this, the path must name a regular file: a FIFO or a device would block ``open`` itself.
"""

from __future__ import annotations

import errno
import os
import pickle
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from contactrig.core.child_process import ChildDied, ChildTimeout, run_in_child
from daq.errors import MissingFileError, SessionFileError

__all__ = ["DEFAULT_TIMEOUT_S", "call_bounded", "check_regular_file", "first_line", "timeout_for"]

#: The deadline for reading a file of up to 4 MB (a default session is ~1 MB and reads in ~40 ms): with the
#: interpreter's start, a command on a damaged file of that size ends within 10 s.
DEFAULT_TIMEOUT_S = 8.0
_FREE_BYTES = 4e6
_BYTES_PER_S = 2e6  # larger files get more time: 1 s per 2 MB beyond the first 4 MB (a slow network share)

T = TypeVar("T")


def first_line(text: str) -> str:
    """The first non-empty line of ``text`` (HDF5 messages run over several lines)."""
    for line in text.strip().splitlines():
        if line.strip():
            return line.strip()
    return "unknown error"


def check_regular_file(path: Path, what: str) -> os.stat_result:
    """The file's status; a missing path or anything but a regular file (FIFO, device, folder) is refused at once."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise MissingFileError(errno.ENOENT, f"no such {what}: {path}") from None
    except OSError as exc:
        raise SessionFileError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if not stat.S_ISREG(st.st_mode):
        kind = (
            "a FIFO (named pipe)"
            if stat.S_ISFIFO(st.st_mode)
            else "a folder"
            if stat.S_ISDIR(st.st_mode)
            else "a device or socket"
        )
        raise SessionFileError(f"{path} is {kind}, not a {what}")
    return st


def timeout_for(size: int) -> float:
    """The deadline for reading a file of ``size`` bytes: ``CONTACTRIG_READ_TIMEOUT_S`` (environment) if set, else
    8 s, plus 1 s per 2 MB beyond the first 4 MB."""
    base = DEFAULT_TIMEOUT_S
    setting = os.environ.get("CONTACTRIG_READ_TIMEOUT_S", "")
    try:
        if setting and float(setting) > 0:
            base = float(setting)
    except ValueError:
        pass
    return base + max(0.0, (size - _FREE_BYTES) / _BYTES_PER_S)


def _answer(fn: Callable[..., Any], args: tuple[Any, ...], path: Path, what: str) -> bytes:
    """Runs in the child: ``fn(*args)`` or its error, pickled."""
    try:
        result: tuple[str, Any] = ("ok", fn(*args))
    except (SessionFileError, OSError) as exc:
        result = ("error", exc)
    except BaseException as exc:  # any failure on untrusted content is one line, never a traceback
        result = (
            "error",
            SessionFileError(f"{path}: unreadable {what} ({type(exc).__name__}: {first_line(str(exc))})"),
        )
    try:
        return pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as exc:  # an exception type that does not pickle: keep its message
        text = str(result[1]) if result[0] == "error" else f"{type(exc).__name__}: {exc}"
        return pickle.dumps(("error", SessionFileError(first_line(text))))


def call_bounded(
    fn: Callable[..., T], args: tuple[Any, ...], *, path: Path, what: str, timeout: float | None = None
) -> T:
    """``fn(*args)`` in a child process, within ``timeout`` seconds (default :func:`timeout_for` the file's size).

    ``fn`` must raise only picklable exceptions (anything else becomes one :class:`SessionFileError` line). A child
    that does not answer in time is killed: :class:`SessionFileError` saying so; one that dies (a crash inside the
    HDF5 library): :class:`SessionFileError` naming the signal. The child never outlives this process
    (:func:`contactrig.core.child_process.run_in_child`).
    """
    st = check_regular_file(path, what)
    limit = timeout if timeout is not None else timeout_for(st.st_size)
    try:
        payload = run_in_child(_answer, (fn, args, path, what), timeout=limit)
    except ChildTimeout:
        raise SessionFileError(
            f"{path}: reading it did not finish within {limit:g} s — its HDF5 structure is damaged (the HDF5 "
            f"library loops on it); not a readable {what}"
        ) from None
    except ChildDied as exc:
        raise SessionFileError(f"{path}: the HDF5 library crashed reading it ({exc}): damaged {what}") from None
    status, value = pickle.loads(payload)
    if status == "error":
        raise value
    return value
