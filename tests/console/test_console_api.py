"""The console's server without a browser: its guards, its files policy, and sessions run through it.

A session run from the console must be the session ``acquire`` writes: the same block checksums as one run
without the console (the simulated bench is seeded), sealed, with the stop record of a Ctrl-C when stopped.
"""

from __future__ import annotations

import os
import stat
import time
from pathlib import Path

import pytest

from tests.console.conftest import HOSTILE, Client, scene_text


def test_every_request_needs_the_token(client: Client):
    http = client.http
    for url in ("/", "/api/sessions", "/static/app.js", "/files/small.toml", "/api/runs"):
        assert http.get(url).status_code == 403, url
        assert http.get(url, headers={"x-contactrig-token": "wrong"}).status_code == 403, url
        assert http.get(url, headers={"x-contactrig-token": client.console.token[:-1]}).status_code == 403, url
    assert http.post("/api/runs", json={}).status_code == 403
    assert client.get("/").status_code == 200


def test_token_in_the_url_becomes_a_cookie_and_leaves_the_url(client: Client):
    r = client.http.get(f"/?token={client.console.token}", follow_redirects=False)
    assert r.status_code == 303 and r.headers["location"] == "/"
    cookie = r.headers["set-cookie"]
    assert "HttpOnly" in cookie and "SameSite=strict" in cookie.replace("Strict", "strict")
    name = client.console.cookie  # one per port (two consoles on one machine keep their own)
    assert client.http.get("/", headers={"cookie": f"{name}={client.console.token}"}).status_code == 200
    client.http.cookies.clear()
    assert client.http.get("/?token=nope", follow_redirects=False).status_code == 403
    assert client.http.get("/", headers={"cookie": f"{name}=nope"}).status_code == 403


def test_foreign_host_and_foreign_origin_are_refused(client: Client):
    assert client.get("/", headers={"host": "evil.example:8765"}).status_code == 403  # DNS rebinding
    body = {"scene": "small.toml", "sim": True}
    assert client.post("/api/plan", body, headers={"origin": "http://evil.example"}).status_code == 403
    assert client.post("/api/plan", body, headers={"origin": "null"}).status_code == 403
    headers = {"x-contactrig-token": client.console.token}  # no Origin at all
    assert client.http.post("/api/plan", json=body, headers=headers).status_code == 403
    assert client.post("/api/plan", body).status_code == 200


def test_pages_forbid_inline_script(client: Client):
    r = client.get("/")
    csp = r.headers["content-security-policy"]
    assert "script-src 'self'" in csp and "unsafe-inline" not in csp.split("script-src", 1)[1].split(";")[0]
    assert r.headers["x-content-type-options"] == "nosniff"
    assert "<script>" not in r.text.replace('<script src="/static/app.js" defer></script>', "")


def test_only_regular_files_under_the_folder_are_served(client: Client, folder: Path, tmp_path: Path):
    (folder / "report").mkdir()
    (folder / "report" / "report.html").write_text("<p>report</p>", encoding="utf-8")
    secret = tmp_path / "secret.txt"
    secret.write_text("secret", encoding="utf-8")
    os.symlink(secret, folder / "out.html")
    os.symlink(folder / "report", folder / "inside")
    (folder / ".hidden.html").write_text("x", encoding="utf-8")
    ok = client.get("/files/report/report.html")
    assert ok.status_code == 200 and ok.text == "<p>report</p>"
    assert ok.headers["content-security-policy"].startswith("sandbox")  # no script runs in a served file
    for bad in ("../secret.txt", "report/../../secret.txt", "%2E%2E/secret.txt", str(secret), "/" + str(secret),
                "out.html", "inside/report.html", ".hidden.html", "report", "nothing.html", "report%00.html",
                "..%2Fsecret.txt"):  # fmt: skip
        r = client.get(f"/files/{bad}")
        assert r.status_code == 404, bad
        assert "secret" not in r.text


def test_the_token_is_stored_private(tmp_path: Path):
    from contactrig.console.security import check_token, new_token, store_token

    token = new_token()
    path = store_token(token, tmp_path / "state")
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert path.read_text().strip() == token
    assert check_token(token, token) and not check_token("", token) and not check_token(None, token)


