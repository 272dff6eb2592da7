"""A forked reader never outlives its parent (issue 26, item 15): a parent killed with SIGKILL while its child reads
leaves no orphan — by the kernel's ``PR_SET_PDEATHSIG``, by the child's watch on the parent, by its own deadline,
and a large answer never blocks the child on a pipe nobody reads. Real processes, real signals."""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from contactrig.core.child_process import ChildDied, ChildTimeout, run_in_child
from tests.processes import HAVE_PROC, kill_and_time_orphans, wait_for_children

PARENT = Path(__file__).with_name("child_parent.py")
ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not HAVE_PROC or sys.platform != "linux", reason="reads /proc (Linux)")


def _start(mode: str, options: str = "") -> subprocess.Popen[bytes]:
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    return subprocess.Popen(
        [sys.executable, str(PARENT), mode, options], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT
    )


def _orphan_life(mode: str, options: str, bound: float, settle: float = 0.2) -> float:
    proc = _start(mode, options)
    try:
        kids = wait_for_children(proc)
        time.sleep(settle)  # the child is inside its work (sleeping: a library that loops)
        return kill_and_time_orphans(proc, kids, bound)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_child_dies_with_its_killed_parent_every_time():
    lives = [_orphan_life("hang", "", bound=2.0) for _ in range(5)]
    assert max(lives) < 2.0, lives


def test_the_kernel_signal_alone_ends_the_child():
    assert _orphan_life("hang", "no-watch", bound=2.0) < 2.0


def test_the_watch_on_the_parent_alone_ends_the_child():
    """Without ``prctl`` (macOS): the child's thread sees the parent's pipe close."""
    assert _orphan_life("hang", "no-pdeathsig", bound=2.0) < 2.0


def test_the_childs_own_deadline_always_fires():
    """Neither the kernel's signal nor the watch: the alarm ends a child stuck in a library (2 s after its start)."""
    assert _orphan_life("hang", "no-pdeathsig,no-watch,fast-alarm", bound=4.0, settle=0.0) < 4.0


def test_a_large_answer_does_not_block_an_orphan():
    """The bug of 670606e: the child held the parent's reading end of the pipe, so writing an answer larger than
    the pipe holds blocked forever once the parent was gone. Now the write fails and the child ends."""
    assert _orphan_life("large", "no-pdeathsig,no-watch", bound=4.0) < 4.0


def _answer(x: int) -> bytes:
    return pickle.dumps(x * 2)


def _sleep(s: float) -> bytes:
    time.sleep(s)
    return b""


def _crash() -> bytes:
    os.kill(os.getpid(), signal.SIGKILL)  # as a library's crash: no answer, a signal
    return b""


def test_answer_timeout_and_crash_in_the_parent():
    assert pickle.loads(run_in_child(_answer, (21,), timeout=10.0)) == 42
    t0 = time.monotonic()
    with pytest.raises(ChildTimeout):
        run_in_child(_sleep, (30.0,), timeout=0.3)
    assert time.monotonic() - t0 < 5.0
    with pytest.raises(ChildDied, match="SIGKILL"):
        run_in_child(_crash, (), timeout=10.0)
