"""A function run in a forked child process with a deadline, a child that never outlives its parent.

:func:`run_in_child` is the one mechanism behind every reader of untrusted files that must not hang or crash the
command (:mod:`daq.bounded` for HDF5 files, :mod:`contactrig.core.topography_file` for profilometer files): the child
runs ``fn(*args)``, which returns bytes (a pickled answer), and sends them through a pipe; the parent waits at most
``timeout`` seconds for them and kills the child on its way out, whatever happens.

A parent that is killed itself (``SIGKILL``, the OOM killer, a closed terminal) runs no ``finally``; the child must
then end on its own. Three guards, each enough alone, so that it does on every platform and in every state:

* **``PR_SET_PDEATHSIG``** (Linux, through ``prctl`` by ctypes): the kernel sends the child ``SIGKILL`` when the
  parent's thread that forked it ends — also while the child is stuck inside a C library holding the GIL.
* **A watch on the parent**: a thread of the child waits on a pipe whose other end only the parent holds
  (:func:`multiprocessing.parent_process`'s sentinel) and ends the child when the pipe closes, which is when the
  parent is gone (macOS and other systems without ``prctl``).
* **Its own deadline**: ``alarm`` (``SIGALRM`` at its default action, which ends the process in the kernel, GIL or
  not) ``timeout`` + :data:`GRACE_S` seconds after the start — after the parent has stopped waiting in any case.

And the child holds no end of the answer pipe but its own: a child that kept the parent's reading end open (what a
fork hands it) would block forever writing a large answer once the parent is gone. The child ignores ``SIGINT``: a
Ctrl-C at the terminal reaches the whole process group, and it is the parent that decides what a Ctrl-C means.

This module imports only the standard library.
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import multiprocessing
import multiprocessing.connection
import os
import signal
import sys
import threading
from collections.abc import Callable
from typing import Any

__all__ = ["GRACE_S", "ChildDied", "ChildTimeout", "death_text", "run_in_child"]

#: How long the child outlives the parent's own deadline at most (its ``alarm``), s: room to hand over a large
#: answer that the parent has begun to read.
GRACE_S = 10

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


class ChildTimeout(Exception):
    """The child did not answer within the deadline (it was killed)."""


class ChildDied(Exception):
    """The child ended without an answer (a crash inside a library: ``exitcode`` −signal, or an exit status)."""

    def __init__(self, exitcode: int | None) -> None:
        super().__init__(death_text(exitcode))
        self.exitcode = exitcode


def death_text(code: int | None) -> str:
    """How a child ended, in words: ``killed by SIGSEGV``, ``exit status 1``."""
    if code is not None and code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"


def _context() -> Any:
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


def run_in_child(fn: Callable[..., bytes], args: tuple[Any, ...], *, timeout: float) -> bytes:
    """``fn(*args)`` (bytes) computed in a child process within ``timeout`` seconds; returns those bytes.

    Raises :class:`ChildTimeout` when no answer came in time and :class:`ChildDied` when the child ended without
    one; the child is killed and reaped before either returns. ``fn`` should catch its own exceptions and encode
    them in its answer (one that escapes ends the child: :class:`ChildDied`)."""
    ctx = _context()
    recv, send = ctx.Pipe(duplex=False)
    alarm_s = math.ceil(max(timeout, 0.0)) + GRACE_S
    proc = ctx.Process(target=_child_main, args=(recv, send, fn, args, os.getpid(), alarm_s), daemon=True)
    proc.start()
    send.close()
    try:
        if not recv.poll(timeout):
            raise ChildTimeout(f"no answer within {timeout:g} s")
        try:
            return recv.recv_bytes()
        except (EOFError, OSError):
            proc.join(2.0)
            raise ChildDied(proc.exitcode) from None
    finally:
        if proc.is_alive():
            proc.kill()
        proc.join()
        recv.close()


def _child_main(
    recv: Any, send: Any, fn: Callable[..., bytes], args: tuple[Any, ...], parent: int, alarm_s: int
) -> None:
    recv.close()  # the parent's end: held here, a large answer would block forever once the parent is gone
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with_parent(parent)
    if hasattr(signal, "alarm"):
        signal.signal(signal.SIGALRM, signal.SIG_DFL)  # the default action ends the process, in the kernel
        signal.alarm(alarm_s)
    payload = fn(*args)
    send.send_bytes(payload)
    send.close()


def _die_with_parent(parent: int) -> None:
    """Arrange for this child to end when its parent does (``PR_SET_PDEATHSIG`` and a watching thread)."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(Exception):  # no libc by that name: the other two guards remain
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    if os.getppid() != parent:  # the parent died before the guard was set
        os._exit(1)
    here = multiprocessing.parent_process()
    sentinel = getattr(here, "sentinel", None) if here is not None else None
    if sentinel is not None:
        threading.Thread(target=_watch_parent, args=(sentinel,), daemon=True, name="watch-parent").start()


def _watch_parent(sentinel: int) -> None:
    """Wait until the pipe only the parent holds closes (the parent is gone), then end this process at once."""
    try:
        multiprocessing.connection.wait([sentinel])
    except (OSError, ValueError):
        return  # cannot watch: the kernel's signal and the alarm remain
    os._exit(1)
