"""Replay: the recorded session re-run through the same acquisition code against its recorded replies."""

from __future__ import annotations

import h5py
import pytest

from daq.errors import SessionStateError
from daq.replay import replay_session
from daq.session_file import SessionFile
from daq.table_import import import_table, tab1_path

from .conftest import make_link
from .sessions import write_session
from .test_engine import SignalTwice


def test_replay_reproduces_a_session_exactly(plan, tmp_path):
    path = tmp_path / "r.h5"
    write_session(plan, path)
    report = replay_session(path)
    assert report.identical, report.differences
    assert report.blocks_replayed == plan.blocks_planned == report.blocks_recorded
    assert report.readings_replayed == plan.blocks_planned * plan.delta.count
    assert report.as_dict()["identical"] is True


def test_replay_detects_a_changed_reply(plan, tmp_path):
    """Change one recorded buffer reply (not the readings): the replayed readings differ from the recorded ones."""
    path = tmp_path / "r.h5"
    write_session(plan, path)
    with h5py.File(path, "a") as h5:
        msgs = h5["entry/exchanges/message"].asstr()[:]
        i = next(k for k, m in enumerate(msgs) if m.startswith("TRAC:DATA:SEL?"))
        reply = h5["entry/exchanges/reply"].asstr()[i]
        first, rest = reply.split(",", 1)
        h5["entry/exchanges/reply"][i] = f"{float(first) * 1.5:.6E},{rest}"
    report = replay_session(path)
    assert not report.identical
    assert any("mean_ohm recorded" in d for d in report.differences)


def test_replay_detects_a_diverging_driver(plan, tmp_path):
    path = tmp_path / "r.h5"
    write_session(plan, path)
    with h5py.File(path, "a") as h5:
        msgs = h5["entry/exchanges/message"].asstr()[:]
        i = next(k for k, m in enumerate(msgs) if m == "INIT:IMM")
        h5["entry/exchanges/message"][i] = "INIT:IMM;*WAI"
    report = replay_session(path)
    assert not report.identical and any("diverged" in d for d in report.differences)


def test_replay_of_an_interrupted_session_leaves_out_the_discarded_block(plan, tmp_path):
    from daq.engine import Interrupts

    path = tmp_path / "i.h5"
    link = make_link(plan, wrapper=lambda t: SignalTwice(t, at=[1]))
    with Interrupts() as intr:
        write_session(plan, path, link=link, interrupts=intr)
    report = replay_session(path)
    assert report.identical and report.blocks_replayed == 1


def test_replay_of_a_killed_session(plan, tmp_path):
    """Blocks on disk, no close and no stop record (as SIGKILL leaves it): every block still replays."""
    from daq.acquire import drive
    from daq.plan import session_steps
    from daq.writers import FileWriter

    from .sessions import start_record

    path = tmp_path / "k.h5"
    sf = SessionFile.create(path)
    writer = FileWriter(sf)
    writer.stop = lambda stop: None  # the process "dies" before the stop record
    link = make_link(plan)
    steps = list(session_steps(plan))[:5]  # two blocks of weight 1, one of weight 2
    drive(link, plan.delta, steps, [writer], start_record(plan), plan.scene.text)
    # drop the close exchanges, as a kill never gets there
    with h5py.File(path, "a") as h5:
        ex = h5["entry/exchanges"]
        blocks = ex["block"][:]
        last = max(i for i, b in enumerate(blocks) if b >= 0) + 1
        for name in ex:
            ex[name].resize((last,))
    sf.close()
    report = replay_session(path)
    assert report.identical and report.blocks_replayed == 3 and not report.complete
    assert any("INCOMPLETE" in n for n in report.notes) and any("killed run" in n for n in report.notes)


def test_replay_of_an_import_is_refused(tmp_path):
    path = import_table(tab1_path(), tmp_path / "tab1.h5", unit="mohm")
    with pytest.raises(SessionStateError, match="imported"):
        replay_session(path)
