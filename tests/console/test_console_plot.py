"""The console's plot and session pages in a real browser (issue 26 items 4–6): block numbers and SEM as the terminal
prints them, a resumed session's plot with every run, the chart (uPlot, served from the package) with ticks, units,
tooltips and zoom, the models' curves after a fit, and a session started in a terminal followed live.

Browser setup (system Chromium, Selenium, the console as a child process) as tests/console/test_console_browser.py.
"""

from __future__ import annotations

import itertools
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.console.conftest import ROOT, scene_text
from tests.console.test_console_browser import continue_all, open_console, shot, text_of, wait

pytest.importorskip("selenium", reason="Selenium is not installed: pip install '.[console]'")

from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By

from tests.console.test_console_browser import pytestmark  # noqa: F401  (slow; skipped without Chromium)

#: the terminal's live line: ``block 3/6  5.44 kg  repeat 3  R = 8.0913 mΩ ± 12.3 µΩ (SEM, n = 10)``
LIVE_LINE = re.compile(r"block (\d+)/\d+\s+([\d.]+) kg\s+repeat (\d+)\s+R = ([\d.]+ mΩ) ± (\S+ \S+) \(SEM")


def acquire_in_terminal(folder: Path, *args: str, stdin: str | None = None,
                        wait_for: bool = True) -> subprocess.Popen[bytes] | str:  # fmt: skip
    """``contactrig acquire`` as an operator types it, in its own process (the console does not start it)."""
    cmd = [sys.executable, "-m", "contactrig", "acquire", *args]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    if not wait_for:
        return subprocess.Popen(cmd, cwd=folder, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    out = subprocess.run(cmd, cwd=folder, input=stdin or "", capture_output=True, text=True, timeout=120, env=env)
    assert out.returncode in (0, 1), out.stderr
    return out.stdout + out.stderr


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("console-plot") / "sessions"
    d.mkdir()
    (d / "small.toml").write_text(scene_text(), encoding="utf-8")
    (d / "slow.toml").write_text(scene_text(count=60, repeats=3), encoding="utf-8")
    return d


def plot_attr(driver, name: str) -> str:
    return str(driver.find_element(By.ID, "plot").get_attribute(f"data-{name}") or "")


def test_a_resumed_sessions_plot_shows_every_block_on_file_numbered_as_the_terminal(browser, console, folder):
    """Run 0 in a terminal, stopped by the operator (q) after the first weight; resumed from the console: the live
    plot holds run 0's blocks and run 1's, the last block's line and the Blocks table number them 1-based and give
    R ± SEM exactly as the terminal's live lines did."""
    terminal = acquire_in_terminal(folder, "small.toml", "--sim", "--sim-speed", "inf", "-o", "resumed.h5",
                                   "--notes", "after re-honing, run 0", stdin="\nq\n")  # fmt: skip
    first = [m.groups() for m in map(LIVE_LINE.search, str(terminal).splitlines()) if m]
    assert [int(n) for n, *_ in first] == [1, 2], terminal
    open_console(browser, console)
    row = wait(browser, lambda d: d.find_elements(By.XPATH, "//tr[td/a[text()='resumed.h5']]//button"))
    row[0].click()
    wait(browser, lambda d: "#/run/" in d.current_url)
    continue_all(browser)
    assert "success" in text_of(browser, "#stop-record")
    wait(browser, lambda d: plot_attr(d, "runs") == "0,1")
    assert plot_attr(browser, "blocks") == "6" and plot_attr(browser, "points") == "6"
    assert text_of(browser, "#block").startswith("last block 6/6: 25.966 kg repeat 2")
    browser.find_element(By.ID, "to-session").click()
    wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, "#blocks tr td"))
    assert text_of(browser, "#session-notes") == "after re-honing, run 0"
    assert plot_attr(browser, "runs") == "0,1"
    cells = [[td.text for td in tr.find_elements(By.TAG_NAME, "td")]
             for tr in browser.find_elements(By.CSS_SELECTOR, "#blocks tr")[1:]]  # fmt: skip
    assert [c[0] for c in cells] == ["1", "2", "3", "4", "5", "6"] and [c[1] for c in cells] == ["0", "0", *"1111"]
    for number, weight, repeat, mean, sem in first:  # the page says what the terminal said, block for block
        row = cells[int(number) - 1]
        assert (row[2], row[3], row[4], row[5]) == (weight, repeat, mean, sem), (row, terminal)
    assert all(c[5].endswith(("nΩ", "µΩ")) for c in cells), cells  # a SEM of nanoohms is shown, not "0.0000 mΩ"


