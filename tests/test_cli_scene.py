"""``contactrig scene init|show`` and the one ``--models`` syntax (issue #11), as a new user would use them."""

from __future__ import annotations

import hashlib
import tomllib

import pytest

from contactrig.cli.main import main
from contactrig.core.scene import default_scene_text, load_scene


def _run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_scene_init_writes_the_documented_default_and_never_overwrites(tmp_path, capsys):
    path = tmp_path / "sub" / "my scene.toml"
    code, out, _ = _run(capsys, "scene", "init", str(path))
    assert code == 0 and str(path) in out
    text = path.read_text(encoding="utf-8")
    assert text == default_scene_text()
    data = tomllib.loads(text)
    # every key of these tables carries its unit/range/meaning in a comment on its own line
    lines_of: dict[str, list[str]] = {}
    table = ""
    for ln in text.splitlines():
        if ln.startswith("["):
            table = ln.strip("[] ")
        elif "=" in ln and not ln.lstrip().startswith("#"):
            lines_of.setdefault(table, []).append(ln)
    for table in ("rig", "delta", "session", "circuit", "instrument"):
        for key in data[table]:
            line = next(ln for ln in lines_of[table] if ln.split("=")[0].strip() == key)
            assert "#" in line, f"[{table}] {key} has no comment"
    assert load_scene(path).name == "paper-default"  # it loads as a scene
    path.write_text("# my edits\n", encoding="utf-8")
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    code, _, err = _run(capsys, "scene", "init", str(path))
    assert code == 2 and err.count("\n") == 1 and "exists; use --force" in err
    assert hashlib.sha256(path.read_bytes()).hexdigest() == digest  # the user's file is untouched
    assert _run(capsys, "scene", "init", str(path), "--force")[0] == 0
    assert path.read_text(encoding="utf-8") == default_scene_text()


def test_scene_show_prints_the_scene_a_sweep_was_made_with(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(default_scene_text().replace("clearance_m = 40e-6", "clearance_m = 31e-6"), encoding="utf-8")
    sweep = tmp_path / "sweep.h5"
    argv = ("simulate", str(scene), "--models", "greenwood_tripp", "--weights", "5.44", "-o", str(sweep))
    code, _, _ = _run(capsys, *argv)
    assert code == 0
    code, out, _ = _run(capsys, "scene", "show", str(sweep))
    assert code == 0 and "clearance_m = 31e-6" in out and "rig sweep" in out


def test_scene_show_of_a_file_without_a_scene_is_one_line(tmp_path, capsys):
    junk = tmp_path / "notes.txt"
    junk.write_text("not a scene = [", encoding="utf-8")
    code, _, err = _run(capsys, "scene", "show", str(junk))
    assert code == 2 and err.count("\n") == 1 and "notes.txt" in err
    code, _, err = _run(capsys, "scene", "show", str(tmp_path / "missing.h5"))
    assert code == 2 and "no such file" in err


@pytest.mark.parametrize(
    "spelling",
    [["--models", "hertz,lagemann"], ["--models", "hertz", "--models", "lagemann"], ["--models", "hertz, lagemann,"]],
)
def test_models_take_one_syntax_in_every_command(spelling, capsys):
    from contactrig.cli.main import build_parser

    parser = build_parser()
    for command in (["database", "-o", "x.h5"], ["simulate"], ["fit", "tab1"], ["report", "tab1", "-o", "r"]):
        args = parser.parse_args([*command, *spelling])
        assert args.models == ["hertz", "lagemann"], command
    # a scene after the option is the scene, not a model
    args = parser.parse_args(["simulate", "--models", "hertz", "my_scene.toml"])
    assert args.models == ["hertz"] and args.scene == "my_scene.toml"


def test_an_unknown_model_is_one_line_naming_the_registered_ones(capsys):
    assert main(["simulate", "--models", "hertzz"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "'hertzz'" in err and "jackson_green" in err
