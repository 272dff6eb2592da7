"""``acquire --sim --adaptive`` (analysis.adaptive_session, issue 27 §2): the session follows the suggestions on the
simulated bench, ends decisive and says why; every suggestion is in the stop record (schema 4) and its block's own
record (schema 5: a killed session keeps them) and replays bit for bit; the file fits; old (schema 3, 4) files are
still read; the operator may place another weight."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import h5py
import pytest

from analysis.adaptive_session import adaptive_source, replay_suggestions
from analysis.simulated_session import SimulatedRigBench
from contactrig.core.scene import parse_scene
from daq import load_session
from daq.acquire import acquire
from daq.session_file import SCHEMA_VERSION

PRESS = Path(__file__).resolve().parents[2] / "contactrig" / "scenes" / "press.toml"


def _scene(models: str = '"greenwood_tripp", "pasaribu_schipper"', noise: str = "iid") -> object:
    """The packaged press scene with two models (8.5 % apart after refitting R_s, σ_f) and ``noise``."""
    text = PRESS.read_text()
    text = re.sub(r"^models\s*=.*$", f"models = [{models}]", text, count=1, flags=re.M)
    text = re.sub(r'^sim_noise = "tab1"', f'sim_noise = "{noise}"', text, count=1, flags=re.M)
    return parse_scene(text, "press (test)")


@pytest.fixture(scope="module")
def press_session(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    path = tmp_path_factory.mktemp("adaptive") / "press.h5"
    result = acquire(_scene(), path, bench=SimulatedRigBench(math.inf), yes=True, quiet=True,
                     adaptive=adaptive_source(30.0, simulated=True))  # fmt: skip
    return path, result


def test_press_iid_ends_decisive_and_says_why(press_session) -> None:
    """Greenwood–Tripp is the simulated truth: the session ends decisive for it, with the margin, long before the
    budget; the stop record carries every suggestion, its evidence and what the operator did."""
    path, result = press_session
    assert result.status == "success"
    assert result.reason.startswith("decisive: Greenwood–Tripp") and "≥ 10" in result.reason
    s = load_session(path)
    assert s.schema_version == SCHEMA_VERSION == 5
    assert s.start["adaptive"]["budget_s"] == 1800.0
    record = s.stop["adaptive"]
    assert record["decision"]["status"] == "decisive"
    entries = record["entries"]
    assert entries and all(e["operator"] == "took the suggestion" for e in entries)
    assert entries[0]["suggestion"]["action"] == "place" and entries[-1]["evidence"] is not None
    assert record["final"]["evidence"]["leader"] == "greenwood_tripp"
    assert s.summary["block"].size < 200


def test_replay_reproduces_every_suggestion_and_the_session_fits(press_session) -> None:
    path, _ = press_session
    same, text = replay_suggestions(str(path))
    assert same, text
    from analysis.fit import compare_models
    from analysis.measured import MeasuredCurve

    s = load_session(path)
    curve = MeasuredCurve.from_session(s)
    assert not curve.paired  # unequal seatings per weight: the fit's unpaired rule
    areas = {k: 1e-8 * curve.weight_kg ** (1.0 if k == "a" else 0.5) for k in ("a", "b")}
    assert compare_models(curve, areas, height_m=1e-6, n_boot=0).ranking  # fits without error


def test_a_changed_suggestion_is_found(press_session, tmp_path: Path) -> None:
    """replay_suggestions compares: an edited recorded suggestion is reported (the seal is not what is tested)."""
    path, _ = press_session
    copy = tmp_path / "edited.h5"
    copy.write_bytes(path.read_bytes())
    import json

    with h5py.File(copy, "r+") as h5:
        rec = json.loads(h5["entry/stop/record"][()])
        rec["adaptive"]["entries"][-1]["suggestion"]["weight_kg"] = 123.0
        rec.pop("seal")
        del h5["entry/stop/record"]
        h5["entry/stop"].create_dataset("record", data=json.dumps(rec), dtype=h5py.string_dtype())
        h5.attrs["contactrig_schema"] = 2  # unsealed schema: the reader does not refuse it for the missing seal
    with pytest.warns(UserWarning):
        same, text = replay_suggestions(str(copy))
    assert not same and "differs" in text


def test_operator_may_place_another_weight(tmp_path: Path) -> None:
    """The operator's own choice is placed and recorded beside the suggestion it replaced."""
    asked = []

    def choose(placement, state, allowed):
        asked.append(placement.weight_kg)
        if len(asked) == 4:
            return 10.0
        return None if len(asked) > 5 else placement.weight_kg

    path = tmp_path / "own.h5"
    result = acquire(_scene(), path, bench=SimulatedRigBench(math.inf), yes=True, quiet=True,
                     adaptive=adaptive_source(30.0, simulated=True, choose=choose))  # fmt: skip
    record = load_session(path).stop["adaptive"]
    actions = [e["operator"] for e in record["entries"]]
    assert "placed 10 kg instead" in actions and actions[-1] == "stopped the session"
    assert record["decision"]["status"] == "operator" and result.reason.startswith("operator")
    same, text = replay_suggestions(str(path))  # the one the operator stopped at (no block follows) included
    assert same and text.startswith(f"{len(actions)} suggestion(s) reproduced"), text


