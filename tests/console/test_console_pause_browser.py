"""The bench's pause in a real browser (issue 29): on the running session's page the operator types a reason and
their name and presses "Pause after this block"; the page says PAUSED with the reason once the block under way is on
file; the pause record is in the file; Resume on the same page goes on to the end.

Set-up as tests/console/test_console_browser.py: the system's Chromium, headless, driven by Selenium (no download).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.console.conftest import scene_text
from tests.console.test_console_protocol import _loaded

pytest.importorskip("selenium", reason="Selenium is not installed: pip install '.[console]'")

from selenium.webdriver.common.by import By

from tests.console.test_console_browser import (
    BROWSER_MARKS,
    continue_all,
    open_console,
    start_from_form,
    text_of,
    wait,
)

pytestmark = BROWSER_MARKS


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("pause") / "sessions"
    d.mkdir()
    (d / "small.toml").write_text(scene_text(), encoding="utf-8")
    return d


def test_pause_and_resume_from_the_run_page(browser, console, folder):
    from daq.pause import pauses_of

    open_console(browser, console)
    start_from_form(browser, "small.toml", "paused.h5", "inf")
    wait(browser, lambda d: d.find_elements(By.ID, "btn-continue"))
    browser.find_element(By.ID, "pause-reason").send_keys("thermocouple came loose")
    browser.find_element(By.ID, "pause-who").send_keys("ann")
    browser.find_element(By.ID, "btn-pause").click()
    wait(browser, lambda d: "pause requested" in text_of(d, "#pause-state"))
    browser.find_element(By.ID, "btn-continue").click()  # 5.44 kg placed: the pause comes before its first block
    wait(browser, lambda d: "PAUSED" in text_of(d, "#pause-state"))
    assert "thermocouple came loose" in text_of(browser, "#pause-state") and "paused" in text_of(browser, "#phase")
    on_file = _loaded(folder / "paused.h5")
    assert on_file is not None and [p["reason"] for p in pauses_of(on_file.runs)] == ["thermocouple came loose"]
    assert len(on_file.summary) == 0  # paused before the first block (the protocol test checks the SCPI log)
    browser.find_element(By.ID, "btn-resume").click()
    continue_all(browser)
    assert "success" in text_of(browser, "#stop-record")
    assert "resumed by ann" in text_of(browser, "#pause-state")
    done = _loaded(folder / "paused.h5")
    assert done is not None and done.sealed and len(done.summary) == 6
    [p] = pauses_of(done.runs)
    assert p["after_block"] == 0 and p["resumed_by"] == "ann"
