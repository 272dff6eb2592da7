"""The analysis report: one Markdown file with provenance, tables and figures (``contactrig report`` / ``demo``).

:func:`write_report` takes one or more :class:`~analysis.pipeline.Analysis` objects (one section each), draws
their figures into ``DIR/figures`` (PNG for the report, SVG beside it) and writes ``DIR/report.md``. A session
without a stop record gets an **INCOMPLETE SESSION** banner at the top of the file and of its section.
"""

from __future__ import annotations

import math
import platform
from collections.abc import Callable, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from analysis.figures import FigureSpec, figure_specs, write_figures
from analysis.fit import regressor_label
from contactrig.core.provenance import software_version, to_json
from sims.models import model_label

__all__ = ["output_directory", "render_markdown", "write_report"]


def output_directory(directory: str | Path) -> Path:
    """Create ``directory`` (and parents) for output; a file of that name is an error naming it."""
    from contactrig.core.validation import SettingError

    out = Path(directory)
    if out.exists() and not out.is_dir():
        raise SettingError("output", str(out), "expected a directory; a file of that name exists")
    out.mkdir(parents=True, exist_ok=True)
    return out


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
    rows = []
    for i, w in enumerate(c.weight_kg):
        rows.append(
            [
                f"{w:g}",
                int(c.n[i]),
                _g(c.mean_ohm[i] * 1e3),
                _g(c.sd_ohm[i] * 1e3, 3),
                _g(c.sem_ohm[i] * 1e3, 3),
                f"{nm.ratio[i]:.5g} ± {nm.se[i]:.2g}",
            ]
        )
    paired = "series (correlation across weights included)" if nm.paired else "independent repeats"
    return (
        _table(["weight [kg]", "repeats", "mean R [mΩ]", "SD [mΩ]", "SEM [mΩ]", "R/R₀ ± SE"], rows)
        + f"\n\nRepeats treated as {paired}. R₀ = {nm.reference_ohm * 1e3:.4g} ± {nm.reference_se_ohm * 1e3:.2g} mΩ; "
        "R₀/R₀ = 1 exactly.\n"
    )


def _area_section(a: Any) -> str:
    names = list(a.areas_m2)
    rows = [[f"{w:g}"] + [_g(a.areas_m2[n][i] * 1e6) for n in names] for i, w in enumerate(a.curve.weight_kg)]
    return _table(["weight [kg]"] + [f"{model_label(n)} A [mm²]" for n in names], rows) + "\n"


def _interval(ci: tuple[float, float], factor: float = 1.0) -> str:
    return f"[{_g(ci[0] * factor, 3)}, {_g(ci[1] * factor, 3)}]"


def _fit_row(cmp: Any, name: str) -> list[str]:
    f = cmp.fits[name]
    est, t, boot, gof = f.estimate, f.intervals.t, f.intervals.bootstrap, f.goodness
    return [
        model_label(name),
        f"{est.R_series_ohm * 1e3:.4g} ± {est.R_series_se * 1e3:.2g}",
        _interval(t.R_series_ohm, 1e3),
        _interval(boot.R_series_ohm, 1e3),
        f"{est.scale:.4g} ± {est.scale_se:.2g}",
        _interval(boot.scale),
        f"{gof.chi2:.3g}",
        f"{gof.reduced_chi2:.3g}",
        _g(gof.p_value, 2),
        f"{gof.aic:.2f}",
        f"{cmp.delta_aic[name]:.3g}",
        f"{cmp.akaike_weights[name]:.2f}",
        f"{cmp.first_fraction.get(name, math.nan):.0%}" if cmp.first_fraction else "–",
        f"{gof.rmse_ohm * 1e3:.3g}",
    ]


def _fit_section(a: Any) -> str:
    cmp = a.comparison
    first = next(iter(cmp.fits.values()))
    lvl = round(first.intervals.level * 100)
    rows = [_fit_row(cmp, name) for name in cmp.ranking]
    headers = [
        "model",
        "R_s ± SE [mΩ]",
        f"R_s {lvl}% t-CI",
        f"R_s {lvl}% bootstrap",
        "s ± SE [Ω·m]",
        f"s {lvl}% bootstrap",
        "χ²",
        "χ²/dof",
        "p",
        "AIC",
        "ΔAIC",
        "Akaike w",
        "first in bootstrap",
        "RMSE [mΩ]",
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
    for w in info.get("warnings", []):
        lines.append(f"- data note: {w}")
    for w in a.sim_info.get("warnings", [])[:10]:
        lines.append(f"- simulation warning: {w}")
    return "\n".join(lines) + "\n"


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
) -> Path:
    """Draw the figures of every analysis into ``directory/figures`` and write ``directory/report.md``."""
    out = output_directory(directory)
    figs = []
    for a in analyses:
        figs.append(write_figures(a, out / "figures", prefix=_slug(a.title), formats=formats))
    text = render_markdown(analyses, figs, out, title=title, preamble=preamble)
    path = out / "report.md"
    tmp = path.with_name(path.name + ".partial")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)
    return path
