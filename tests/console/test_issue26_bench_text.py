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


def test_form_text_that_is_not_unicode_is_refused_naming_the_option(client: Client, folder):
    """JSON may carry a lone surrogate ("\\udcd8"): the form's sample is refused as acquire --sample refuses it."""
    body = '{"scene": "small.toml", "sim": true, "overrides": {"session.sample": "Kolben-\\udcd8"}}'
    r = client.http.post("/api/plan", content=body.encode(), headers={**client.headers,
                                                                       "content-type": "application/json"})  # fmt: skip
    assert r.status_code == 400 and r.json()["error"].startswith("--sample = 'Kolben-\\udcd8' is not allowed: text")


def test_the_sessions_index_lists_a_file_with_bad_text_and_answers(client: Client, folder, monkeypatch):
    """One session holding a lone surrogate (as an older contactrig stored it) and one file whose name is not UTF-8:
    the index answers (no HTTP 500) and lists both, their text shown with visible escapes."""
    import os

    from tests.daq.test_issue26_text import _older_session

    _older_session(folder / "old.h5", monkeypatch, sample="Kolben-\udcd8")
    _older_session(folder / os.fsdecode(b"name-\xff.h5"), monkeypatch)
    from tests.console.test_console_index import indexed

    rows = {row["path"]: row for row in indexed(client)["sessions"]}  # indexed() checks the status (200)
    assert rows["old.h5"]["sample"] == "Kolben-\\xd8"
    assert "file name is not UTF-8" in rows["name-\\xff.h5"]["note"]
