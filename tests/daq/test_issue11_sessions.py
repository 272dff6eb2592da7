"""Issue #11: the plan and its duration at the start, an ETA of block time only, a confirmed skip, --resume asking
about skipped weights, the session's history, replay of a Ctrl-C'd run and its exit code, a press scene's weights.

Expected values are computed here from the test's own inputs (the small scene's Delta settings, the answers given),
not taken from the code under test.
"""

from __future__ import annotations

import io
import warnings

import h5py
import pytest

from contactrig.core.scene import parse_scene
from contactrig.core.validation import SettingError
from daq.acquire import acquire, skipped_weights, terminal_prompter
from daq.engine import Interrupts
from daq.plan import PlaceWeight, SessionPlan
from daq.records import session_history
from daq.replay import replay_session
from daq.session_file import load_session

from .conftest import SMALL_SCENE, make_link, small_scene
from .sessions import reseal, write_session
from .test_acquire import _bench
from .test_engine import SignalTwice


def _load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_session(path)


# ---- 1. the plan and the estimated duration; the ETA counts block time only ----------------------------------


def test_acquire_prints_the_plan_and_an_estimated_duration(tmp_path):
    out = io.StringIO()
    acquire(small_scene(), tmp_path / "s.h5", yes=True, bench=_bench(), stream=out)
    text = out.getvalue()
    plan_line, estimate = text.splitlines()[:2]
    assert plan_line.startswith("plan: 6 blocks") and "loading order 5.44, 10.526, 25.966 kg" in plan_line
    assert "2 repeat(s) per weight" in plan_line and "8 readings per block" in plan_line
    block_s = 8 * (0.002 + 1.0 / 50 + 0.005)  # count × (delay + NPLC/line frequency + 5 ms overhead)
    assert f"6 blocks × {block_s:.3g} s" in estimate and "unattended: no operator time" in estimate
    assert f"≈ {6 * block_s:.2g} s" in estimate


def test_an_attended_session_states_the_operator_allowance(tmp_path):
    out = io.StringIO()
    acquire(small_scene(), tmp_path / "s.h5", prompter=lambda step: "go", bench=_bench(), stream=out)
    estimate = out.getvalue().splitlines()[1]
    # three weights × 60 s allowed for placing each: said to be an allowance, added to the measuring time
    assert "3 min 00 s operator allowance (1 min 00 s per weight to place it: an allowance, not a measurement)" in (
        estimate
    )
    assert estimate.endswith("≈ 3 min 01 s")


def test_eta_leaves_out_the_time_spent_waiting_for_the_operator():
    import numpy as np

    from daq.records import BlockRecord, now_iso
    from daq.writers import LiveDisplay

    t = [0.0]
    display = LiveDisplay(10, stream=io.StringIO(), quiet=True, clock=lambda: t[0])
    r = np.full(4, 1e-3)

    def block():
        display.block(BlockRecord(block=0, run=0, weight_kg=5.0, repeat=1, unit="V", reading=r, time_s=np.arange(4.0),
                                  resistance_ohm=r, valid=np.ones(4, bool), started=now_iso()))  # fmt: skip

    assert display.eta_s is None
    t[0] = 2.0
    block()  # 2 s of block time
    with display.paused():
        t[0] += 300.0  # the operator takes 5 min to change weights
    t[0] += 2.0
    block()
    assert display.block_times_s == [2.0, 2.0]
    assert display.eta_s == pytest.approx(2.0 * 8)  # 8 blocks left at 2 s, not (304 s / 2) each


# ---- 2. a skip is confirmed -----------------------------------------------------------------------------------


def test_skip_is_confirmed_before_it_takes_effect():
    out = io.StringIO()
    replies = iter(["s", "n", "s", "", "s", "y"])
    ask = terminal_prompter(out, read=lambda: next(replies))
    step = PlaceWeight(1, 10.526, 2)
    assert ask(step) == "skip"
    text = out.getvalue()
    assert text.count("skip 10.526 kg? [y/N]") == 3 and text.count("not skipped") == 2
    assert next(replies, None) is None  # the skip took effect only at the "y"
    go = iter(["s", "", ""])  # not confirmed, then Enter: go on
    assert terminal_prompter(io.StringIO(), read=lambda: next(go))(step) == "go"


