"""The ``contactrig instruments`` commands on the simulated bench."""

from __future__ import annotations

import json

import pytest

from daq.cli import main


def test_identify_sim(capsys):
    assert main(["instruments", "identify", "--sim"]) == 0
    out = capsys.readouterr().out
    assert "MODEL 6221" in out and "MODEL 2182A" in out


def test_delta_sim_text(capsys):
    assert main(["instruments", "delta", "--sim", "--current", "1e-3", "--count", "20"]) == 0
    out = capsys.readouterr().out
    for word in ("mean", "SD", "SEM", "N ", "invalid"):
        assert word in out


def test_delta_sim_json_values(capsys):
    assert (
        main(["instruments", "delta", "GPIB0::12::INSTR", "--sim", "--current", "2e-3", "--count", "7", "--json"]) == 0
    )
    data = json.loads(capsys.readouterr().out)
    assert set(data) >= {"readings", "mean", "sd", "sem", "n_invalid", "unit"}
    assert len(data["readings"]) == 7 and data["n_invalid"] == 0 and data["unit"] == "V"
    # default bench: 5 mΩ; Delta reading = R·(high − low)/2 = 5e-3 · 2e-3
    assert data["mean"] == pytest.approx(1e-5, rel=1e-3)


@pytest.mark.parametrize(
    "argv, flag",
    [
        (["--current", "0.5", "--count", "5"], "--current"),
        (["--current", "1e-3", "--count", "0"], "--count"),
        (["--current", "1e-3", "--count", "5", "--delay", "0"], "--delay"),
    ],
)
def test_bad_arguments_one_line_error(capsys, argv, flag):
    assert main(["instruments", "delta", "--sim", *argv]) == 2
    err = capsys.readouterr().err
    assert flag in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_address_required_without_sim(capsys):
    assert main(["instruments", "identify"]) == 2
    assert "--sim" in capsys.readouterr().err


def test_unknown_address_one_line_error(capsys):
    assert main(["instruments", "identify", "GPIB0::99::INSTR", "--sim"]) == 2
    err = capsys.readouterr().err
    assert "GPIB0::99::INSTR" in err and len(err.strip().splitlines()) == 1
