"""What the console's pages get of a session (issue 26 items 4 and 6), through the app without a browser: block
numbers and R ± SEM exactly as the terminal's live lines print them, the notes and the number of runs, and a session
that ``contactrig acquire`` writes in another process followed from its file (status, blocks, ETA; no control)."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
import time
from pathlib import Path

from tests.console.conftest import ROOT, Client, scene_text

LIVE_LINE = re.compile(r"block (\d+)/\d+\s+([\d.]+) kg\s+repeat (\d+)\s+R = ([\d.]+ mΩ) ± (\S+ \S+) \(SEM, n = (\d+)\)")


def test_the_session_page_numbers_blocks_and_shows_r_and_sem_as_the_terminal(client: Client, folder: Path):
    from analysis.simulated_session import SimulatedRigBench
    from daq.acquire import acquire

    terminal = io.StringIO()
    answers = iter(["go", "quit"])
    acquire(folder / "small.toml", folder / "s.h5", bench=SimulatedRigBench(float("inf")), stream=terminal,
            prompter=lambda step: next(answers), overrides={"session.notes": "liner L-7 honed"})  # fmt: skip
    acquire(None, folder / "s.h5", bench=SimulatedRigBench(float("inf")), stream=terminal, resume=True, yes=True)
    said = [m.groups() for m in LIVE_LINE.finditer(terminal.getvalue())]
    assert [int(s[0]) for s in said] == [1, 2, 3, 4, 5, 6], terminal.getvalue()
    d = client.get("/api/session?path=s.h5").json()
    page = [(str(b["number"]), f"{b['weight_kg']:g}", str(b["repeat"]), b["mean_text"], b["sem_text"], str(b["n"]))
            for b in d["blocks"]]  # fmt: skip
    assert page == said
    assert [b["block"] for b in d["blocks"]] == [0, 1, 2, 3, 4, 5]  # the file's 0-based positions, as stored
    assert d["notes"] == "liner L-7 honed" and d["runs"] == 2 and [h["run"] for h in d["history"]] == [0, 1]
    assert d["weights"] == [5.44, 10.526, 25.966]


def test_a_session_acquired_in_another_process_is_followed_from_its_file(client: Client, folder: Path):
    (folder / "slow.toml").write_text(scene_text(count=60, repeats=3), encoding="utf-8")  # ≈ 1.6 s a block at pace 1
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "contactrig", "acquire", "slow.toml", "--sim", "--sim-speed", "1",
                             "--yes", "-o", "t.h5"], cwd=folder, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)  # fmt: skip
    states = []
    try:
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline:
            r = client.get("/api/follow?path=t.h5")
            if r.status_code == 200:
                states.append(r.json())
                if not states[-1]["running"]:
                    break
            time.sleep(0.3)
    finally:
        assert proc.wait(timeout=90) == 0
    running = [s for s in states if s["running"]]
    assert running, states
    assert all(s["status"] == "running" and s["run"] is None for s in running)  # no console run: no control here
    assert all(s["status_line"].startswith("t.h5: RUNNING") for s in running)
    assert any(s["eta_s"] is not None and s["eta_s"] > 0 for s in running)  # from the second block on
    assert "acquire slow.toml" in running[0]["command"]
    counts = [len(s["blocks"]) for s in states]
    assert counts == sorted(counts) and counts[0] < 9 and counts[-1] == 9, counts  # blocks came in as written
    final = states[-1]
    assert final["status"] == "success" and [b["number"] for b in final["blocks"]] == list(range(1, 10))
    assert "block 9/9" in final["status_line"]


def test_follow_refuses_a_path_outside_the_folder(client: Client):
    r = client.get("/api/follow?path=../x.h5")
    assert r.status_code == 400 and "not a session file" in r.json()["error"]


def test_the_vendored_chart_library_and_its_licence_are_package_data():
    """uPlot is served from the package (no CDN): its script, stylesheet and licence are in console/static and the
    package-data globs of pyproject.toml take them into the wheel."""
    import fnmatch
    import tomllib

    static = ROOT / "contactrig" / "console" / "static"
    globs = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]["package-data"]
    for name in ("uPlot.iife.min.js", "uPlot.min.css", "uPlot.LICENSE", "plot.js"):
        assert (static / name).is_file(), name
        assert any(fnmatch.fnmatch(f"console/static/{name}", g) for g in globs["contactrig"]), name
    assert "MIT License" in (static / "uPlot.LICENSE").read_text(encoding="utf-8")
    page = (static / "index.html").read_text(encoding="utf-8")
    assert re.findall(r'src="([^"]+)"', page) == ["/static/uPlot.iife.min.js", "/static/plot.js", "/static/app.js"]
