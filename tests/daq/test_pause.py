"""The operator's pause at a block boundary (issue 29, :mod:`daq.pause`): taken after the block under way, with the
source idle (the simulated 6221's own state, and the last command in the recorded SCPI log), recorded with its
reason, who and UTC times in the run record while the session waits, resumed with the next block re-armed;
replay reproduces the session; a Ctrl-C while paused stops it; files of schema 4 still read."""

from __future__ import annotations

import os
import re
import signal
import sys
import threading
import time
import warnings
from pathlib import Path

import h5py
import pytest

from daq.acquire import drive
from daq.link import open_visa_link
from daq.pause import PauseControl, pauses_of
from daq.plan import SessionPlan, session_steps
from daq.replay import replay_session
from daq.session_file import SessionFile, load_session
from daq.writers import FileWriter
from instruments.simulated import SimulatedBench, simulated_resource_manager

from .conftest import resistance_at, small_scene
from .sessions import load_quietly, start_record

OFFSET = re.compile(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d+)?[+-]\d\d:\d\d$")  # ISO-8601 with its UTC offset


class PauseAfter:
    """A writer that asks for a pause when block ``n`` (0-based) is on file, as the console's Pause would."""

    def __init__(self, control: PauseControl, n: int) -> None:
        self.control, self.n = control, n

    def start(self, start, scene_text):
        pass

    def exchanges(self, exchanges, block):
        pass

    def block(self, rec):
        if rec.block == self.n:
            self.control.request("liner re-honed: check the wear track", "ann")

    def stop(self, stop):
        pass


def _bench(plan: SessionPlan):
    bench = SimulatedBench(resistance_ohm=resistance_at(plan.session.weights_kg[0]), seed=3, time_scale=0.0)
    rm = simulated_resource_manager(bench=bench)
    link = open_visa_link(plan.instrument.address, plan.instrument.timeout_ms, rm,
                          place_weight=lambda w: setattr(bench, "resistance_ohm", resistance_at(w)))  # fmt: skip
    return link, rm.visalib.devices[plan.instrument.address]


def _run(plan, path, control, writers=(), interrupts=None):
    link, source = _bench(plan)
    sf = SessionFile.create(path)
    result: dict = {}

    def go():
        try:
            result["outcome"] = drive(link, plan.block_settings, session_steps(plan), [FileWriter(sf), *writers],
                                      start_record(plan), plan.scene.text, blocks_planned=plan.blocks_planned,
                                      pause=control, interrupts=interrupts)  # fmt: skip
        finally:
            sf.close()

    return go, source, result


def _wait(predicate, timeout=30.0):
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_pause_waits_at_the_block_boundary_source_idle_and_resume_goes_on(tmp_path: Path):
    plan = SessionPlan.from_scene(small_scene())
    path = tmp_path / "p.h5"
    control = PauseControl()
    go, source, result = _run(plan, path, control, [PauseAfter(control, 1)])
    thread = threading.Thread(target=go)
    thread.start()
    _wait(lambda: control.paused)
    time.sleep(0.3)  # the engine waits: nothing is sent meanwhile
    assert source._armed_at is None and (source._sweep is None or source._sweep.finished)  # the 6221 idle
    assert not source.prop("output")
    s = load_quietly(path)  # the file, read by another reader while the session waits
    assert len(s.summary) == 2 and not s.complete
    assert s.exchanges["message"].iloc[-1] == "SOUR:SWE:ABOR"  # the last command: the source idle
    [p] = pauses_of(s.runs)
    assert p["reason"] == "liner re-honed: check the wear track" and p["who"] == "ann" and p["after_block"] == 2
    assert OFFSET.match(p["paused"]) and "resumed" not in p
    n_exchanges = len(s.exchanges)
    time.sleep(0.2)
    assert len(load_quietly(path).exchanges) == n_exchanges and thread.is_alive()
    control.resume("bob")
    thread.join(30)
    assert result["outcome"].stop.status == "success"
    s = load_session(path)
    assert s.sealed and len(s.summary) == plan.blocks_planned
    [p] = pauses_of(s.runs)
    assert p["resumed_by"] == "bob" and OFFSET.match(p["resumed"]) and p["resumed"] >= p["paused"]
    third = s.exchanges[s.exchanges["block"] == 2]["message"].tolist()
    assert third[0].startswith("SOUR:SWE:ABOR") and any(m.startswith("SOUR:DELT:ARM") for m in third)  # re-armed
    report = replay_session(path)
    assert report.identical  # the pause changes nothing replay serves back; it is said
    assert any("paused after block 2" in n and "re-honed" in n and "by bob" in n for n in report.notes)


