"""The console's index and search on a folder of 10 000 session files, in a browser (issue 29's acceptance).

The folder is the run-index benchmark's (:func:`tests.daq.run_files.build_lab`: hard links of 20 real sessions,
1 % damaged: a truncated copy at ``k % 100 == 37``, garbage at ``k % 100 == 73``), indexed once before the console
starts. That is the cost of this test: 10 000 bounded reads, two at once, ~6.3 ms of CPU a file — 104–116 s on the
shared 2-core development machine at load 5–6 (the whole test 2.5 min), about 35–40 s estimated on two free cores.
Times are printed, never asserted: speed is the benchmark's (``tests/benchmarks/bench_run_index.py``).

The page must show how many sessions match and the first page of rows, list the damaged files as damaged, narrow a
search (sample, tag, full text in the notes) to exactly the sessions ``daq.run_index.query`` finds on the same
folder, in the same order, and page through every match.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from tests.console.test_console_browser import BROWSER_MARKS, open_console, shot, text_of, wait
from tests.console.test_console_index_browser import fill, rows
from tests.daq.run_files import build_lab

pytest.importorskip("selenium", reason="Selenium is not installed: pip install '.[console]'")

from selenium import webdriver
from selenium.webdriver.common.by import By

pytestmark = BROWSER_MARKS
N_FILES = 10_000
DISTINCT = 20
#: rows on one page of the console's index (contactrig.console.catalog.PAGE_ROWS)
PAGE = 500


BROWSER_WINDOW = "1200,1000"  # the window of the conftest's browser fixture


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from daq.run_index import add_mark, refresh

    d = tmp_path_factory.mktemp("index10k") / "lab"
    d.mkdir()
    t = time.perf_counter()
    build_lab(d, N_FILES, DISTINCT)
    # a tag on one session: every link of it carries it (a tag belongs to the session's content id)
    add_mark(d / "day000" / "run00004.h5", "tag", "re-honed-liner", who="test")
    print(f"\n{N_FILES} files built in {time.perf_counter() - t:.1f} s")
    t = time.perf_counter()
    r = refresh(d)
    print(f"first index of {r.read} files: {time.perf_counter() - t:.1f} s (load average {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} cores)")  # fmt: skip
    return d


def expected(folder: Path, *where: str) -> list[str]:
    """The paths (relative to ``folder``) that ``daq.run_index.query`` finds, as the page sorts them: newest first."""
    from daq.run_index import query

    found, _ = query(folder, list(where), refresh=False, descending=True, detail=False)
    return [Path(r["path"]).relative_to(folder).as_posix() for r in found]


def statuses(driver: webdriver.Chrome) -> dict[str, tuple[str, str]]:
    """File name → (class, text) of its status cell, for every row of the table (read in one step)."""
    script = (
        "return [...document.querySelectorAll('#sessions-table tr')].filter((r) => r.querySelector('td.text a'))"
        ".map((r) => [r.querySelector('td.text a').textContent, r.children[2].className, r.children[2].textContent]);"
    )
    return {p: (c, t) for p, c, t in driver.execute_script(script)}


def emptied(driver: webdriver.Chrome, id_: str) -> None:
    """A filter box emptied as a user does it (an ``input`` event: Selenium's ``clear`` sends none)."""
    driver.execute_script("const b = document.getElementById(arguments[0]); b.value = '';"
                          "b.dispatchEvent(new Event('input'));", id_)  # fmt: skip


def count(driver: webdriver.Chrome) -> str:
    return text_of(driver, "#index-count")


def shown(n: int, offset: int, matched: int) -> str:
    return f"{matched} session{'' if matched == 1 else 's'} match" + (f"; shown {offset + 1}–{offset + n}" if n else "")


def every_page(driver: webdriver.Chrome, want: list[str]) -> list[str]:
    """The rows of every page, from the first to the last with "next page", each page checked against ``want``."""
    seen: list[str] = []
    for offset in range(0, len(want), PAGE):
        page = want[offset : offset + PAGE]
        wait(driver, lambda d, p=page, o=offset: rows(d) == p and count(d) == shown(len(p), o, len(want)))
        seen += rows(driver)
        assert driver.find_element(By.ID, "page-prev").is_enabled() == (offset > 0)
        last = offset + PAGE >= len(want)
        assert driver.find_element(By.ID, "page-next").is_enabled() == (not last)
        if not last:
            driver.find_element(By.ID, "page-next").click()
    return seen


def first_page(driver: webdriver.Chrome) -> None:
    while driver.find_element(By.ID, "page-prev").is_enabled():
        driver.find_element(By.ID, "page-prev").click()
        time.sleep(0.05)


def test_index_and_search_on_10000_sessions(browser, console, folder, tmp_path):
    everything = expected(folder)
    damaged = {f"day{k // 100:03d}/run{k:05d}.h5" for k in range(N_FILES) if k % 100 in (37, 73)}
    assert len(everything) == N_FILES  # the originals the links were made from are in .sources: not indexed
    open_console(browser, console, "#/")
    browser.get("about:blank")
    t = time.perf_counter()
    browser.get(f"{console.base}/#/sessions")
    wait(browser, lambda d: rows(d) == everything[:PAGE] and count(d) == shown(PAGE, 0, len(everything)))
    print(f"index page of {len(everything)} sessions opened (count and first {PAGE} rows drawn) in "
          f"{time.perf_counter() - t:.2f} s")  # fmt: skip
    shot(browser, "index-10k", tmp_path)
    # damaged files: listed, as damaged (unreadable files come last: the last pages)
    corrupt = expected(folder, "status=corrupt")
    assert set(corrupt) == damaged
    browser.execute_script("const s = document.getElementById('f-status'); s.value = 'corrupt';"
                           "s.dispatchEvent(new Event('change'));")  # fmt: skip
    wait(browser, lambda d: rows(d) == corrupt[:PAGE] and count(d) == shown(min(PAGE, len(corrupt)), 0, len(corrupt)))
    assert set(statuses(browser).values()) == {("corrupt", "CORRUPT")}
    browser.execute_script("const s = document.getElementById('f-status'); s.value = '';"
                           "s.dispatchEvent(new Event('change'));")  # fmt: skip
    # paging: every one of the sessions once, in the order of the query, the damaged ones last and marked damaged
    wait(browser, lambda d: rows(d) == everything[:PAGE])
    assert every_page(browser, everything) == everything
    last = statuses(browser)  # the last page: the damaged files come last, each marked CORRUPT
    assert {p for p, (c, t) in last.items() if (c, t) == ("corrupt", "CORRUPT")} == damaged
    first_page(browser)
    wait(browser, lambda d: rows(d) == everything[:PAGE])
    # searches: each narrows to exactly the sessions the query finds, page after page
    for box, value, where in (
        ("f-sample", "sample-3", "sample~sample-3"),
        ("f-tag", "re-honed-liner", "tag=re-honed-liner"),
        ("f-text", "re-honed", "text~re-honed"),
    ):
        want = expected(folder, where)
        assert 0 < len(want) < len(everything), where
        fill(browser, box, value)
        assert every_page(browser, want) == want, where
        emptied(browser, box)
        wait(browser, lambda d: count(d) == shown(PAGE, 0, len(everything)))
    # two filters at once: the intersection
    want = expected(folder, "sample~sample-0", "text~re-honed")
    fill(browser, "f-sample", "sample-0")
    fill(browser, "f-text", "re-honed")
    assert every_page(browser, want) == want
    shot(browser, "index-10k-search", tmp_path)
