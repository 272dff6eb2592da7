"""The report of a resumed session (issue 26 item 4): the number of runs on file, not the first run's number, and the
session's notes — the operator's text from the start records, once when unchanged, per run when ``--resume --notes``
changed them — in report.md and report.html alike."""

from __future__ import annotations

import html
import re
import warnings
from pathlib import Path

import pytest

from contactrig.core.scene import default_scene_text, parse_scene


def _scene() -> object:
    text = re.sub(r"(?m)^count = .*$", "count = 10", default_scene_text())
    text = re.sub(r"(?m)^repeats = .*$", "repeats = 2", text)
    return parse_scene(text.replace("[session]\n", "[session]\nweights_kg = [5.44, 10.526, 25.966]\n"), "<test>")


def _resumed_session(path: Path, notes: list[str]) -> None:
    """Run 0 stopped by the operator at the second weight, run 1 resumed to the end (``notes[k]``: run k's)."""
    from analysis.simulated_session import SimulatedRigBench
    from daq.acquire import acquire

    answers = iter(["go", "quit"])
    first = acquire(_scene(), path, bench=SimulatedRigBench(float("inf")), prompter=lambda step: next(answers),
                    quiet=True, overrides={"session.notes": notes[0]})  # fmt: skip
    assert first.status == "aborted"
    second = acquire(None, path, resume=True, yes=True, bench=SimulatedRigBench(float("inf")), quiet=True,
                     overrides={"session.notes": notes[1]})  # fmt: skip
    assert second.status == "success" and second.run == 1


def _report(path: Path, out: Path) -> tuple[str, str]:
    from analysis.pipeline import analyse_session
    from analysis.report import write_report

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = analyse_session(path, n_boot=0)
    md = write_report([a], out).read_text(encoding="utf-8")
    page = html.unescape(re.sub(r"<[^>]+>", "", (out / "report.html").read_text(encoding="utf-8")))
    return md, page


@pytest.mark.slow
def test_a_resumed_sessions_report_counts_its_runs_and_shows_each_runs_notes(tmp_path):
    path = tmp_path / "resumed.h5"
    _resumed_session(path, ["first run after re-honing", "second run: piston cleaned"])
    md, page = _report(path, tmp_path / "rep")
    for text in (md, page):
        plain = text.replace("\\", "")  # Markdown escapes
        assert "session runs: 2 (1 resume(s))" in plain
        assert "session run: 0" not in plain  # the first run's number is not the run count
        assert "session notes, run 0: first run after re-honing" in plain
        assert "session notes, run 1: second run: piston cleaned" in plain


@pytest.mark.slow
def test_notes_kept_on_resume_are_shown_once(tmp_path):
    path = tmp_path / "kept.h5"
    _resumed_session(path, ["Al-Si piston, run-in 2 h", "Al-Si piston, run-in 2 h"])
    md, page = _report(path, tmp_path / "rep")
    for text in (md, page):
        plain = text.replace("\\", "")
        assert plain.count("session notes: Al-Si piston, run-in 2 h") == 1 and "session notes, run" not in plain
