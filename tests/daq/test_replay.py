"""Replay: the recorded session re-run through the same acquisition code against its recorded replies."""

from __future__ import annotations

import h5py
import pytest

from daq.errors import SessionStateError
from daq.replay import replay_session
from daq.session_file import SessionFile
from daq.table_import import import_table, tab1_path

from .conftest import make_link
from .sessions import reseal, write_session
from .test_engine import SignalTwice


def test_replay_reproduces_a_session_exactly(plan, tmp_path):
    path = tmp_path / "r.h5"
    write_session(plan, path)
    report = replay_session(path)
    assert report.identical, report.differences
    assert report.blocks_replayed == plan.blocks_planned == report.blocks_recorded
    assert report.readings_replayed == plan.blocks_planned * plan.block_settings.count
    assert report.as_dict()["identical"] is True


def _edit_exchange(path, match, edit):
    """Edit the first recorded exchange whose message satisfies ``match``; re-sign its block's exchange digest
    (a recording whose replies and readings disagree, as a buggy writer would leave), return the block."""
    from daq.records import exchanges_digest
    from daq.session_reader import exchange_list
    from daq.session_reader import read_table as _read_table

    with h5py.File(path, "a") as h5:
        ex = h5["entry/exchanges"]
        msgs = ex["message"].asstr()[:]
        i = next(k for k, m in enumerate(msgs) if match(m))
        edit(ex, i)
        block = int(ex["block"][i])
        s = h5["entry/summary"]
        row = list(s["block"][:]).index(block)
        cols = _read_table(ex, ("kind", "message", "reply", "t_s", "error"), ex["kind"].shape[0])
        a = int(s["first_exchange"][row])
        s["exchanges_sha256"][row] = exchanges_digest(exchange_list(cols, a, a + int(s["n_exchanges"][row]))).encode()
    return block


def _scale_first_reading(ex, i):
    first, rest = ex["reply"].asstr()[i].split(",", 1)
    ex["reply"][i] = f"{float(first) * 1.5:.6E},{rest}"


def test_a_damaged_recording_is_refused_on_load(plan, tmp_path):
    from daq.errors import ChecksumError

    path = tmp_path / "r.h5"
    write_session(plan, path)
    with h5py.File(path, "a") as h5:
        msgs = h5["entry/exchanges/message"].asstr()[:]
        i = next(k for k, m in enumerate(msgs) if m.startswith("TRAC:DATA:SEL?"))
        _scale_first_reading(h5["entry/exchanges"], i)
    with pytest.raises(ChecksumError, match="exchanges of block 1 are damaged"):
        replay_session(path)


def test_replay_detects_replies_that_do_not_give_the_recorded_readings(plan, tmp_path):
    path = tmp_path / "r.h5"
    write_session(plan, path)
    block = _edit_exchange(path, lambda m: m.startswith("TRAC:DATA:SEL?"), _scale_first_reading)
    reseal(path)  # the seal would refuse the edited file at load; replay's own comparison is under test here
    report = replay_session(path)
    assert not report.identical
    assert any(d.startswith(f"block {block + 1} ") and "mean_ohm recorded" in d for d in report.differences)


def test_replay_detects_a_diverging_driver(plan, tmp_path):
    path = tmp_path / "r.h5"
    write_session(plan, path)

    def edit(ex, i):
        ex["message"][i] = "INIT:IMM;*WAI"

    _edit_exchange(path, lambda m: m == "INIT:IMM", edit)
    reseal(path)
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
    drive(link, plan.block_settings, steps, [writer], start_record(plan), plan.scene.text)
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