def test_schema_3_files_are_still_read(press_session, tmp_path: Path) -> None:
    """A schema-3 file (no adaptive records) loads through the upgrade chain."""
    path = tmp_path / "fixed.h5"
    text = re.sub(r"^repeats = 6", "repeats = 2", PRESS.read_text(), count=1, flags=re.M)
    acquire(parse_scene(text, "press, 2 repeats"), path, bench=SimulatedRigBench(math.inf), yes=True, quiet=True)
    with h5py.File(path, "r+") as h5:
        h5.attrs["contactrig_schema"] = 3
    s = load_session(path)
    assert s.schema_version == 3 and "adaptive" not in s.start


def test_watch_shows_the_evidence_and_the_stop_reason(press_session) -> None:
    from analysis.watch import state_from_session, status_line

    path, result = press_session
    line = status_line(state_from_session(load_session(path)))
    assert "evidence: Greenwood–Tripp leads" in line and "(100 %)" in line and result.reason in line


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--budget-min", "5"], "--budget-min only applies to --adaptive"),
        (["--adaptive", "--budget-min", "-5"], "--budget-min = -5.0 is not allowed"),
        (["--adaptive", "--resume"], "--adaptive does not resume"),
    ],
)
def test_bad_adaptive_options_are_one_line_errors(args, says, tmp_path: Path, capsys) -> None:
    from contactrig.cli.main import main

    assert main(["acquire", "--sim", *args, "-o", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert says in err and len(err.splitlines()) == 1 and not (tmp_path / "x.h5").exists()


def test_session_state_is_plain_data_for_the_console(press_session) -> None:
    """What the console shows, as JSON: the report of the design rebuilt from the file, with the stop record."""
    import json

    from analysis.adaptive_session import session_state

    path, result = press_session
    state = session_state(load_session(path))
    assert state is not None
    assert json.loads(json.dumps(state, allow_nan=False)) == state
    assert state["stop"]["status"] == "decisive" and state["stop_record"]["reason"] == result.reason
    assert state["progress"] == 1.0 and state["evidence"]["leader"] == "greenwood_tripp"


def test_each_suggestion_is_also_its_blocks_record(press_session) -> None:
    """Schema 5: each suggestion, with the evidence behind it and what the operator did, is the record of the first
    block it led to (``/entry/adaptive/block_<row>``): the same entries as the stop record's, at the right rows."""
    path, _ = press_session
    s = load_session(path)
    entries = s.stop["adaptive"]["entries"]
    assert s.adaptive and sorted(s.adaptive) == [e["block"] for e in entries]  # no compliance block: row = count
    for row, entry in s.adaptive.items():
        assert entry == entries[[e["block"] for e in entries].index(row)]
        assert entry["operator"] == "took the suggestion" and "suggestion" in entry and "evidence" in entry


def test_a_block_record_is_sealed(press_session, tmp_path: Path) -> None:
    """The blocks' suggestion records are a part of the seal: an edited one makes the file refused as altered."""
    from daq.errors import ChecksumError

    path, _ = press_session
    copy = tmp_path / "edited.h5"
    copy.write_bytes(path.read_bytes())
    with h5py.File(copy, "r+") as h5:
        group = h5["entry/adaptive"]
        name = sorted(group)[-1]
        text = group[name][()].decode().replace('"took the suggestion"', '"placed 1 kg instead"')
        del group[name]
        group.create_dataset(name, data=text, dtype=h5py.string_dtype())
    with pytest.raises(ChecksumError, match="the records of the suggestions changed"):
        load_session(copy)


def test_schema_4_files_are_still_read_and_replayed(press_session, tmp_path: Path) -> None:
    """A schema-4 adaptive file (suggestions in the stop record only, its seal without the blocks' records) loads
    sealed and replays from its stop record."""
    path, _ = press_session
    old = tmp_path / "schema4.h5"
    old.write_bytes(path.read_bytes())
    with h5py.File(old, "r+") as h5:
        del h5["entry/adaptive"]
        h5.attrs["contactrig_schema"] = 4
    s = load_session(old)
    assert s.schema_version == 4 and s.sealed and s.adaptive == {}
    same, text = replay_suggestions(str(old))
    assert same and text.startswith(f"{len(s.stop['adaptive']['entries'])} suggestion(s)")


def test_a_killed_adaptive_session_keeps_its_suggestions_and_replays_them(tmp_path: Path) -> None:
    """``acquire --sim --adaptive`` killed (SIGKILL) mid-session: the file has no stop record, yet every block's
    suggestion was flushed with it, and replay reproduces them bit for bit; an edited one is found."""
    import os
    import signal
    import subprocess
    import sys
    import time
    import warnings

    if not hasattr(signal, "SIGKILL"):
        pytest.skip("SIGKILL")
    scene = tmp_path / "press.toml"
    scene.write_text(_scene().text)
    path = tmp_path / "killed.h5"
    argv = [sys.executable, "-m", "contactrig", "acquire", str(scene), "--sim", "--sim-speed", "10", "--adaptive",
            "--yes", "--quiet", "--budget-min", "30", "-o", str(path)]  # fmt: skip
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        end = time.monotonic() + 120
        while time.monotonic() < end and proc.poll() is None:
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # a RUNNING session, said
                    if len(load_session(path).summary) >= 10:
                        break
            except Exception:  # not yet created, or caught between writes: look again
                pass
            time.sleep(0.05)
        assert proc.poll() is None, f"the session ended before it was killed: {proc.stdout.read().decode()[-800:]}"
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    with pytest.warns(UserWarning):
        s = load_session(path)
    assert not s.complete and s.stop is None and len(s.summary) >= 10
    assert s.adaptive and max(s.adaptive) >= 8  # the suggestions of blocks after the three starting loads
    assert all(entry["operator"] == "took the suggestion" for entry in s.adaptive.values())
    with pytest.warns(UserWarning):
        same, text = replay_suggestions(str(path))
    assert same, text
    assert text.startswith(f"{len(s.adaptive)} suggestion(s) reproduced bit for bit") and "incomplete" in text
    from contactrig.cli.main import main

    with pytest.warns(UserWarning):
        assert main(["replay", str(path)]) == 0  # the blocks and the suggestions, as `contactrig replay` checks them
    with h5py.File(path, "r+") as h5:  # no seal to break: the replay itself compares
        group = h5["entry/adaptive"]
        name = f"block_{max(s.adaptive)}"
        record = json.loads(group[name][()])
        record["p_decisive"] = 0.123456
        del group[name]
        group.create_dataset(name, data=json.dumps(record), dtype=h5py.string_dtype())
    with pytest.warns(UserWarning):
        same, text = replay_suggestions(str(path))
    assert not same and "differs" in text


def test_recorded_suggestions_keep_two_made_before_the_same_block_count() -> None:
    """A block in compliance is not ingested, so the next suggestion is made at the same block count: both are kept
    (in order), from the blocks' records and the stop record alike; a block's record the stop record contradicts, or
    leaves out, is reported."""
    from types import SimpleNamespace

    from analysis.adaptive_session import recorded_suggestions

    one, two = {"block": 6, "operator": "took the suggestion"}, {"block": 6, "operator": "placed 10 kg instead"}
    stop = {"adaptive": {"entries": [{"block": 0, "operator": "took the suggestion"}, one, two]}}
    found = recorded_suggestions(SimpleNamespace(adaptive={6: one, 7: two}, stop=stop))
    assert found == {0: [stop["adaptive"]["entries"][0]], 6: [one, two]}
    assert recorded_suggestions(SimpleNamespace(adaptive={6: one, 7: two}, stop=None)) == {6: [one, two]}
    assert "differs" in recorded_suggestions(SimpleNamespace(adaptive={6: two}, stop=stop))
    alone = {"adaptive": {"entries": [one]}}
    assert "not in the stop record" in recorded_suggestions(SimpleNamespace(adaptive={6: one, 7: two}, stop=alone))


def test_a_repeat_at_the_present_seating_is_one_seating_end_to_end(tmp_path: Path, monkeypatch) -> None:
    """A taken "repeat at the present seating" suggestion (forced here: the design rightly hardly ever makes one) is
    recorded as a repeat at that seating (its weight and seating number, a block number of its own, no prompt to
    place the weight), simulated at that seating's contact factor (only the instruments' noise differs: the
    simulated bench's factors per block, recorded in the start record, are the truth), fitted as one seating (its
    blocks averaged: ``fit``'s repeats at that weight are seatings, not blocks) and counted as one by the design,
    and replayed: the suggestions bit for bit, the instrument replies identical."""
    import numpy as np

    from analysis.adaptive_session import session_design
    from analysis.measured import MeasuredCurve
    from analysis.sequential import Placement, SequentialDesign
    from daq.replay import replay_session

    real = SequentialDesign.suggest

    def suggest(self: SequentialDesign) -> Placement:
        p = real(self)
        if self.blocks in (6, 7) and self.current is not None:  # after the start design: repeat twice
            return Placement(float(self.weights_kg[self.current]), "repeat", 1, 0.0, self.cost.of("repeat"),
                             p.criterion, "forced by the test")  # fmt: skip
        return p

    monkeypatch.setattr(SequentialDesign, "suggest", suggest)
    placed: list[float] = []

    def prompter(step):  # the operator asked to place (or re-place) a weight
        placed.append(step.weight_kg)
        return "go"

    path = tmp_path / "repeat.h5"
    acquire(_scene(), path, bench=SimulatedRigBench(math.inf), prompter=prompter, quiet=True,
            adaptive=adaptive_source(30.0, simulated=True))  # fmt: skip
    s = load_session(path)
    rows = s.summary
    assert rows["block"].is_unique and len(rows) > 8
    took = {j: e["suggestion"]["action"] for j, e in s.adaptive.items()}
    assert took[6] == took[7] == "repeat" and s.adaptive[6]["operator"] == "took the suggestion"
    w, rep = float(rows["weight_kg"][5]), int(rows["repeat"][5])
    # the file: rows 5–7 one seating (weight and seating number of row 5), own block numbers
    assert rows["weight_kg"][5:8].tolist() == [w] * 3 and rows["repeat"][5:8].tolist() == [rep] * 3 == [2] * 3
    assert len(placed) == len(rows) - 2  # no prompt to place the weight for the two repeats
    # the simulated bench: the seating's contact factor for all three (truth: the start record's factors per block)
    truth = np.asarray(s.start["simulation"]["block_resistance_ohm"])
    blocks = rows["block"].to_numpy()
    mean = rows["mean_ohm"].to_numpy()
    seat = truth[blocks[5]]
    assert not np.isclose(truth[blocks[6]], seat, rtol=1e-3)  # a new seating would have had another factor
    assert np.allclose(mean[5:8], seat, rtol=1e-4)  # instrument noise only, ≪ the 15 % re-seating scatter
    others = [j for j in range(len(rows)) if j not in (6, 7)]
    assert np.allclose(mean[others], truth[blocks[others]], rtol=1e-4)
    # fit: one repeat at that weight for the three blocks, their mean; the design counts seatings alike
    curve = MeasuredCurve.from_summary(rows, seatings=True)
    i = int(np.flatnonzero(curve.weight_kg == w)[0])
    at_w = rows["weight_kg"].to_numpy() == w
    n_seatings = len(set(rows["repeat"][at_w].tolist()))
    assert curve.n[i] == n_seatings == np.count_nonzero(at_w) - 2
    assert curve.values_ohm[i, rep - 1] == pytest.approx(float(np.mean(mean[5:8])), rel=1e-15)
    design = session_design(s)
    j = design.index_of(w)
    assert [len(x) for x in design.seatings[j]][rep - 1] == 3 and len(design.seatings[j]) == n_seatings
    # replay: the suggestions (the forced ones too, the test's design still in place) and the instrument replies
    same, text = replay_suggestions(str(path))
    assert same, text
    assert replay_session(path).identical
