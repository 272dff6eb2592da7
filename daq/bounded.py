"""Reading untrusted data files in bounded time: the HDF5 open and parse run in a child process with a deadline.

Why a child process: a damaged HDF5 file (zeroed pages, a corrupt B-tree or object header) can make the HDF5 C
library loop forever, or crash the process; neither can be stopped from a thread, and no cheap pre-validation of
the HDF5 structure covers every case the library may trip over. A forked child costs a few milliseconds (it
inherits the imported modules), reads the file, and hands back the parsed, checked result (pickled through a
pipe); the parent waits at most ``timeout`` seconds and then kills it. A crash of the child (SIGSEGV inside the
library) becomes a one-line error too. The child ignores SIGINT: a Ctrl-C at the terminal reaches the whole process
group, and it is the parent that decides what a Ctrl-C means (it kills the child on its way out).

Before any of this, the path must name a regular file: a FIFO or a device would block ``open`` itself.
"""

from __future__ import annotations

import errno
import multiprocessing
import os
import pickle
import signal
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

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


def _child(conn: Any, fn: Callable[..., Any], args: tuple[Any, ...], path: Path, what: str) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
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
        payload = pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as exc:  # an exception type that does not pickle: keep its message
        text = str(result[1]) if result[0] == "error" else f"{type(exc).__name__}: {exc}"
        payload = pickle.dumps(("error", SessionFileError(first_line(text))))
    conn.send_bytes(payload)
    conn.close()


def _context() -> Any:
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


def call_bounded(
    fn: Callable[..., T], args: tuple[Any, ...], *, path: Path, what: str, timeout: float | None = None
) -> T:
    """``fn(*args)`` in a child process, within ``timeout`` seconds (default :func:`timeout_for` the file's size).

    ``fn`` must raise only picklable exceptions (anything else becomes one :class:`SessionFileError` line). A child
    that does not answer in time is killed: :class:`SessionFileError` saying so; one that dies (a crash inside the
    HDF5 library): :class:`SessionFileError` naming the signal.
    """
    st = check_regular_file(path, what)
    limit = timeout if timeout is not None else timeout_for(st.st_size)
    ctx = _context()
    recv, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(send, fn, args, path, what), daemon=True)
    proc.start()
    send.close()
    try:
        if not recv.poll(limit):
            raise SessionFileError(
                f"{path}: reading it did not finish within {limit:g} s — its HDF5 structure is damaged (the HDF5 "
                f"library loops on it); not a readable {what}"
            )
        try:
            status, value = pickle.loads(recv.recv_bytes())
        except (EOFError, OSError):
            proc.join(2.0)
            raise SessionFileError(
                f"{path}: the HDF5 library crashed reading it ({_death(proc.exitcode)}): damaged {what}"
            ) from None
    finally:
        if proc.is_alive():
            proc.kill()
        proc.join()
        recv.close()
    if status == "error":
        raise value
    return value


def _death(code: int | None) -> str:
    if code is not None and code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"
