"""Issue 26 items 1-3 (and the console's part of item 4) without a browser: an answer belongs to one question; the
console stops like a terminal on real signals, with an event stream open; off loopback the Host check stays; two
consoles keep their own tokens; a resumed simulated session keeps its speed.

What is checked comes from outside the console's code: the session file (blocks on file, their weights, the stop
record, the last SCPI command sent: ``SOUR:SWE:ABOR``, the source idle), the kernel's process table (/proc), and the
time and text of a real ``contactrig console`` process.
"""

from __future__ import annotations

import http.cookiejar
import json
import signal
import sys
import threading
import time
import urllib.error
import urllib.request
import warnings
from pathlib import Path
from typing import Any

import pytest

from tests.console.conftest import Client, ConsoleProcess, scene_text


def _wait_prompt(client: Client, run: str, not_id: str | None = None, timeout: float = 60) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        s = client.get(f"/api/runs/{run}").json()
        if s["prompt"] is not None and (not_id is None or s["prompt"]["id"] != not_id):
            return dict(s)
        assert s["phase"] != "ended", s
        time.sleep(0.02)
    raise AssertionError("no question asked")


def _loaded(path: Path) -> Any:
    from daq.session_file import load_session

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return load_session(path)
        except Exception:  # not there yet, or caught mid-write: asked again
            return None


# -- item 1: an answer belongs to one question ---------------------------------------------------------------------


def test_a_second_continue_for_one_question_is_refused(client: Client, folder: Path):
    """Two Continue requests for the same question 0.6 s apart (a double click, two tabs, a slow network): the
    first is taken, the second refused (409) — it must not start the next weight, which nobody placed. Late Skip and
    Stop answers to that question are refused too, and so are answers naming a question never asked."""
    run = client.start("twice.h5")  # 5.44, 10.526, 25.966 kg × 2 blocks, instant simulated bench
    first = _wait_prompt(client, run)["prompt"]
    assert first["weight_kg"] == 5.44 and first["id"]
    url = f"/api/runs/{run}/answer"
    assert client.post(url, {"prompt": first["id"], "decision": "go"}).status_code == 200
    time.sleep(0.6)
    again = client.post(url, {"prompt": first["id"], "decision": "go"})
    assert again.status_code == 409 and "already answered" in again.json()["error"], again.text
    second = _wait_prompt(client, run, not_id=first["id"])
    assert second["prompt"]["weight_kg"] == 10.526 and second["prompt"]["id"] != first["id"]
    for late in ({"decision": "skip"}, {"decision": "quit"}, {"decision": "go"}):
        r = client.post(url, {"prompt": first["id"], **late})
        assert r.status_code == 409 and r.json()["refused"], r.text
    foreign = client.post(url, {"prompt": "0123456789abcdef", "decision": "go"})
    assert foreign.status_code == 409 and "not asked" in foreign.json()["error"]
    assert client.post(url, {"decision": "go"}).status_code == 400  # an answer names its question
    wrong_kind = client.post(url, {"prompt": second["prompt"]["id"], "measure": True})
    assert wrong_kind.status_code == 409
    state = client.get(f"/api/runs/{run}").json()
    assert state["prompt"]["id"] == second["prompt"]["id"]  # still asking for 10.526 kg: nothing was measured at it
    assert [b["weight_kg"] for b in state["blocks"]] == [5.44, 5.44]
    assert client.post(url, {"prompt": second["prompt"]["id"], "decision": "quit"}).status_code == 200
    end = client.drive(run)
    assert end["stop"]["status"] == "aborted" and "at weight 10.526 kg" in end["stop"]["reason"], end["stop"]
    with pytest.warns(Warning, match="aborted"):
        s = _load_strict(folder / "twice.h5")
    assert list(s.summary["weight_kg"]) == [5.44, 5.44] and list(s.summary["repeat"]) == [1, 2]
    assert s.stop["blocks_done"] == 2


def _load_strict(path: Path) -> Any:
    from daq.session_file import load_session

    return load_session(path)