def test_the_chart_has_ticks_units_tooltips_zoom_and_the_fitted_curves(browser, console, folder, tmp_path):
    acquire_in_terminal(folder, "small.toml", "--sim", "--sim-speed", "inf", "--yes", "-o", "chart.h5")
    from daq.session_file import load_session

    summary = load_session(folder / "chart.h5").summary
    open_console(browser, console, "#/session/chart.h5")
    wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, "#plot .u-over"))
    # uPlot draws the scripts served by the console itself, no CDN
    assert browser.execute_script("return typeof uPlot") == "function"
    scripts = browser.execute_script("return [...document.scripts].map((s) => s.src)")
    assert all(s.startswith(console.base + "/static/") for s in scripts), scripts
    u = "document.getElementById('plot')._uplot"
    labels = browser.execute_script(f"return {u}.axes.map((a) => a.label)")
    assert labels == ["weight on the piston [kg]", "R [mΩ]"]
    ticks = browser.execute_script(f"return {u}.axes.map((a) => a._values)")
    splits = browser.execute_script(f"return {u}.axes.map((a) => a._splits)")
    weights = sorted(set(summary["weight_kg"]))
    r_mohm = summary["mean_ohm"].to_numpy() * 1e3
    assert len(ticks[0]) >= 4 and len(ticks[1]) >= 4, ticks
    scales = browser.execute_script(f"return [{u}.scales.x.min, {u}.scales.x.max, {u}.scales.y.min, {u}.scales.y.max]")
    assert scales[0] < weights[0] and scales[1] > weights[-1], scales  # every weight in view
    assert scales[2] < r_mohm.min() and scales[3] > r_mohm.max(), scales  # every block, in mΩ
    for (lo, hi), split in zip([scales[:2], scales[2:]], splits, strict=True):
        steps = [b - a for a, b in itertools.pairwise(split)]
        assert lo <= split[0] and split[-1] <= hi and max(steps) - min(steps) < 1e-9 * max(steps), split
    # hover the second weight: the tooltip names its blocks (1-based, as the terminal) and their values
    x = browser.execute_script(f"return {u}.valToPos(arguments[0], 'x')", weights[1])
    over = browser.find_element(By.CSS_SELECTOR, "#plot .u-over")
    size = over.size
    ActionChains(browser).move_to_element_with_offset(over, int(x - size["width"] / 2), 0).perform()
    tip = wait(browser, lambda d: d.find_element(By.ID, "plot-tooltip").text or None, timeout=10)
    at = summary[summary["weight_kg"] == weights[1]]
    for _, b in at.iterrows():
        number, repeat = int(b["block"]) + 1, int(b["repeat"])  # the file's 0-based position, read 1-based
        assert f"block {number} (run 0, repeat {repeat}): R = {b['mean_ohm'] * 1e3:.4f} mΩ" in tip, tip
    assert f"{weights[1]:g} kg" in tip and "mean of 2 repeat(s)" in tip, tip
    shot(browser, "plot-tooltip", tmp_path)
    # zoom: a drag narrows the weight axis, a double-click zooms out again
    before = browser.execute_script(f"return [{u}.scales.x.min, {u}.scales.x.max]")
    ActionChains(browser).move_to_element_with_offset(over, -size["width"] // 3, -20).click_and_hold() \
        .move_by_offset(size["width"] // 4, 40).release().perform()  # fmt: skip
    zoomed = browser.execute_script(f"return [{u}.scales.x.min, {u}.scales.x.max]")
    assert zoomed[1] - zoomed[0] < 0.5 * (before[1] - before[0]), (before, zoomed)
    ActionChains(browser).double_click(over).perform()
    span = before[1] - before[0]
    wait(browser, lambda d: d.execute_script(f"return {u}.scales.x.max - {u}.scales.x.min") >= 0.99 * span)
    # the fit's models over the data, each a series of the chart
    browser.find_element(By.ID, "btn-fit").click()
    wait(browser, lambda d: int(plot_attr(d, "curves") or 0) >= 4, timeout=240)
    series = browser.execute_script(f"return {u}.series.map((s) => s.label)")
    assert "fit: Greenwood–Tripp" in series and "mean ± 1 SEM" in series and "repeat 2" in series, series
    browser.execute_script("document.getElementById('plot').scrollIntoView()")
    shot(browser, "plot-fit", tmp_path)


def test_the_page_formats_a_resistance_as_the_terminal_does(browser, console):
    """One rule: plot.js's formatOhm (tooltip's SEM over repeats) against daq.engine.format_ohm, over 16 decades."""
    from daq.engine import format_ohm

    open_console(browser, console)
    wait(browser, lambda d: d.execute_script("return typeof Plot") == "object")
    values = [s * 10.0**e for e in range(-13, 3) for s in (1.0, 1.234, 4.6749, 9.996, 0.5)]
    page = browser.execute_script("return arguments[0].map((x) => Plot.formatOhm(x))", values)
    assert page == [format_ohm(v) for v in values]


def test_a_session_started_in_a_terminal_is_followed_live(browser, console, folder, tmp_path):
    """``contactrig acquire`` in another process: the index offers to follow it; its page shows status, blocks and
    ETA as they come, read from the file, and no control (Continue/Stop stay with the terminal)."""
    proc = acquire_in_terminal(folder, "slow.toml", "--sim", "--sim-speed", "1", "--yes", "-o", "terminal.h5",
                               wait_for=False)  # fmt: skip
    assert isinstance(proc, subprocess.Popen)
    try:
        open_console(browser, console)
        deadline = time.monotonic() + 60
        while not browser.find_elements(By.XPATH, "//tr[td/a[text()='terminal.h5']]//a[@class='follow']"):
            assert time.monotonic() < deadline and proc.poll() is None, (
                f"the running session is not offered to follow: {proc.poll()}, {browser.page_source[-3000:]}"
            )
            wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, "#sessions-table tr"))  # the index is read
            if not browser.find_elements(By.XPATH, "//tr[td/a[text()='terminal.h5']]//a[@class='follow']"):
                time.sleep(0.3)
                browser.refresh()
        browser.find_element(By.XPATH, "//tr[td/a[text()='terminal.h5']]//a[@class='follow']").click()
        wait(browser, lambda d: "running" in text_of(d, "#follow-status"))
        seen, statuses = [], []
        deadline = time.monotonic() + 60
        while "running" in (status := text_of(browser, "#follow-status")) and time.monotonic() < deadline:
            seen.append(int(plot_attr(browser, "points") or 0))
            statuses.append(status)
            time.sleep(0.3)
        assert any(re.search(r"ETA \d+ s", s) for s in statuses), statuses  # from the second block on
        assert "control stays with that process" in text_of(browser, "#follow-who")
        assert "acquire slow.toml" in text_of(browser, "#follow-who")
        for button in ("btn-continue", "btn-skip", "btn-quit", "btn-stop-after", "btn-stop-now"):
            assert not browser.find_elements(By.ID, button)
        assert max(seen) >= 2 and min(seen) < 9, seen  # blocks appeared while it ran
        assert seen == sorted(seen), seen
        shot(browser, "follow", tmp_path)
        wait(browser, lambda d: "success" in text_of(d, "#follow-status"), timeout=60)
        assert plot_attr(browser, "points") == "9"
        assert "block 9/9" in text_of(browser, "#follow-line")
    finally:
        proc.wait(timeout=60)


