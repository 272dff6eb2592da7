"""``report --force`` killed (SIGKILL) at a random moment of its writing never leaves the old report text beside new
figures (issue 26, item 16: on 670606e it did, 7 kills of 10). Real processes on a slow disk
(:mod:`tests.daq.slow_io`: every rename, link and unlink 0.2 s): two sessions of the same name (so the same figure
names) and different data are reported into one folder in turn; after each kill the folder holds files of one
report only, and ``report.md`` or ``report.html`` only beside every figure of its report."""

from __future__ import annotations

import os
import random
import sys
from pathlib import Path

import pytest

from contactrig.core.scene import parse_scene
from daq.plan import SessionPlan
from tests.daq.conftest import make_link, sim_scene_text
from tests.daq.sessions import write_session
from tests.processes import check_one_set, files_of, run_until_change

ROOT = Path(__file__).resolve().parents[2]
SLOW = ROOT / "tests" / "daq" / "slow_io.py"

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL")


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    out = {}
    for name, seed in (("alpha", 3), ("bravo", 11)):
        path = tmp_path_factory.mktemp(name) / "s.h5"
        plan = SessionPlan.from_scene(parse_scene(sim_scene_text(), "<test>"))
        write_session(plan, path, link=make_link(plan, seed=seed))
        out[name] = path
    return out


@pytest.mark.slow
def test_killed_report_force_leaves_one_report(sessions, tmp_path):
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}", "MPLBACKEND": "Agg"}

    def report(name: str, folder: Path, delay: float | None) -> float:
        folder.mkdir(exist_ok=True)
        argv = [sys.executable, str(SLOW), "report", str(sessions[name]), "--bootstrap", "0", "--no-compare-models",
                "-o", str(folder), "--force", "--quiet"]  # fmt: skip
        return run_until_change(argv, env, folder, delay)

    out = tmp_path / "out"
    window = report("alpha", out, None)  # from the first change in the folder to the end
    refs = {"alpha": files_of(out)}
    report("bravo", tmp_path / "ref-bravo", None)
    refs["bravo"] = files_of(tmp_path / "ref-bravo")
    figures = sorted(f for f in refs["alpha"] if f.startswith("figures/"))
    assert len(figures) >= 4 and sorted(f for f in refs["bravo"] if f.startswith("figures/")) == figures
    assert any(refs["alpha"][f] != refs["bravo"][f] for f in figures)
    marker = {name: str(path.parent).encode() for name, path in sessions.items()}
    rng = random.Random(2616)
    states = []
    for k in range(3):
        report("bravo" if k % 2 == 0 else "alpha", out, rng.uniform(0.2 * window, window))
        # report.md is the set's head (moved in last); report.html is self-contained (figures inline), so a new one
        # without report.md is whole in itself — what must never happen is files of two sets side by side
        states.append(check_one_set(files_of(out), refs, ("report.md", "report.html"), marker, whole=("report.md",)))
    assert states