def test_concurrent_answers_to_one_question_take_one(client: Client):
    """Eight requests answering one question at the same instant (threads): exactly one is taken."""
    run = client.start("race.h5")
    prompt = _wait_prompt(client, run)["prompt"]
    barrier = threading.Barrier(8)
    codes: list[int] = []

    def answer() -> None:
        barrier.wait()
        codes.append(client.post(f"/api/runs/{run}/answer", {"prompt": prompt["id"], "decision": "go"}).status_code)

    threads = [threading.Thread(target=answer) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30)
    assert sorted(codes) == [200] + [409] * 7, codes
    nxt = _wait_prompt(client, run, not_id=prompt["id"])
    assert nxt["prompt"]["weight_kg"] == 10.526 and len(nxt["blocks"]) == 2
    client.post(f"/api/runs/{run}/answer", {"prompt": nxt["prompt"]["id"], "decision": "quit"})
    client.drive(run)


# -- item 2: the console stops like a terminal ---------------------------------------------------------------------

linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads the process table in /proc")


def _children(pid: int) -> list[int]:
    """The acquisition children of process ``pid`` (from /proc)."""
    found = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            ppid = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            cmd = (d / "cmdline").read_bytes()
        except (OSError, IndexError, ValueError):
            continue
        if ppid == pid and b"contactrig.console.child" in cmd:
            found.append(int(d.name))
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state != "Z"


class _Events:
    """An open event stream of a run, read in a thread: each state with its arrival time, and when it closed."""

    def __init__(self, console: ConsoleProcess, run: str) -> None:
        self.states: list[tuple[float, dict[str, Any]]] = []
        self.closed_at: float | None = None
        self.thread = threading.Thread(target=self._read, daemon=True)
        if not run:  # no page open
            self.response = None
            return
        req = urllib.request.Request(f"{console.base}/api/runs/{run}/events",
                                     headers={"X-Contactrig-Token": console.token})  # fmt: skip
        self.response = urllib.request.urlopen(req, timeout=120)
        self.thread.start()

    def _read(self) -> None:
        assert self.response is not None
        try:
            for line in self.response:
                if line.startswith(b"data: "):
                    self.states.append((time.monotonic(), json.loads(line[6:])))
        except OSError:
            pass
        self.closed_at = time.monotonic()

    def last_block_at(self) -> float:
        """When the stream brought the last block."""
        count, at = -1, 0.0
        for t, s in self.states:
            if len(s["blocks"]) != count:
                count, at = len(s["blocks"]), t
        return at


def _start_measuring(console: ConsoleProcess, output: str, scene: str, speed: str) -> tuple[str, int]:
    """A session started and its first weight placed; returns the run id and the acquisition child's pid."""
    run = console.api("/api/runs", {"scene": scene, "sim": True, "sim_speed": speed, "output": output})["id"]
    deadline = time.monotonic() + 60
    while (state := console.api(f"/api/runs/{run}"))["prompt"] is None and time.monotonic() < deadline:
        time.sleep(0.05)
    console.api(f"/api/runs/{run}/answer", {"decision": "go", "prompt": state["prompt"].get("id")})
    [child] = _children(console.proc.pid)
    return run, child


def _wait_blocks(console: ConsoleProcess, run: str, n: int) -> None:
    deadline = time.monotonic() + 60
    while len(console.api(f"/api/runs/{run}")["blocks"]) < n:
        assert time.monotonic() < deadline, "no block measured"
        time.sleep(0.05)


def _exit(console: ConsoleProcess, timeout: float = 60) -> tuple[int, float, str]:
    """Wait for the console process to end: its exit code, when it ended, and what it printed."""
    deadline = time.monotonic() + timeout
    while console.proc.poll() is None:
        if time.monotonic() > deadline:
            console.proc.kill()
            raise AssertionError(f"the console did not exit within {timeout} s of the signal")
        time.sleep(0.02)
    ended = time.monotonic()
    assert console.proc.stderr is not None
    return console.proc.returncode, ended, console.proc.stderr.read()


