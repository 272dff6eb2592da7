"""Sessions are readable while written (issue #13, first bullet): a second process reads a running session and sees
every completed block; ``load_session`` says it is running; the writer is undisturbed; a writer killed with a
reader attached leaves a readable file that ``--resume`` completes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

from daq.errors import IncompleteSessionWarning
from daq.replay import replay_session
from daq.session_file import load_session

from .conftest import ROOT, small_sim_scene

READER = """
import json, sys, time, warnings
from daq.session_file import load_session
path, seconds = sys.argv[1], float(sys.argv[2])
end = time.monotonic() + seconds
while time.monotonic() < end:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            s = load_session(path, timeout=5)
        print(json.dumps({"status": s.status, "blocks": len(s.summary), "running": s.running}), flush=True)
        if s.complete:
            break
    except Exception as exc:
        print(json.dumps({"error": f"{type(exc).__name__}: {exc}"}), flush=True)
    time.sleep(0.05)
"""


@pytest.fixture(scope="module")
def scene(tmp_path_factory) -> Path:
    return small_sim_scene(tmp_path_factory.mktemp("live"))


def _acquire(scene: Path, out: Path, *extra: str, speed: str = "4") -> subprocess.Popen:
    args = [str(scene)] if "--resume" not in extra else []
    return subprocess.Popen(
        [sys.executable, "-m", "contactrig", "acquire", *args, "-o", str(out), "--sim", "--yes", "--sim-speed", speed,
         *extra],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )  # fmt: skip


def _reader(path: Path, seconds: float) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", READER, str(path), str(seconds)], cwd=ROOT, stdout=subprocess.PIPE, text=True
    )


def _wait_for_block(proc: subprocess.Popen, k: int, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    lines = []
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        lines.append(line)
        if not line or line.startswith(f"block {k}/"):
            if line:
                return
            break
    proc.kill()
    raise AssertionError(f"writer did not reach block {k}:\n" + "".join(lines))


def test_a_second_process_sees_blocks_appear_while_the_writer_runs(scene, tmp_path):
    import json

    out = tmp_path / "live.h5"
    writer = _acquire(scene, out)
    _wait_for_block(writer, 1)
    reader = _reader(out, 40)
    try:
        rest, _ = writer.communicate(timeout=60)
        polls, _ = reader.communicate(timeout=60)
    finally:
        for p in (writer, reader):
            if p.poll() is None:
                p.kill()
    assert writer.returncode == 0, rest  # the writer is undisturbed by the reader
    seen = [json.loads(line) for line in polls.splitlines()]
    errors = [p for p in seen if "error" in p]
    assert not errors, errors
    running = [p["blocks"] for p in seen if p["status"] == "running"]
    assert all(p["running"] == (p["status"] == "running") for p in seen)
    assert len(set(running)) >= 3, seen  # blocks appear one after the other while the session runs
    assert running == sorted(running) and 1 <= running[0] and running[-1] <= 12, seen
    assert seen[-1]["status"] == "success" and seen[-1]["blocks"] == 12
    s = load_session(out)
    assert s.complete and s.sealed and not s.running and replay_session(out).identical


def test_sigkill_of_the_writer_with_a_reader_attached_leaves_a_readable_file(scene, tmp_path):
    import h5py

    out = tmp_path / "killed.h5"
    writer = _acquire(scene, out)
    _wait_for_block(writer, 3)
    # a reader holding the file open (no lock: the writer has it) and one polling it while the writer dies
    holder = subprocess.Popen(
        [sys.executable, "-c", "import h5py,sys; f=h5py.File(sys.argv[1],'r',locking=False); print('open', flush=True);"
         " sys.stdin.read()", str(out)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    poller = _reader(out, 3)
    try:
        assert holder.stdout.readline().strip() == "open"
        time.sleep(0.3)
        writer.send_signal(signal.SIGKILL)
        writer.wait(timeout=10)
        with pytest.warns(IncompleteSessionWarning, match="INCOMPLETE"):
            s = load_session(out)
        assert not s.complete and not s.running and s.status == "incomplete" and len(s.summary) >= 3
        assert list(s.summary.block) == list(range(len(s.summary)))
        poller.communicate(timeout=30)
        # --resume completes it while the reader still holds the file open
        resumed = _acquire(scene, out, "--resume", speed="50")
        rest, _ = resumed.communicate(timeout=60)
        assert resumed.returncode == 0, rest
    finally:
        holder.stdin.close()
        holder.wait(timeout=10)
        for p in (writer, poller):
            if p.poll() is None:
                p.kill()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # complete, sealed: nothing to warn about
        s = load_session(out)
    assert s.complete and s.sealed and len(s.summary) == 12 and replay_session(out).identical
    with h5py.File(out, "r") as h5:  # and it is an ordinary HDF5 file again for any other reader
        assert h5["entry/summary/block"].shape == (12,)
