"""Tables, figures and the Markdown report of ``contactrig bench``."""

from __future__ import annotations

import platform
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path

from analysis.studies.atlas import Outcome
from analysis.studies.rows import Row, reference_of

__all__ = ["format_atlas", "format_rows", "report_files", "write_report"]


def _fmt(x: float) -> str:
    return "—" if x != x else f"{x:.3g}"


def format_rows(rows: Sequence[Row]) -> str:
    """A plain-text table: study, method, setting, error, seconds."""
    header = ("study", "method", "setting", "error", "seconds")
    body = [(r.study, r.method, r.setting, _fmt(r.error), f"{r.seconds:.4g}") for r in rows]
    widths = [max(len(h), *(len(b[i]) for b in body)) if body else len(h) for i, h in enumerate(header)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(c.ljust(w) for c, w in zip(b, widths, strict=True)) for b in body]
    return "\n".join(lines)


def format_atlas(outcomes: Sequence[Outcome]) -> str:
    """A plain-text table of the atlas: case, method, expected, got, detail."""
    lines = [f"stability atlas: {sum(o.ok for o in outcomes)}/{len(outcomes)} cases as expected"]
    for o in outcomes:
        mark = "ok  " if o.ok else "FAIL"
        lines.append(
            f"{mark} {o.case.method:<38} {o.case.name:<40} expected {o.case.expect:<7} got {o.got:<7} {o.detail[:90]}"
        )
    return "\n".join(lines)


def _md_table(header: Sequence[str], body: Sequence[Sequence[str]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |" for row in body]
    return "\n".join(out)


def report_files(directory: str | Path, studies: Sequence[str]) -> list[Path]:
    """Every file :func:`write_report` may write into ``directory``: ``report.md`` and each study's PNG and SVG."""
    out = Path(directory)
    return [out / "report.md"] + [out / f"{name}.{fmt}" for name in studies for fmt in ("png", "svg")]


def write_report(
    rows: Sequence[Row],
    outcomes: Sequence[Outcome],
    directory: str | Path,
    *,
    studies: Sequence[str],
    quick: bool,
    force: bool = False,
) -> Path:
    """Write one log–log error-against-time figure per study and ``report.md`` into ``directory`` (created when
    missing). Every file is checked first: an existing one is refused unless ``force``; each is written atomically
    (:mod:`contactrig.core.files`)."""
    from analysis.figures import figure_error_vs_time, save_figure
    from contactrig.core.files import output_folder, refuse_existing, write_text_atomic

    out = output_folder(directory)
    refuse_existing(report_files(out, studies), force=force)

    parts = [
        "# contactrig: error against run time, and the stability atlas",
        "",
        f"Run {datetime.now().astimezone().isoformat(timespec='seconds')} on {platform.node()} "
        f"({platform.processor() or platform.machine()}, Python {platform.python_version()})"
        f"{', quick sizes' if quick else ''}. Times are wall-clock, best of three where repeated.",
        "",
    ]
    for name in studies:
        study_rows = [r for r in rows if r.study == name]
        if not study_rows:
            continue
        fig = figure_error_vs_time(study_rows, study=name)
        png = save_figure(fig, out, name, formats=("png", "svg"), force=force)[0]
        parts += [
            f"## {name}",
            "",
            f"Reference: {reference_of(name)}.",
            "",
            _md_table(
                ("method", "setting", "error", "seconds"),
                [(r.method, r.setting, _fmt(r.error), f"{r.seconds:.4g}") for r in study_rows],
            ),
            "",
            f"![{name}]({png.name})",
            "",
        ]
    if outcomes:
        parts += [
            "## Stability atlas",
            "",
            "Expected: `finite` (finite, non-negative, correct), `warning` (finite with an explicit warning) or "
            "`error` (an explicit error). NaN, inf, negative pressure or area, an unexpected exception or a hang "
            "is `FAIL`.",
            "",
            _md_table(
                ("method", "case", "expected", "got", "detail"),
                [
                    (
                        o.case.method,
                        o.case.name,
                        o.case.expect,
                        ("" if o.ok else "**") + o.got + ("" if o.ok else "**"),
                        o.detail[:160],
                    )
                    for o in outcomes
                ],
            ),
            "",
        ]
    return write_text_atomic(out / "report.md", "\n".join(parts), force=force)
