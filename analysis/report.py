"""The analysis report: ``report.md`` and a self-contained ``report.html`` (``contactrig report`` / ``demo``).

:func:`write_report` takes one or more :class:`~analysis.pipeline.Analysis` objects (one section each), draws
their figures into ``DIR/figures`` (PNG for the report, SVG beside it) and writes ``DIR/report.md`` (figures linked)
and ``DIR/report.html`` (one file: figures inline as base64 PNG, tables, provenance; no script, no external
resource, and a Content-Security-Policy that forbids both). A session without a stop record gets an **INCOMPLETE
SESSION** banner at the top of the file and of its section.

Each section also says what it was computed from and what may make it wrong: the fingerprints of the measurement's
scene and of the simulation (and, in bold, a mismatch passed with ``--allow-mismatch``), the simulation's and the
models' validity warnings, what the data did not allow (weights left out, no fit), unphysical fits and bootstrap
intervals that are not available, with the reason. Resistances are shown in the unit the data call for
(:func:`analysis.resistance.resistance_unit`). When the analysis carries a ``model_ranking`` (the boundary-element
reference of :mod:`analysis.compare_models`), its verdict lines and figure are in the contact-area section; the
resistance model's sentence (:mod:`analysis.resistance_model`: fitted σ_f, R_s, clean-metal fraction) is in the
fit section.

**Strings read from files are data.** The report is built as a small document (headings, paragraphs, tables,
lists, code blocks, figures) whose text is either our own or :class:`Data` — operator, sample, host, command, scene
text, file names, status and stop reasons, model keys that are not registered, warnings that may quote a file —
and :class:`Data` is escaped by the renderer: :func:`contactrig.core.text.escape_markdown` /
:func:`~contactrig.core.text.markdown_code_block` for Markdown, :func:`~contactrig.core.text.escape_html` for
HTML. Records (start, stop) are shown whole, as JSON code blocks. Output files follow
:mod:`contactrig.core.files`: the folder is created, an existing file is refused unless ``force``, and the report's
files (text and figures) replace the old ones as one set (:func:`~contactrig.core.files.replace_together`: a kill
never leaves the old text beside new figures).
"""

from __future__ import annotations

import base64
import html
import math
import platform
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from analysis.figures import FigureSpec, figure_specs, planned_figures, write_figures
from analysis.fit import regressor_label
from analysis.resistance import resistance_unit
from contactrig.core.files import output_folder, refuse_existing, replace_together
from contactrig.core.provenance import software_version, to_json
from contactrig.core.text import escape_html, escape_markdown, escape_terminal, markdown_code_block
from sims.models import model_label, model_names

__all__ = [
    "Data",
    "output_directory",
    "render_html",
    "render_markdown",
    "report_outputs",
    "write_report",
]


def output_directory(directory: str | Path) -> Path:
    """The output folder, created with its parents when missing (:func:`contactrig.core.files.output_folder`)."""
    return output_folder(directory)


def report_outputs(directory: str | Path, titles: Sequence[str], formats: Sequence[str] = ("png", "svg")) -> list[Path]:
    """Every file :func:`write_report` may write for analyses titled ``titles``: ``report.md``, ``report.html``
    and the figures."""
    out = Path(directory)
    files = [out / "report.md", out / "report.html"]
    for title in titles:
        files += planned_figures(out / "figures", _slug(title), formats)
    return files


def _slug(text: str) -> str:
    out = "".join(c.lower() if c.isascii() and c.isalnum() else "-" for c in text)
    while "--" in out:
        out = out.replace("--", "-")
    return out.strip("-") or "analysis"


# ---------------------------------------------------------------------------------------------------------------
# The document: our own text is ``str``; text read from a file is ``Data`` and escaped by each renderer.


@dataclass(frozen=True)
class Data:
    """Text read from a file (or typed by someone else): shown literally in every output, never interpreted."""

    value: Any


@dataclass(frozen=True)
class Strong:
    """Bold text (its content an inline: ``str``, :class:`Data`, :class:`Code` or a list of them)."""

    content: Any


