"""Issue 27 in a real browser: an adaptive session on the simulated press with iid noise, started from the New-session
form (adaptive, budget (min)); the page shows each suggestion as the big prompt with "place another weight" beside it,
the progress-to-decision bar with the reason while it does not move, and the stop reason at the end; the follow page
reads the same from the file.

Set-up as tests/console/test_console_browser.py: the system's Chromium, headless, driven by Selenium (no download).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.console.conftest import ConsoleProcess
from tests.console.test_console_adaptive import press_iid_text

pytest.importorskip("selenium", reason="Selenium is not installed: pip install '.[console]'")

from selenium.common.exceptions import StaleElementReferenceException
from selenium.webdriver.common.by import By

from tests.console.test_console_browser import BROWSER_MARKS, no_dialog, open_console, shot, text_of, wait

pytestmark = BROWSER_MARKS


@pytest.fixture(scope="module")
def console(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ConsoleProcess]:
    folder = tmp_path_factory.mktemp("adaptive") / "sessions"
    folder.mkdir()
    (folder / "press_iid.toml").write_text(press_iid_text(), encoding="utf-8")
    c = ConsoleProcess(folder, tmp_path_factory.mktemp("state"))
    yield c
    c.close()


def test_adaptive_session_in_the_browser(browser: Any, console: ConsoleProcess, tmp_path: Path) -> None:
    open_console(browser, console, "#/new")
    wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, "#scene option[value='press_iid.toml']"))
    browser.execute_script("const s = document.getElementById('scene'); s.value = arguments[0];"
                           "s.dispatchEvent(new Event('change'));", "press_iid.toml")  # fmt: skip
    for field, value in (("sim-speed", "inf"), ("output", "adaptive.h5"), ("budget-min", "30")):
        browser.find_element(By.ID, field).clear()
        browser.find_element(By.ID, field).send_keys(value)
    browser.find_element(By.ID, "adaptive").click()
    wait(browser, lambda d: "adaptive: the weights above are the placements allowed" in text_of(d, "#plan"))
    browser.find_element(By.ID, "start").click()
    wait(browser, lambda d: "#/run/" in d.current_url)

    # the first suggestion: the big prompt in the analysis's words, "place another weight" beside it
    wait(browser, lambda d: d.find_elements(By.ID, "btn-take"))
    run = browser.current_url.split("#/run/")[1]
    suggestion = console.api(f"/api/runs/{run}")["prompt"]["suggestion"]  # the analysis's words, as the child sent them
    big, detail = text_of(browser, "#suggestion"), text_of(browser, "#suggestion-detail")
    assert big.startswith("place ") and big.endswith(" kg (2 seatings)")  # the start: three loads, two seatings each
    assert detail and f"{big}: {detail}" == suggestion["text"] and detail == suggestion["why"]
    assert "adaptive, budget 30 min" in text_of(browser, "#phase")
    # the bar at 0 and the reason it does not move (the analysis's sentence: the limiting noise component)
    bar = browser.find_element(By.ID, "evidence-bar")
    assert float(bar.get_attribute("value") or -1) == 0.0
    assert "is larger than the difference between Greenwood–Tripp and Pasaribu–Schipper" in text_of(
        browser, "#evidence-why"
    )
    browser.find_element(By.ID, "btn-other").click()  # the allowed weights offered; this time the suggestion taken
    options = [o.get_attribute("value") for o in browser.find_elements(By.CSS_SELECTOR, "#other-kg option")]
    assert [float(v or "nan") for v in options] == [0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0]
    shot(browser, "adaptive-suggestion", tmp_path)

    seen_progress = []
    deadline = time.monotonic() + 120
    while not browser.find_elements(By.ID, "adaptive-stop"):
        assert time.monotonic() < deadline, "the adaptive session did not end"
        try:
            for button in browser.find_elements(By.ID, "btn-take"):
                seen_progress.append(float(browser.find_element(By.ID, "evidence-bar").get_attribute("value") or 0))
                button.click()
        except StaleElementReferenceException:
            pass
        time.sleep(0.05)
    no_dialog(browser)
    assert max(seen_progress) > 0.0  # the bar moved while the evidence grew
    # the stop reason: decisive, the winner and its margin, as the stop record has it
    stop = text_of(browser, "#adaptive-stop")
    assert stop.startswith("decisive: Greenwood–Tripp ahead of every other model"), stop
    assert float(browser.find_element(By.ID, "evidence-bar").get_attribute("value") or 0) == 1.0
    wait(browser, lambda d: "decisive: Greenwood–Tripp" in text_of(d, "#stop-record"))
    shot(browser, "adaptive-stopped", tmp_path)

    # the follow page (a session written by any process): the evidence and the stop reason from the file
    browser.get(f"{console.base}/#/follow/adaptive.h5")
    wait(browser, lambda d: d.find_elements(By.ID, "adaptive-stop"))
    assert text_of(browser, "#adaptive-stop") == stop
    assert float(browser.find_element(By.ID, "evidence-bar").get_attribute("value") or 0) == 1.0
