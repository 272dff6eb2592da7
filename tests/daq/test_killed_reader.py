"""A command killed (SIGKILL) while its forked reader reads a session leaves no orphan (issue 26, item 15: on
670606e, 8 readers from 21 kills were left blocked, one still alive after 51 minutes). The reader is made to hang
(:mod:`tests.daq.slow_read`: a library that loops on a damaged file), the command is killed mid-read, and its
child must be gone within 2 s — several times, for every command that reads sessions this way."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from daq.plan import SessionPlan
from tests.processes import HAVE_PROC, kill_and_time_orphans, wait_for_children

from .conftest import small_scene
from .sessions import write_session

SCRIPT = Path(__file__).with_name("slow_read.py")
ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not HAVE_PROC or sys.platform != "linux", reason="reads /proc (Linux)")


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    path = tmp_path_factory.mktemp("killed") / "s.h5"
    write_session(SessionPlan.from_scene(small_scene()), path)
    return path


COMMANDS = {
    "export": lambda s, out: ["export", str(s), "-o", str(out / "x.csv"), "--force"],
    "sessions": lambda s, out: ["sessions", str(s.parent)],
    "replay": lambda s, out: ["replay", str(s)],
    "watch": lambda s, out: ["watch", str(s), "--once", "--png", str(out / "w.png"), "--force"],
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_killed_command_leaves_no_reader_behind(command, session, tmp_path):
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}", "MPLBACKEND": "Agg"}
    lives = []
    for _ in range(3 if command == "export" else 1):
        proc = subprocess.Popen(
            [sys.executable, str(SCRIPT), *COMMANDS[command](session, tmp_path)],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
        )
        try:
            kids = wait_for_children(proc)
            time.sleep(0.3)  # the reader is inside its (hanging) read
            lives.append(kill_and_time_orphans(proc, kids, bound=2.0))
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    assert max(lives) < 2.0, lives