def _source_left_idle(path: Path) -> Any:
    s = _loaded(path)
    assert s is not None and s.sealed and s.status == "aborted", s
    assert s.exchanges["message"].iloc[-1] == "SOUR:SWE:ABOR"  # the last command sent: the source idle
    return s


@linux_only
@pytest.mark.slow
@pytest.mark.parametrize(("signum", "page"), [(signal.SIGINT, True), (signal.SIGTERM, True), (signal.SIGTERM, False)])
def test_first_signal_stops_every_session_after_its_block(folder: Path, tmp_path: Path, signum: int, page: bool):
    """With an event stream open (or none): the first SIGINT or SIGTERM stops the running session after the block
    under way (the terminal's first Ctrl-C: stop record, source idle), the stream ends, the console exits within 5 s
    of the block's end and prints what it stopped; its acquisition child is gone."""
    (folder / "slow.toml").write_text(scene_text(count=60, repeats=3), encoding="utf-8")  # ≈ 1 s a block at speed 2
    console = ConsoleProcess(folder, tmp_path / "state")
    try:
        run, child = _start_measuring(console, "sig.h5", "slow.toml", "2")
        events = _Events(console, run if page else "")
        _wait_blocks(console, run, 1)
        console.proc.send_signal(signum)
        code, exited, said = _exit(console)
    finally:
        if console.proc.poll() is None:
            console.proc.kill()
    if page:
        events.thread.join(5)
        assert exited - events.last_block_at() < 5.0, said
        assert events.closed_at is not None and events.closed_at <= exited + 0.5  # the stream was closed
        final = events.states[-1][1]
        assert final["phase"] == "ended" and final["console_closing"], final
    name = signal.Signals(signum).name
    assert f"{name}: stopping 1 running session(s) after the current block: sig.h5" in said, said
    assert "stopped sig.h5: aborted, " in said and "interrupted (Ctrl-C): stopped after the block" in said, said
    assert code == 1  # stopped early: the file can be resumed
    assert not _alive(child)
    s = _source_left_idle(folder / "sig.h5")
    assert 1 <= len(s.summary) < 3 and "stopped after the block" in s.stop["reason"]


@linux_only
@pytest.mark.slow
def test_second_signal_stops_now(folder: Path, tmp_path: Path):
    """A second SIGTERM stops now (the terminal's second Ctrl-C): the block under way is discarded, the completed
    ones kept, the source idle; the console exits at once."""
    (folder / "long.toml").write_text(scene_text(count=200, repeats=3), encoding="utf-8")  # ≈ 3 s a block at speed 2
    console = ConsoleProcess(folder, tmp_path / "state")
    try:
        run, child = _start_measuring(console, "now.h5", "long.toml", "2")
        events = _Events(console, run)
        _wait_blocks(console, run, 1)
        time.sleep(0.3)  # inside the second block
        console.proc.send_signal(signal.SIGTERM)
        time.sleep(0.3)
        console.proc.send_signal(signal.SIGTERM)
        second = time.monotonic()
        code, exited, said = _exit(console)
    finally:
        if console.proc.poll() is None:
            console.proc.kill()
    assert exited - second < 5.0, said
    assert "SIGTERM again: stopping now" in said and "Ctrl-C twice" in said, said
    assert code == 1 and not _alive(child)
    events.thread.join(5)
    assert events.closed_at is not None
    s = _source_left_idle(folder / "now.h5")
    assert len(s.summary) == 1 and "discarded" in s.stop["reason"], s.stop


