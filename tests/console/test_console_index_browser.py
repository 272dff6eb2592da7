"""The console's index in a browser (issue 29): a folder of a few hundred generated sessions (hard links of a few
real ones, some damaged), its page opened, searched with the filters, a tag added on a session's page, and two
sessions compared — the diff names the one instrument setting that differs. Then the bench's queue: two planned
sessions, reordered, one cancelled, the other started with Start."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from tests.console.conftest import scene_text
from tests.console.test_console_browser import BROWSER_MARKS, continue_all, open_console, shot, text_of, wait
from tests.daq.run_files import write_run

pytest.importorskip("selenium", reason="Selenium is not installed: pip install '.[console]'")

from selenium import webdriver
from selenium.webdriver.common.by import By

pytestmark = BROWSER_MARKS
#: generated session files (hard links), 1 in 50 damaged
N_FILES = 300


def _build(folder: Path) -> None:
    src = folder / "originals"
    src.mkdir()
    sources = [write_run(src / f"s{i}.h5", sample=f"sample-{i}", operator=("ann", "bob", "chen")[i % 3],
                         notes="liner re-honed" if i == 2 else "", started=f"2026-01-{1 + i:02d}T10:00:00.000+00:00")
               for i in range(4)]  # fmt: skip
    write_run(folder / "pair-a.h5", sample="pair", started="2026-02-01T10:00:00.000+00:00")
    write_run(folder / "pair-b.h5", sample="pair", nplc="2.0", started="2026-02-02T10:00:00.000+00:00")
    data = sources[0].read_bytes()
    for k in range(N_FILES):
        sub = folder / f"day{k // 100:02d}"
        sub.mkdir(exist_ok=True)
        out = sub / f"run{k:04d}.h5"
        if k % 50 == 7:
            out.write_bytes(data[: len(data) // 2])  # truncated: damaged
        else:
            os.link(sources[k % len(sources)], out)
    old = time.time() - 3600  # settled: a file changed in the last 2 s is read again at every refresh
    for p in folder.rglob("*.h5"):
        os.utime(p, (old, old))


BROWSER_WINDOW = "1200,1000"  # the window of the conftest's browser fixture


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from daq.run_index import refresh

    d = tmp_path_factory.mktemp("index") / "lab"
    d.mkdir()
    (d / "small.toml").write_text(scene_text(), encoding="utf-8")
    _build(d)
    t = time.perf_counter()
    r = refresh(d)
    print(f"\nfirst index of {r.read} files: {time.perf_counter() - t:.1f} s")
    return d


def rows(driver: webdriver.Chrome) -> list[str]:
    """The file names in the index table (read in one step: the table may be redrawn meanwhile)."""
    script = "return [...document.querySelectorAll('#sessions-table td.text a')].map((a) => a.textContent);"
    return list(driver.execute_script(script))


def fill(driver: webdriver.Chrome, id_: str, value: str) -> None:
    box = driver.find_element(By.ID, id_)
    box.clear()
    if value:
        box.send_keys(value)


def test_search_tag_and_diff_on_a_folder_of_sessions(browser, console, folder, tmp_path):
    total = N_FILES + 6  # the links, the originals and the pair
    open_console(browser, console)
    wait(browser, lambda d: len(rows(d)) == total)
    browser.get("about:blank")
    t = time.perf_counter()
    browser.get(f"{console.base}/#/sessions")
    wait(browser, lambda d: len(rows(d)) == total)
    opened = time.perf_counter() - t
    print(f"index page of {total} sessions opened (page loaded, every row drawn) in {opened:.2f} s")
    assert opened < 3.0  # target ≤ 1 s; the shared test machine is loaded
    assert len(browser.find_elements(By.CSS_SELECTOR, "#sessions-table td.corrupt")) == N_FILES // 50
    assert rows(browser)[:2] == ["pair-b.h5", "pair-a.h5"]  # the newest first
    fill(browser, "f-text", "re-honed")  # full text in notes: the links of s2 and s2 itself
    wait(browser, lambda d: len(rows(d)) == N_FILES // 4 + 1)
    assert all(r.endswith(("s2.h5",)) or r.startswith("day") for r in rows(browser))
    fill(browser, "f-operator", "chen")  # and operator~chen: s2 is chen's
    wait(browser, lambda d: len(rows(d)) == N_FILES // 4 + 1)
    fill(browser, "f-operator", "bob")
    wait(browser, lambda d: "(no session matches)" in text_of(d, "#sessions-table"))
    fill(browser, "f-operator", "")
    fill(browser, "f-text", "")
    browser.execute_script("const s = document.getElementById('f-status'); s.value = 'corrupt';"
                           "s.dispatchEvent(new Event('change'));")  # fmt: skip
    wait(browser, lambda d: len(rows(d)) == N_FILES // 50)
    browser.execute_script("const s = document.getElementById('f-status'); s.value = '';"
                           "s.dispatchEvent(new Event('change'));")  # fmt: skip
    fill(browser, "f-sample", "pair")
    wait(browser, lambda d: rows(d) == ["pair-b.h5", "pair-a.h5"])
    # a tag on one session's page, then found by the tag filter with who wrote it
    browser.find_element(By.LINK_TEXT, "pair-b.h5").click()
    wait(browser, lambda d: d.find_elements(By.ID, "mark-text"))
    fill(browser, "mark-text", "nplc2")
    fill(browser, "mark-who", "A. Tribologist")
    browser.find_element(By.ID, "btn-mark").click()
    wait(browser, lambda d: "nplc2 — A. Tribologist" in text_of(d, "#marks"))
    browser.get(f"{console.base}/#/sessions")
    fill(browser, "f-tag", "nplc2")
    wait(browser, lambda d: rows(d) == ["pair-b.h5"])
    tag = browser.find_element(By.CSS_SELECTOR, "#sessions-table span.tag")
    assert tag.text == "nplc2" and tag.get_attribute("title").startswith("A. Tribologist, ")
    # any value recorded at the start, by the name the diff gives it; a bad one says why in the page
    fill(browser, "f-tag", "")
    fill(browser, "f-sample", "pair")
    fill(browser, "f-value", "settings.delta.nplc>=2")
    wait(browser, lambda d: rows(d) == ["pair-b.h5"])
    fill(browser, "f-value", "settings.delta.nplc>=fast")
    wait(browser, lambda d: "NUMBER" in text_of(d, "#index-state"))
    fill(browser, "f-value", "")
    # why do these two runs differ?
    fill(browser, "f-tag", "")
    fill(browser, "f-sample", "pair")
    wait(browser, lambda d: rows(d) == ["pair-b.h5", "pair-a.h5"])
    for box in browser.find_elements(By.CSS_SELECTOR, "#sessions-table input.pick")[::-1]:
        box.click()
    shot(browser, "index-search", tmp_path)
    browser.find_element(By.ID, "btn-compare").click()
    wait(browser, lambda d: d.find_elements(By.ID, "diff-table"))
    fields = [c.text for c in browser.find_elements(By.CSS_SELECTOR, "#diff-table td.field")]
    assert [f for f in fields if f.startswith("settings.")] == ["settings.delta.nplc"], fields
    assert "A: pair-a.h5" in text_of(browser, "#diff-table") and "B: pair-b.h5" in text_of(browser, "#diff-table")
    row = browser.find_element(By.XPATH, "//tr[td[text()='settings.delta.nplc']]")
    assert [c.text for c in row.find_elements(By.TAG_NAME, "td")] == ["settings.delta.nplc", "1", "2"]  # JSON numbers
    shot(browser, "diff", tmp_path)


def queued(driver: webdriver.Chrome) -> list[str]:
    script = "return [...document.querySelectorAll('#queue-table tr.queued td:nth-child(2)')].map((c) => c.textContent)"
    return list(driver.execute_script(script))


def test_the_queue_page(browser, console, folder, tmp_path):
    open_console(browser, console, "#/new")
    for name in ("plan-1.h5", "plan-2.h5"):
        browser.get(f"{console.base}/#/new")
        wait(browser, lambda d: "plan:" in text_of(d, "#plan"))
        fill(browser, "sim-speed", "inf")
        fill(browser, "output", name)
        browser.find_element(By.ID, "queue-wait").click()
        browser.find_element(By.ID, "btn-enqueue").click()
        wait(browser, lambda d, n=name: n in queued(d))
    assert queued(browser) == ["plan-1.h5", "plan-2.h5"]
    assert "waits for your Start" in text_of(browser, "#queue-table")
    browser.find_elements(By.CSS_SELECTOR, "#queue-table button.down")[0].click()
    wait(browser, lambda d: queued(d) == ["plan-2.h5", "plan-1.h5"])
    shot(browser, "queue", tmp_path)
    browser.find_elements(By.CSS_SELECTOR, "#queue-table button.cancel")[1].click()
    wait(browser, lambda d: queued(d) == ["plan-2.h5"])
    browser.find_element(By.CSS_SELECTOR, "#queue-table button.start").click()
    link = wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, "#queue-started a.started"))
    assert link[0].text == "plan-2.h5" and queued(browser) == []
    link[0].click()
    wait(browser, lambda d: "#/run/" in d.current_url)
    continue_all(browser)
    assert "success" in text_of(browser, "#stop-record")
    assert not (folder / "plan-1.h5").exists()
