"""The ``contactrig instruments`` commands on the simulated bench."""

from __future__ import annotations

import json

import pytest

from contactrig.cli.main import main


def test_identify_sim(capsys):
    assert main(["instruments", "identify", "--sim"]) == 0
    out = capsys.readouterr().out
    assert "MODEL 6221" in out and "MODEL 2182A" in out


def test_delta_sim_text(capsys):
    assert main(["instruments", "delta", "--sim", "--current", "1e-3", "--count", "20"]) == 0
    lines = dict(line.split(None, 1) for line in capsys.readouterr().out.splitlines() if not line.startswith("R "))
    assert set(lines) == {"mean", "SD", "SEM", "N", "invalid"}
    # default bench 5 mΩ at ±1 mA: Delta readings of 5 µV; noise 8 nV/√1 PLC · √6/4 ≈ 5 nV SD per reading
    assert float(lines["mean"].split()[0]) == pytest.approx(5e-6, rel=1e-2)
    assert 1e-9 < float(lines["SD"].split()[0]) < 2e-8
    assert int(lines["N"]) == 20 and int(lines["invalid"]) == 0


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


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["identify", "--sim", "--seed", "-1"], ["--seed", "-1"]),
        (["identify", "--sim", "--timeout-ms", "0"], ["--timeout-ms", "0"]),
        (["identify", "nonsense"], ["ADDRESS", "'nonsense'", "GPIB0::12::INSTR"]),
        (["delta", "--sim", "--current", "nan", "--count", "5"], ["--current", "nan"]),
        (["delta", "--sim", "--current", "1e-3", "--count", "5", "--nplc", "0"], ["--nplc", "0.0", "[0.01, 50]"]),
    ],
)
def test_bad_values_name_the_option_value_and_range(capsys, argv, words):
    assert main(["instruments", *argv]) == 2
    err = capsys.readouterr().err
    assert all(w in err for w in words), err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_no_visa_library_is_one_clear_error(capsys, monkeypatch):
    import pyvisa

    def no_library(*args, **kwargs):
        raise ValueError("Could not locate a VISA implementation.")

    monkeypatch.setattr(pyvisa, "ResourceManager", no_library)
    assert main(["instruments", "identify", "GPIB0::12::INSTR"]) == 2
    err = capsys.readouterr().err
    assert "no VISA library" in err and "GPIB0::12::INSTR" in err and len(err.strip().splitlines()) == 1


def test_identify_through_the_pair_registry(capsys):
    assert main(["instruments", "identify", "--sim", "--pair", "k6221_2182a"]) == 0
    assert "MODEL 6221" in capsys.readouterr().out
    assert main(["instruments", "identify", "--sim", "--pair", "four_wire_smu"]) == 2
    err = capsys.readouterr().err
    assert (
        "[instrument] pair = 'four_wire_smu'" in err and "'k6221_2182a'" in err and len(err.strip().splitlines()) == 1
    )
