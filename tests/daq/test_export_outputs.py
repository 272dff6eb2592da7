"""Export outputs (issue 26, items 16 and 10). ``export --force`` killed (SIGKILL) at a random moment of its
writing never leaves a new summary beside old readings (on 670606e it did, 5 kills of 5). Real processes on a slow
disk (:mod:`tests.daq.slow_io`: every rename, link and unlink 0.2 s), two sessions exported over each other in turn.
Output names of up to 255 bytes (multi-byte UTF-8 too) are written; a derived name that would pass the limit is a
one-line error before anything is read or written."""

from __future__ import annotations

import os
import random
import sys
from pathlib import Path

import pytest

from daq.plan import SessionPlan
from tests.processes import check_one_set, files_of, run_until_change

from .conftest import make_link, small_scene
from .sessions import write_session

ROOT = Path(__file__).resolve().parents[2]
SLOW = Path(__file__).with_name("slow_io.py")

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL")


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    out = {}
    for name, seed in (("alpha", 3), ("bravo", 11)):
        path = tmp_path_factory.mktemp(name) / f"{name}.h5"
        plan = SessionPlan.from_scene(small_scene())
        write_session(plan, path, link=make_link(plan, seed=seed))
        out[name] = path
    return out


@pytest.mark.slow
def test_killed_export_force_leaves_one_export(sessions, tmp_path):
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}

    def export(name: str, folder: Path, delay: float | None) -> float:
        folder.mkdir(exist_ok=True)
        argv = [sys.executable, str(SLOW), "export", str(sessions[name]), "-o", str(folder / "x.csv"), "--force"]
        return run_until_change(argv, env, folder, delay)

    refs = {}
    for name in sessions:
        export(name, tmp_path / f"ref-{name}", None)
        refs[name] = files_of(tmp_path / f"ref-{name}")
        assert sorted(refs[name]) == ["x-readings.csv", "x.csv"]
    assert refs["alpha"]["x-readings.csv"] != refs["bravo"]["x-readings.csv"]
    out = tmp_path / "out"
    export("alpha", out, None)
    window = export("bravo", out, None)  # from the first change in the folder to the end
    rng = random.Random(2616)
    states = []
    for k in range(5):
        export("alpha" if k % 2 == 0 else "bravo", out, rng.uniform(0.0, window))
        states.append(check_one_set(files_of(out), refs, ("x.csv",), {n: f"{n}.h5".encode() for n in refs}))
    export("bravo", out, None)  # a later export completes normally
    assert files_of(out) == refs["bravo"], states


@pytest.mark.parametrize("stem", ["x" * 250, "ü" * 125], ids=["255B", "255B-utf8"])
def test_export_to_a_name_of_255_bytes(sessions, tmp_path, capsys, stem):
    from contactrig.cli.main import main

    out = tmp_path / f"{stem}.xlsx"
    assert len(os.fsencode(out.name)) == 255
    assert main(["export", str(sessions["alpha"]), "--to", "xlsx", "-o", str(out)]) == 0
    assert out.stat().st_size > 0 and sorted(os.listdir(tmp_path)) == [out.name]
    csv = tmp_path / f"{stem[: len(stem) - 1]}.csv"  # the readings file beside it would pass 255 bytes
    capsys.readouterr()
    assert main(["export", str(sessions["alpha"]), "-o", str(csv)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "-readings.csv" in err and "at most 255 bytes" in err, err
    assert sorted(os.listdir(tmp_path)) == [out.name]
