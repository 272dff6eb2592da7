"""Helpers for tests that kill real processes: the children of a process and whether a process is still alive,
read from ``/proc`` (Linux)."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

HAVE_PROC = Path("/proc/self/stat").exists()


def _stat(pid: int) -> tuple[str, int] | None:
    """(state, parent pid) of ``pid``, or None when there is no such process."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError, PermissionError):
        return None
    fields = text[text.rindex(")") + 2 :].split()
    return fields[0], int(fields[1])


def alive(pid: int) -> bool:
    """Whether ``pid`` is running (a zombie — ended, not yet reaped — counts as ended)."""
    st = _stat(pid)
    return st is not None and st[0] not in ("Z", "X")


def children(pid: int) -> list[int]:
    """The live processes whose parent is ``pid``."""
    found = []
    for name in os.listdir("/proc"):
        if name.isdigit():
            st = _stat(int(name))
            if st is not None and st[1] == pid and st[0] not in ("Z", "X"):
                found.append(int(name))
    return found


def wait_for_children(proc: subprocess.Popen[bytes], timeout: float = 30.0) -> list[int]:
    """The children of ``proc`` once it has at least one (fails after ``timeout`` s or when ``proc`` ended)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        kids = children(proc.pid)
        if kids:
            return kids
        if proc.poll() is not None:
            out = proc.stdout.read().decode(errors="replace") if proc.stdout else ""
            raise AssertionError(f"the parent ended (exit {proc.returncode}) before it started a child: {out}")
        time.sleep(0.02)
    raise AssertionError(f"no child of {proc.pid} within {timeout} s")


def kill_and_time_orphans(proc: subprocess.Popen[bytes], kids: list[int], bound: float) -> float:
    """SIGKILL ``proc``, then wait up to ``bound`` s for every process of ``kids`` to end; returns how long the
    last one lived after the kill (s), or fails naming the survivors (which are killed then)."""
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    t0 = time.monotonic()
    while time.monotonic() - t0 < bound:
        if not any(alive(k) for k in kids):
            return time.monotonic() - t0
        time.sleep(0.01)
    survivors = [k for k in kids if alive(k)]
    for k in survivors:
        try:
            os.kill(k, signal.SIGKILL)
        except ProcessLookupError:
            pass
    raise AssertionError(f"children {survivors} outlived their killed parent by more than {bound} s")
