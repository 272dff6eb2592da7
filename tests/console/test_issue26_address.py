"""The console's address field on the simulated bench (issue 26 item 7): any valid VISA resource name is rehearsed
there as acquire --sim --address does (the same daq.overrides validation), an invalid one is refused naming
--address."""

from __future__ import annotations

import pytest

from tests.console.conftest import Client


def test_the_plan_preview_takes_any_valid_visa_address_and_refuses_others(client: Client):
    for address in ("ASRL/dev/ttyUSB0::INSTR", "TCPIP0::192.168.0.50::1394::SOCKET", "USB0::0x05E6::0x6221::1::INSTR"):
        r = client.post("/api/plan", {"scene": "small.toml", "sim": True, "overrides": {"instrument.address": address}})
        assert r.status_code == 200 and r.json()["address"] == address
    r = client.post("/api/plan", {"scene": "small.toml", "sim": True,
                                  "overrides": {"instrument.address": "GPIB0::abc::INSTR"}})  # fmt: skip
    assert r.status_code == 400 and r.json()["error"].startswith("--address = 'GPIB0::abc::INSTR' is not allowed")


@pytest.mark.slow
def test_a_console_session_runs_at_a_serial_port_path_on_the_simulated_bench(client: Client, folder):
    from daq.session_file import load_session

    run = client.start("serial.h5", overrides={"instrument.address": "ASRL/dev/ttyUSB0::INSTR"})
    assert client.drive(run)["stop"]["status"] == "success"
    assert load_session(folder / "serial.h5").start["instrument"]["address"] == "ASRL/dev/ttyUSB0::INSTR"
