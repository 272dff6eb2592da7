"""The console in a real browser: the system's Chromium (``apt-get install chromium chromium-driver``), headless,
driven by Selenium with the driver's path given (Selenium Manager never downloads anything).

The console runs as ``contactrig console DIR --port 0`` (loopback, a free port) on a temporary folder with the
simulated bench. Screenshots of each page go to ``$CONTACTRIG_SCREENSHOTS`` when set (the manual's, Bench day, come from
``CONTACTRIG_SCREENSHOTS=contactrig/docs/img``), else to the test's temporary folder.
"""

from __future__ import annotations

import os
import shutil
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import pytest

from tests.console.conftest import HOSTILE, ConsoleProcess, scene_text

pytest.importorskip("selenium", reason="Selenium is not installed: pip install '.[console]'")

from selenium import webdriver
from selenium.common.exceptions import NoAlertPresentException
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

CHROMIUM = next((p for p in ("/usr/bin/chromium", shutil.which("chromium") or "") if p and os.path.exists(p)), None)
DRIVER = next((p for p in ("/usr/bin/chromedriver", shutil.which("chromedriver") or "") if p and os.path.exists(p)),
              None)  # fmt: skip
#: every browser test module's ``pytestmark``: slow, and skipped with the reason where Chromium is missing
BROWSER_MARKS = [
    pytest.mark.slow,
    pytest.mark.skipif(
        CHROMIUM is None or DRIVER is None,
        reason="Chromium not found (/usr/bin/chromium and /usr/bin/chromedriver): apt-get install -y chromium "
        "chromium-driver (.ci/run does it)",
    ),
]
pytestmark = BROWSER_MARKS
HOSTILE_TEXT = "".join(HOSTILE.values())


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("console") / "sessions"
    d.mkdir()
    (d / "small.toml").write_text(scene_text(), encoding="utf-8")
    (d / "slow.toml").write_text(scene_text(count=60, repeats=3), encoding="utf-8")
    hostile = scene_text(weights="[5.44]", repeats=1, sample=HOSTILE_TEXT, operator=HOSTILE["attr"])
    (d / "hostile.toml").write_text(hostile, encoding="utf-8")
    from analysis.simulated_session import SimulatedRigBench
    from daq.acquire import acquire

    acquire(d / "hostile.toml", d / 'x"><img src=x onerror=alert(2)>.h5', bench=SimulatedRigBench(float("inf")),
            yes=True, quiet=True)  # fmt: skip
    return d


def chrome(window: str = "1000,1000") -> webdriver.Chrome:
    """A headless Chromium of its own (its own profile, cookies and tabs) driven through the system's chromedriver."""
    # Both paths are given, so Selenium Manager is not consulted; offline, should a Selenium version ever do it.
    os.environ.setdefault("SE_OFFLINE", "true")
    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", f"--window-size={window}",
                "--disable-gpu"):  # fmt: skip
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(executable_path=str(DRIVER)), options=options)
    driver.set_page_load_timeout(30)
    return driver


def shot(driver: webdriver.Chrome, name: str, tmp_path: Path) -> None:
    out = Path(os.environ.get("CONTACTRIG_SCREENSHOTS") or tmp_path)
    out.mkdir(parents=True, exist_ok=True)
    driver.save_screenshot(str(out / f"console-{name}.png"))


def wait(driver: webdriver.Chrome, condition: Any, timeout: float = 60) -> Any:
    return WebDriverWait(driver, timeout, poll_frequency=0.05).until(condition)


def no_dialog(driver: webdriver.Chrome) -> None:
    try:
        text = driver.switch_to.alert.text
    except NoAlertPresentException:
        return
    raise AssertionError(f"a dialog fired: {text!r}")


def open_console(driver: webdriver.Chrome, console: ConsoleProcess, hash_: str = "#/sessions") -> None:
    driver.get(f"{console.base}/?token={console.token}")  # sets the cookie, redirects to the bare URL
    driver.get(f"{console.base}/{hash_}")


def text_of(driver: webdriver.Chrome, css: str) -> str:
    return str(driver.find_element(By.CSS_SELECTOR, css).text)


def points(driver: webdriver.Chrome) -> int:
    return int(driver.find_element(By.ID, "plot").get_attribute("data-points") or 0)