# ---- 3. --resume asks about skipped weights -------------------------------------------------------------------


def _skipped_first_then_quit(path):
    answers = iter(["skip", "go", "quit"])  # 5.44 skipped, 10.526 measured, stopped at 25.966
    first = acquire(small_scene(), path, prompter=lambda step: next(answers), bench=_bench(1), quiet=True)
    assert first.status == "aborted" and first.blocks_done == 2


def test_resume_measures_a_skipped_weight_now_when_the_operator_says_so(tmp_path):
    path = tmp_path / "s.h5"
    _skipped_first_then_quit(path)
    asked = []
    second = acquire(None, path, resume=True, yes=True, bench=_bench(2), quiet=True,
                     resume_chooser=lambda w: asked.append(w) or True)  # fmt: skip
    assert asked == [5.44] and second.status == "success"
    s = _load(path)
    assert list(s.summary.weight_kg[s.summary.run == 1]) == [5.44, 5.44, 25.966, 25.966]  # placed first
    assert s.runs[1]["loading_order_kg"] == [5.44, 25.966]
    assert s.runs[1]["resume_choices"] == [
        {"weight_kg": 5.44, "weight_index": 0, "choice": "measure it now", "by": "operator"}
    ]
    assert replay_session(path).identical


def test_resume_with_yes_keeps_a_skipped_weight_skipped_and_says_so(tmp_path):
    path = tmp_path / "s.h5"
    _skipped_first_then_quit(path)
    out = io.StringIO()
    second = acquire(None, path, resume=True, yes=True, bench=_bench(2), stream=out)
    assert "5.44 kg was skipped: keep it skipped — the default with --yes" in out.getvalue()
    assert second.status == "success" and "5.44 kg" in second.reason
    s = _load(path)
    assert list(s.summary.weight_kg) == [10.526, 10.526, 25.966, 25.966]  # the loading order did not change
    assert s.runs[1]["resume_choices"][0]["by"] == "default with --yes"
    assert s.stop["weights_skipped"] == [5.44]


def test_resume_without_an_operator_answer_refuses_before_touching_anything(tmp_path):
    from daq.acquire import terminal_resume_chooser
    from daq.errors import SessionStateError

    path = tmp_path / "s.h5"
    _skipped_first_then_quit(path)
    before = path.read_bytes()

    def eof():
        raise EOFError

    with pytest.raises(SessionStateError, match=r"skipped 5\.44 kg"):
        acquire(None, path, resume=True, bench=_bench(2), quiet=True,
                resume_chooser=terminal_resume_chooser(io.StringIO(), read=eof))  # fmt: skip
    assert path.read_bytes() == before


def test_skipped_weights_of_a_killed_run_are_inferred_from_the_gaps():
    plan = SessionPlan.from_scene(small_scene())
    assert skipped_weights(plan, frozenset({2, 3})) == [0]  # no stop record: 5.44 has no block, 10.526 has
    assert skipped_weights(plan, frozenset({0, 1})) == []  # stopped after the first weight: nothing skipped
    assert skipped_weights(plan, frozenset({0, 1}), frozenset({10.526})) == [1]  # recorded in a stop record


# ---- 4. the session's history ----------------------------------------------------------------------------------


def test_history_shows_loading_order_skips_resumes_and_interruptions(tmp_path):
    path = tmp_path / "s.h5"
    _skipped_first_then_quit(path)
    acquire(None, path, resume=True, yes=True, bench=_bench(2), quiet=True)
    lines = session_history(_load(path))
    assert lines[0] == "loading order: 10.526, 25.966 kg"
    assert lines[1] == "runs: 2 (1 resume(s)); interruptions: 0 by Ctrl-C, 0 killed"
    assert lines[2].startswith("run 0 (started ") and "placed 10.526 kg; skipped by the operator: 5.44 kg" in lines[2]
    assert "ended: stopped early (operator) — operator stopped the session at weight 25.966 kg" in lines[2]
    assert lines[3].startswith("run 1 (resumed ")
    assert "5.44 kg was skipped: keep it skipped (default with --yes); placed 25.966 kg; ended: done" in lines[3]


