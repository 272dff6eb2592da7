"""The simulated bench as a user types it (issue 26 items 7 and 8): it answers at any valid VISA resource name the
operator's bench will use (never contacting anything), and a resumed simulated session draws fresh noise per run
(recorded), while replay stays identical."""

from __future__ import annotations

import socket

import numpy as np
import pytest

from analysis.simulated_session import SimulatedRigBench, run_noise_seed
from contactrig.cli.main import main
from contactrig.core.validation import SettingError
from daq.acquire import acquire
from daq.overrides import visa_resource
from daq.replay import replay_session
from daq.session_file import load_session

from .conftest import small_sim_scene

#: Resource names as VISA writes them (NI-VISA / IVI VISA spec, "Resource names"), for the interfaces a 6221 bench
#: is reached by: GPIB, RS-232 by number and by device path, LAN socket and VXI-11, a USB-TMC adapter.
ADDRESSES = [
    "GPIB0::12::INSTR",
    "GPIB1::7::INSTR",
    "ASRL3::INSTR",
    "ASRL/dev/ttyUSB0::INSTR",
    "TCPIP0::192.168.0.50::1394::SOCKET",
    "TCPIP0::192.168.0.50::inst0::INSTR",
    "USB0::0x05E6::0x6221::1234567::INSTR",
]


@pytest.fixture
def no_network(monkeypatch):
    """Any attempt to open a socket fails the test: the simulated bench contacts nothing."""

    def refuse(*a, **k):
        raise AssertionError("the simulated bench tried to open a network socket")

    monkeypatch.setattr(socket.socket, "connect", refuse)
    monkeypatch.setattr(socket, "create_connection", refuse)


@pytest.mark.parametrize("address", ADDRESSES)
def test_the_simulated_bench_answers_at_any_valid_visa_address(tmp_path, address, no_network):
    scene = small_sim_scene(tmp_path, count=8, repeats=1)
    out = tmp_path / "s.h5"
    code = main(["acquire", str(scene), "--sim", "--yes", "--sim-speed", "inf", "--quiet", "--address", address,
                 "-o", str(out)])  # fmt: skip
    assert code == 0
    s = load_session(out)
    assert s.complete and s.start["instrument"]["address"] == address
    assert s.start["instrument"]["source"].startswith("KEITHLEY INSTRUMENTS INC.,MODEL 6221")
    if address.startswith("ASRL"):  # the scene's RS-232 parameters, as the real run will use them
        assert s.start["instrument"]["serial"]["baud_rate"] == 19200
    assert replay_session(out).identical


@pytest.mark.parametrize(
    "bad",
    ["nope::x", "GPIB0::abc::INSTR", "GPIB0::31::INSTR", "TCPIP0::192.168.0.50::SOCKET",
     "TCPIP0::192.168.0.50::70000::SOCKET", "GPIB0::12::INSTR::extra"],
)  # fmt: skip
def test_an_invalid_address_is_refused_naming_the_option(tmp_path, bad, capsys):
    with pytest.raises(SettingError, match=r"^--address = .* is not allowed: a VISA resource name"):
        visa_resource(bad)
    out = tmp_path / "s.h5"
    code = main(["acquire", "--sim", "--yes", "--sim-speed", "inf", "--address", bad, "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("contactrig acquire: error: --address = ")
    assert list(tmp_path.iterdir()) == []  # no file, no temporary file


def test_the_serial_terminator_of_the_scene_is_the_simulated_ports(tmp_path):
    text = small_sim_scene(tmp_path, count=8, repeats=1).read_text()
    scene = tmp_path / "cr.toml"
    scene.write_text(text.replace("[instrument]\n", '[instrument]\nterminator = "CR"\n', 1))
    out = tmp_path / "s.h5"
    code = main(["acquire", str(scene), "--sim", "--yes", "--sim-speed", "inf", "--quiet", "--address",
                 "ASRL/dev/ttyUSB0::INSTR", "-o", str(out)])  # fmt: skip
    assert code == 0 and load_session(out).start["instrument"]["serial"]["terminator"] == "CR"


def _blocks(session):
    r = session.readings
    return {int(b): r.loc[r["block"] == b, "reading"].to_numpy() for b in np.unique(r["block"])}


def test_a_resumed_simulated_session_draws_new_noise_and_replays_identically(tmp_path):
    """Run 1 stops after the first weight (2 blocks), run 2 measures the rest. The first block of run 2 was, before
    the fix, the first block of run 1 again (correlation 1.000000). Now each run's noise seed is the run-th child of
    SeedSequence(sim_seed) (checked against numpy's own spawn), recorded, and the readings of run 2's first block are
    uncorrelated with run 1's (|r| < 0.5: 64 readings, 5 standard deviations of r under independence)."""
    scene = small_sim_scene(tmp_path, count=64, repeats=2)
    path = tmp_path / "s.h5"
    answers = iter(["go", "quit"])
    first = acquire(scene, path, bench=SimulatedRigBench(float("inf")), prompter=lambda step: next(answers),
                    quiet=True)  # fmt: skip
    assert first.status == "aborted" and first.blocks_done == 2
    acquire(None, path, resume=True, yes=True, bench=SimulatedRigBench(float("inf")), quiet=True)
    s = load_session(path)
    assert s.complete and len(s.runs) == 2
    seed = s.runs[0]["simulation"]["seed"]
    for k, run in enumerate(s.runs):
        child = np.random.SeedSequence(seed).spawn(2)[k]  # numpy's own derivation of the k-th independent stream
        assert run["simulation"]["run"] == k
        assert run["simulation"]["noise_seed"] == int(child.generate_state(1)[0]) == run_noise_seed(seed, k)
    assert s.runs[0]["simulation"]["noise_seed"] != s.runs[1]["simulation"]["noise_seed"]
    blocks = _blocks(s)
    run2_first = min(int(b) for b in s.summary["block"][s.summary["run"] == 1])
    a = blocks[0] - blocks[0].mean()
    b = blocks[run2_first] - blocks[run2_first].mean()
    r = float(a @ b / np.sqrt((a @ a) * (b @ b)))
    assert abs(r) < 0.5, r
    assert replay_session(path).identical


def test_acquire_takes_quiet_as_the_option_vocabulary_says(tmp_path, capsys):
    """Issue 26 item 13: --quiet (OPTION_VOCABULARY: "no progress bar on stderr") is accepted; the plan, block lines
    and notes are left out, the final line stays."""
    from contactrig.cli.options import OPTION_VOCABULARY

    assert OPTION_VOCABULARY["--quiet"][0] == "flag"
    scene = small_sim_scene(tmp_path, count=8, repeats=1)
    args = ["acquire", str(scene), "--sim", "--yes", "--sim-speed", "inf"]
    assert main([*args, "-o", str(tmp_path / "loud.h5")]) == 0
    loud = capsys.readouterr().err.splitlines()
    assert main([*args, "--quiet", "-o", str(tmp_path / "quiet.h5")]) == 0
    quiet = capsys.readouterr().err.splitlines()
    assert any(line.startswith("plan: ") for line in loud) and len(loud) > 3
    assert len(quiet) == 1 and quiet[0].endswith("success, 3 of 3 blocks — all 3 planned blocks done")
