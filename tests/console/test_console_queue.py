"""The bench's queue (issue 29): planned sessions started one after the other on their bench address, reordered,
cancelled, waiting for the operator's Start, kept across a console restart; a refused start stops that bench's
queue with the reason."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from tests.console.conftest import Client


def plan(client: Client, output: str, wait: bool = False, **extra: Any) -> Any:
    return client.post("/api/queue", {"scene": "small.toml", "sim": True, "sim_speed": "inf", "output": output,
                                      "wait": wait, "client": "tester", **extra})  # fmt: skip


def started(client: Client, n: int, timeout: float = 60) -> list[dict[str, Any]]:
    deadline = time.monotonic() + timeout
    while len(s := client.get("/api/queue").json()["started"]) < n:
        assert time.monotonic() < deadline, s
        time.sleep(0.05)
    return list(s)


def test_queued_sessions_start_one_after_the_other(client: Client, folder: Path):
    from daq.session_file import load_session

    assert plan(client, "q1.h5").status_code == 200
    assert plan(client, "q2.h5").status_code == 200
    [first] = started(client, 1)
    assert first["file"] == "q1.h5"
    time.sleep(0.5)  # q1 waits for its operator at the first weight: q2 (the same bench) does not start
    assert len(client.get("/api/queue").json()["started"]) == 1 and not (folder / "q2.h5").exists()
    assert client.drive(first["run"])["stop"]["status"] == "success"
    second = started(client, 2)[1]
    assert second["file"] == "q2.h5" and client.get("/api/queue").json()["items"] == []
    assert client.drive(second["run"])["stop"]["status"] == "success"
    for name in ("q1.h5", "q2.h5"):
        s = load_session(folder / name)
        assert s.sealed and s.status == "success"


def test_reorder_cancel_start_and_a_restart(folder: Path):
    """Items that wait for the operator's Start: reordered and cancelled; the queue's file is rewritten at each
    change and read back by the next console; Start starts the first."""
    client = Client(folder)
    try:
        ids = [plan(client, f"w{k}.h5", wait=True, overrides={"session.sample": f"S-{k}"}).json()["id"]
               for k in range(3)]  # fmt: skip
        time.sleep(0.5)
        assert client.get("/api/queue").json()["started"] == [] and not list(folder.glob("w*.h5"))
        assert client.post(f"/api/queue/{ids[2]}/move", {"to": 0}).status_code == 200
        assert client.post(f"/api/queue/{ids[1]}/cancel", {}).status_code == 200
        order = [i["form"]["output"] for i in client.get("/api/queue").json()["items"]]
        assert order == ["w2.h5", "w0.h5"]
        on_file = json.loads((folder / ".contactrig-console-queue.json").read_text())
        assert [i["form"]["output"] for i in on_file["items"]] == order
    finally:
        client.close()
    again = Client(folder, port=8766)
    try:
        items = again.get("/api/queue").json()["items"]
        assert [i["form"]["output"] for i in items] == order and items[0]["form"]["overrides"] == {
            "session.sample": "S-2"
        }
        assert again.post(f"/api/queue/{ids[2]}/start", {}).status_code == 200
        [run] = started(again, 1)
        assert run["file"] == "w2.h5" and again.drive(run["run"])["stop"]["status"] == "success"
        time.sleep(0.5)  # w0 still waits for its Start
        assert [i["form"]["output"] for i in again.get("/api/queue").json()["items"]] == ["w0.h5"]
    finally:
        again.close()


def test_a_refused_start_stops_that_bench(client: Client, folder: Path):
    assert plan(client, "r1.h5").status_code == 200
    [first] = started(client, 1)
    assert plan(client, "r2.h5").status_code == 200
    assert plan(client, "r3.h5").status_code == 200
    (folder / "r2.h5").write_bytes(b"written meanwhile by someone else")
    client.drive(first["run"])
    deadline = time.monotonic() + 30
    while not (items := client.get("/api/queue").json()["items"])[0]["error"]:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    assert "r2.h5 exists" in items[0]["error"] and [i["form"]["output"] for i in items] == ["r2.h5", "r3.h5"]
    time.sleep(0.5)
    assert not (folder / "r3.h5").exists()  # nothing behind it starts until the operator decides
    assert (folder / "r2.h5").read_bytes() == b"written meanwhile by someone else"
    assert client.post(f"/api/queue/{items[0]['id']}/cancel", {}).status_code == 200
    [_, third] = started(client, 2)
    assert third["file"] == "r3.h5" and client.drive(third["run"])["stop"]["status"] == "success"


def test_bad_queue_requests(client: Client, folder: Path):
    (folder / "taken.h5").write_bytes(b"x")
    for body, needle in (({"output": "../x.h5"}, "file name"), ({"output": "taken.h5"}, "exists"),
                         ({"output": "x.h5", "scene": "../etc/passwd"}, "scene"),
                         ({"output": "x.h5", "overrides": {"session.nope": "1"}}, "overrides")):  # fmt: skip
        r = plan(client, wait=True, **body)
        assert r.status_code == 400 and needle in r.json()["error"] and "\n" not in r.json()["error"], (body, r.text)
    item = plan(client, "ok.h5", wait=True).json()["id"]
    assert plan(client, "ok.h5", wait=True).status_code == 409  # queued already
    for url, body in ((f"/api/queue/{item}/move", {"to": 5}), (f"/api/queue/{item}/move", {"to": "0"}),
                      ("/api/queue/nope/cancel", {})):  # fmt: skip
        r = client.post(url, body)
        assert r.status_code == 409 and "\n" not in r.json()["error"], (url, body, r.text)
    assert client.post(f"/api/queue/{item}/cancel", {}, headers={"origin": "http://evil.example"}).status_code == 403
    assert client.http.post(f"/api/queue/{item}/cancel", json={}).status_code == 403  # no token
    assert len(client.get("/api/queue").json()["items"]) == 1


def test_an_unreadable_queue_file_is_left_as_it_is(folder: Path):
    damaged = b'{"version": 1, "items": [{"id": 3}'
    (folder / ".contactrig-console-queue.json").write_bytes(damaged)
    client = Client(folder)
    try:
        q = client.get("/api/queue").json()
        assert q["items"] == [] and "cannot be read" in q["broken"]
        r = plan(client, "x.h5", wait=True)
        assert r.status_code == 409 and "cannot be read" in r.json()["error"]
        assert (folder / ".contactrig-console-queue.json").read_bytes() == damaged
    finally:
        client.close()
