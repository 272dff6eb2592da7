"""Issue 26 items 1, 2 and 4 (keys) in real browsers: two browser contexts (two Chromium instances, as two operators'
tabs or PCs) on one session, one of them on a slow network — its late answer is refused and the page says so; the
keys of the terminal (Enter, s, q) on the page; signals to the console with the page open.

Set-up as tests/console/test_console_browser.py: the system's Chromium, headless, driven by Selenium (no download).
"""

from __future__ import annotations

import signal
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.console.conftest import ConsoleProcess, scene_text
from tests.console.test_console_protocol import _alive, _children, _exit, _loaded, linux_only

pytest.importorskip("selenium", reason="Selenium is not installed: pip install '.[console]'")

from selenium import webdriver
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys

from tests.console.test_console_browser import BROWSER_MARKS, chrome, text_of, wait

pytestmark = BROWSER_MARKS

#: the page's network made slow for its answers: each reaches the console ``arguments[0]`` ms after the click
DELAY_ANSWERS = """
const delay = arguments[0], plain = window.fetch;
window.fetch = (url, init) => String(url).includes("/answer")
  ? new Promise((done) => setTimeout(done, delay)).then(() => plain(url, init)) : plain(url, init);
"""


def open_run(driver: webdriver.Chrome, console: ConsoleProcess, run: str) -> None:
    driver.get(f"{console.base}/?token={console.token}")  # sets the cookie, redirects to the bare URL
    driver.get(f"{console.base}/#/run/{run}")


def press(driver: webdriver.Chrome, key: str) -> None:
    ActionChains(driver).send_keys(key).perform()


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    d = tmp_path / "sessions"
    d.mkdir()
    (d / "small.toml").write_text(scene_text(), encoding="utf-8")
    (d / "slow.toml").write_text(scene_text(count=60, repeats=3), encoding="utf-8")  # ≈ 1 s a block at speed 2
    return d


@pytest.fixture
def console(folder: Path, tmp_path: Path) -> Iterator[ConsoleProcess]:
    c = ConsoleProcess(folder, tmp_path / "state")
    yield c
    c.close()


def test_a_late_answer_from_a_second_browser_is_refused_and_shown(console: ConsoleProcess, folder: Path):
    """Two browsers on one session's question; the second's Continue is clicked first but reaches the console 1.5 s
    later (a slow network), after the first's Continue has started the weight's blocks and the next weight is asked:
    it is refused, and its page says so; the next weight stays asked, nothing measured at it. Then the keys, as at
    the terminal: s (asks to confirm) and n keep the weight, Enter continues, q stops."""
    from daq.session_file import load_session

    a, b = chrome("1000,900"), chrome("1000,900")
    try:
        run = console.api("/api/runs", {"scene": "small.toml", "sim": True, "sim_speed": "inf", "output": "two.h5",
                                        "client": "a"})["id"]  # fmt: skip
        for d in (a, b):
            open_run(d, console, run)
        for d in (a, b):
            wait(d, lambda d: "Place 5.44 kg" in text_of(d, "#weight"))
        b.execute_script(DELAY_ANSWERS, 1500)
        b.find_element(By.ID, "btn-continue").click()
        a.find_element(By.ID, "btn-continue").click()
        wait(a, lambda d: "Place 10.526 kg" in text_of(d, "#weight"))
        refused = wait(b, lambda d: [e for e in d.find_elements(By.ID, "answer-refused") if e.is_displayed()])[0]
        assert "Answer refused" in refused.text and "place 5.44 kg' was already answered" in refused.text, refused.text
        state = console.api(f"/api/runs/{run}")
        assert state["prompt"]["weight_kg"] == 10.526 and [x["weight_kg"] for x in state["blocks"]] == [5.44, 5.44]
        wait(b, lambda d: "Place 10.526 kg" in text_of(d, "#weight"))  # the second page follows the session
        assert not [e for e in a.find_elements(By.ID, "answer-refused") if e.is_displayed()]

        press(a, "s")
        wait(a, lambda d: d.find_elements(By.ID, "btn-confirm-skip"))
        press(a, "n")  # as `skip 10.526 kg? [y/N]`: not skipped
        wait(a, lambda d: not d.find_elements(By.ID, "btn-confirm-skip"))
        assert console.api(f"/api/runs/{run}")["prompt"]["weight_kg"] == 10.526
        press(a, Keys.ENTER)
        wait(a, lambda d: "Place 25.966 kg" in text_of(d, "#weight"))
        press(a, "q")
        wait(a, lambda d: d.find_elements(By.ID, "stop-record"))
        assert "operator stopped the session at weight 25.966 kg" in text_of(a, "#stop-record")
    finally:
        a.quit()
        b.quit()
    with pytest.warns(Warning, match="aborted"):
        s = load_session(folder / "two.h5")
    assert list(s.summary["weight_kg"]) == [5.44, 5.44, 10.526, 10.526]


@linux_only
def test_signals_to_the_console_with_a_page_open(console: ConsoleProcess, folder: Path):
    """A page follows a session (its event stream open); SIGINT to the console: the page shows the console shutting
    down and then the stop record of a stop after the block; the console exits within 5 s and no acquisition child
    is left."""
    d = chrome("1000,900")
    try:
        run = console.api("/api/runs", {"scene": "slow.toml", "sim": True, "sim_speed": "2", "output": "page.h5",
                                        "client": "a"})["id"]  # fmt: skip
        open_run(d, console, run)
        wait(d, lambda d: d.find_elements(By.ID, "btn-continue"))[0].click()
        [child] = _children(console.proc.pid)
        deadline = time.monotonic() + 60
        while not console.api(f"/api/runs/{run}")["blocks"] and time.monotonic() < deadline:
            time.sleep(0.05)
        console.proc.send_signal(signal.SIGINT)
        closing = "the console is shutting down"
        wait(d, lambda d: closing in text_of(d, "#phase") or d.find_elements(By.ID, "stop-record"))
        wait(d, lambda d: d.find_elements(By.ID, "stop-record"))
        shown = time.monotonic()
        assert "stopped after the block" in text_of(d, "#stop-record")
        code, exited, said = _exit(console)
        assert exited - shown < 5.0 and code == 1, said
        assert "stopped page.h5: aborted, " in said
        assert not _alive(child)
    finally:
        d.quit()
    s = _loaded(folder / "page.h5")
    assert s is not None and s.sealed and s.status == "aborted" and 1 <= len(s.summary) < 3
