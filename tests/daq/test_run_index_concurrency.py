"""Issue 29: the run index under concurrent refreshes from real processes, and random sequences of add, delete,
move, damage, tag and fit: the index always equals an index built from nothing (daq.run_index.fresh_scan)."""

from __future__ import annotations

import os
import shutil
import sqlite3
import subprocess
import sys
import time
from unittest import mock

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from daq import run_index as ri

from .conftest import ROOT
from .run_files import write_run


@pytest.fixture(scope="module")
def templates(tmp_path_factory):
    base = tmp_path_factory.mktemp("templates")
    return [write_run(base / f"t{i}.h5", sample=f"s{i}", started=f"2026-01-0{i + 1}T10:00:00.000+00:00")
            for i in range(3)]  # fmt: skip


_REFRESHER = """
import sys, time
from daq import run_index as ri
end = time.monotonic() + float(sys.argv[2])
n = 0
while time.monotonic() < end:
    ri.refresh(sys.argv[1], jobs=1)
    n += 1
print(n)
"""


def test_concurrent_refreshes_from_processes_never_corrupt_the_index(templates, tmp_path):
    folder = tmp_path / "shared"
    folder.mkdir()
    shutil.copy(templates[0], folder / "first.h5")
    procs = [
        subprocess.Popen([sys.executable, "-c", _REFRESHER, str(folder), "6"], cwd=ROOT, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
        for _ in range(3)
    ]  # fmt: skip
    try:
        for i in range(12):  # the folder changes under them: files added, moved, removed, damaged
            shutil.copy(templates[i % 3], folder / f"new{i}.h5")
            if i % 3 == 1:
                os.rename(folder / f"new{i - 1}.h5", folder / f"moved{i}.h5")
            if i % 3 == 2:
                os.unlink(folder / f"new{i}.h5")
            if i == 5:
                (folder / "broken.h5").write_bytes(b"\0" * 4096)
            time.sleep(0.3)
        outs = [p.communicate(timeout=120) for p in procs]
    finally:
        for p in procs:
            p.kill()
    assert all(p.returncode == 0 for p in procs), [o[1][-2000:] for o in outs]
    assert all(int(o[0]) >= 1 for o in outs)
    with sqlite3.connect(folder / ri.INDEX_NAME) as con:
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    ri.refresh(folder)
    assert ri.indexed_rows(folder) == ri.fresh_scan(folder)


_OPS = st.lists(
    st.tuples(st.sampled_from(["add", "delete", "move", "damage", "tag", "fit", "refresh"]), st.integers(0, 7)),
    min_size=1, max_size=7,
)  # fmt: skip


def _computer(k):
    """Marks written as computer ``pc<k % 3>`` on a network share (odd ``k``: each computer its own sidecar) or in
    the plain sidecar (even ``k``)."""
    share = mock.patch.object(ri, "network_share", return_value="nfs4" if k % 2 else "")
    host = mock.patch("socket.gethostname", return_value=f"pc{k % 3}")
    return share, host


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(ops=_OPS)
def test_random_changes_leave_the_index_equal_to_a_fresh_scan(templates, tmp_path_factory, ops):
    folder = tmp_path_factory.mktemp("random")
    (folder / "sub").mkdir()
    names = [folder / f"f{i}.h5" for i in range(4)] + [folder / "sub" / f"g{i}.h5" for i in range(4)]
    shutil.copy(templates[0], names[0])
    ri.refresh(folder)
    tagged: dict[str, set[str]] = {}
    for op, k in ops:
        present = [p for p in names if p.exists()]
        target = present[k % len(present)] if present else None
        if op == "add":
            free = [p for p in names if not p.exists()]
            if free:
                shutil.copy(templates[k % 3], free[k % len(free)])
        elif op == "delete" and target is not None:
            target.unlink()
        elif op == "move" and target is not None:
            free = [p for p in names if not p.exists()]
            if free:
                os.rename(target, free[k % len(free)])
        elif op == "damage" and target is not None:
            with open(target, "r+b") as f:  # same size, garbage in the middle
                f.seek(target.stat().st_size // 2)
                f.write(os.urandom(512))
        elif op == "tag" and target is not None:
            share, host = _computer(k)
            with share, host:
                mark = ri.add_mark(target, "tag", f"t{k}", who="test")
            tagged.setdefault(mark["content_id"], set()).add(mark["text"])
        elif op == "fit" and target is not None and ri.session_record(target)["status"] not in ri.UNREADABLE:
            share, host = _computer(k)
            with share, host:
                ri.record_fit(target, discriminates=k % 2 == 0, best=f"m{k}", statement="Verdict: test", who="test")
        else:
            ri.refresh(folder)
    ri.refresh(folder)
    rows = ri.indexed_rows(folder)
    assert rows == ri.fresh_scan(folder)
    assert all(set(tags) == tagged.get(cid, set()) for _, cid, _, _, tags, _ in rows)  # every computer's tags
