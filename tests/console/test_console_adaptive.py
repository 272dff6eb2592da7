"""Issue 27, the console's part: an adaptive session started from the New-session form runs the child acquisition
with the adaptive source exactly as ``contactrig acquire --sim --adaptive --budget-min N`` does; every suggestion is
a question with an id (take it, place another allowed weight, stop); the page gets the design's own state (evidence,
progress to a decision, the reason it does not move, the stop reason) and the follow page reads it from the file.

The scene: the packaged press with two models and iid re-seating noise, as tests/analysis/test_adaptive_session.py
sets it up (there it ends decisive for Greenwood–Tripp in a few minutes of bench time).
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.console.conftest import ROOT, Client

PRESS = ROOT / "contactrig" / "scenes" / "press.toml"


def press_iid_text() -> str:
    """The press scene with Greenwood–Tripp and Pasaribu–Schipper only, and iid re-seating noise (SD 0.15)."""
    text = PRESS.read_text(encoding="utf-8")
    text = re.sub(r"^models\s*=.*$", 'models = ["greenwood_tripp", "pasaribu_schipper"]', text, count=1, flags=re.M)
    return re.sub(r'^sim_noise = "tab1"', 'sim_noise = "iid"', text, count=1, flags=re.M)


@pytest.fixture
def press_client(folder: Path) -> Iterator[Client]:
    (folder / "press_iid.toml").write_text(press_iid_text(), encoding="utf-8")
    c = Client(folder)
    yield c
    c.close()


def test_form_errors_name_the_field(press_client: Client) -> None:
    """A budget that is no number of minutes > 0, a budget without adaptive, an adaptive resume: refused (400),
    naming the field, nothing started."""
    base = {"scene": "press_iid.toml", "sim": True, "sim_speed": "inf", "output": "a.h5", "client": "t"}
    for extra, words in (({"adaptive": True, "budget_min": "0"}, "budget_min"),
                         ({"adaptive": True, "budget_min": "soon"}, "budget_min 'soon'"),
                         ({"budget_min": "30"}, "budget_min only applies"),
                         ({"adaptive": True, "resume": True, "output": "small.toml"}, "")):  # fmt: skip
        r = press_client.post("/api/runs", {**base, **extra})
        assert r.status_code == 400, (extra, r.text)
        assert words in r.json()["error"]
    assert press_client.get("/api/runs").json()["runs"] == []


def test_adaptive_start_suggestions_answers_and_stop(press_client: Client, folder: Path) -> None:
    """``adaptive`` + ``budget_min`` start the adaptive source: each placement is asked as a suggestion (its text is
    the one recorded in the stop record: the console shows the analysis's words), answered by id; a weight outside
    the allowed ones and a fixed plan's ``skip`` are refused (409) and the same question stays asked; one answer
    places another weight, recorded as such; the session ends by the design's rule and the page gets why."""
    from analysis.adaptive_session import replay_suggestions
    from daq import load_session

    run = press_client.start("adaptive.h5", scene="press_iid.toml", adaptive=True, budget_min="30")
    asked: list[dict[str, Any]] = []
    states: list[dict[str, Any]] = []

    def decide(s: dict[str, Any]) -> dict[str, Any]:
        p = s["prompt"]
        assert p["event"] == "suggest"
        if asked and asked[-1]["id"] == p["id"]:  # the same question, still asked after a refusal
            return {"decision": "go"}
        asked.append(p)
        states.append(s["adaptive"])
        if len(asked) == 6:  # the operator places another weight than the suggested one
            for bad in ({"decision": "skip"}, {"decision": "place", "weight_kg": 3.0}):
                r = press_client.post(f"/api/runs/{run}/answer", {"prompt": p["id"], **bad})
                assert r.status_code == 409, r.text
            other = next(w for w in p["allowed_kg"] if w != p["weight_kg"])
            return {"decision": "place", "weight_kg": other}
        return {"decision": "go"}

    end = press_client.drive(run, decide, timeout=120)
    assert end["budget_min"] == 30.0 and end["end"]["code"] == 0, end
    assert press_client.get("/api/runs").json()["runs"][0]["budget_min"] == 30.0
    assert len(asked) >= 5
    # the state the page shows is the design's report: progress in [0, 1], the threshold, the reason
    first = states[0]
    assert first["evidence"] is None and first["progress"] == 0.0 and first["threshold"] == 10.0
    assert "is larger than the difference between" in first["why"] and first["evidence_line"].startswith("evidence:")
    assert all(0.0 <= st["progress"] <= 1.0 for st in states)
    # the stop: the design's decision and reason as the file records them (the analysis decides, not the console)
    stop = end["adaptive_stop"]
    s = load_session(folder / "adaptive.h5")
    assert stop["decision"] == s.stop["adaptive"]["decision"] and stop["stop_reason"] == s.stop["reason"]
    assert stop["decision"]["status"] in ("decisive", "futile") and end["stop"]["reason"] == stop["stop_reason"]
    assert stop["stop_reason"].startswith("decisive: " if stop["decision"]["status"] == "decisive" else "stop — ")
    # what the file holds: the same suggestions, the operator's actions, and the budget as --budget-min 30 sets it
    assert s.start["adaptive"]["budget_s"] == 1800.0
    entries = s.stop["adaptive"]["entries"]
    assert [e["suggestion"]["text"] for e in entries] == [p["suggestion"]["text"] for p in asked]
    placed = [e["operator"] for e in entries]
    other = next(w for w in asked[5]["allowed_kg"] if w != asked[5]["weight_kg"])
    assert placed[5] == f"placed {other:g} kg instead"
    assert placed[:5] + placed[6:] == ["took the suggestion"] * (len(placed) - 1)
    same, text = replay_suggestions(str(folder / "adaptive.h5"))
    assert same, text
    # the follow page reads the evidence and the stop reason from the file
    f = press_client.get("/api/follow", params={"path": "adaptive.h5"}).json()
    assert f["adaptive"]["progress"] == end["adaptive"]["progress"]
    assert f["adaptive"]["stop_record"]["decision"] == stop["decision"]
    assert f["adaptive"]["stop_record"]["reason"] == stop["stop_reason"]


def test_follow_of_a_fixed_plan_has_no_adaptive_state(press_client: Client, folder: Path) -> None:
    run = press_client.start("fixed.h5")
    assert press_client.drive(run)["end"]["code"] == 0
    assert press_client.get("/api/follow", params={"path": "fixed.h5"}).json()["adaptive"] is None


def test_a_queued_adaptive_session_keeps_its_budget(press_client: Client) -> None:
    """The queue's form keeps adaptive and its budget (checked when queued, as a start checks it); started from the
    queue, the session asks suggestions and runs with that budget."""
    base = {"scene": "press_iid.toml", "sim": True, "sim_speed": "inf", "output": "q.h5", "client": "t"}
    r = press_client.post("/api/queue", {**base, "adaptive": True, "budget_min": "-1"})
    assert r.status_code == 400 and "budget_min" in r.json()["error"]
    assert press_client.post("/api/queue", {**base, "adaptive": True, "budget_min": "20"}).status_code == 200
    deadline = time.monotonic() + 30
    while not (started := press_client.get("/api/queue").json()["started"]):
        assert time.monotonic() < deadline
        time.sleep(0.05)
    end = press_client.drive(started[0]["run"], lambda s: {"decision": "go"} if s["prompt"]["event"] == "suggest"
                             else {"decision": "quit"}, timeout=120)  # fmt: skip
    assert end["budget_min"] == 20.0 and end["adaptive_stop"] is not None and end["adaptive"] is not None


def test_stop_at_a_suggestion_and_stop_after_the_block(press_client: Client) -> None:
    """Stop at a suggestion (``quit``, the terminal's ``q``) ends the session with the operator's reason; "stop after
    this block" (SIGINT, as Ctrl-C) while it measures ends it aborted, the source idle, the state still shown."""
    run = press_client.start("op.h5", scene="press_iid.toml", adaptive=True, budget_min="30")
    seen: list[str] = []

    def decide(s: dict[str, Any]) -> dict[str, Any]:
        if s["prompt"]["id"] not in seen:
            seen.append(s["prompt"]["id"])
        return {"decision": "go" if len(seen) < 3 else "quit"}

    end = press_client.drive(run, decide, timeout=120)
    assert end["adaptive_stop"]["decision"]["status"] == "operator"
    assert end["stop"]["reason"].startswith("operator: stopped at the suggestion ")
    assert end["stop"]["reason"] == end["adaptive_stop"]["stop_reason"] and end["adaptive"]["what_would"]
    run = press_client.start("int.h5", scene="press_iid.toml", adaptive=True, budget_min="30", sim_speed="20")
    end = press_client.drive(run, lambda s: press_client.post(f"/api/runs/{run}/stop", {"client": "tester"})
                             and {"decision": "go"}, timeout=120)  # fmt: skip
    assert end["stop"]["status"] == "aborted" and end["adaptive"] is not None, end["stop"]


class _Pipe:
    """The child's channel without a console: events collected, every suggestion taken."""

    def __init__(self) -> None:
        self.events: list[dict[str, Any]] = []

    def send(self, event: dict[str, Any]) -> None:
        self.events.append(event)

    def ask(self, event: dict[str, Any]) -> dict[str, Any]:
        self.send(event)
        return {"decision": "go"}


def test_the_child_sends_the_design_state_after_every_block(tmp_path: Path) -> None:
    """After every block the design's state (``evidence``, its ``blocks`` the count so far), before each placement
    the suggestion with the state the stop record keeps for it; the extra reports change no suggestion (replay)."""
    import json
    import math

    from analysis.adaptive_session import replay_suggestions
    from analysis.simulated_session import SimulatedRigBench
    from contactrig.console.child import pipe_adaptive
    from contactrig.core.scene import parse_scene
    from daq import load_session
    from daq.acquire import acquire

    pipe = _Pipe()
    factory, final = pipe_adaptive(pipe, 30.0, simulated=True)
    path = tmp_path / "child.h5"
    acquire(parse_scene(press_iid_text(), "press (test)"), path, bench=SimulatedRigBench(math.inf), quiet=True,
            adaptive=factory)  # fmt: skip
    final()
    s = load_session(path)
    after = [e["adaptive"] for e in pipe.events if e["event"] == "evidence"]
    assert [a["blocks"] for a in after] == list(range(1, len(s.summary) + 1))
    asked = [e for e in pipe.events if e["event"] == "suggest"]
    entries = s.stop["adaptive"]["entries"]
    assert len(asked) == len(entries)
    for e, rec in zip(asked, entries, strict=True):
        kept = {k: e["adaptive"][k] for k in ("suggestion", "evidence", "p_decisive", "progress", "noise")}
        assert kept == json.loads(json.dumps({k: rec[k] for k in kept}))
    assert pipe.events[-1]["event"] == "adaptive" and pipe.events[-1]["decision"] == s.stop["adaptive"]["decision"]
    same, text = replay_suggestions(str(path))
    assert same, text