def test_sessions_index_is_the_shared_index(client: Client, folder: Path):
    """The page's rows are ``daq.run_index.query``'s (see test_console_index.py); a hostile sample comes back as the
    same string (JSON escapes it; the page puts it in the DOM as text, see the browser tests)."""
    from daq.run_index import query
    from tests.console.test_console_index import indexed

    hostile = "".join(HOSTILE.values()) + "x" * 100_000
    (folder / "hostile.toml").write_text(scene_text(sample=hostile, weights="[5.44]", repeats=1), encoding="utf-8")
    run = client.start("hostile.h5", scene="hostile.toml")
    assert client.drive(run)["stop"]["status"] == "success"
    # CI of 27 Nov 2026 (two cores at load 5): the first refresh after the run ended listed nothing. The cause: the
    # answer read `indexing` after its rows, so rows read while a refresh ran were claimed for after it (fixed and
    # tested in test_console_index.py). Up to three refreshes stay; if none lists the session, the message gives
    # each refresh's rows and notes.
    seen = []
    for _ in range(3):
        page = indexed(client)
        rows = page["sessions"]
        seen.append((len(rows), page["notes"]))
        if rows:
            break
    assert rows, f"the session never came into the index: {seen}"
    expected, _ = query(folder, refresh=False, descending=True)
    assert [r["path"] for r in rows] == [Path(e["path"]).relative_to(folder).as_posix() for e in expected]
    assert rows[0]["sample"] == hostile


@pytest.mark.slow
def test_console_session_equals_a_session_without_it(client: Client, folder: Path, tmp_path: Path):
    """Same scene, same seed: the console's file and acquire's own have the same block checksums; both sealed."""
    from analysis.simulated_session import SimulatedRigBench
    from daq.acquire import acquire
    from daq.session_file import load_session

    run = client.start("console.h5")
    state = client.drive(run)
    assert state["stop"]["status"] == "success" and len(state["blocks"]) == 6
    plain = tmp_path / "plain.h5"
    acquire(folder / "small.toml", plain, bench=SimulatedRigBench(float("inf")), yes=True, quiet=True)
    a, b = load_session(folder / "console.h5"), load_session(plain)
    assert a.sealed and b.sealed and a.status == b.status == "success"
    assert list(a.summary["sha256"]) == list(b.summary["sha256"])


@pytest.mark.slow
def test_stop_after_block_then_resume(client: Client, folder: Path):
    """Stop after this block = one SIGINT to acquire (as Ctrl-C): stop record written, blocks kept; the sessions
    page offers resume, which completes the file."""
    from daq.session_file import load_session

    (folder / "slow.toml").write_text(scene_text(count=60, repeats=3), encoding="utf-8")
    run = client.start("stopped.h5", scene="slow.toml", speed="20")  # a block takes ≈ 0.1 s
    stopped = {"done": False}

    def decide(s):
        if s["prompt"]["event"] == "prompt" and not stopped["done"]:
            client.post(f"/api/runs/{run}/answer", {"decision": "go", "prompt": s["prompt"]["id"]})
            deadline = time.monotonic() + 30
            while not client.get(f"/api/runs/{run}").json()["blocks"] and time.monotonic() < deadline:
                time.sleep(0.01)
            stopped["done"] = True
            assert client.post(f"/api/runs/{run}/stop", {"client": "tester"}).json()["stop_requests"] == 1
            return {}
        return None

    state = client.drive(run, decide)
    stop = state["stop"]
    assert stop["status"] == "aborted" and "stopped after the block" in stop["reason"], stop
    assert 1 <= stop["blocks_done"] < 9
    with pytest.warns(Warning, match="aborted"):
        s = load_session(folder / "stopped.h5")
    assert s.status == "aborted" and len(s.summary) == stop["blocks_done"]
    again = client.post("/api/runs", {"resume": True, "output": "stopped.h5", "sim": True, "sim_speed": "inf",
                                      "client": "tester"}).json()  # fmt: skip
    final = client.drive(again["id"])
    assert final["stop"] is not None and final["stop"]["status"] == "success", (final["end"], final["lines"][-5:])
    done = load_session(folder / "stopped.h5")
    assert done.status == "success" and done.sealed and len(done.summary) == 9


