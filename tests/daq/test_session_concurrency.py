"""A session file in use is never destroyed: real second processes — writers with and without ``--force``,
``--resume``, ``import -o`` — against a running acquisition, a reader holding the file (HDF5's locking), and a
lock-free reader (whose open file must stay intact when ``--force`` replaces the name).

Each trial is a few seconds; ``CONTACTRIG_CONCURRENCY_TRIALS=50`` runs the acceptance count (issue 19).
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from .conftest import ROOT, small_sim_scene
from .sessions import load_quietly
from .test_exit_codes import _finish, _wait_for_line

TRIALS = int(os.environ.get("CONTACTRIG_CONCURRENCY_TRIALS", "1"))
IN_USE = "is open in another process"


@pytest.fixture(scope="module")
def scene(tmp_path_factory) -> Path:
    return small_sim_scene(tmp_path_factory.mktemp("conc"), count=20, repeats=4)


def _cli(*args: str, speed: str = "inf") -> subprocess.Popen:
    """``contactrig ARGS`` (acquire gets the simulated bench at ``speed``), output captured."""
    extra = ["--sim", "--yes", "--sim-speed", speed] if args[0] == "acquire" else []
    return subprocess.Popen(
        [sys.executable, "-m", "contactrig", *args, *extra],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


_READER = textwrap.dedent(
    """
    import hashlib, json, sys, h5py
    f = h5py.File(sys.argv[1], "r", locking=sys.argv[2] == "lock")
    def digest():
        g = f["entry/summary"]
        return hashlib.sha256(g["sha256"][:].tobytes() + g["mean_ohm"][:].tobytes()).hexdigest()
    before = digest()
    print("ready", flush=True)
    sys.stdin.readline()
    print(json.dumps({"before": before, "after": digest()}), flush=True)
    f.close()
    """
)


def _reader(path: Path, locking: bool) -> subprocess.Popen:
    proc = subprocess.Popen(
        [sys.executable, "-c", _READER, str(path), "lock" if locking else "nolock"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    _wait_for_line(proc, r"^ready")
    return proc


def _release(reader: subprocess.Popen) -> dict:
    out, _ = reader.communicate("\n", timeout=30)
    assert reader.returncode == 0, out
    return json.loads(out.strip().splitlines()[-1])


def _refused_writers(path: Path, scene: Path, *, table: Path) -> list[subprocess.Popen]:
    """Every command that writes a session, aimed at ``path`` side by side."""
    return [
        _cli("acquire", str(scene), "-o", str(path), "--force"),
        _cli("acquire", "-o", str(path), "--resume"),
        _cli("import", str(table), "--unit", "ohm", "-o", str(path), "--force"),
    ]  # (without --force: refused as existing before any lock is looked at — tests/daq/test_output_links.py)


def _all_refused(procs: list[subprocess.Popen]) -> list[str]:
    outs = []
    for proc in procs:
        rc, out = _finish(proc)
        assert rc == 2, f"{proc.args}: exit {rc}\n{out}"
        outs.append(out)
    return outs


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.slow
@pytest.mark.parametrize("trial", range(TRIALS))
def test_a_session_in_use_is_never_touched(scene, tmp_path, trial):
    table = tmp_path / "t.csv"
    table.write_text("weight_kg,r1\n1,0.002\n2,0.0019\n")
    path = tmp_path / "s.h5"

    # 1. a running acquisition: every other writer is refused, and the run goes on to a sealed, complete file
    writer = _cli("acquire", str(scene), "-o", str(path), speed="1")  # ~1 s a block: still running when they try
    _wait_for_line(writer, r"^block 1/")
    outs = _all_refused(_refused_writers(path, scene, table=table))
    assert IN_USE in outs[0] and "another process" in outs[1] and IN_USE in outs[2], outs
    writer.send_signal(signal.SIGINT)  # stop it early (exit 1: aborted, resumable) to keep the trial short
    rc, out = _finish(writer)
    assert rc == 1, out
    s = load_quietly(path)
    assert s.status == "aborted" and s.sealed and len(s.summary) >= 1
    blocks = len(s.summary)

    # 2. a reader holding the file (HDF5's shared lock): every writer refused, every byte as it was
    before = _sha(path)
    reader = _reader(path, locking=True)
    outs = _all_refused(_refused_writers(path, scene, table=table))
    # (--resume may also find the file locked by another refused writer's check, and say it is being written)
    assert all(IN_USE in o or "exists" in o or "another process" in o for o in outs), outs
    assert _sha(path) == before
    _release(reader)

    # 3. a reader without locking (h5py locking=False): not detectable, but --force replaces the name, never the
    # bytes: its open file reads as before, and the new session is complete
    reader = _reader(path, locking=False)
    rc, out = _finish(_cli("acquire", str(scene), "-o", str(path), "--force"))
    assert rc == 0, out
    seen = _release(reader)
    assert seen["before"] == seen["after"]
    new = load_quietly(path)
    assert new.status == "success" and new.sealed and new.start["started"] != s.start["started"]
    assert len(new.summary) == 12 and blocks >= 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.h5", "t.csv"]  # no temporary file left behind