@linux_only
@pytest.mark.slow
def test_a_killed_console_leaves_no_acquisition_running(folder: Path, tmp_path: Path):
    """The console SIGKILLed while a block is measured: its child notices (its stdin, the console's pipe, closes)
    and stops as one Ctrl-C stops it — after the block under way, not after the weight's remaining blocks, source
    idle, stop record written — and ends."""
    (folder / "slow.toml").write_text(scene_text(count=60, repeats=4), encoding="utf-8")  # ≈ 1 s a block at speed 2
    console = ConsoleProcess(folder, tmp_path / "state")
    try:
        run, child = _start_measuring(console, "k.h5", "slow.toml", "2")
        _wait_blocks(console, run, 1)
    finally:
        console.proc.send_signal(signal.SIGKILL)
        console.proc.wait()
    deadline = time.monotonic() + 30
    while _alive(child) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _alive(child), "the acquisition went on without its console"
    s = _source_left_idle(folder / "k.h5")
    assert 1 <= len(s.summary) <= 2 and "stopped after the block" in s.stop["reason"], s.stop


# -- item 3: off loopback, and two consoles --------------------------------------------------------------------


def _get(url: str, host: str, token: str) -> int:
    req = urllib.request.Request(url, headers={"Host": host, "X-Contactrig-Token": token})
    try:
        with urllib.request.urlopen(req, timeout=30) as r:
            return int(r.status)
    except urllib.error.HTTPError as exc:
        return int(exc.code)


@pytest.mark.slow
def test_all_interfaces_warn_and_keep_the_host_check(folder: Path, tmp_path: Path):
    """``--host 0.0.0.0``: a warning that the bench is reachable from the network; the Host check stays — the
    names of --allowed-host and loopback's are answered, any other Host is refused (DNS rebinding)."""
    console = ConsoleProcess(folder, tmp_path / "state", "--host", "0.0.0.0", "--allowed-host", "Bench-PC.lab.example")
    try:
        port = console.base.rsplit(":", 1)[1]
        assert console.proc.stderr is not None
        console.proc.stderr.readline()  # where the token is stored
        warning = console.proc.stderr.readline()
        assert warning.startswith("WARNING: --host 0.0.0.0") and "reachable from the network" in warning, warning
        assert f"bench-pc.lab.example:{port}" in warning
        url = f"{console.base}/api/sessions"
        assert _get(url, f"evil.example:{port}", console.token) == 403
        assert _get(url, f"bench-pc.lab.example:{port}", console.token) == 200
        assert _get(url, f"127.0.0.1:{port}", console.token) == 200
        assert _get(url, f"bench-pc.lab.example:{port}", "wrong") == 403  # the name does not replace the token
    finally:
        console.close()


