"""Issue #11 on the analysis side: a scene file passed where a session is expected is named as such (by content),
and the report shows the session's history — loading order, skips, resumes, interruptions — escaped."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from contactrig.cli.main import main

from .test_report_html import ANSI, SCRIPT, W, _parse, _sweep_file

ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]
SCENE = ROOT / "contactrig" / "scenes" / "default.toml"


@pytest.mark.parametrize("command", ["fit", "figures", "report"])
def test_a_scene_passed_as_session_is_named_a_scene_file(command, tmp_path, capsys):
    extra = [] if command == "fit" else ["-o", str(tmp_path / "out")]
    assert main([command, str(SCENE), *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is a scene file (TOML), not a session" in err[0] and "truncated" not in err[0]
    assert f"{command} takes SESSION.h5" in err[0] and "tab1" in err[0] and "--sim" in err[0]


def test_the_scene_check_goes_by_content_not_suffix(tmp_path, capsys):
    disguised = tmp_path / "scene.h5"
    shutil.copy(SCENE, disguised)
    assert main(["fit", str(disguised)]) == 2
    assert "is a scene file" in capsys.readouterr().err
    junk = tmp_path / "notes.toml"  # a .toml that is not a scene: the session reader's own error
    junk.write_text("just some text\n", encoding="utf-8")
    assert main(["fit", str(junk)]) == 2
    err = capsys.readouterr().err
    assert "scene file" not in err and "not a readable HDF5 session file" in err


def _resumed_session(path):
    """Run 0: weights 5 and 10, 15 skipped, stopped by Ctrl-C; run 1 (resumed): 15 kept skipped, 20 measured."""
    from daq.records import BlockRecord, StopRecord, now_iso
    from daq.session_file import SessionFile

    rng = np.random.default_rng(1)
    block = 0

    def blocks(sf, run, weights):
        nonlocal block
        for w in weights:
            for rep in range(3):
                r = 2e-4 + 5e-10 / (1e-7 * (w / 5) ** 0.8) * (1 + 0.02 * rng.normal()) + 1e-7 * rng.normal(size=5)
                sf.append_block(BlockRecord(block=block, run=run, weight_kg=float(w), repeat=rep + 1, unit="V",
                                            reading=r, time_s=np.arange(5.0), resistance_ohm=r,
                                            valid=np.ones(5, bool), started=now_iso()))  # fmt: skip
                block += 1

    with SessionFile.create(path) as sf:
        sf.write_start({"started": f"T0 {SCRIPT}", "operator": "op", "run": 0}, "")
        blocks(sf, 0, W[:2])
        sf.write_stop(StopRecord(status="aborted", reason=f"interrupted (Ctrl-C): {ANSI}", stopped=now_iso(),
                                 blocks_planned=12, blocks_done=6, readings_done=30,
                                 weights_skipped=(float(W[2]),)))  # fmt: skip
    with SessionFile.open_for_resume(path) as sf:
        choice = {"weight_kg": float(W[2]), "weight_index": 2, "choice": "keep it skipped", "by": f"op {SCRIPT}"}
        sf.write_start({"started": "T1", "run": 1, "resume_choices": [choice]}, "")
        blocks(sf, 1, W[3:])
        sf.write_stop(StopRecord(status="success", reason="plan done", stopped=now_iso(), blocks_planned=12,
                                 blocks_done=9, readings_done=45, weights_skipped=(float(W[2]),)))  # fmt: skip
    return path


def test_the_report_shows_the_session_history_escaped(tmp_path, capsys):
    session = _resumed_session(tmp_path / "s.h5")
    sim = _sweep_file(tmp_path / "sim.h5", weights=np.array([5.0, 10.0, 20.0]))
    rc = main(["report", str(session), "--sim", str(sim), "-o", str(tmp_path / "rep"), "--bootstrap", "20",
               "--no-compare-models"])  # fmt: skip
    assert rc == 0, capsys.readouterr().err
    page = _parse((tmp_path / "rep" / "report.html").read_text(encoding="utf-8"))
    assert "Session history" in page.headings
    text = "".join(page.text)
    assert "loading order: 5, 10, 20 kg" in text
    assert "runs: 2 (1 resume(s)); interruptions: 1 by Ctrl-C, 0 killed" in text
    assert f"run 0 (started T0 {SCRIPT}); placed 5, 10 kg; skipped by the operator: 15 kg; ended: stopped early " \
           "(Ctrl-C) — interrupted (Ctrl-C): \\x1b[31mred" in text  # fmt: skip
    assert f"run 1 (resumed T1); 15 kg was skipped: keep it skipped (op {SCRIPT}); placed 20 kg; ended: done" in text
    assert not any(tag == "script" for tag, _ in page.tags)  # the script from the file is text, never markup
    md = (tmp_path / "rep" / "report.md").read_text(encoding="utf-8")
    assert "### Session history" in md and SCRIPT not in md and "\x1b" not in md