@pytest.mark.slow
def test_one_session_per_bench_and_a_foreign_stop_asks_first(client: Client, folder: Path):
    from daq.session_file import load_session

    run = client.start("first.h5")
    deadline = time.monotonic() + 60
    while client.get(f"/api/runs/{run}").json()["prompt"] is None and time.monotonic() < deadline:
        time.sleep(0.02)
    second = client.post("/api/runs", {"scene": "small.toml", "sim": True, "output": "second.h5", "client": "other"})
    assert second.status_code == 409 and "running on" in second.json()["error"]
    assert not (folder / "second.h5").exists()
    foreign = client.post(f"/api/runs/{run}/stop", {"client": "other"})
    assert foreign.status_code == 409 and "confirm" in foreign.json()
    assert client.get(f"/api/runs/{run}").json()["stop_requests"] == 0
    assert client.post(f"/api/runs/{run}/stop", {"client": "other", "confirm": True}).status_code == 200
    state = client.drive(run)
    assert state["stop"]["status"] == "aborted"  # stopped at the prompt: nothing measured, the stop record written
    with pytest.warns(Warning, match="aborted"):
        assert load_session(folder / "first.h5").status == "aborted"


def test_bad_form_values_are_one_line_errors(client: Client, folder: Path):
    for body, needle in (
        ({"output": "../x.h5"}, "file name"),
        ({"output": "x.txt"}, "file name"),
        ({"output": "small.toml"}, "file name"),
        ({"output": "x.h5", "scene": "../etc/passwd"}, "scene"),
        ({"output": "x.h5", "sim_speed": "-1", "sim": True}, "sim_speed"),
        ({"resume": True, "output": "/etc/passwd"}, "resume"),
        ({"output": "x.h5", "sim": True, "overrides": {"instrument.visa_library": "@py"}}, "--visa-library"),
        ({"output": "x.h5", "overrides": {"session.sim_seed": "3"}}, "--sim-seed"),
        ({"output": "x.h5", "sim": True, "overrides": {"instrument.address": "nonsense"}}, "--address"),
        ({"output": "x.h5", "overrides": {"session.nope": "x"}}, "overrides"),
    ):
        r = client.post("/api/runs", body)
        assert r.status_code == 400 and needle in r.json()["error"], (body, r.text)
        assert "\n" not in r.json()["error"]
    assert not list(folder.glob("*.h5"))


@pytest.mark.slow
def test_stop_now_discards_the_block_under_way(client: Client, folder: Path):
    """Stop now = the second Ctrl-C: the block under way is discarded, every completed one kept, the source idle
    (the driver's close on every path) and the stop record written."""
    from daq.session_file import load_session

    (folder / "long.toml").write_text(scene_text(count=200, repeats=3), encoding="utf-8")
    run = client.start("now.h5", scene="long.toml", speed="5")  # a block takes ≈ 1 s

    def decide(s):
        if s["stop_requests"] == 0:
            client.post(f"/api/runs/{run}/answer", {"decision": "go", "prompt": s["prompt"]["id"]})
            time.sleep(0.3)  # inside the first block
            assert client.post(f"/api/runs/{run}/stop", {"client": "tester", "now": True}).json()["stop_requests"] == 2
            return {}
        return None

    stop = client.drive(run, decide)["stop"]
    assert stop["status"] == "aborted" and "Ctrl-C twice" in stop["reason"] and "discarded" in stop["reason"], stop
    with pytest.warns(Warning):
        s = load_session(folder / "now.h5")
    assert s.status == "aborted" and len(s.summary) == stop["blocks_done"] == 0


@pytest.mark.slow
def test_skip_is_recorded_as_at_the_terminal(client: Client, folder: Path):
    run = client.start("skipped.h5")

    def decide(s):
        return {"decision": "skip"} if s["prompt"].get("weight_kg") == 10.526 else None

    stop = client.drive(run, decide)["stop"]
    assert stop["status"] == "success" and stop["weights_skipped"] == [10.526], stop
    assert "skipped by the operator: 10.526 kg" in stop["reason"]
    run = client.start("full.h5")
    client.drive(run)
    past = client.get("/api/overlay", params={"sample": "AL-SI piston in cast-iron liner, dry", "leave_out": "full.h5"})
    [only] = past.json()["sessions"]
    assert only["path"] == "skipped.h5" and [p["weight_kg"] for p in only["points"]] == [5.44, 25.966]


def test_console_command_errors_are_one_line(folder: Path, tmp_path: Path):
    from contactrig.cli.main import main

    assert main(["console", str(tmp_path / "missing"), "--no-browser"]) == 2
    assert main(["console", str(folder), "--port", "70000", "--no-browser"]) == 2


