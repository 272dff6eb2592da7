"""``contactrig simulate``: JSON shape, weights override, model restriction, HDF5 output, errors."""

from __future__ import annotations

import json

import pytest

from contactrig.cli.main import main
from contactrig.cli.simulate import parse_list
from daq.sweep_file import load_sweep


def test_simulate_json_with_weights_and_output(tmp_path, capsys):
    out = tmp_path / "sim.h5"
    rc = main(["simulate", "--models", "greenwood_tripp", "--weights", "0,5.44,25.966", "--json", "-o", str(out)])
    assert rc == 0
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    assert set(data) == {"units", "models", "warnings", "bulk_elasticity"}
    assert data["bulk_elasticity"] == []  # the rigid model unless --elastic
    gt = data["models"]["greenwood_tripp"]
    assert gt["weight_kg"] == [0.0, 5.44, 25.966]
    assert set(gt) == {"weight_kg", "contact_area_m2", "min_separation_m"}
    assert gt["contact_area_m2"][0] == 0.0 and 0 < gt["contact_area_m2"][1] < gt["contact_area_m2"][2]
    back = load_sweep(out)
    assert back.models["greenwood_tripp"].contact_area_m2.tolist() == gt["contact_area_m2"]
    assert back.provenance["scene_name"] == "paper-default"


def test_simulate_table_for_a_scene_file(tmp_path, capsys):
    from contactrig.core.scene import default_scene_text

    scene = tmp_path / "scene.toml"
    scene.write_text(default_scene_text().replace("clearance_m = 40e-6", "clearance_m = 20e-6"))
    assert main(["simulate", str(scene), "--models", "greenwood_tripp", "--weights", "10"]) == 0
    out = capsys.readouterr().out
    assert "greenwood_tripp" in out and "area_mm2" in out


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--weights", "1,,2"], "--weights"),
        (["--weights", "1,heavy"], "--weights"),
        (["--weights", "-3"], "--weights"),
        (["--models", "hertzian"], "hertzian"),
        (["no_such_scene.toml"], "not found"),
    ],
)
def test_simulate_errors_are_one_line_exit_2(argv, message, capsys):
    assert main(["simulate", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_parse_list():
    assert parse_list("--weights", "1, 2.5") == [1.0, 2.5]
    assert parse_list("--models", "a,b", str) == ["a", "b"]


def test_simulate_imports_neither_pyvisa_nor_matplotlib():
    import subprocess
    import sys

    code = (
        "import sys, io, contextlib\n"
        "import sims.rig, sims.rig.dynamics, daq.sweep_file\n"
        "from contactrig.cli.main import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    rc = main(['simulate', '--models', 'greenwood_tripp', '--weights', '5.44', '--json'])\n"
        "heavy = [m for m in ('pyvisa', 'matplotlib') if m in sys.modules]\n"
        "print(rc, heavy)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == "0 []", out.stdout + out.stderr