def start_from_form(driver: webdriver.Chrome, scene: str, name: str, speed: str, tmp_path: Path | None = None,
                    blocks: int | None = None, **overrides: str) -> None:  # fmt: skip
    driver.get(driver.current_url.split("#")[0] + "#/new")
    wait(driver, lambda d: d.find_elements(By.CSS_SELECTOR, f"#scene option[value='{scene}']"))
    # the choice as a user makes it (value + change event), without leaving the select's pop-up open in screenshots
    driver.execute_script("const s = document.getElementById('scene'); s.value = arguments[0];"
                          "s.dispatchEvent(new Event('change'));", scene)  # fmt: skip
    field = driver.find_element(By.ID, "sim-speed")
    field.clear()
    field.send_keys(speed)
    driver.find_element(By.ID, "output").clear()
    driver.find_element(By.ID, "output").send_keys(name)
    for key, value in overrides.items():  # this run's sample, operator… over the scene (daq.overrides)
        driver.find_element(By.ID, f"ov-session-{key}").send_keys(value)
    driver.find_element(By.ID, "scene").click()
    wait(driver, lambda d: ("estimated duration" in text_of(d, "#plan") and "slow" not in scene) or True)
    wait(driver, lambda d: "plan:" in text_of(d, "#plan") and (blocks is None or f"plan: {blocks} blocks" in
                                                               text_of(d, "#plan")))  # fmt: skip
    if tmp_path is not None:
        driver.find_element(By.TAG_NAME, "h1").click()
        shot(driver, "new-session", tmp_path)
    driver.find_element(By.ID, "start").click()
    wait(driver, lambda d: "#/run/" in d.current_url)


def continue_all(driver: webdriver.Chrome, timeout: float = 90) -> list[int]:
    """Click Continue at each weight until the run ends; the plot's point count seen after each click."""
    seen = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if driver.find_elements(By.ID, "stop-record"):
            seen.append(points(driver))
            return seen
        buttons = driver.find_elements(By.ID, "btn-continue")
        if buttons:
            seen.append(points(driver))
            try:
                buttons[0].click()
            except Exception:  # replaced by a newer state between finding and clicking
                pass
        time.sleep(0.05)
    raise AssertionError("the run did not end")


def test_sessions_new_run_finished_report(browser, console, folder, tmp_path):
    open_console(browser, console)
    wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, "#sessions-table td.sample"))
    start_from_form(browser, "small.toml", "browser.h5", "20", tmp_path, blocks=6, sample="piston S-42, liner L-7",
                    operator="A. Tribologist", notes="first run after re-honing")  # fmt: skip
    wait(browser, lambda d: d.find_elements(By.ID, "btn-continue"))
    assert "Place 5.44 kg" in text_of(browser, "#weight")
    browser.find_element(By.ID, "btn-continue").click()
    wait(browser, lambda d: points(d) >= 1)
    wait(browser, lambda d: d.find_elements(By.ID, "btn-continue"))
    shot(browser, "running", tmp_path)
    seen = continue_all(browser)
    assert seen[-1] == 6 and seen[0] >= 2 and seen == sorted(seen), seen  # the live plot grew, block by block
    assert "success" in text_of(browser, "#stop-record")
    browser.find_element(By.ID, "to-session").click()
    wait(browser, lambda d: "success" in text_of(d, "#session-status"))
    assert text_of(browser, "#session-sample") == "piston S-42, liner L-7"  # the form's override, recorded
    browser.find_element(By.ID, "btn-fit").click()
    wait(browser, lambda d: "Greenwood" in text_of(d, "#action-output"), timeout=240)  # the table as `fit` prints it
    shot(browser, "finished", tmp_path)
    browser.find_element(By.ID, "btn-report").click()
    wait(browser, lambda d: d.find_elements(By.ID, "report-link"), timeout=240)
    browser.get(browser.find_element(By.ID, "report-link").get_attribute("href"))
    wait(browser, lambda d: "browser.h5" in d.page_source or "R_s" in d.page_source)
    shot(browser, "report", tmp_path)
    assert (folder / "browser-report" / "report.html").is_file()


def test_stop_after_a_block_and_resume(browser, console, folder):
    from daq.session_file import load_session

    open_console(browser, console)
    start_from_form(browser, "slow.toml", "stopped.h5", "20")
    wait(browser, lambda d: d.find_elements(By.ID, "btn-continue")).__getitem__(0).click()
    wait(browser, lambda d: points(d) >= 1)
    browser.find_element(By.ID, "btn-stop-after").click()
    wait(browser, lambda d: d.find_elements(By.ID, "stop-record"))
    assert "stopped after the block" in text_of(browser, "#stop-record")
    with pytest.warns(Warning):
        stopped = load_session(folder / "stopped.h5")
    assert stopped.status == "aborted" and 1 <= len(stopped.summary) < 9
    browser.get(f"{console.base}/#/sessions")
    row = wait(browser, lambda d: d.find_elements(By.XPATH, "//tr[td/a[text()='stopped.h5']]//button"))
    row[0].click()
    wait(browser, lambda d: "#/run/" in d.current_url)
    continue_all(browser)
    assert "success" in text_of(browser, "#stop-record")
    done = load_session(folder / "stopped.h5")
    assert done.status == "success" and done.sealed and len(done.summary) == 9


