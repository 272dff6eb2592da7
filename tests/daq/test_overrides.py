"""Per-run overrides of the scene (``acquire --address/--visa-library/--sample/--operator/--notes/--sim-seed``,
:mod:`daq.overrides`): validated by the scene's own validators, recorded apart from the scene text, shown by
``scene show``, kept and checked by ``--resume`` (issue 20 item 1)."""

from __future__ import annotations

import pytest

from contactrig.cli.main import main
from contactrig.core.scene import parse_scene
from contactrig.core.validation import SettingError
from daq.acquire import acquire
from daq.link import VisaBench
from daq.overrides import OVERRIDES, apply_overrides, overrides_by_option, plan_with_overrides
from daq.plan import SessionPlan
from daq.session_file import load_session
from instruments.simulated import SOCKET_ADDRESS, SimulatedBench, simulated_resource_manager

from .conftest import small_scene


def _bench(seed=1):
    return VisaBench(simulated_resource_manager(bench=SimulatedBench(resistance_ohm=5e-3, seed=seed, time_scale=0.0)))


BAD = {"instrument.address": "nope", "instrument.visa_library": 3, "session.sample": 7, "session.operator": [1],
       "session.notes": 1.5, "session.sim_seed": -1}  # fmt: skip


@pytest.mark.parametrize("o", OVERRIDES, ids=lambda o: o.option)
def test_an_override_is_validated_as_its_scene_key_and_named_by_its_option(o):
    """The reference: the same value written in the scene text is refused by the scene's validator; the override
    gives the same reason, naming the option."""
    table, name = o.key.split(".")
    text = small_scene().text.replace(f"[{table}]\n", f"[{table}]\n{name} = {BAD[o.key]!r}\n".replace("'", '"'), 1)
    text = "\n".join(line for line in text.splitlines() if not line.startswith(f"{name} = ") or
                     line == f"{name} = {BAD[o.key]!r}".replace("'", '"'))  # fmt: skip
    with pytest.raises(SettingError) as in_scene:
        SessionPlan.from_scene(parse_scene(text))
    with pytest.raises(SettingError) as as_option:
        plan_with_overrides(small_scene(), {o.key: BAD[o.key]})
    assert as_option.value.field == o.option
    assert str(as_option.value).startswith(f"{o.option} = ")
    assert in_scene.value.allowed in as_option.value.allowed


def test_every_option_is_on_the_acquire_parser():
    from contactrig.cli.main import build_parser

    acquire_parser = build_parser()._subparsers._group_actions[0].choices["acquire"]
    options = {s for a in acquire_parser._actions for s in a.option_strings}
    assert {o.option for o in OVERRIDES} <= options
    assert overrides_by_option({"address": "GPIB0::1::INSTR", "sample": None, "sim_seed": "4"}) == {
        "instrument.address": "GPIB0::1::INSTR", "session.sim_seed": 4}  # fmt: skip


def test_overrides_are_recorded_apart_from_the_scene_text(tmp_path):
    path = tmp_path / "s.h5"
    given = {"session.sample": "steel B", "session.operator": "ann", "session.notes": "new liner"}
    acquire(small_scene(), path, yes=True, bench=_bench(), quiet=True, overrides=given)
    s = load_session(path)
    assert s.scene_text == small_scene().text  # the scene as the file was
    assert s.start["overrides"] == given and s.start["override_changes"] == []
    assert (s.start["sample"], s.start["operator"], s.start["notes"]) == ("steel B", "ann", "new liner")
    assert s.start["operator_source"] == "override"
    assert s.start["plan"]["session"]["sample"] == "steel B"
    assert apply_overrides(small_scene(), given).text == small_scene().text


def test_scene_show_prints_the_scene_and_the_overrides(tmp_path, capsys):
    path = tmp_path / "s.h5"
    acquire(small_scene(), path, yes=True, bench=_bench(), quiet=True, overrides={"session.sample": "steel B"})
    assert main(["scene", "show", str(path)]) == 0
    out = capsys.readouterr().out
    assert 'sample = "test sample"' in out  # the recorded text, unchanged
    assert "#   run 1: --sample 'steel B'" in out
    assert "#   [session] sample = 'steel B'  (override --sample)" in out
    assert "#   [instrument] address = 'GPIB0::12::INSTR'  (scene or default)" in out
    parse_scene(out)  # still a scene: the additions are comments


def _stopped_after_one_weight(path, **kw):
    answers = iter(["go", "quit"])
    first = acquire(small_scene(), path, prompter=lambda step: next(answers), bench=_bench(), quiet=True, **kw)
    assert first.status == "aborted"


def test_resume_keeps_the_overrides_and_records_a_changed_address(tmp_path):
    path = tmp_path / "s.h5"
    _stopped_after_one_weight(path, overrides={"session.sample": "steel B", "session.operator": "ann"})
    said = []
    stream = type("S", (), {"write": lambda self, t: said.append(t), "flush": lambda self: None})()
    acquire(None, path, resume=True, yes=True, bench=_bench(2), stream=stream,
            overrides={"instrument.address": SOCKET_ADDRESS})  # fmt: skip
    s = load_session(path)
    assert s.complete and s.runs[1]["overrides"] == {"session.sample": "steel B", "session.operator": "ann",
                                                      "instrument.address": SOCKET_ADDRESS}  # fmt: skip
    assert s.runs[1]["instrument"]["address"] == SOCKET_ADDRESS
    assert s.runs[1]["override_changes"] == [
        {"key": "instrument.address", "option": "--address", "before": "GPIB0::12::INSTR", "after": SOCKET_ADDRESS}
    ]
    assert "--address changed on resume: 'GPIB0::12::INSTR' → 'TCPIP0" in "".join(said)


def test_resume_with_another_sample_is_refused_unless_allowed(tmp_path):
    path = tmp_path / "s.h5"
    _stopped_after_one_weight(path, overrides={"session.sample": "steel B"})
    before = path.read_bytes()
    with pytest.raises(SettingError, match=r"--sample = 'steel C'.*recorded with \[session\] sample = 'steel B'"):
        acquire(None, path, resume=True, yes=True, bench=_bench(2), quiet=True, overrides={"session.sample": "steel C"})
    assert path.read_bytes() == before  # nothing written
    acquire(None, path, resume=True, yes=True, bench=_bench(2), quiet=True, overrides={"session.sample": "steel B"})
    assert load_session(path).runs[1]["override_changes"] == []  # the same value is no change


def test_resume_with_allow_change_records_the_new_sample(tmp_path):
    path = tmp_path / "s.h5"
    _stopped_after_one_weight(path)
    acquire(None, path, resume=True, yes=True, bench=_bench(2), quiet=True, overrides={"session.sample": "steel C"},
            allow_change=True)  # fmt: skip
    change = load_session(path).runs[1]["override_changes"]
    assert change == [{"key": "session.sample", "option": "--sample", "before": "test sample", "after": "steel C"}]


def test_cli_refuses_a_bad_or_misplaced_override_before_any_file(tmp_path, capsys):
    path = tmp_path / "s.h5"
    assert main(["acquire", "--sim", "--yes", "-o", str(path), "--sim-seed", "x"]) == 2
    assert "--sim-seed = 'x' is not allowed" in capsys.readouterr().err
    assert main(["acquire", "-o", str(path), "--sim-seed", "3"]) == 2
    assert "--sim-seed = 3 is not allowed: applies to the simulated bench (--sim) only" in capsys.readouterr().err
    assert main(["acquire", "--sim", "--yes", "-o", str(path), "--visa-library", "@py"]) == 2
    assert "not to --sim" in capsys.readouterr().err
    assert not path.exists()