def test_allowed_host_must_be_a_name(folder: Path, capsys: pytest.CaptureFixture[str]):
    from contactrig.cli.main import main

    for bad in ("http://bench.lab", "bench.lab:8765", "bench lab", ""):
        assert main(["console", str(folder), "--allowed-host", bad, "--no-browser"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--allowed-host" in err[0] and "Traceback" not in err[0], err


def test_the_host_check_is_never_off(tmp_path: Path):
    """Bound to every interface (or one address), the console answers only the names it was given (a foreign Host:
    403, the DNS-rebinding guard), with the token still needed."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Starlette's note on its httpx-based client
        from starlette.testclient import TestClient

    from contactrig.console.app import build_app
    from contactrig.console.server import make_console

    for host in ("0.0.0.0", "::", "192.0.2.7"):
        console = make_console(tmp_path, host, 8765)
        app = TestClient(build_app(console))
        token = {"x-contactrig-token": console.token}
        assert app.get("/api/runs", headers={**token, "host": "evil.example:8765"}).status_code == 403, host
        loopback = "192.0.2.7:8765" if host == "192.0.2.7" else "127.0.0.1:8765"
        assert app.get("/api/runs", headers={**token, "host": loopback}).status_code == 200, host
    named = make_console(tmp_path, "0.0.0.0", 8765, allowed=["bench.lab"])
    assert named.allowed_hosts == {"bench.lab:8765", "127.0.0.1:8765", "localhost:8765"}


@pytest.mark.slow
def test_two_consoles_on_two_ports_keep_their_tokens(tmp_path: Path):
    """Two consoles on one machine, one browser's cookie jar (cookies do not tell ports apart): logging in to the
    second does not log out of the first; each token is stored in a file of its own port, removed on exit."""
    a_dir, b_dir = tmp_path / "a", tmp_path / "b"
    a_dir.mkdir()
    b_dir.mkdir()
    state = tmp_path / "state"
    a = ConsoleProcess(a_dir, state)
    b = ConsoleProcess(b_dir, state)
    try:
        jar = http.cookiejar.CookieJar()
        browser = urllib.request.build_opener(urllib.request.HTTPCookieProcessor(jar))
        for c in (a, b):  # the URL with the token, as printed; the console sets its cookie
            assert browser.open(f"{c.base}/?token={c.token}", timeout=30).status == 200
        for c in (a, b, a):
            assert browser.open(f"{c.base}/api/sessions", timeout=30).status == 200
        stored = {p.name: p.read_text().strip() for p in (state / "contactrig").iterdir()}
        assert stored == {f"console-token-{a.base.rsplit(':', 1)[1]}": a.token,
                          f"console-token-{b.base.rsplit(':', 1)[1]}": b.token}  # fmt: skip
    finally:
        a.close()
        b.close()
    assert not list((state / "contactrig").iterdir())


# -- item 4 (the console's part): resume keeps the session's sim speed ---------------------------------------------


@pytest.mark.slow
def test_resume_keeps_the_sessions_sim_speed(client: Client, folder: Path):
    """A simulated session started at speed 7 and resumed from the sessions page (which sends no speed) runs on at
    speed 7, as recorded in the new run's start record."""
    run = client.start("speed.h5", speed="7")
    prompt = _wait_prompt(client, run)["prompt"]
    client.post(f"/api/runs/{run}/answer", {"prompt": prompt.get("id"), "decision": "quit"})
    client.drive(run)
    r = client.post("/api/runs", {"resume": True, "output": "speed.h5", "sim": True, "client": "tester"})
    assert r.status_code == 200, r.text
    again = r.json()["id"]
    prompt = _wait_prompt(client, again)["prompt"]
    client.post(f"/api/runs/{again}/answer", {"prompt": prompt.get("id"), "decision": "quit"})
    client.drive(again)
    runs = _loaded(folder / "speed.h5").runs
    assert [r["simulation"]["sim_speed"] for r in runs] == [7.0, 7.0]


@linux_only
@pytest.mark.slow
def test_a_command_running_from_the_page_ends_with_the_console(folder: Path, tmp_path: Path):
    """A Fit started from the page (``contactrig fit`` in a child process) when the console is stopped: the command
    is ended, the page told why, and the console exits at once — no child left behind."""
    from analysis.simulated_session import SimulatedRigBench
    from daq.acquire import acquire

    acquire(folder / "small.toml", folder / "done.h5", bench=SimulatedRigBench(float("inf")), yes=True, quiet=True)
    console = ConsoleProcess(folder, tmp_path / "state")
    answer: dict[str, Any] = {}
    asked = threading.Thread(target=lambda: answer.update(console.api("/api/session/fit", {"path": "done.h5"})))
    asked.start()
    deadline = time.monotonic() + 30
    while not (fits := _commands(console.proc.pid, b"fit")) and time.monotonic() < deadline:
        time.sleep(0.02)
    assert fits, "the fit did not start"
    console.proc.send_signal(signal.SIGINT)
    code, _, said = _exit(console, timeout=5)
    asked.join(5)
    assert code == 0 and "no session running" in said, said
    assert "stopped: the console is shutting down" in answer["stderr"], answer
    assert not any(_alive(pid) for pid in fits)


def _commands(pid: int, name: bytes) -> list[int]:
    """The ``contactrig NAME`` commands that process ``pid`` runs (from /proc)."""
    found = []
    for d in Path("/proc").iterdir():
        try:
            ppid = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            cmd = (d / "cmdline").read_bytes().split(b"\0")
        except (OSError, IndexError, ValueError):
            continue
        if ppid == pid and b"contactrig" in cmd and name in cmd:
            found.append(int(d.name))
    return found
