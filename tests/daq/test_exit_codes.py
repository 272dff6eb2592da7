"""One exit-code contract for ``contactrig`` (0 done, 1 stopped early, 2 error), tested with real SIGINTs sent to
real ``contactrig acquire --sim`` processes: once, twice at several spacings (the second one landing in the block, in
the clean-up, or while the process exits), and during ``--resume`` (while the file is read, and while blocks run).

Every process is bounded (``wait(timeout)``); several trials run side by side to keep the test short.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

from daq.session_file import load_session

from .conftest import ROOT, small_sim_scene

SPEED = "4"  # simulated instrument time 4× real: a block of 20 readings takes ~0.3 s


@pytest.fixture(scope="module")
def scene(tmp_path_factory) -> Path:
    return small_sim_scene(tmp_path_factory.mktemp("exit"))


def _start(*args: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "contactrig", "acquire", *args, "--sim", "--yes", "--sim-speed", SPEED],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


def _wait_for_line(proc: subprocess.Popen, pattern: str, timeout: float = 60.0) -> list[str]:
    lines: list[str] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        lines.append(line)
        if re.search(pattern, line):
            return lines
    proc.kill()
    raise AssertionError(f"no line matching {pattern!r}:\n" + "".join(lines))


def _finish(proc: subprocess.Popen, timeout: float = 60.0) -> tuple[int, str]:
    try:
        rest, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        raise AssertionError("the process did not end in time") from None
    return proc.returncode, rest


def _session(path: Path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_session(path)


@pytest.fixture(scope="module")
def stopped(scene, tmp_path_factory) -> Path:
    """A session stopped by one Ctrl-C after its second block (rc 1), to be resumed."""
    out = tmp_path_factory.mktemp("exit") / "stopped.h5"
    proc = _start(str(scene), "-o", str(out))
    _wait_for_line(proc, r"^block 2/")
    proc.send_signal(signal.SIGINT)
    rc, rest = _finish(proc)
    assert rc == 1, rest
    assert "Traceback" not in rest and "stopping after this block" in rest
    s = _session(out)
    assert s.complete and s.status == "aborted" and s.sealed and 2 <= len(s.summary) < 12
    return out


def test_ctrl_c_once_exits_1(stopped):
    pass  # the fixture is the trial; this test makes its result a test result of its own


@pytest.mark.parametrize("gaps", [(0.0, 0.002, 0.03), (0.1, 0.25, 0.5)])
def test_ctrl_c_twice_exits_1_whatever_the_spacing(scene, tmp_path, gaps):
    """Three processes side by side; in each the second SIGINT follows the first after ``gap`` seconds — inside the
    block, at its end, in the clean-up or while the process exits. Always exit 1, never −2 or 130."""
    procs = []
    for k, _ in enumerate(gaps):
        out = tmp_path / f"twice{k}.h5"
        procs.append((_start(str(scene), "-o", str(out)), out))
    for (proc, _), gap in zip(procs, gaps, strict=True):
        _wait_for_line(proc, r"^block 2/")
        proc.send_signal(signal.SIGINT)
        time.sleep(gap)
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
    for (proc, out), gap in zip(procs, gaps, strict=True):
        rc, rest = _finish(proc)
        assert rc == 1, f"gap {gap}: exit {rc}\n{rest}"
        assert "Traceback" not in rest
        s = _session(out)
        assert s.complete and s.status == "aborted" and s.sealed


def _past_interpreter_start(proc: subprocess.Popen, timeout: float = 30.0) -> float:
    """Wait until ``contactrig`` code runs in ``proc`` (numpy, imported only after ``main()`` has installed its
    SIGINT handler, is mapped); return the time. A Ctrl-C in the interpreter's own first ~0.1 s, before any of our
    code exists, gets Python's default treatment — nothing a program can change."""
    deadline = time.monotonic() + timeout
    maps = Path(f"/proc/{proc.pid}/maps")
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            if "_multiarray_umath" in maps.read_text():
                return time.monotonic()
        except OSError:
            pass
        time.sleep(0.005)
    raise AssertionError("the process never got past the interpreter's start")


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs /proc")
@pytest.mark.parametrize("delays", [(0.0, 0.3, 0.6), (None, None, None)])
def test_ctrl_c_during_resume_exits_1(scene, stopped, tmp_path, delays):
    """``--resume`` interrupted while it starts and reads the file (``delays``: seconds after contactrig's code
    began), or — None — once a resumed block is on disk, by one, two, or two quick SIGINTs. Always exit 1; the file
    stays resumable."""
    procs = []
    for k in range(len(delays)):
        out = tmp_path / f"resume{k}.h5"
        shutil.copyfile(stopped, out)
        procs.append((_start("-o", str(out), "--resume"), out))
    for k, ((proc, _), delay) in enumerate(zip(procs, delays, strict=True)):
        if delay is not None:
            t0 = _past_interpreter_start(proc)
            time.sleep(max(0.0, t0 + delay - time.monotonic()))
            proc.send_signal(signal.SIGINT)
            continue
        _wait_for_line(proc, r"^block \d+/")
        for _ in range(k + 1 if k < 2 else 2):
            proc.send_signal(signal.SIGINT)
            time.sleep(0.0 if k == 2 else 0.1)
    for (proc, out), delay in zip(procs, delays, strict=True):
        rc, rest = _finish(proc)
        assert rc == 1, f"delay {delay}: exit {rc}\n{rest}"
        assert "Traceback" not in rest
        s = _session(out)
        assert s.status in ("aborted", "incomplete") and len(s.summary) >= 2


def test_errors_exit_2_with_one_line(scene, tmp_path):
    """An error (here: --resume of a file that is not a session) is one line on stderr and exit 2."""
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not a session\x1b[2J")
    proc = _start("-o", str(bad), "--resume")
    rc, out = _finish(proc)
    assert rc == 2, out
    lines = [ln for ln in out.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("contactrig acquire: error: ") and str(bad) in lines[0], out
