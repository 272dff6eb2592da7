"""The analysis report: one Markdown file with provenance, tables and figures (``contactrig report`` / ``demo``).

:func:`write_report` takes one or more :class:`~analysis.pipeline.Analysis` objects (one section each), draws
their figures into ``DIR/figures`` (PNG for the report, SVG beside it) and writes ``DIR/report.md``. A session
without a stop record gets an **INCOMPLETE SESSION** banner at the top of the file and of its section.

Each section also says what it was computed from and what may make it wrong: the fingerprints of the measurement's
scene and of the simulation (and, in bold, a mismatch passed with ``--allow-mismatch``), the simulation's and the
models' validity warnings, what the data did not allow (weights left out, no fit), unphysical fits and bootstrap
intervals that are not available, with the reason. Resistances are shown in the unit the data call for
(:func:`analysis.resistance.resistance_unit`). Output files follow :mod:`contactrig.core.files`: the folder is
created, an existing file is refused unless ``force``, every file is written atomically.
"""

from __future__ import annotations

import math
import platform
from collections.abc import Callable, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from analysis.figures import FigureSpec, figure_specs, planned_figures, write_figures
from analysis.fit import regressor_label
from analysis.resistance import resistance_unit
from contactrig.core.files import output_folder, refuse_existing, write_text_atomic
from contactrig.core.provenance import software_version, to_json
from sims.models import model_label

__all__ = ["output_directory", "render_markdown", "report_outputs", "write_report"]


def output_directory(directory: str | Path) -> Path:
    """The output folder, created with its parents when missing (:func:`contactrig.core.files.output_folder`)."""
    return output_folder(directory)


def report_outputs(directory: str | Path, titles: Sequence[str], formats: Sequence[str] = ("png", "svg")) -> list[Path]:
    """Every file :func:`write_report` may write for analyses titled ``titles``: ``report.md`` and the figures."""
    out = Path(directory)
    files = [out / "report.md"]
    for title in titles:
        files += planned_figures(out / "figures", _slug(title), formats)
    return files


def _slug(text: str) -> str:
    out = "".join(c.lower() if c.isalnum() else "-" for c in text)
    while "--" in out:
        out = out.replace("--", "-")
    return out.strip("-") or "analysis"


