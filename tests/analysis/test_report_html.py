"""The report as Markdown and self-contained HTML (issue #13), strings from files shown as data (issue #16), the
boundary-element verdicts and the resistance model's sentence in the report (issues #14, #15), one error-bar
convention, repeats labelled in Fig. 9, the stop record whole.

Expectations are independent of the code under test: the hostile strings are ours, parsed HTML is checked with the
standard library's parser, the stop record is compared with what the test wrote, the favoured model is recomputed
from the comparison's raw quantities, the resistance model's fit is checked against the σ_f and R_s the test put in.
"""

from __future__ import annotations

import base64
import html
import json
import re
from html.parser import HTMLParser
from types import SimpleNamespace

import numpy as np
import pytest

from contactrig.cli.main import main

W = np.array([5.0, 10.0, 15.0, 20.0])
SCRIPT = "<script>alert(1)</script>"
LINK = "](javascript:x)"
MARKUP = "**bold**\n# heading"
ANSI = "\x1b[31mred\x1b]0;pwned\x07"
CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")


def _run(argv):
    try:
        return main([str(a) for a in argv])
    except SystemExit as exc:
        return exc.code


class _Page(HTMLParser):
    """Every start tag with its attributes, and the text of the document and of each heading."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tags: list[tuple[str, dict[str, str | None]]] = []
        self.text: list[str] = []
        self.headings: list[str] = []
        self._in_heading = False

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        if re.fullmatch(r"h[1-6]", tag):
            self._in_heading = True
            self.headings.append("")

    def handle_endtag(self, tag):
        if re.fullmatch(r"h[1-6]", tag):
            self._in_heading = False

    def handle_data(self, data):
        self.text.append(data)
        if self._in_heading:
            self.headings[-1] += data


def _parse(text: str) -> _Page:
    page = _Page()
    page.feed(text)
    page.close()
    return page


def _shown_markdown(text: str) -> str:
    """What a Markdown renderer shows of escaped text: backslash escapes and entities resolved."""
    return html.unescape(re.sub(r"\\([!-/:-@\[-`{-~])", r"\1", text))


def _sweep_file(path, weights=W, warnings=()):
    from tests.analysis.sessions import write_toy_sweep

    return write_toy_sweep(path, weights, peak_pa=1e5, warnings=warnings)


STOP_REASON = f"operator stopped: {SCRIPT} {ANSI}"


def _hostile_session(path, weights=W, repeats=3, scene_text=""):
    """A complete session whose start and stop records carry markup, links, script and terminal escapes."""
    from daq.records import StopRecord, now_iso
    from tests.analysis.sessions import model_resistance, write_session

    rng = np.random.default_rng(0)
    start = {"started": now_iso(), "operator": SCRIPT, "sample": LINK, "host": MARKUP, "command": ANSI, "rig": ANSI}
    write_session(
        path,
        ((w, rep, model_resistance(w, rng, 0.02)) for rep in range(repeats) for w in weights),
        start=start,
        scene_text=scene_text,
        stop=lambda n: StopRecord(
            status="aborted", reason=STOP_REASON, stopped=now_iso(), blocks_planned=n + 4, blocks_done=n,
            readings_done=5 * n,
        ),
    )
    return path


@pytest.fixture(scope="module")
def hostile_report(tmp_path_factory):
    """``contactrig report`` of the hostile session (its file name hostile too) against a sweep whose warning
    carries terminal escapes; returns (folder, stdout, stderr, session path)."""
    import contextlib
    import io

    tmp = tmp_path_factory.mktemp("hostile")
    session = _hostile_session(tmp / "s<b>x\x1b[2J.h5")
    sim = _sweep_file(tmp / "sim.h5", warnings=[f"note from the file {ANSI} {SCRIPT}"])
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = _run(["report", session, "--sim", sim, "-o", tmp / "rep", "--bootstrap", "50", "--no-compare-models"])
    assert rc == 0, err.getvalue()
    return tmp / "rep", out.getvalue(), err.getvalue(), session


def test_html_report_is_one_self_contained_file_without_script(hostile_report):
    folder, _, _, _ = hostile_report
    text = (folder / "report.html").read_text(encoding="utf-8")
    page = _parse(text)
    tags = [t for t, _ in page.tags]
    assert "script" not in tags and not {"link", "iframe", "object", "embed", "base", "form"} & set(tags)
    images = [a for t, a in page.tags if t == "img"]
    assert len(images) >= 4  # Fig. 9, 11, 12 and the fit at least
    for attrs in images:
        src = attrs["src"] or ""
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
    for _, attrs in page.tags:
        for key in ("src", "href", "action", "poster", "data"):
            value = (attrs.get(key) or "").strip().lower()
            assert not value.startswith(("http:", "https:", "//", "javascript:", "file:")), (key, value)
        assert not any(k.startswith("on") for k in attrs)  # no event handler attributes
    assert tags.count("table") >= 3  # measured, area, fit
    assert "url(" not in text  # no external style resource either
    csp = [a for t, a in page.tags if t == "meta" and a.get("http-equiv") == "Content-Security-Policy"]
    assert csp and "default-src 'none'" in (csp[0]["content"] or "")


def test_strings_from_files_are_shown_literally_in_markdown_and_html(hostile_report):
    folder, _, _, _ = hostile_report
    md_all = (folder / "report.md").read_text(encoding="utf-8")
    # fenced code blocks show their content literally (the stop record's JSON is one); outside them, nothing live —
    # no raw tag, link target, bold, heading or escape sequence from the file
    fences = re.findall(r"^(`{3,})\w*\n.*?\n\1$", md_all, re.S | re.M)
    assert fences  # the stop record and the scene file
    md = re.sub(r"^(`{3,})\w*\n.*?\n\1$", "", md_all, flags=re.S | re.M)
    assert "\x1b" not in md_all
    assert "<script" not in md and "](javascript" not in md and "**bold**" not in md and "\x1b" not in md
    assert not any(line.lstrip().startswith("# heading") for line in md.splitlines())
    shown = _shown_markdown(md)
    for literal in (SCRIPT, LINK, "**bold** # heading"):  # the line break of a one-line field becomes a space
        assert literal in shown, literal
    assert "\\x1b[31mred" in shown  # the escape sequence as visible text
    # HTML: the parsed document shows the strings as text; no element came from them
    page = _parse((folder / "report.html").read_text(encoding="utf-8"))
    text = "".join(page.text)
    for literal in (SCRIPT, LINK, "**bold**", "# heading"):
        assert literal in text, literal
    assert not any("heading" in h and "bold" in h for h in page.headings)
    assert not CONTROL.search(text.replace("\n", "").replace("\t", ""))


def test_terminal_output_of_report_fit_and_figures_has_no_control_characters(hostile_report, tmp_path, capsys):
    _, out, err, session = hostile_report
    for stream in (out, err):
        assert not CONTROL.search(stream.replace("\n", "")), repr(stream)
    assert "\\x1b[31mred" in err  # the sweep file's warning, shown with its escape made visible
    sim = _sweep_file(tmp_path / "sim.h5", warnings=[f"note {ANSI}"])
    for argv in (["fit", session, "--sim", sim, "--bootstrap", "0"],
                 ["figures", session, "--sim", sim, "-o", tmp_path / "figs", "--bootstrap", "0"]):  # fmt: skip
        assert _run(argv) == 0
        captured = capsys.readouterr()
        for stream in (captured.out, captured.err):
            assert not CONTROL.search(stream.replace("\n", "")), repr(stream)
        assert "\\x1b[31mred" in captured.err


def test_the_stop_record_is_shown_whole_in_both_reports(hostile_report):
    from daq import load_session

    folder, _, _, session = hostile_report
    stop = load_session(session).stop
    assert stop["reason"] == STOP_REASON and stop["blocks_done"] == 12
    md = (folder / "report.md").read_text(encoding="utf-8")
    block = md.split("Stop record (JSON, whole):", 1)[1]
    body = re.search(r"\n(`{3,})json\n(.*?)\n\1\n", block, re.S)
    assert body is not None
    # control characters are JSON-escaped (\u001b), so the block parses back to the record exactly
    assert json.loads(body.group(2)) == json.loads(json.dumps(stop))
    page = _parse((folder / "report.html").read_text(encoding="utf-8"))
    records = [t for t in page.text if t.lstrip().startswith("{") and '"blocks_planned"' in t]
    assert records and json.loads(records[0]) == json.loads(json.dumps(stop))
    assert "SESSION ABORTED" in "".join(page.text)  # the stop status banner


def test_report_refuses_an_existing_html_report_without_force(tmp_path, capsys):
    session = _hostile_session(tmp_path / "s.h5")
    sim = _sweep_file(tmp_path / "sim.h5")
    out = tmp_path / "rep"
    out.mkdir()
    (out / "report.html").write_text("mine")
    argv = ["report", session, "--sim", sim, "-o", out, "--bootstrap", "0", "--no-compare-models"]
    assert _run(argv) == 2
    assert "report.html exists; use --force" in capsys.readouterr().err
    assert (out / "report.html").read_text() == "mine" and not (out / "report.md").exists()
    assert _run([*argv, "--force"]) == 0
    assert (out / "report.html").read_text().startswith("<!DOCTYPE html>")
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp")]


# ---- figures: one error-bar convention, repeats labelled ----------------------------------------------------------
def _toy_analysis(labels=None):
    from analysis.measured import MeasuredCurve
    from analysis.pipeline import analyse
    from contactrig.core.scene import load_scene
    from daq.sweep_file import config_fingerprint
    from sims.config import SimConfig

    rng = np.random.default_rng(4)
    values = (8e-3 / (W / 5.0) ** 0.8)[:, None] * (1 + 0.05 * rng.normal(size=(4, 4)))
    curve = MeasuredCurve(W, values, paired=True, repeat_labels=labels or ("0", "1", "2", "3"))
    scene = load_scene(None)
    sweep = SimpleNamespace(
        models={"hertz": SimpleNamespace(weight_kg=W, contact_area_m2=1e-7 * (W / 5) ** 0.8)}, warnings=[],
        provenance={"fingerprint": config_fingerprint(SimConfig.from_scene(scene))},
    )  # fmt: skip
    return analyse(curve, sweep, scene, title="toy", n_boot=0), values


def _half_bars(container):
    (bars,) = container.lines[2]
    return np.array([abs(seg[1, 1] - seg[0, 1]) / 2 for seg in bars.get_segments()])


def test_every_figure_with_error_bars_draws_and_states_one_sem_convention():
    from analysis import figures as F

    a, values = _toy_analysis()
    sem_mohm = values.std(axis=1, ddof=1) / np.sqrt(values.shape[1]) * 1e3  # independent: SD/√n of the repeats
    with_bars = []
    for spec in F.figure_specs():
        fig = spec.draw(a)
        if fig is None:
            continue
        containers = [c for ax in fig.axes for c in ax.containers if getattr(c, "has_yerr", False)]
        if containers:
            with_bars.append(spec.key)
            assert "error bars: ± 1 SEM of the repeats" in spec.caption, spec.key
    assert {"fig09_measured", "fig12_normalised", "fit_residuals"} <= set(with_bars)
    fig9 = F.get_figure("fig09_measured").draw(a)
    np.testing.assert_allclose(_half_bars(fig9.axes[0].containers[0]), sem_mohm, rtol=1e-9)
    fit = F.get_figure("fit_residuals").draw(a)
    np.testing.assert_allclose(_half_bars(fit.axes[0].containers[0]), sem_mohm, rtol=1e-9)
    # Fig. 12: ± 1 SE of R/R₀; at the first weight R₀/R₀ = 1 exactly, so no bar; elsewhere ≈ the relative SEMs
    fig12 = F.get_figure("fig12_normalised").draw(a)
    half = _half_bars(fig12.axes[0].containers[0])
    assert half[0] == 0.0 and np.all(half[1:] > 0)
    mean, n = values.mean(axis=1), values.shape[1]
    r = mean / mean[0]
    # first-order SE of a ratio of paired means: the SD over series of (R_ik − r_i R_0k)/R̄_0, over √n
    influence = (values - r[:, None] * values[0][None, :]) / mean[0]
    np.testing.assert_allclose(half[1:], influence[1:].std(axis=1, ddof=1) / np.sqrt(n), rtol=1e-9)


def test_fig9_labels_every_repeat_m1_to_mn():
    from analysis import figures as F

    a, _ = _toy_analysis()
    legend = {t.get_text() for t in F.figure_measured(a.curve).axes[0].get_legend().get_texts()}
    assert {"M1", "M2", "M3", "M4"} <= legend and "mean ± 1 SEM" in legend
    b, _ = _toy_analysis(labels=("M1", "M2", "M5", "M6"))  # series with names keep them
    legend = {t.get_text() for t in F.figure_measured(b.curve).axes[0].get_legend().get_texts()}
    assert {"M1", "M2", "M5", "M6"} <= legend and "M3" not in legend


def test_load_session_warnings_show_file_text_escaped(hostile_report):
    """A Python user's terminal gets the notes escaped; Session.warnings keeps the file's text as data."""
    import warnings

    from daq import load_session
    from daq.errors import SessionNoteWarning

    session = hostile_report[3]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        loaded = load_session(session)
    notes = [str(w.message) for w in caught if issubclass(w.category, SessionNoteWarning)]
    assert notes and all("\x1b" not in n and "\x07" not in n for n in notes)
    assert any("\\x1b" in n for n in notes)  # shown, not executed
    assert any("\x1b" in n for n in loaded.warnings)  # the data itself is unchanged
