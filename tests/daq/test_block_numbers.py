"""One 1-based block number everywhere a person reads it (issue 20 item 4): the live line, the stop message, the
CSV export's ``block`` column and ``watch``'s status line call the same block the same number — its position in
the plan, counted from 1 — also when a skipped weight makes it differ from the count of blocks taken."""

from __future__ import annotations

import io

import pandas as pd

from analysis.watch import state_from_session, status_line
from daq.acquire import drive
from daq.engine import Interrupts
from daq.export import export_session
from daq.plan import session_steps
from daq.session_file import SessionFile
from daq.writers import FileWriter, LiveDisplay

from .conftest import make_link
from .sessions import load_quietly, start_record
from .test_engine import SignalAfter


def test_the_same_block_has_the_same_number_everywhere(plan, tmp_path):
    path = tmp_path / "n.h5"
    decisions = iter(["skip", "go"])  # skip 5.44 kg (plan blocks 1–2), measure 10.526 kg (blocks 3–4)
    link = make_link(plan, wrapper=lambda t: SignalAfter(t, at=[1]))  # Ctrl-C once in the second block taken
    live = io.StringIO()
    sf = SessionFile.create(path)
    with Interrupts() as intr:
        try:
            out = drive(link, plan.block_settings, session_steps(plan), [FileWriter(sf), LiveDisplay(6, stream=live)],
                        start_record(plan), plan.scene.text, interrupts=intr, blocks_planned=plan.blocks_planned,
                        prompter=lambda step: next(decisions))  # fmt: skip
        finally:
            sf.close()
    # the plan: weights 5.44, 10.526, 25.966 kg × 2 repeats; 10.526 kg (weight index 1) repeat 2 is its 4th block
    assert (plan.session.weights_kg[1], plan.session.repeats) == (10.526, 2)
    expected = 1 * plan.session.repeats + 2
    last_line = [ln for ln in live.getvalue().splitlines() if ln.startswith("block ")][-1]
    assert last_line.startswith(f"block {expected}/6 (2 taken)  10.526 kg  repeat 2"), last_line
    assert out.stop.reason.endswith(f"repeat 2 (block {expected})"), out.stop.reason
    export_session(path, "csv", tmp_path / "n.csv")
    readings = pd.read_csv(tmp_path / "n-readings.csv", comment="#")
    rows = readings[(readings.weight_kg == 10.526) & (readings.repeat == 2)]
    assert set(rows.block) == {expected} and sorted(set(readings.block)) == [3, 4]
    assert f"block {expected}/6 (2 taken)" in status_line(state_from_session(load_quietly(path)))
    assert list(load_quietly(path).summary.block) == [2, 3]  # the file stores the 0-based position
