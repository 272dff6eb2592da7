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


# ---- killing a writer at a random moment of its writing ----------------------------------------------------------
def snapshot(folder: Path) -> dict[str, tuple[int, int, int]]:
    """Every entry under ``folder`` (hidden ones included): relative path → (inode, mtime in ns, size)."""
    out: dict[str, tuple[int, int, int]] = {}
    for dirpath, dirnames, filenames in os.walk(folder):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            try:
                st = p.lstat()
            except OSError:
                continue
            out[str(p.relative_to(folder))] = (st.st_ino, st.st_mtime_ns, st.st_size)
    return out


def run_until_change(
    argv: list[str], env: dict[str, str], folder: Path, delay_s: float | None, timeout: float = 300.0
) -> float:
    """Run ``argv`` and watch ``folder``; once anything in it changes, kill the process (SIGKILL) ``delay_s`` later
    (None: let it finish). Returns the time from the first change to the end (s); fails when it exits non-zero."""
    before = snapshot(folder)
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        end = time.monotonic() + timeout
        changed = None
        while time.monotonic() < end:
            if proc.poll() is not None:
                out = proc.stdout.read().decode(errors="replace") if proc.stdout else ""
                assert proc.returncode == 0, f"exit {proc.returncode}: {out[-2000:]}"
                return time.monotonic() - (changed or time.monotonic())
            if changed is None and snapshot(folder) != before:
                changed = time.monotonic()
            if changed is not None and delay_s is not None and time.monotonic() - changed >= delay_s:
                proc.send_signal(signal.SIGKILL)
                proc.wait()
                return time.monotonic() - changed
            time.sleep(0.003)
        raise AssertionError(f"{argv} did not end within {timeout} s")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def files_of(folder: Path) -> dict[str, bytes]:
    """Every regular file under ``folder`` (relative path → bytes), staging folders of the writers left out."""
    out = {}
    for p in folder.rglob("*"):
        if p.is_file() and not any(part.startswith(".contactrig-") for part in p.relative_to(folder).parts):
            out[str(p.relative_to(folder))] = p.read_bytes()
    return out


def check_one_set(
    found: dict[str, bytes],
    sets: dict[str, dict[str, bytes]],
    heads: tuple[str, ...],
    marker: dict[str, bytes],
    whole: tuple[str, ...] | None = None,
) -> str:
    """Check that the files ``found`` are of one of ``sets`` (name → relative path → bytes) and that where one of
    ``heads`` (the files a reader opens) is present, the whole set it belongs to is. A head's origin is told by the
    set's ``marker`` in its text (its bytes change from run to run: a time stamp), any other file's by its bytes.
    ``whole``: the heads whose presence requires the whole set (default: every head; a self-contained head, such as
    report.html with its figures inline, may stand without the rest, but never beside files of another set).
    Returns a description of the state (which set, which files)."""
    common = set(sets)
    for rel, data in found.items():
        if rel in heads:
            origin = {name for name in sets if marker[name] in data}
        else:
            origin = {name for name, files in sets.items() if files.get(rel) == data}
        assert origin, f"{rel} belongs to no set (a partial or foreign file)"
        common &= origin
        assert common, f"files of different sets side by side: {sorted(found)} ({rel} is of {sorted(origin)})"
    for head in heads if whole is None else whole:
        if head in found:
            missing = {name: sorted(set(sets[name]) - set(found)) for name in common}
            assert any(not m for m in missing.values()), f"{head} is there without the rest of its set: {missing}"
    return f"{sorted(common)}: {sorted(found)}"