@pytest.mark.slow
def test_real_bench_path_over_loopback_lan(client: Client, folder: Path):
    """Not simulated: the form's real bench (VisaBench) with this run's address and VISA library (@py) set in the
    form over the scene (daq.overrides), a LAN address served by the simulated instruments' socket server on
    loopback — the path a lab PC takes to a 6221 on the network."""
    pytest.importorskip("pyvisa_py")
    from daq.session_file import load_session
    from instruments.server import SimServer
    from instruments.simulated import SimulatedBench

    with SimServer(port=0, bench=SimulatedBench(resistance_ohm=5e-3, seed=1, time_scale=0.0)) as server:
        address = server.address  # the scene's address stays GPIB0::12::INSTR: the form's override replaces it
        (folder / "lan.toml").write_text(scene_text(weights="[5.44]"), encoding="utf-8")
        overrides = {"instrument.address": address, "instrument.visa_library": "@py"}
        r = client.post("/api/runs", {"scene": "lan.toml", "sim": False, "overrides": overrides, "output": "lan.h5",
                                      "client": "tester"})  # fmt: skip
        assert r.status_code == 200, r.text
        state = client.drive(r.json()["id"])
    assert state["stop"]["status"] == "success", state
    s = load_session(folder / "lan.h5")
    assert s.sealed and not s.start["sim"] and s.start["instrument"]["address"] == address
    assert s.summary["mean_ohm"].to_numpy() == pytest.approx(5e-3, rel=1e-2)
    assert s.start["overrides"] == overrides and "GPIB0::12::INSTR" in s.scene_text  # the scene text unchanged


@pytest.mark.slow
def test_exports_sorting_and_filtering(client: Client, folder: Path):
    """Export CSV and xlsx (``contactrig export`` itself) beside the session, served back from DIR; the index
    sorts and filters as ``contactrig sessions --sort/--where`` does."""
    (folder / "other.toml").write_text(scene_text(weights="[5.44]", repeats=1, sample="B sample"), encoding="utf-8")
    for name, scene in (("one.h5", "small.toml"), ("two.h5", "other.toml")):
        assert client.drive(client.start(name, scene=scene))["stop"]["status"] == "success"
    for to in ("csv", "xlsx"):
        r = client.post("/api/session/export", {"path": "one.h5", "to": to}).json()
        assert r["code"] == 0 and r["written"], r
        assert all((folder / w).is_file() for w in r["written"])
        for link in r["links"]:
            assert client.get(link).status_code == 200
    assert client.post("/api/session/export", {"path": "../one.h5"}).status_code == 400
    from tests.console.test_console_index import indexed

    by_sample = [r["path"] for r in indexed(client, sort="sample", order="asc")["sessions"]]
    assert by_sample == ["one.h5", "two.h5"]  # "Al-Si …" before "B sample"
    only = indexed(client, where="sample~b SAM")["sessions"]
    assert [r["path"] for r in only] == ["two.h5"]


@pytest.mark.slow
def test_overrides_from_the_form_are_the_runs(client: Client, folder: Path):
    """Sample, operator and notes set in the form (hostile text included) are this run's, recorded as acquire
    --sample/--operator/--notes record them (the scene text unchanged); the plan preview uses them."""
    from daq.session_file import load_session

    given = {"session.sample": "S-42 " + HOSTILE["script"], "session.operator": HOSTILE["attr"],
             "session.notes": HOSTILE["ansi"] + " run 3"}  # fmt: skip
    form = client.get("/api/overrides").json()["overrides"]
    assert {"instrument.address", "instrument.visa_library", "session.sample", "session.operator",
            "session.notes"} <= {o["key"] for o in form}  # fmt: skip
    preview = client.post("/api/plan", {"scene": "small.toml", "sim": True,
                                        "overrides": {"instrument.address": "GPIB0::7::INSTR"}}).json()  # fmt: skip
    assert preview["address"] == "GPIB0::7::INSTR"
    run = client.start("over.h5", overrides=given)
    assert client.drive(run)["stop"]["status"] == "success"
    s = load_session(folder / "over.h5")
    assert s.start["sample"] == given["session.sample"] and s.start["operator"] == given["session.operator"]
    assert s.start["overrides"] == given and "S-42" not in s.scene_text
    from tests.console.test_console_index import indexed

    row = next(r for r in indexed(client)["sessions"] if r["path"] == "over.h5")
    assert row["sample"] == given["session.sample"] and row["notes"] == given["session.notes"]