def test_compliance_blocks_are_marked_named_and_left_out_of_the_mean(browser, console):
    """plot.js with blocks as the server sends them (view.block_row), one of them taken in compliance: it has no
    point and no part in the mean, the note under the chart names its number, the tooltip says it was excluded."""
    from contactrig.console.view import block_row

    rows = [block_row(0, 0, 5.44, 1, 8.1e-3, 1.2e-8, 10, 0, False),
            block_row(1, 0, 5.44, 2, 8.3e-3, 1.1e-8, 10, 0, False),
            block_row(2, 0, 10.526, 1, float("nan"), float("nan"), 0, 10, True),
            block_row(3, 0, 10.526, 2, 5.0e-3, 9e-9, 10, 0, False)]  # fmt: skip
    open_console(browser, console)
    wait(browser, lambda d: d.execute_script("return typeof Plot") == "object")
    got = browser.execute_script("""
        const holder = document.createElement("div"); holder.id = "plot-test"; document.body.append(holder);
        Plot.draw(holder, { blocks: arguments[0], weights: [5.44, 10.526, 25.966] });
        const u = holder._uplot, m = holder._model;
        return { compliance: holder.getAttribute("data-compliance"), points: holder.getAttribute("data-points"),
                 note: holder.querySelector(".plot-note").textContent, data: u.data,
                 labels: u.series.map((s) => s.label), tip: Plot.tooltipLines(m, 1) };
    """, rows)  # fmt: skip
    assert got["compliance"] == "1" and got["points"] == "3"
    assert got["note"].startswith("✕ compliance in block(s) 3: excluded")
    assert got["data"][0] == [5.44, 10.526, 25.966]
    mean = got["data"][got["labels"].index("mean ± 1 SEM")]
    assert mean[1] == pytest.approx(5.0) and mean[0] == pytest.approx(8.2)  # mΩ; the compliance block left out
    assert got["data"][got["labels"].index("repeat 1")][1] is None
    assert "block 3 (run 0, repeat 1): COMPLIANCE: excluded" in got["tip"]
    assert "mean of 1 repeat(s): 5.0000 mΩ" in got["tip"]
