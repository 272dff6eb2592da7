"""One output policy for every command that writes (issue 20 item 2): an output in a missing nested folder is
written there, the folders created — `contactrig acquire --sim --yes -o runs/s1.h5` in a folder without `runs/`
included. Every subcommand with an output option must have a case here (the parser is searched for them).

The commands whose work takes many seconds (figures, report, demo, design, compare-models) are stopped right after
their output check — the step that creates the folder and runs before any work — by a wrapper around
:func:`contactrig.core.files.refuse_existing`; the others run to the end and their files are looked for."""

from __future__ import annotations

import argparse
from importlib import resources

import pytest

import contactrig.core.files
from contactrig.cli.main import build_parser, main
from contactrig.core.scene import default_scene_text

#: argparse destinations of options that name an output (file or folder)
OUTPUT_DESTS = {"output", "out", "plot", "png", "live"}


class _Stopped(Exception):
    """Raised once the command's outputs are checked: the rest of a slow command is not what is tested."""


def _sim_session(tmp):
    main(["acquire", str(tmp / "scene.toml"), "--sim", "--yes", "-o", str(tmp / "s.h5")])
    return tmp / "s.h5"


# command → (arguments, files expected under the missing folder {out}, whether to stop after the output check)
#: A measured height map shipped with the package (the example scene's liner, X3P).
LINER_X3P = str(resources.files("contactrig").joinpath("scenes/measured/liner.x3p"))

CASES = {
    "acquire": (["{scene}", "--sim", "--yes", "-o", "{out}/runs/s1.h5"], ["runs/s1.h5"], False),
    "import": (["--tab1", "-o", "{out}/t.h5"], ["t.h5"], False),
    "simulate": (["--weights", "1", "--models", "hertz", "-o", "{out}/sim.h5"], ["sim.h5"], False),
    "database": (["--models", "hertz", "--n-separations", "16", "-o", "{out}/db.h5"], ["db.h5"], False),
    "export": (["{session}", "-o", "{out}/x.csv"], ["x.csv", "x-readings.csv"], False),
    "watch": (["{session}", "--once", "--png", "{out}/w.png"], ["w.png"], False),
    "scene": (["init", "{out}/s.toml"], ["s.toml"], False),
    "bench": (["--quick", "--study", "none", "--no-atlas", "-o", "{out}"], ["report.md"], False),
    "instruments": (["verify", "--sim", "-o", "{out}"], ["verify.json", "verify.md"], False),
    "surface": ([LINER_X3P, "--plot", "{out}/surface.png"], ["surface.png"], False),
    "figures": (["tab1", "--bootstrap", "0", "-o", "{out}"], [], True),
    "report": (["tab1", "--bootstrap", "0", "-o", "{out}"], [], True),
    "demo": (["--bootstrap", "0", "-o", "{out}"], [], True),
    "design": (["-o", "{out}"], [], True),
    "compare-models": (["--models", "hertz", "--plot", "{out}/c.png"], [], True),
}


def _writing_subcommands() -> set[str]:
    """Every subcommand (or its sub-subcommands) with an output option or an output PATH argument."""
    found = set()
    sub = build_parser()._subparsers._group_actions[0]  # type: ignore[union-attr]
    for name, parser in sub.choices.items():
        parsers = [parser]
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                parsers += list(action.choices.values())
        dests = {a.dest for p in parsers for a in p._actions}
        if dests & OUTPUT_DESTS or "path" in dests:
            found.add(name)
    return found


def test_every_writing_subcommand_has_a_case():
    assert _writing_subcommands() == set(CASES)


@pytest.mark.parametrize("command", sorted(CASES))
def test_an_output_in_a_missing_nested_folder_is_created(command, tmp_path, monkeypatch, capsys):
    if command == "surface":
        pytest.importorskip("SurfaceTopography", reason="the packaged X3P map needs the 'surfaces' extra")
    args, files, stop = CASES[command]
    scene = tmp_path / "scene.toml"
    scene.write_text(default_scene_text().replace("repeats = 6 ", "repeats = 1 "), encoding="utf-8")
    session = _sim_session(tmp_path) if "{session}" in args else None
    out = tmp_path / "no" / "such" / "folder"
    argv = [command, *(a.format(out=out, scene=scene, session=session) for a in args)]
    if stop:
        check = contactrig.core.files.refuse_existing

        def check_then_stop(*a, **kw):
            check(*a, **kw)
            raise _Stopped

        monkeypatch.setattr(contactrig.core.files, "refuse_existing", check_then_stop)
        with pytest.raises(_Stopped):
            main(argv)
        assert out.is_dir()
        return
    assert main(argv) == 0, capsys.readouterr().err
    for name in files:
        assert (out / name).is_file(), (name, sorted(p.name for p in out.iterdir()))
