"""Issue 27, the console's New-session form offers what ``acquire --adaptive --noise-from SESSION.h5`` does: the prior
noise of the adaptive design from an earlier session in the console's folder (``noise_from``), checked when the form is
sent (a one-line error naming the field, nothing started), recorded in the start record and said on the evidence line
("noise from NAME"); in a real browser too (the field, the error, the evidence line)."""

from __future__ import annotations

import math
import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.console.conftest import Client, ConsoleProcess
from tests.console.test_console_adaptive import press_iid_text


def _earlier(folder: Path) -> Path:
    """A fixed-plan session of a quieter bench (iid 5 %, 3 repeats) in ``folder``: the earlier session."""
    from analysis.simulated_session import SimulatedRigBench
    from contactrig.core.scene import parse_scene
    from daq.acquire import acquire

    text = re.sub(r"^sim_repeat_sd = 0.15", "sim_repeat_sd = 0.05", press_iid_text(), count=1, flags=re.M)
    text = re.sub(r"^repeats = 6", "repeats = 3", text, count=1, flags=re.M)
    acquire(parse_scene(text, "press, 5 %"), folder / "earlier.h5", bench=SimulatedRigBench(math.inf), yes=True,
            quiet=True)  # fmt: skip
    return folder / "earlier.h5"


@pytest.fixture
def prior_client(folder: Path) -> Iterator[Client]:
    (folder / "press_iid.toml").write_text(press_iid_text(), encoding="utf-8")
    _earlier(folder)
    (folder / "notes.h5").write_text("not a session", encoding="utf-8")
    c = Client(folder)
    yield c
    c.close()


def test_noise_from_in_the_form(prior_client: Client, folder: Path) -> None:
    from daq import load_session
    from daq.run_index import content_id

    base = {"scene": "press_iid.toml", "sim": True, "sim_speed": "inf", "output": "a.h5", "client": "t"}
    for extra, words in (({"noise_from": "earlier.h5"}, "noise_from only applies to an adaptive session"),
                         ({"adaptive": True, "noise_from": "../earlier.h5"}, "not a session file in the console's"),
                         ({"adaptive": True, "noise_from": "none.h5"}, "not a session file in the console's"),
                         ({"adaptive": True, "noise_from": "notes.h5"}, "not a readable HDF5 session file"),
                         ({"adaptive": True, "noise_from": "press_iid.toml"}, "not a readable HDF5")):  # fmt: skip
        for url in ("/api/runs", "/api/queue"):
            r = prior_client.post(url, {**base, **extra})
            assert r.status_code == 400, (extra, r.text)
            error = r.json()["error"]
            assert words in error and "noise_from" in error and len(error.splitlines()) == 1, error
    assert prior_client.get("/api/runs").json()["runs"] == [] and not (folder / "a.h5").exists()

    run = prior_client.start("adaptive.h5", scene="press_iid.toml", adaptive=True, budget_min="30",
                             noise_from="earlier.h5")  # fmt: skip
    lines: list[str] = []

    def decide(s: dict[str, Any]) -> dict[str, Any]:
        lines.append(s["adaptive"]["evidence_line"])
        return {"decision": "go"}

    end = prior_client.drive(run, decide, timeout=120)
    assert end["end"]["code"] == 0, end
    s = load_session(folder / "adaptive.h5")
    assert s.start["adaptive"]["noise_from"] == {
        "file": "earlier.h5",
        "content_id": content_id(load_session(folder / "earlier.h5").start),
    }
    assert s.start["adaptive"]["noise"]["source"] == "noise from earlier.h5"
    assert lines and all(line.endswith("· noise from earlier.h5") for line in lines)


def test_a_queued_adaptive_session_keeps_its_prior(prior_client: Client, folder: Path) -> None:
    from daq import load_session

    body = {"scene": "press_iid.toml", "sim": True, "sim_speed": "inf", "output": "q.h5", "client": "t",
            "adaptive": True, "budget_min": "20", "noise_from": "earlier.h5"}  # fmt: skip
    assert prior_client.post("/api/queue", body).status_code == 200
    deadline = time.monotonic() + 30
    while not (started := prior_client.get("/api/queue").json()["started"]):
        assert time.monotonic() < deadline
        time.sleep(0.05)
    prior_client.drive(started[0]["run"], lambda s: {"decision": "quit"}, timeout=120)
    assert load_session(folder / "q.h5").start["adaptive"]["noise_from"]["file"] == "earlier.h5"


# ---- in a real browser ------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def console(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ConsoleProcess]:
    folder = tmp_path_factory.mktemp("adaptive-prior") / "sessions"
    folder.mkdir()
    (folder / "press_iid.toml").write_text(press_iid_text(), encoding="utf-8")
    _earlier(folder)
    c = ConsoleProcess(folder, tmp_path_factory.mktemp("state"))
    yield c
    c.close()


@pytest.mark.slow
def test_noise_from_in_the_browser(browser: Any, console: ConsoleProcess, tmp_path: Path) -> None:
    pytest.importorskip("selenium", reason="Selenium is not installed: pip install '.[console]'")
    from selenium.webdriver.common.by import By

    from tests.console.test_console_browser import CHROMIUM, DRIVER, no_dialog, open_console, shot, text_of, wait

    if CHROMIUM is None or DRIVER is None:
        pytest.skip("Chromium not found: apt-get install -y chromium chromium-driver (.ci/run does it)")
    open_console(browser, console, "#/new")
    wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, "#scene option[value='press_iid.toml']"))
    browser.execute_script("const s = document.getElementById('scene'); s.value = arguments[0];"
                           "s.dispatchEvent(new Event('change'));", "press_iid.toml")  # fmt: skip
    for field, value in (("sim-speed", "inf"), ("output", "prior.h5"), ("budget-min", "30"), ("noise-from", "no.h5")):
        browser.find_element(By.ID, field).clear()
        browser.find_element(By.ID, field).send_keys(value)
    browser.find_element(By.ID, "adaptive").click()
    browser.find_element(By.ID, "start").click()  # a file that is not there: the form says so, nothing starts
    wait(browser, lambda d: "noise_from 'no.h5': not a session file" in text_of(d, "#form-error"))
    assert "#/new" in browser.current_url
    browser.find_element(By.ID, "noise-from").clear()
    browser.find_element(By.ID, "noise-from").send_keys("earlier.h5")
    browser.find_element(By.ID, "start").click()
    wait(browser, lambda d: "#/run/" in d.current_url)
    wait(browser, lambda d: d.find_elements(By.ID, "btn-take"))
    wait(browser, lambda d: "noise from earlier.h5" in text_of(d, "#evidence-line"))
    shot(browser, "adaptive-prior", tmp_path)
    browser.find_element(By.ID, "btn-quit").click()  # stop at the first suggestion: the operator's reason
    wait(browser, lambda d: d.find_elements(By.ID, "adaptive-stop"))
    no_dialog(browser)
    assert "operator" in text_of(browser, "#adaptive-stop")