def test_a_pause_resumed_before_the_boundary_is_not_recorded(tmp_path: Path):
    plan = SessionPlan.from_scene(small_scene())
    control = PauseControl()
    control.request("wrong button", "ann")
    control.resume("ann")
    go, _, result = _run(plan, tmp_path / "n.h5", control)
    go()
    assert result["outcome"].stop.status == "success"
    assert pauses_of(load_session(tmp_path / "n.h5").runs) == []


@pytest.mark.skipif(sys.platform == "win32", reason="SIGINT to the own process")
def test_ctrl_c_while_paused_stops_with_the_source_idle(tmp_path: Path):
    """A Ctrl-C (the console's Stop: SIGINT to the acquisition) while paused: aborted at once, the stop record
    written, the source idle, the pause on file without a resume."""
    from daq.engine import Interrupts

    plan = SessionPlan.from_scene(small_scene())
    control = PauseControl()
    interrupts = Interrupts()
    go, source, result = _run(plan, tmp_path / "s.h5", control, [PauseAfter(control, 0)], interrupts)

    def ctrl_c_when_paused():
        _wait(lambda: control.paused)
        os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=ctrl_c_when_paused).start()
    with interrupts:  # the engine in the main thread, with acquire's Ctrl-C policy installed
        go()
    assert result["outcome"].interrupted
    s = load_quietly(tmp_path / "s.h5")
    assert s.status == "aborted" and s.sealed and len(s.summary) == 1
    assert s.exchanges["message"].iloc[-1] == "SOUR:SWE:ABOR"
    assert source._armed_at is None and not source.prop("output")
    [p] = pauses_of(s.runs)
    assert p["after_block"] == 1 and "resumed" not in p


class CtrlCWhilePauseIsWritten(PauseAfter):
    """A writer told of the pause before the file is: it sends the Ctrl-C while the pause record is being written."""

    def pause(self, pauses):
        if "resumed" not in pauses[-1]:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)  # the handler runs here, inside the writers' round


@pytest.mark.skipif(sys.platform == "win32", reason="SIGINT to the own process")
def test_ctrl_c_while_the_pause_is_written_waits_for_the_record_then_stops(tmp_path: Path):
    """The CI failure of 2026-11-27: a Ctrl-C that lands while the pause record is written must not cut the run
    record short (it read ``record is not valid JSON``): the record goes to every writer, then the run stops
    instead of waiting for a resume."""
    from daq.engine import Interrupts

    plan = SessionPlan.from_scene(small_scene())
    control = PauseControl()
    interrupts = Interrupts()
    link, source = _bench(plan)
    path = tmp_path / "w.h5"
    sf = SessionFile.create(path)
    try:
        with interrupts:
            outcome = drive(link, plan.block_settings, session_steps(plan),
                            [CtrlCWhilePauseIsWritten(control, 0), FileWriter(sf)], start_record(plan),
                            plan.scene.text, blocks_planned=plan.blocks_planned, pause=control,
                            interrupts=interrupts)  # fmt: skip
    finally:
        sf.close()
    assert outcome.interrupted and outcome.stop.status == "aborted"
    s = load_quietly(path)
    assert s.sealed and len(s.summary) == 1 and not source.prop("output")
    [p] = pauses_of(s.runs)  # on file whole: the writer after the Ctrl-C got it too
    assert p["after_block"] == 1 and "resumed" not in p


def test_bad_reason_is_one_line_naming_it():
    from contactrig.core.validation import SettingError

    with pytest.raises(SettingError, match="reason"):
        PauseControl().request("  ", "ann")
    with pytest.raises(SettingError, match="who"):
        PauseControl().request("x", "")


def test_a_schema_4_file_still_reads(tmp_path: Path):
    from .sessions import write_session

    plan = SessionPlan.from_scene(small_scene())
    path = tmp_path / "old.h5"
    write_session(plan, path)
    with h5py.File(path, "r+") as h5:
        h5.attrs["contactrig_schema"] = 4
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = load_session(path)
    assert s.schema_version == 4 and s.sealed and pauses_of(s.runs) == []