@dataclass(frozen=True)
class Code:
    """Inline code (a file name, a JSON record); always treated as data."""

    value: Any


@dataclass(frozen=True)
class Heading:
    level: int
    content: Any


@dataclass(frozen=True)
class Para:
    content: Any


@dataclass(frozen=True)
class Notice:
    """A banner (INCOMPLETE SESSION): a block quote in Markdown, a framed box in HTML."""

    content: Any


@dataclass(frozen=True)
class Bullets:
    items: tuple[Any, ...]


@dataclass(frozen=True)
class Table:
    headers: tuple[Any, ...]
    rows: tuple[tuple[Any, ...], ...]


@dataclass(frozen=True)
class CodeBlock:
    """Multi-line data (a scene file, a JSON record), shown whole; ``summary`` folds it in HTML (``<details>``)."""

    text: str
    info: str = "text"
    summary: str = ""


@dataclass(frozen=True)
class Image:
    title: str
    png: Path
    vector: Path | None
    caption: str


# ---- Markdown -------------------------------------------------------------------------------------------------
def _md(x: Any) -> str:
    if isinstance(x, str):
        return x
    if isinstance(x, Data):
        return escape_markdown(x.value)
    if isinstance(x, Strong):
        return f"**{_md(x.content)}**"
    if isinstance(x, Code):
        return _md_code_span(x.value)
    return "".join(_md(p) for p in x)


def _md_code_span(value: Any) -> str:
    """``value`` as a one-line Markdown code span whose fence it cannot close (no control character, no newline;
    ``|`` escaped so a table cell holds it too)."""
    text = escape_terminal(value).replace("|", "\\|")
    longest = max((len(m) for m in re.findall(r"`+", text)), default=0)
    fence = "`" * (longest + 1)
    pad = " " if text[:1] == "`" or text[-1:] == "`" or not text.strip() else ""
    return f"{fence}{pad}{text}{pad}{fence}"


def _md_block(block: Any, directory: Path) -> str:
    if isinstance(block, Heading):
        return f"{'#' * block.level} {_md(block.content)}\n"
    if isinstance(block, Para):
        return _md(block.content) + "\n"
    if isinstance(block, Notice):
        return "> " + _md(block.content) + "\n"
    if isinstance(block, Bullets):
        return "\n".join(f"- {_md(item)}" for item in block.items) + "\n"
    if isinstance(block, Table):
        lines = [
            "| " + " | ".join(_md(h) for h in block.headers) + " |",
            "|" + "|".join("---" for _ in block.headers) + "|",
        ]
        lines += ["| " + " | ".join(_md(c) for c in row) + " |" for row in block.rows]
        return "\n".join(lines) + "\n"
    if isinstance(block, CodeBlock):
        return (f"{block.summary}:\n\n" if block.summary else "") + markdown_code_block(block.text, block.info) + "\n"
    if isinstance(block, Image):
        rel = block.png.relative_to(directory).as_posix()
        extra = ""
        if block.vector is not None:
            extra = f" ([{block.vector.suffix[1:].upper()}]({block.vector.relative_to(directory).as_posix()}))"
        caption = f"\n{block.caption}\n" if block.caption else ""
        return f"![{block.title}]({rel}){extra}\n{caption}"
    raise TypeError(f"not a report block: {block!r}")


# ---- HTML -----------------------------------------------------------------------------------------------------
def _html(x: Any) -> str:
    if isinstance(x, str):
        return html.escape(x, quote=False)
    if isinstance(x, Data):
        return escape_html(x.value)
    if isinstance(x, Strong):
        return f"<strong>{_html(x.content)}</strong>"
    if isinstance(x, Code):
        return f"<code>{escape_html(x.value)}</code>"
    return "".join(_html(p) for p in x)


