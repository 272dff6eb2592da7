"""The sessions index (``contactrig sessions``): good, running, killed and corrupt files in one folder; nothing
raises, the corrupt file is listed as such, strings from files are escaped for the terminal."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import h5py
import pytest

from contactrig.cli.main import main
from daq.index import format_table, index_sessions, session_entry
from daq.plan import SessionPlan

from .conftest import ROOT, small_scene
from .sessions import write_session

HOSTILE = "evil\x1b]0;pwned\x07\x1b[2J sample"


def _start_writer(out, time_scale):
    return subprocess.Popen(
        [sys.executable, "-m", "tests.daq.acquire_script", str(out), str(time_scale)],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


def _wait_for_block(proc, k, timeout=30.0):
    deadline = time.monotonic() + timeout
    lines = []
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        lines.append(line)
        if line.startswith(f"block {k}/"):
            return
    proc.kill()
    raise AssertionError(f"writer did not reach block {k}:\n" + "".join(lines))


@pytest.fixture
def folder(tmp_path):
    """good.h5 (hostile sample), sub/other-sample.h5, killed.h5 (SIGKILL mid-run), corrupt.h5 (truncated),
    junk.h5 (not HDF5), sweep.h5 (HDF5, not a session); running.h5 is being written while the test runs."""
    plan = SessionPlan.from_scene(small_scene(sample=f"sample = {json.dumps(HOSTILE)}"))
    write_session(plan, tmp_path / "good.h5")
    (tmp_path / "sub").mkdir()
    write_session(SessionPlan.from_scene(small_scene(sample='sample = "Bronze ring"')), tmp_path / "sub" / "b.h5")
    data = (tmp_path / "good.h5").read_bytes()
    (tmp_path / "corrupt.h5").write_bytes(data[: len(data) // 3])
    (tmp_path / "junk.h5").write_bytes(b"this is not HDF5\n" * 10)
    with h5py.File(tmp_path / "sweep.h5", "w") as h5:
        h5["x"] = [1.0, 2.0]
    killed = _start_writer(tmp_path / "killed.h5", 0.25)
    _wait_for_block(killed, 2)
    killed.send_signal(signal.SIGKILL)
    killed.wait(timeout=10)
    running = _start_writer(tmp_path / "running.h5", 1.0)  # ~0.4 s per block, 12 blocks
    _wait_for_block(running, 1)
    try:
        yield tmp_path
    finally:
        running.kill()
        running.wait(timeout=10)


def test_index_of_good_running_killed_and_corrupt_files(folder):
    entries = index_sessions(folder)
    by_name = {os.path.relpath(e.path, folder): e for e in entries}
    assert set(by_name) == {"good.h5", os.path.join("sub", "b.h5"), "killed.h5", "running.h5", "corrupt.h5", "junk.h5"}
    assert by_name["good.h5"].status == "success" and by_name["good.h5"].sample == HOSTILE
    assert by_name["good.h5"].blocks_done == by_name["good.h5"].blocks_planned == 6
    assert by_name["good.h5"].operator == "tester" and by_name["good.h5"].kind == "real"
    assert by_name["killed.h5"].status == "incomplete"
    assert 2 <= by_name["killed.h5"].blocks_done < 12 and by_name["killed.h5"].blocks_planned == 12
    assert by_name["running.h5"].status == "running" and by_name["running.h5"].blocks_done >= 1
    for bad in ("corrupt.h5", "junk.h5"):
        assert by_name[bad].status == "corrupt" and "truncated or corrupted" in by_name[bad].note
    # unreadable files last; readable ones by start time
    assert [e.status for e in entries][-2:] == ["corrupt", "corrupt"]
    starts = [e.start_time for e in entries[:-2]]
    assert starts == sorted(starts)
    # the non-session HDF5 file only on request
    assert "sweep.h5" not in by_name
    assert any(e.path.endswith("sweep.h5") and e.status == "other" for e in index_sessions(folder, include_other=True))


def test_sessions_command_table_json_filter_and_escaping(folder, capsys):
    assert main(["sessions", str(folder)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out
    assert "evil\\x1b]0;pwned\\x07" in out
    assert "CORRUPT" in out and "running" in out and "incomplete" in out and "success" in out
    assert out.splitlines()[0].split() == ["start", "status", "blocks", "kind", "sample", "operator", "file"]

    assert main(["sessions", str(folder), "--json", "--sample", "bronze"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [os.path.basename(r["path"]) for r in rows] == ["b.h5"] and rows[0]["sample"] == "Bronze ring"

    assert main(["sessions", str(folder), "--json", "--sort", "sample"]) == 0
    rows = json.loads(capsys.readouterr().out)
    readable = [r["sample"].casefold() for r in rows if r["status"] not in ("corrupt", "other")]
    assert readable == sorted(readable)


def test_entry_of_a_missing_or_odd_path_never_raises(tmp_path):
    assert session_entry(tmp_path / "nope.h5").status == "corrupt"
    fifo = tmp_path / "fifo.h5"
    os.mkfifo(fifo)
    e = session_entry(fifo)
    assert e.status == "corrupt" and "FIFO" in e.note
    assert "CORRUPT" in format_table([e])


def test_sessions_refuses_a_missing_folder(tmp_path, capsys):
    assert main(["sessions", str(tmp_path / "absent")]) == 2
    assert "absent" in capsys.readouterr().err
