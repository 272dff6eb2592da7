"""``export --force`` killed (SIGKILL) at a random moment of its writing never leaves a new summary beside old
readings (issue 26, item 16: on 670606e it did, 5 kills of 5). Real processes on a slow disk
(:mod:`tests.daq.slow_io`: every rename, link and unlink 0.2 s), two sessions exported over each other in turn."""

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