def _table(headers: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def _g(x: float, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return f"{x:.{digits}g}"


def _banner(info: dict[str, Any]) -> str:
    if info.get("kind") != "session":
        return ""
    if not info.get("complete", True):
        return (
            "> **INCOMPLETE SESSION** — the file has no stop record (the acquisition was killed, lost power or is "
            "still running). Only the blocks flushed to disk are analysed.\n\n"
        )
    if info.get("status") not in ("success", None):
        reason = (info.get("stop") or {}).get("reason", "")
        return f"> **SESSION {str(info['status']).upper()}** — {reason}\n\n"
    return ""


def _measured_section(a: Any) -> str:
    c = a.curve
    nm = a.measured_norm
    k, unit = resistance_unit(c.mean_ohm)
    ratio = {float(w): f"{r:.5g} ± {e:.2g}" for w, r, e in zip(nm.weight_kg, nm.ratio, nm.se, strict=True)}
    rows = []
    for i, w in enumerate(c.weight_kg):
        rows.append(
            [
                f"{w:g}",
                int(c.n[i]),
                _g(c.mean_ohm[i] * k),
                _g(c.sd_ohm[i] * k, 3),
                _g(c.sem_ohm[i] * k, 3),
                ratio.get(float(w), "left out"),
            ]
        )
    paired = "series (correlation across weights included)" if nm.paired else "independent repeats"
    headers = ["weight [kg]", "repeats", f"mean R [{unit}]", f"SD [{unit}]", f"SEM [{unit}]", "R/R₀ ± SE"]
    return (
        _table(headers, rows)
        + f"\n\nRepeats treated as {paired}. R₀ = {nm.reference_ohm * k:.4g} ± {nm.reference_se_ohm * k:.2g} {unit}; "
        "R₀/R₀ = 1 exactly.\n"
    )


def _area_section(a: Any) -> str:
    names = list(a.areas_m2)
    rows = [[f"{w:g}"] + [_g(a.areas_m2[n][i] * 1e6) for n in names] for i, w in enumerate(a.curve.weight_kg)]
    return _table(["weight [kg]"] + [f"{model_label(n)} A [mm²]" for n in names], rows) + "\n"


def _interval(ci: tuple[float, float], factor: float = 1.0) -> str:
    return f"[{_g(ci[0] * factor, 3)}, {_g(ci[1] * factor, 3)}]"


def _boot_cell(boot: Any, ci: tuple[float, float], factor: float = 1.0) -> str:
    """A bootstrap interval, or what the reason says (e.g. "not available with 3 series")."""
    if boot.available:
        return _interval(ci, factor)
    return boot.note.split(":")[0]


def _fit_row(cmp: Any, name: str, k: float) -> list[str]:
    f = cmp.fits[name]
    est, t, boot, gof = f.estimate, f.intervals.t, f.intervals.bootstrap, f.goodness
    return [
        model_label(name) + ("" if f.physical else " — **UNPHYSICAL**"),
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
    ]


def _first(cmp: Any, name: str) -> str:
    if not cmp.first_fraction:
        return "–"
    return f"{cmp.first_fraction[name]:.0%}" if name in cmp.first_fraction else "– (unphysical)"


def _fit_section(a: Any) -> str:
    cmp = a.comparison
    if cmp is None:
        return "No fit: " + "; ".join(n for n in a.left_out if n.startswith("no fit")).removeprefix("no fit: ") + "\n"
    first = next(iter(cmp.fits.values()))
    lvl = round(first.intervals.level * 100)
    k, unit = resistance_unit(first.points.measured_ohm)
    rows = [_fit_row(cmp, name, k) for name in cmp.ranking]
    headers = [
        "model",
        f"R_s ± SE [{unit}]",
        f"R_s {lvl}% t-CI [{unit}]",
        f"R_s {lvl}% bootstrap [{unit}]",
        "s ± SE [Ω·m]",
        f"s {lvl}% bootstrap",
        "χ²",
        "χ²/dof",
        "p",
        "AIC",
        "ΔAIC",
        "Akaike w",
        "first in bootstrap",
        f"RMSE [{unit}]",
    ]
    boot = first.intervals.bootstrap
    text = _table(headers, rows)
    text += (
        f"\n\nModel: R = R_s + s·x(A(W)), x = {regressor_label(a.conversion)}, "
        f"h = {a.circuit.contact_height_m:g} m; weights 1/σ² with σ "
        f"{_WEIGHTING_TEXT.get(first.weighting, first.weighting)}; {boot.n_boot} bootstrap resamples of the repeats "
        f"({_BOOTSTRAP_TEXT.get(boot.resampling, boot.resampling)}), {boot.method} intervals; t-intervals with "
        f"{first.intervals.t.dof[0]:.3g} degrees of freedom; p: goodness of fit against "
        f"{first.goodness.reference}. k = 2 for every model, so ΔAIC = ΔBIC = Δχ².\n\n"
        f"**{cmp.statement}**\n"
    )
    notes = [f"- {model_label(n)}: {note}" for n in cmp.ranking for note in cmp.fits[n].diagnostics.warnings]
    notes += [f"- {model_label(n)}: UNPHYSICAL: {why}" for n in cmp.ranking for why in cmp.fits[n].unphysical]
    if not boot.available:
        notes.append(f"- bootstrap intervals {boot.note}")
    diag = [_diagnostics_line(n, cmp.fits[n].diagnostics) for n in cmp.ranking]
    if notes:
        text += "\nNotes:\n\n" + "\n".join(notes) + "\n"
    text += "\nSolver diagnostics (scipy.optimize.least_squares):\n\n" + "\n".join(diag) + "\n"
    truth = _simulated_truth(a)
    if truth:
        text += "\n" + truth
    return text


def _diagnostics_line(name: str, d: Any) -> str:
    return (
        f"- {model_label(name)}: nfev = {d.nfev}, status = {d.status} ({d.message}), cost = {d.cost:.4g}, "
        f"closed-form check {d.linear_check:.1e}"
    )


_WEIGHTING_TEXT = {
    "relative": "= pooled relative SD × mean R / √n (scatter ∝ R)",
    "pooled": "= pooled SD / √n",
    "repeats": "= each weight's own SEM",
    "blocks": "from the within-block standard errors",
}
_BOOTSTRAP_TEXT = {"series": "whole series", "within": "within each weight"}


def _simulated_truth(a: Any) -> str:
    """For a session on the simulated bench: the true R_s and ζ it was built with, against the fit."""
    start = a.measured_info.get("start") or {}
    if not start.get("sim"):
        return ""
    model = (start.get("simulation") or {}).get("model") or (
        ((start.get("plan") or {}).get("session") or {}).get("sim_model")
    )
    c = a.circuit
    repeat_sd = float((start.get("simulation") or {}).get("repeat_sd") or 0.0)
    reseat = f" × a mean-one log-normal re-seating factor per block (σ = {repeat_sd:g})" if repeat_sd > 0 else ""
    lines = [
        "Simulated bench: the resistance was generated as R = R_s + ζh/A(W)"
        + reseat
        + (f" with model **{model}**" if model else "")
        + f", R_s = {c.series_resistance_ohm * 1e3:g} mΩ and ζ = {c.resistivity_ohm_m:g} Ω·m (scene [circuit])."
    ]
    if model and model in a.comparison.fits and a.conversion == "bulk":
        e = a.comparison.fits[model].estimate
        lines.append(
            f" Its fit recovers R_s = {e.R_series_ohm * 1e3:.4g} ± {e.R_series_se * 1e3:.2g} mΩ and "
            f"s = {e.scale:.4g} ± {e.scale_se:.2g} Ω·m."
        )
    return "".join(lines) + "\n"


def _provenance(a: Any) -> str:
    info = a.measured_info
    lines = [f"- measured data: `{info.get('path', a.curve.source)}` ({info.get('kind', '?')}, status "
             f"{info.get('status', '?')}, {'complete' if info.get('complete', True) else 'INCOMPLETE'})"]  # fmt: skip
    start = info.get("start") or {}
    for k in ("started", "operator", "host", "command", "sim", "imported", "sample", "rig", "scene_name", "run"):
        if k in start:
            lines.append(f"- session {k}: {start[k]}")
    for k in sorted(start):
        if k in ("software", "versions") or "ident" in k:
            lines.append(f"- session {k}: `{to_json(start[k])}`")
    stop = info.get("stop")
    if stop:
        lines.append(f"- stop record: `{to_json(stop)}`")
    lines.append(f"- scene: {getattr(a.scene, 'name', '?')} ({getattr(a.scene, 'source', '?')})")
    lines.append(f"- simulation: {a.sim_info.get('source', '?')}")
    prov = a.sim_info.get("provenance") or {}
    if prov.get("software_version"):
        lines.append(f"- simulation software version: {prov['software_version']}")
    lines += _fingerprint_lines(a.fingerprint)
    for w in info.get("warnings", []):
        lines.append(f"- data note: {w}")
    return "\n".join(lines) + "\n"


def _fingerprint_lines(fp: dict[str, Any]) -> list[str]:
    """What the analysis was computed from (hashes of the scene tables on both sides) and any mismatch allowed."""
    if not fp:
        return []
    lines = []
    for side in ("measured", "simulation"):
        tables = (fp.get(side) or {}).get("tables") or {}
        hashes = ", ".join(f"{name} {t.get('sha256', '')[:12]}" for name, t in sorted(tables.items()))
        version = (fp.get(side) or {}).get("software_version")
        lines.append(
            f"- fingerprint of the {side} scene: {hashes or 'none recorded'}"
            + (f" (contactrig {version})" if version else "")
        )
    if fp.get("allowed"):
        lines.append(
            "- **SCENE MISMATCH ALLOWED (--allow-mismatch)**: the simulation is not of the measurement's scene — "
            + "; ".join(fp.get("differences", []))
        )
    return lines


def _warnings_section(a: Any) -> str:
    """Model-validity and simulation warnings, and what the data did not allow (empty when there is nothing)."""
    lines = [f"- **warning**: {w}" for w in a.warnings]
    lines += [f"- **left out**: {n}" for n in a.left_out]
    if a.fingerprint.get("allowed"):
        lines.append("- **scene mismatch allowed**: " + "; ".join(a.fingerprint.get("differences", [])))
    return "\n".join(lines) + "\n" if lines else ""


def render_markdown(
    analyses: Sequence[Any],
    figures: Sequence[dict[str, list[Path]]],
    directory: Path,
    *,
    title: str = "contactrig analysis report",
    preamble: str = "",
) -> str:
    """The Markdown text of the report (figures linked relative to ``directory``)."""
    now = datetime.now(UTC).isoformat(timespec="seconds")
    parts = [f"# {title}\n"]
    parts += [_banner(a.measured_info) for a in analyses if _banner(a.measured_info)]
    parts.append(
        f"Generated {now} by contactrig {software_version()} (Python {platform.python_version()}, "
        f"numpy {np.__version__}).\n"
    )
    if preamble:
        parts.append(preamble + "\n")
    for a, figs in zip(analyses, figures, strict=True):
        parts.append(f"## {a.title}\n")
        banner = _banner(a.measured_info)
        if banner:
            parts.append(banner)
        parts.append("### Provenance\n\n" + _provenance(a))
        caveats = _warnings_section(a)
        if caveats:
            parts.append("### Warnings and what was left out\n\n" + caveats)
        parts += _sections(a, figs, directory)
    return "\n".join(parts)


# The report's sections after the provenance: key (what a FigureSpec names as its ``section``), heading, text.
_SECTIONS: tuple[tuple[str, str, Callable[[Any], str] | None], ...] = (
    ("measured", "Measured resistance", _measured_section),
    ("area", "Simulated real contact area", _area_section),
    ("normalised", "Normalised curves (seed Fig. 12)", None),
    ("fit", "Fit and model comparison", _fit_section),
)


def _sections(a: Any, figs: dict[str, list[Path]], directory: Path) -> list[str]:
    """Each section's text followed by the registered figures that belong to it (in registration order); figures
    of any other section go under "Further figures"."""
    specs = [s for s in figure_specs() if s.key in figs]
    known = {key for key, _, _ in _SECTIONS}
    out = []
    for key, heading, text in _SECTIONS:
        images = [_img(figs, s, directory) for s in specs if s.section == key]
        if text is None and not images:
            continue
        out.append(f"### {heading}\n" + (f"\n{text(a)}" if text is not None else ""))
        out += images
    further = [_img(figs, s, directory) for s in specs if s.section not in known]
    if further:
        out.append("### Further figures\n")
        out += further
    return out


def _img(figs: dict[str, list[Path]], spec: FigureSpec, directory: Path) -> str:
    paths = figs[spec.key]
    png = next((p for p in paths if p.suffix == ".png"), paths[0])
    vector = [p for p in paths if p.suffix in (".svg", ".pdf")]
    rel = png.relative_to(directory).as_posix()
    extra = f" ([{vector[0].suffix[1:].upper()}]({vector[0].relative_to(directory).as_posix()}))" if vector else ""
    caption = f"\n{spec.caption}\n" if spec.caption else ""
    return f"![{spec.title}]({rel}){extra}\n{caption}"


def write_report(
    analyses: Sequence[Any],
    directory: str | Path,
    *,
    title: str = "contactrig analysis report",
    preamble: str = "",
    formats: Sequence[str] = ("png", "svg"),
    force: bool = False,
) -> Path:
    """Draw the figures of every analysis into ``directory/figures`` and write ``directory/report.md``.

    Every file is checked first (:func:`report_outputs`): an existing one is refused unless ``force``."""
    out = output_directory(directory)
    refuse_existing(report_outputs(out, [a.title for a in analyses], formats), force=force)
    figs = []
    for a in analyses:
        figs.append(write_figures(a, out / "figures", prefix=_slug(a.title), formats=formats, force=force))
    text = render_markdown(analyses, figs, out, title=title, preamble=preamble)
    return write_text_atomic(out / "report.md", text, force=force)