def _html_block(block: Any, directory: Path) -> str:
    if isinstance(block, Heading):
        level = min(max(block.level, 1), 6)
        return f"<h{level}>{_html(block.content)}</h{level}>"
    if isinstance(block, Para):
        return f"<p>{_html(block.content)}</p>"
    if isinstance(block, Notice):
        return f'<div class="notice">{_html(block.content)}</div>'
    if isinstance(block, Bullets):
        return "<ul>\n" + "\n".join(f"<li>{_html(item)}</li>" for item in block.items) + "\n</ul>"
    if isinstance(block, Table):
        head = "".join(f"<th>{_html(h)}</th>" for h in block.headers)
        body = "\n".join("<tr>" + "".join(f"<td>{_html(c)}</td>" for c in row) + "</tr>" for row in block.rows)
        return f'<div class="table"><table>\n<thead><tr>{head}</tr></thead>\n<tbody>\n{body}\n</tbody>\n</table></div>'
    if isinstance(block, CodeBlock):
        pre = f"<pre><code>{escape_html(block.text)}</code></pre>"
        if block.summary:
            return f"<details><summary>{html.escape(block.summary)}</summary>\n{pre}\n</details>"
        return pre
    if isinstance(block, Image):
        data = base64.b64encode(block.png.read_bytes()).decode("ascii")
        caption = f"<figcaption>{_html(block.caption)}</figcaption>" if block.caption else ""
        return (
            f'<figure><img src="data:image/png;base64,{data}" alt="{html.escape(block.title, quote=True)}">'
            f"{caption}</figure>"
        )
    raise TypeError(f"not a report block: {block!r}")


_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; line-height: 1.45;
       max-width: 1100px; margin: 2em auto; padding: 0 1.2em; color: #1d1d1d; }