def test_history_counts_a_ctrl_c_and_a_kill(plan, tmp_path):
    path = tmp_path / "i.h5"
    link = make_link(plan, wrapper=lambda t: SignalTwice(t, at=[1]))
    with Interrupts() as intr:
        write_session(plan, path, link=link, interrupts=intr)
    lines = session_history(_load(path))
    assert "interruptions: 1 by Ctrl-C, 0 killed" in lines[1] and "ended: stopped early (Ctrl-C)" in lines[2]
    with h5py.File(path, "a") as h5:  # as a kill leaves it: no stop record
        del h5["entry/stop"]
    assert "ended: killed (no stop record" in session_history(_load(path))[2]


# ---- 5. replay: a Ctrl-C'd run is stopped early, not killed; DIFFERENT exits 2 --------------------------------


def test_replay_calls_a_run_stopped_by_ctrl_c_twice_stopped_early(plan, tmp_path):
    path = tmp_path / "i.h5"
    link = make_link(plan, wrapper=lambda t: SignalTwice(t, at=[1]))
    with Interrupts() as intr:
        write_session(plan, path, link=link, interrupts=intr)
    report = replay_session(path)
    assert report.identical
    assert not any("killed" in n for n in report.notes), report.notes
    assert any(n.startswith("run 0: stopped early (Ctrl-C) during block 2") and "SOUR:SWE:ABOR" in n
               for n in report.notes)  # fmt: skip


def test_a_replay_that_differs_exits_2_with_one_line_saying_what(plan, tmp_path, capsys):
    from contactrig.cli.main import main

    from .test_replay import _edit_exchange, _scale_first_reading

    path = tmp_path / "r.h5"
    write_session(plan, path)
    capsys.readouterr()
    assert main(["replay", str(path)]) == 0
    block = _edit_exchange(path, lambda m: m.startswith("TRAC:DATA:SEL?"), _scale_first_reading)
    reseal(path)
    capsys.readouterr()
    assert main(["replay", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("contactrig replay: error: ") and "DIFFERENT" in err[0]
    assert f"block {block + 1} " in err[0] and "mean_ohm recorded" in err[0]
    assert main(["replay", str(path), "--json"]) == 2


# ---- 7. a press scene's session weights -----------------------------------------------------------------------


def test_a_press_scene_takes_its_session_weights_from_press():
    text = SMALL_SCENE + "\n[press]\nweights_kg = [0.5, 1.0, 2.0]\n"
    assert SessionPlan.from_scene(parse_scene(text, "<t>")).session.weights_kg == (0.5, 1.0, 2.0)
    assert SessionPlan.from_scene(small_scene()).session.weights_kg == (5.44, 10.526, 25.966)  # rig scene: [rig]
    given = text.replace("[session]\n", "[session]\nweights_kg = [3.0]\n")
    assert SessionPlan.from_scene(parse_scene(given, "<t>")).session.weights_kg == (3.0,)  # [session] wins
    heavy = SMALL_SCENE + "\n[press]\nweights_kg = [0.5, 2000.0]\n"
    with pytest.raises(SettingError, match=r"press\] weights_kg"):
        SessionPlan.from_scene(parse_scene(heavy, "<t>"))


def test_the_packaged_press_scene_plans_its_press_weights():
    import tomllib

    from contactrig.core.scene import load_scene

    from .conftest import ROOT

    path = ROOT / "contactrig" / "scenes" / "press.toml"
    press = tomllib.loads(path.read_text(encoding="utf-8"))["press"]["weights_kg"]
    assert SessionPlan.from_scene(load_scene(path)).session.weights_kg == tuple(press)
