"""Issue 20 item 6: every command that prints results has ``--json``; its output validates against the JSON Schema
shipped for it (``contactrig/schemas/<command>.json``, package data) and carries units."""

from __future__ import annotations

import json
from importlib import resources

import pytest

from contactrig.cli.main import build_parser, main
from tests.cli_tree import subcommand_parsers

jsonschema = pytest.importorskip("jsonschema")

#: Commands that print results (not only file paths or a status line): each must have --json and a schema.
RESULT_COMMANDS = ("circuit", "fit", "simulate", "database", "compare-models", "design", "replay", "sessions", "bench",
                   "instruments delta", "instruments identify", "surface")  # fmt: skip


def _schema(command: str) -> dict:
    name = command.replace(" ", "-") + ".json"
    return json.loads(resources.files("contactrig").joinpath("schemas", name).read_text(encoding="utf-8"))


def test_result_commands_have_json_and_a_valid_schema():
    commands = subcommand_parsers(build_parser())
    with_json = {n for n, p in commands.items() if any("--json" in a.option_strings for a in p._actions)}
    assert set(RESULT_COMMANDS) <= with_json
    for name in with_json:
        jsonschema.Draft202012Validator.check_schema(_schema(name))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("json")
    text = resources.files("contactrig").joinpath("scenes/default.toml").read_text(encoding="utf-8")
    scene = folder / "small.toml"
    scene.write_text(text.replace("n = 512", "n = 64"), encoding="utf-8")
    sim = folder / "sim.h5"
    assert main(["simulate", str(scene), "--weights", "5,10,20,26", "-o", str(sim), "--models", "hertz,lagemann"]) == 0
    session = folder / "s.h5"
    assert main(["import", "--tab1", "-o", str(session)]) == 0
    from daq.plan import SessionPlan
    from tests.daq.conftest import small_scene
    from tests.daq.sessions import write_session

    write_session(SessionPlan.from_scene(small_scene()), folder / "acquired.h5")  # a recorded one, to replay
    return folder, scene, sim, session


def _packaged(name: str):
    return resources.files("contactrig").joinpath(name)


def _argv(command: str, folder, scene, sim, session) -> list[str]:
    return {
        "circuit": ["circuit", "--paper"],
        "fit": ["fit", str(session), "--sim", str(sim), "--bootstrap", "20", "--allow-mismatch"],
        "simulate": ["simulate", str(scene), "--weights", "5,10", "--models", "hertz"],
        "database": ["database", str(scene), "-o", str(folder / "db.h5"), "--models", "hertz", "--force"],
        "compare-models": ["compare-models", str(scene), "--models", "hertz", "--pressures", "1MPa,3MPa", "--jobs",
                           "1"],
        "design": ["design", str(scene), "-o", str(folder / "design"), "--sessions", "20", "--force"],
        "replay": ["replay", str(folder / "acquired.h5")],
        "sessions": ["sessions", str(folder)],
        "bench": ["bench", "--quick", "--study", "none", "--no-atlas"],
        "instruments delta": ["instruments", "delta", "--sim", "--current", "1e-3", "--count", "4"],
        "instruments identify": ["instruments", "identify", "--sim"],
        "surface": ["surface", str(_packaged("scenes/measured/liner.x3p"))],
    }[command]


@pytest.mark.parametrize("command", RESULT_COMMANDS)
def test_json_output_validates_against_its_schema(command, files, capsys):
    capsys.readouterr()
    code = main([*_argv(command, *files), "--json"])
    out = capsys.readouterr().out
    assert code == 0
    data = json.loads(out)
    jsonschema.validate(data, _schema(command), cls=jsonschema.Draft202012Validator)
    if isinstance(data, dict) and command != "instruments identify":  # identities are text, nothing has a unit
        assert "by_suffix" in data["units"] and data["units"]["by_suffix"]["_ohm"] == "Ω"
        del data["units"]  # the schema demands them
        with pytest.raises(jsonschema.ValidationError, match="'units' is a required property"):
            jsonschema.validate(data, _schema(command), cls=jsonschema.Draft202012Validator)