def test_hostile_strings_stay_inert(browser, console, folder, tmp_path):
    open_console(browser, console)
    cell = wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, "#sessions-table td.sample"))
    no_dialog(browser)
    samples = [c.get_attribute("textContent") for c in browser.find_elements(By.CSS_SELECTOR, "td.sample")]
    assert HOSTILE_TEXT in samples, samples  # the DOM shows the text itself
    assert cell and not browser.find_elements(By.CSS_SELECTOR, "#main img, #main script")
    link = browser.find_element(By.XPATH, "//a[contains(text(), 'onerror=alert(2)')]")
    link.click()
    wait(browser, lambda d: d.find_elements(By.ID, "session-sample"))
    no_dialog(browser)
    assert browser.find_element(By.ID, "session-sample").get_attribute("textContent") == HOSTILE_TEXT
    assert not browser.find_elements(By.CSS_SELECTOR, "#main img, #main script")
    assert browser.execute_script("return typeof window.__xss") == "undefined"


def test_request_without_token_is_refused(browser, console):
    with pytest.raises(urllib.error.HTTPError) as err:
        console.api("/api/sessions", token=False)
    assert err.value.code == 403
    browser.delete_all_cookies()
    browser.get(f"{console.base}/")
    assert "403" in browser.find_element(By.TAG_NAME, "body").text
    browser.get(f"{console.base}/?token=wrong")
    assert "403" in browser.find_element(By.TAG_NAME, "body").text


def test_a_closed_tab_leaves_a_complete_sealed_file(browser, console, folder, tmp_path):
    """The tab that started the session is closed mid-session; the session goes on (answered from elsewhere) and
    the file is complete, sealed, and has the block checksums of a session run without the console."""
    from analysis.simulated_session import SimulatedRigBench
    from daq.acquire import acquire
    from daq.session_file import load_session

    open_console(browser, console)
    first = browser.current_window_handle
    start_from_form(browser, "small.toml", "closed-tab.h5", "20")
    run = browser.current_url.rsplit("/", 1)[1]
    wait(browser, lambda d: d.find_elements(By.ID, "btn-continue"))[0].click()
    browser.switch_to.new_window("tab")
    other = browser.current_window_handle
    browser.switch_to.window(first)
    browser.close()  # mid-session: the first weight's blocks are being measured
    browser.switch_to.window(other)
    deadline = time.monotonic() + 60
    while (state := console.api(f"/api/runs/{run}"))["phase"] != "ended" and time.monotonic() < deadline:
        if state["prompt"] is not None:
            console.api(f"/api/runs/{run}/answer", {"decision": "go", "prompt": state["prompt"]["id"]})
        time.sleep(0.05)
    assert state["stop"]["status"] == "success", state
    plain = tmp_path / "plain.h5"
    acquire(folder / "small.toml", plain, bench=SimulatedRigBench(float("inf")), yes=True, quiet=True)
    a, b = load_session(folder / "closed-tab.h5"), load_session(plain)
    assert a.sealed and a.status == "success" and len(a.summary) == 6
    assert list(a.summary["sha256"]) == list(b.summary["sha256"])


def test_skip_asks_to_confirm_as_the_terminal_does(browser, console, tmp_path):
    open_console(browser, console)
    start_from_form(browser, "small.toml", "skip.h5", "inf")
    wait(browser, lambda d: d.find_elements(By.ID, "btn-skip"))[0].click()
    browser.find_element(By.XPATH, "//button[starts-with(text(), 'No,')]").click()  # not skipped: still asked
    assert "Place 5.44 kg" in text_of(browser, "#weight") and not browser.find_elements(By.ID, "btn-confirm-skip")
    browser.find_element(By.ID, "btn-skip").click()
    browser.find_element(By.ID, "btn-confirm-skip").click()
    wait(browser, lambda d: "Place 10.526 kg" in text_of(d, "#weight"))
    continue_all(browser)
    assert "skipped by the operator: 5.44 kg" in text_of(browser, "#stop-record")
    browser.find_element(By.ID, "to-session").click()  # past sessions of the same sample, overlaid on request
    wait(browser, lambda d: d.find_elements(By.ID, "session-status"))
    browser.find_element(By.ID, "overlay").click()
    wait(browser, lambda d: int(d.find_element(By.ID, "plot").get_attribute("data-overlaid") or 0) >= 1)
    browser.get(f"{console.base}/#/sessions")  # every session of this module's tests, the hostile one among them
    wait(browser, lambda d: len(d.find_elements(By.CSS_SELECTOR, "#sessions-table td.sample")) >= 4)
    shot(browser, "sessions", tmp_path)