h1 { border-bottom: 2px solid #444; padding-bottom: .2em; }
h2 { border-bottom: 1px solid #bbb; margin-top: 2.2em; }
.table { overflow-x: auto; }
table { border-collapse: collapse; margin: .8em 0; font-size: .85em; }
th, td { border: 1px solid #c8c8c8; padding: .25em .55em; text-align: right; white-space: nowrap; }
th { background: #f0f0f0; } td:first-child, th:first-child { text-align: left; }
figure { margin: 1.2em 0; } img { max-width: 100%; height: auto; border: 1px solid #e2e2e2; }
figcaption { font-size: .85em; color: #444; margin-top: .3em; }
pre { background: #f6f6f6; padding: .6em; overflow-x: auto; font-size: .8em; white-space: pre-wrap;
      word-break: break-all; }
code { font-size: .9em; word-break: break-all; }
.notice { border: 2px solid #b00; background: #fff0f0; padding: .5em .8em; margin: 1em 0; }
li { margin: .15em 0; }
"""

#: No script, no external resource of any kind: images must be data: URLs, styles inline.
_CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'; base-uri 'none'; form-action 'none'"


def render_html(blocks: Sequence[Any], directory: Path, title: str) -> str:
    """A self-contained HTML page of ``blocks`` (figures read from ``directory`` and inlined as base64 PNG)."""
    body = "\n".join(_html_block(b, directory) for b in blocks)
    return (
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f'<meta http-equiv="Content-Security-Policy" content="{_CSP}">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{html.escape(title)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n{body}\n</body>\n</html>\n"
    )


# ---------------------------------------------------------------------------------------------------------------
# The report's content.


def _g(x: float | None, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return f"{x:.{digits}g}"


def _label(name: str) -> Any:
    """A model's display label: the registry's (our text) for a registered model, else the key as data."""
    return model_label(name) if name in model_names() else Data(model_label(name))


def _about_models(text: str, names: Any) -> Any:
    """Text we generated that names models (a verdict): ours when every model is registered, else data."""
    return text if all(n in model_names() for n in names) else Data(text)


def _banner(info: dict[str, Any]) -> Notice | None:
    if info.get("kind") != "session":
        return None
    if not info.get("complete", True):
        return Notice(
            [
                Strong("INCOMPLETE SESSION"),
                " — the file has no stop record (the acquisition was killed, lost power or is still running). Only "
                "the blocks flushed to disk are analysed.",
            ]
        )
    if info.get("status") not in ("success", None):
        reason = (info.get("stop") or {}).get("reason", "")
        return Notice([Strong(["SESSION ", Data(str(info["status"]).upper())]), " — ", Data(reason)])
    return None


def _measured_section(a: Any) -> list[Any]:
    c = a.curve
    nm = a.measured_norm
    k, unit = resistance_unit(c.mean_ohm)
    ratio = {float(w): f"{r:.5g} ± {e:.2g}" for w, r, e in zip(nm.weight_kg, nm.ratio, nm.se, strict=True)}
    rows = []
    for i, w in enumerate(c.weight_kg):
        rows.append(
            (
                f"{w:g}",
                str(int(c.n[i])),
                _g(c.mean_ohm[i] * k),
                _g(c.sd_ohm[i] * k, 3),
                _g(c.sem_ohm[i] * k, 3),
                ratio.get(float(w), "left out"),
            )
        )
    paired = "series (correlation across weights included)" if nm.paired else "independent repeats"
    headers = ("weight [kg]", "repeats", f"mean R [{unit}]", f"SD [{unit}]", f"SEM [{unit}]", "R/R₀ ± SE")
    return [
        Table(headers, tuple(rows)),
        Para(
            f"Repeats treated as {paired}. R₀ = {nm.reference_ohm * k:.4g} ± {nm.reference_se_ohm * k:.2g} {unit}; "
            "R₀/R₀ = 1 exactly."
        ),
        *_independence_note(a),
    ]


def _independence_note(a: Any) -> list[Any]:
    """When some series are copies of others: the table counts every column, the fit only the independent ones."""
    cmp = a.comparison
    if cmp is None or not cmp.series_notes:
        return []
    return [
        Para(
            f"The columns above include copies of other series; the fit counts {cmp.n_repeats} independent series "
            f"(SD and SEM in this table are over every column): {'; '.join(cmp.series_notes)}."
        )
    ]


def _area_section(a: Any) -> list[Any]:
    names = list(a.areas_m2)
    rows = tuple((f"{w:g}", *(_g(a.areas_m2[n][i] * 1e6) for n in names)) for i, w in enumerate(a.curve.weight_kg))
    out: list[Any] = [Table(("weight [kg]", *([_label(n), " A [mm²]"] for n in names)), rows)]
    return out + _ranking_blocks(a)


def _ranking_blocks(a: Any) -> list[Any]:
    """The boundary-element reference's verdicts (issue #14), when the analysis carries a comparison."""
    cmp = getattr(a, "model_ranking", None)
    if cmp is None:
        note = getattr(a, "model_ranking_note", "")
        return [Para(["Contact models against the boundary-element reference: ", note])] if note else []
    from analysis.compare_models import report_lines

    head, favoured, *lines = report_lines(cmp)
    pressures = ", ".join(f"{p / 1e6:.3g}" for p in cmp.pressures_pa)
    return [
        Para([head, " ", Strong(favoured), "."]),
        Bullets(tuple(lines)),
        Para(
            f"Mean nominal pressures compared: {pressures} MPa; {cmp.provenance.get('wall_s', float('nan')):.1f} s "
            f"({cmp.provenance.get('executor', '?')}). The favoured model has the smallest RMS of ln(A_model/A_BEM) "
            "over these pressures."
        ),
    ]


def _interval(ci: tuple[float, float], factor: float = 1.0) -> str:
    return f"[{_g(ci[0] * factor, 3)}, {_g(ci[1] * factor, 3)}]"


def _boot_cell(boot: Any, ci: tuple[float, float], factor: float = 1.0) -> str:
    """A bootstrap interval, or what the reason says (e.g. "not available with 3 series")."""
    if boot.available:
        return _interval(ci, factor)
    return str(boot.note.split(":")[0])


def _fit_row(cmp: Any, name: str, k: float) -> tuple[Any, ...]:
    f = cmp.fits[name]
    est, t, boot, gof = f.estimate, f.intervals.t, f.intervals.bootstrap, f.goodness
    return (
        [_label(name), "" if f.physical else [" — ", Strong("UNPHYSICAL")]],
        f"{est.R_series_ohm * k:.4g} ± {est.R_series_se * k:.2g}",
        _interval(t.R_series_ohm, k),
        _boot_cell(boot, boot.R_series_ohm, k),
        f"{est.scale:.4g} ± {est.scale_se:.2g}",
        _boot_cell(boot, boot.scale),
        f"{gof.chi2:.3g}",
        f"{gof.reduced_chi2:.3g}",
        _g(gof.p_value, 2),
        f"{gof.aic:.2f}",
        f"{cmp.delta_aic[name]:.3g}",
        f"{cmp.akaike_weights[name]:.2f}",
        _first(cmp, name),
        f"{gof.rmse_ohm * k:.3g}",
    )


def _first(cmp: Any, name: str) -> str:
    if not cmp.first_fraction:
        return "–"
    return f"{cmp.first_fraction[name]:.0%}" if name in cmp.first_fraction else "– (unphysical)"


def _fit_section(a: Any) -> list[Any]:
    cmp = a.comparison
    if cmp is None:
        return [Para("No fit: " + "; ".join(n for n in a.left_out if n.startswith("no fit")).removeprefix("no fit: "))]
    first = next(iter(cmp.fits.values()))
    lvl = round(first.intervals.level * 100)
    k, unit = resistance_unit(first.points.measured_ohm)
    headers = (
        "model", f"R_s ± SE [{unit}]", f"R_s {lvl}% t-CI [{unit}]", f"R_s {lvl}% bootstrap [{unit}]", "s ± SE [Ω·m]",
        f"s {lvl}% bootstrap", "χ²", "χ²/dof", "p", "AIC", f"Δ{cmp.criterion}", f"{cmp.criterion} weight",
        "first in bootstrap", f"RMSE [{unit}]",
    )  # fmt: skip
    boot = first.intervals.bootstrap
    blocks: list[Any] = [
        Table(headers, tuple(_fit_row(cmp, name, k) for name in cmp.ranking)),
        Para(
            f"Model: R = R_s + s·x(A(W)), x = {regressor_label(a.conversion)}, "
            f"h = {a.circuit.contact_height_m:g} m; weights 1/σ² with σ "
            f"{_WEIGHTING_TEXT.get(first.weighting, first.weighting)}; {boot.n_boot} bootstrap resamples of the "
            f"repeats ({_BOOTSTRAP_TEXT.get(boot.resampling, boot.resampling)}), {boot.method} intervals; t-intervals "
            f"with {first.intervals.t.dof[0]:.3g} degrees of freedom; p: goodness of fit against "
            f"{first.goodness.reference}. k = 2 for every model, so ΔAIC = ΔBIC = Δχ²"
            + (f" (ΔQAIC = Δχ²/ĉ, ĉ = {cmp.c_hat:.3g})" if cmp.criterion == "QAIC" else "")
            + f". {cmp.n_repeats} independent series or repeats; errors: {first.estimate.error_rule}."
        ),
        Para(Strong(_about_models(cmp.statement, cmp.ranking))),
    ]
    if a.conversion == "physical":
        blocks += _shares_blocks(cmp.best)
    notes: list[Any] = [
        [_label(n), ": ", _about_models(note, [n])] for n in cmp.ranking for note in cmp.fits[n].diagnostics.warnings
    ]
    notes += [
        [_label(n), ": UNPHYSICAL: ", _about_models(why, [n])] for n in cmp.ranking for why in cmp.fits[n].unphysical
    ]
    notes += list(cmp.series_notes)
    if not boot.available:
        notes.append(f"bootstrap intervals {boot.note}")
    if notes:
        blocks += [Para("Notes:"), Bullets(tuple(notes))]
    blocks += [
        Para("Solver diagnostics (scipy.optimize.least_squares):"),
        Bullets(tuple(_diagnostics_line(n, cmp.fits[n].diagnostics) for n in cmp.ranking)),
    ]
    blocks += _simulated_truth(a)
    statement = getattr(a, "resistance_statement", "")
    if statement:
        blocks += [Heading(4, "Resistance model: film, series and clean-metal constriction"), Para(statement)]
    return blocks


def _shares_blocks(fit: Any) -> list[Any]:
    """The physical model's terms as shares of the measured mean per weight, for the best model."""
    names = list(fit.shares)
    rows = tuple(
        (f"{w:g}", *(f"{100 * float(fit.shares[n][i]):.2f}" for n in names)) for i, w in enumerate(fit.points.weight_kg)
    )
    return [
        Para(["Share of the measured mean R per weight [%], ", _label(fit.model), " (R_s, σ_f/A, Barber, macro):"]),
        Table(("weight [kg]", *names), rows),
    ]


def _diagnostics_line(name: str, d: Any) -> Any:
    return [
        _label(name),
        f": nfev = {d.nfev}, status = {d.status} (",
        Data(d.message),
        f"), cost = {d.cost:.4g}, closed-form check {d.linear_check:.1e}",
    ]


_WEIGHTING_TEXT = {
    "relative": "= pooled relative SD × mean R / √n (scatter ∝ R)",
    "pooled": "= pooled SD / √n",
    "repeats": "= each weight's own SEM",
    "blocks": "from the within-block standard errors",
}
_BOOTSTRAP_TEXT = {"series": "whole series", "within": "within each weight"}


def _simulated_truth(a: Any) -> list[Any]:
    """For a session on the simulated bench: the true R_s and ζ it was built with, against the fit."""
    start = a.measured_info.get("start") or {}
    if not start.get("sim"):
        return []
    sim = start.get("simulation") or {}
    model = sim.get("model") or (((start.get("plan") or {}).get("session") or {}).get("sim_model"))
    c = a.circuit
    try:
        repeat_sd = float(sim.get("repeat_sd") or 0.0)
    except (TypeError, ValueError):
        repeat_sd = 0.0
    reseat = f" × a mean-one log-normal re-seating factor per block (σ = {repeat_sd:g})" if repeat_sd > 0 else ""
    parts: list[Any] = ["Simulated bench: the resistance was generated as R = R_s + ζh/A(W)", reseat]
    if model:
        parts += [" with model ", Strong(Data(model))]
    parts.append(f", R_s = {c.series_resistance_ohm * 1e3:g} mΩ and ζ = {c.resistivity_ohm_m:g} Ω·m (scene [circuit]).")
    if model and model in a.comparison.fits and a.conversion == "bulk":
        e = a.comparison.fits[model].estimate
        parts.append(
            f" Its fit recovers R_s = {e.R_series_ohm * 1e3:.4g} ± {e.R_series_se * 1e3:.2g} mΩ and "
            f"s = {e.scale:.4g} ± {e.scale_se:.2g} Ω·m."
        )
    return [Para(parts)]


_START_KEYS = ("started", "operator", "host", "command", "sim", "imported", "sample", "rig", "scene_name")


def _runs_and_notes(info: dict[str, Any]) -> list[Any]:
    """The number of runs on file (``measured_info["runs"]``: a resumed session has several; the start record's own
    ``run`` is the first run's, 0) and the session's notes — once when every run kept them, else per run (``acquire
    --resume --notes`` records a change). The notes are the operator's text: shown as data."""
    start = info.get("start") or {}
    runs = [r for r in info.get("runs") or () if isinstance(r, dict)]
    items: list[Any] = []
    if runs:
        items.append(["session runs: ", Data(len(runs)), f" ({len(runs) - 1} resume(s))"])
    notes = [(r.get("run", k), r.get("notes")) for k, r in enumerate(runs)] or [(start.get("run", 0),
                                                                                  start.get("notes"))]  # fmt: skip
    texts = [str(text) for _, text in notes if text]
    if texts and len(set(texts)) == 1 and len(texts) == len(notes):
        return [*items, ["session notes: ", Data(texts[0])]]
    return items + [[f"session notes, run {run}: ", Data(text)] for run, text in notes if text]


def _provenance(a: Any) -> list[Any]:
    info = a.measured_info
    complete = "complete" if info.get("complete", True) else "INCOMPLETE"
    items: list[Any] = [
        ["measured data: ", Code(info.get("path", a.curve.source)), f" ({info.get('kind', '?')}, status ",
         Data(info.get("status", "?")), f", {complete})"],
    ]  # fmt: skip
    start = info.get("start") or {}
    items += [[f"session {k}: ", Data(start[k])] for k in _START_KEYS if k in start]
    items += _runs_and_notes(info)
    for k in sorted(start):
        if k in ("software", "versions") or "ident" in k:
            items.append(["session ", Data(k), ": ", Code(to_json(start[k], sort_keys=True))])
    items.append(["scene: ", Data(getattr(a.scene, "name", "?")), " (", Data(getattr(a.scene, "source", "?")), ")"])
    items.append(["simulation: ", Data(a.sim_info.get("source", "?"))])
    prov = a.sim_info.get("provenance") or {}
    if prov.get("software_version"):
        items.append(["simulation software version: ", Data(prov["software_version"])])
    items += _fingerprint_lines(a.fingerprint)
    items += [["data note: ", Data(w)] for w in info.get("warnings", [])]
    blocks: list[Any] = [Bullets(tuple(items))]
    stop = info.get("stop")
    if stop:
        blocks.append(CodeBlock(to_json(stop, indent=2, sort_keys=True), "json", "Stop record (JSON, whole)"))
    text = getattr(a.scene, "text", "") or ""
    if text.strip():
        blocks.append(CodeBlock(text, "toml", f"Scene file ({len(text.splitlines())} lines)"))
    return blocks


def _history_section(a: Any) -> list[Any]:
    """The session's history (``measured_info["history"]``, :func:`daq.records.session_history`): loading order,
    skips, resumes, interruptions. Its lines carry text from the file: shown as data."""
    history = a.measured_info.get("history") or []
    if not history:
        return []
    return [Heading(3, "Session history"), Bullets(tuple(Data(line) for line in history))]


def _fingerprint_lines(fp: dict[str, Any]) -> list[Any]:
    """What the analysis was computed from (hashes of the scene tables on both sides) and any mismatch allowed."""
    if not fp:
        return []
    lines: list[Any] = []
    for side in ("measured", "simulation"):
        tables = (fp.get(side) or {}).get("tables") or {}
        hashes = ", ".join(f"{name} {str(t.get('sha256', ''))[:12]}" for name, t in sorted(tables.items()))
        version = (fp.get(side) or {}).get("software_version")
        lines.append(
            [f"fingerprint of the {side} scene: ", Data(hashes or "none recorded")]
            + ([" (contactrig ", Data(version), ")"] if version else [])
        )
    if fp.get("allowed"):
        lines.append(
            [
                Strong("SCENE MISMATCH ALLOWED (--allow-mismatch)"),
                ": the simulation is not of the measurement's scene — ",
                Data("; ".join(fp.get("differences", []))),
            ]
        )
    return lines


def _warnings_section(a: Any) -> list[Any]:
    """Model-validity and simulation warnings, and what the data did not allow (empty when there is nothing)."""
    items: list[Any] = [[Strong("warning"), ": ", Data(w)] for w in a.warnings]
    items += [[Strong("left out"), ": ", n] for n in a.left_out]
    if a.fingerprint.get("allowed"):
        items.append([Strong("scene mismatch allowed"), ": ", Data("; ".join(a.fingerprint.get("differences", [])))])
    return [Bullets(tuple(items))] if items else []


# The report's sections after the provenance: key (what a FigureSpec names as its ``section``), heading, content.
_SECTIONS: tuple[tuple[str, str, Callable[[Any], list[Any]] | None], ...] = (
    ("measured", "Measured resistance", _measured_section),
    ("area", "Simulated real contact area", _area_section),
    ("normalised", "Normalised curves (seed Fig. 12)", None),
    ("fit", "Fit and model comparison", _fit_section),
)


def _sections(a: Any, figs: dict[str, list[Path]]) -> list[Any]:
    """Each section's content followed by the registered figures that belong to it (in registration order); figures
    of any other section go under "Further figures"."""
    specs = [s for s in figure_specs() if s.key in figs]
    known = {key for key, _, _ in _SECTIONS}
    out: list[Any] = []
    for key, heading, content in _SECTIONS:
        images = [_img(figs, s) for s in specs if s.section == key]
        if content is None and not images:
            continue
        out.append(Heading(3, heading))
        if content is not None:
            out += content(a)
        out += images
    further = [_img(figs, s) for s in specs if s.section not in known]
    if further:
        out.append(Heading(3, "Further figures"))
        out += further
    return out


def _img(figs: dict[str, list[Path]], spec: FigureSpec) -> Image:
    paths = figs[spec.key]
    png = next((p for p in paths if p.suffix == ".png"), paths[0])
    vector = next((p for p in paths if p.suffix in (".svg", ".pdf")), None)
    return Image(spec.title, png, vector, spec.caption)


def report_blocks(
    analyses: Sequence[Any],
    figures: Sequence[dict[str, list[Path]]],
    *,
    title: str = "contactrig analysis report",
    preamble: Sequence[Any] | str = (),
) -> list[Any]:
    """The report as a list of blocks (rendered by :func:`render_markdown` and :func:`render_html`). ``preamble``:
    blocks after the header (a ``str`` is one paragraph of data, shown literally)."""
    now = datetime.now(UTC).isoformat(timespec="seconds")
    blocks: list[Any] = [Heading(1, title)]
    blocks += [b for b in (_banner(a.measured_info) for a in analyses) if b is not None]
    blocks.append(
        Para(
            f"Generated {now} by contactrig {software_version()} (Python {platform.python_version()}, "
            f"numpy {np.__version__})."
        )
    )
    blocks += [Para(Data(preamble))] if isinstance(preamble, str) and preamble else list(preamble or ())
    for a, figs in zip(analyses, figures, strict=True):
        blocks.append(Heading(2, Data(a.title)))
        banner = _banner(a.measured_info)
        if banner is not None:
            blocks.append(banner)
        blocks += [Heading(3, "Provenance"), *_provenance(a)]
        blocks += _history_section(a)
        caveats = _warnings_section(a)
        if caveats:
            blocks += [Heading(3, "Warnings and what was left out"), *caveats]
        blocks += _sections(a, figs)
    return blocks


def render_markdown(
    analyses: Sequence[Any],
    figures: Sequence[dict[str, list[Path]]],
    directory: Path,
    *,
    title: str = "contactrig analysis report",
    preamble: Sequence[Any] | str = (),
) -> str:
    """The Markdown text of the report (figures linked relative to ``directory``)."""
    blocks = report_blocks(analyses, figures, title=title, preamble=preamble)
    return "\n".join(_md_block(b, Path(directory)) for b in blocks)


def write_report(
    analyses: Sequence[Any],
    directory: str | Path,
    *,
    title: str = "contactrig analysis report",
    preamble: Sequence[Any] | str = (),
    formats: Sequence[str] = ("png", "svg"),
    force: bool = False,
) -> Path:
    """Draw the figures of every analysis into ``directory/figures`` and write ``directory/report.md`` and the
    self-contained ``directory/report.html``; returns the path of ``report.md``.

    Every file is checked first (:func:`report_outputs`): an existing one is refused unless ``force``."""
    out = output_directory(directory)
    outputs = refuse_existing(report_outputs(out, [a.title for a in analyses], formats), force=force)
    # written whole into a staging folder that mirrors `out`, then swapped in as one set (report.md last)
    with replace_together(out, outputs, force=force) as stage:
        figs = [write_figures(a, stage / "figures", prefix=_slug(a.title), formats=formats) for a in analyses]
        blocks = report_blocks(analyses, figs, title=title, preamble=preamble)
        (stage / "report.html").write_text(render_html(blocks, stage, title), encoding="utf-8")
        (stage / "report.md").write_text("\n".join(_md_block(b, stage) for b in blocks), encoding="utf-8")
    return out / "report.md"
