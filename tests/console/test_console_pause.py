"""The bench's pause from the console (issue 29): Pause with a reason, taken at the next block boundary — the source
idle (the last command of the recorded SCPI log is ``SOUR:SWE:ABOR`` and nothing is sent while paused) —, the pause
record (reason, who, UTC time with its offset) in the session file while it waits, and Resume from the same page
going on with the next block to the end; replay reproduces the session. Bad requests are refused in one line."""

from __future__ import annotations

import re
import time
from pathlib import Path
from typing import Any

from tests.console.conftest import Client
from tests.console.test_console_protocol import _loaded, _wait_prompt

OFFSET = re.compile(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d+)?[+-]\d\d:\d\d$")


def _wait_state(client: Client, run: str, predicate, timeout: float = 60) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        s = client.get(f"/api/runs/{run}").json()
        if predicate(s):
            return dict(s)
        time.sleep(0.02)
    raise AssertionError(f"run {run}: state not reached: {s}")


def test_pause_with_a_reason_is_recorded_and_resume_goes_on(client: Client, folder: Path):
    from daq.pause import pauses_of
    from daq.replay import replay_session

    run = client.start("paused.h5")
    first = _wait_prompt(client, run)
    client.post(f"/api/runs/{run}/answer", {"prompt": first["prompt"]["id"], "decision": "go"})
    second = _wait_prompt(client, run, not_id=first["prompt"]["id"])  # both blocks of 5.44 kg are on file
    r = client.post(f"/api/runs/{run}/pause", {"reason": "re-seat the piston: lubricant on the liner", "who": "ann"})
    assert r.status_code == 200, r.text
    assert client.get(f"/api/runs/{run}").json()["pause_request"]["reason"].startswith("re-seat")
    client.post(f"/api/runs/{run}/answer", {"prompt": second["prompt"]["id"], "decision": "go"})
    paused = _wait_state(client, run, lambda s: s["phase"] == "paused")
    assert paused["pause_request"] is None and paused["pauses"][0]["reason"].startswith("re-seat")
    path = folder / "paused.h5"
    on_file = _loaded(path)
    assert on_file is not None and not on_file.complete and len(on_file.summary) == 2
    [p] = pauses_of(on_file.runs)
    assert (p["reason"], p["who"], p["after_block"]) == ("re-seat the piston: lubricant on the liner", "ann", 2)
    assert OFFSET.match(p["paused"]) and "resumed" not in p
    assert on_file.exchanges["message"].iloc[-1] == "SOUR:SWE:ABOR"  # the source left idle
    n = len(on_file.exchanges)
    time.sleep(0.5)  # paused: the child sends nothing, takes no block
    again = _loaded(path)
    assert again is not None and len(again.exchanges) == n and len(again.summary) == 2
    assert client.get(f"/api/runs/{run}").json()["phase"] == "paused"
    assert client.post(f"/api/runs/{run}/pause", {"reason": "twice", "who": "ann"}).status_code == 409
    assert client.post(f"/api/runs/{run}/resume", {"who": "bob"}).status_code == 200
    end = client.drive(run)
    assert end["stop"]["status"] == "success" and end["pauses"][0]["resumed_by"] == "bob"
    done = _loaded(path)
    assert done is not None and done.sealed and len(done.summary) == 6
    [p] = pauses_of(done.runs)
    assert p["resumed_by"] == "bob" and OFFSET.match(p["resumed"])
    third = done.exchanges[done.exchanges["block"] == 2]["message"].tolist()
    assert any(m.startswith("SOUR:DELT:ARM") for m in third)  # the next block armed the source again
    assert replay_session(path).identical


def test_bad_pause_requests(client: Client, folder: Path):
    run = client.start("bad.h5")
    _wait_prompt(client, run)
    for body, says in (({"who": "ann"}, "reason"), ({"reason": " ", "who": "ann"}, "reason"),
                       ({"reason": "x"}, "who"), ({"reason": "a\nb", "who": "ann"}, "one line")):  # fmt: skip
        r = client.post(f"/api/runs/{run}/pause", body)
        assert r.status_code in (400, 409) and says in r.json()["error"], (body, r.text)
    assert client.post(f"/api/runs/{run}/resume", {"who": "ann"}).status_code == 409  # not paused
    assert client.post("/api/runs/nope/pause", {"reason": "x", "who": "y"}).status_code == 404
    client.post(f"/api/runs/{run}/stop", {"client": "tester"})
    client.drive(run)
    r = client.post(f"/api/runs/{run}/pause", {"reason": "x", "who": "ann"})
    assert r.status_code == 409 and "ended" in r.json()["error"]


def test_stop_while_paused_ends_the_session_with_the_source_idle(client: Client, folder: Path):
    from daq.pause import pauses_of

    run = client.start("stopped.h5")
    first = _wait_prompt(client, run)
    client.post(f"/api/runs/{run}/answer", {"prompt": first["prompt"]["id"], "decision": "go"})
    second = _wait_prompt(client, run, not_id=first["prompt"]["id"])
    assert client.post(f"/api/runs/{run}/pause", {"reason": "end of shift", "who": "ann"}).status_code == 200
    client.post(f"/api/runs/{run}/answer", {"prompt": second["prompt"]["id"], "decision": "go"})
    _wait_state(client, run, lambda s: s["phase"] == "paused")
    assert client.post(f"/api/runs/{run}/stop", {"client": "tester"}).status_code == 200
    end = _wait_state(client, run, lambda s: s["phase"] == "ended")
    assert end["stop"]["status"] == "aborted"
    s = _loaded(folder / "stopped.h5")
    assert s is not None and s.sealed and s.status == "aborted" and len(s.summary) == 2
    assert s.exchanges["message"].iloc[-1] == "SOUR:SWE:ABOR"
    [p] = pauses_of(s.runs)
    assert p["reason"] == "end of shift" and "resumed" not in p
