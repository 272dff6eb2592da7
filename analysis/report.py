"""The analysis report: one Markdown file with provenance, tables and figures (``contactrig report`` / ``demo``).

:func:`write_report` takes one or more :class:`~analysis.pipeline.Analysis` objects (one section each), draws
their figures into ``DIR/figures`` (PNG for the report, SVG beside it) and writes ``DIR/report.md``. A session
without a stop record gets an **INCOMPLETE SESSION** banner at the top of the file and of its section.
"""

from __future__ import annotations

import json
import math
import platform
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from analysis.figures import (
    figure_database,
    figure_fit,
    figure_measured,
    figure_normalised,
    figure_simulated_area,
    model_label,
    save_figure,
)
from contactrig.core.provenance import software_version

__all__ = ["output_directory", "render_markdown", "write_figures", "write_report"]


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


def write_figures(
    analysis: Any, directory: str | Path, prefix: str = "", formats: Sequence[str] = ("png", "svg")
) -> dict[str, list[Path]]:
    """Draw every figure of ``analysis`` into ``directory``; returns name → written paths.

    Seed Fig. 2 (database) only when the analysis holds the contact database (simulated in this run).
    """
    out: dict[str, list[Path]] = {}
    pre = f"{prefix}-" if prefix else ""
    title = analysis.title
    if analysis.database is not None:
        curves = {name: analysis.database[name] for name in analysis.areas_m2}
        out["fig02_database"] = save_figure(figure_database(curves), directory, f"{pre}fig02_database", formats)
    out["fig09_measured"] = save_figure(
        figure_measured(analysis.curve, title=f"{title}: measured resistance (seed Fig. 9)"),
        directory, f"{pre}fig09_measured", formats,
    )  # fmt: skip
    area = {n: (analysis.curve.weight_kg, a) for n, a in analysis.areas_m2.items()}
    out["fig11_area"] = save_figure(figure_simulated_area(area), directory, f"{pre}fig11_area", formats)
    n_min = int(np.min(analysis.curve.n))
    fig12 = figure_normalised(
        analysis.measured_norm, analysis.simulated_norm, title=f"{title}: normalised (seed Fig. 12)",
        dof=n_min - 1 if n_min >= 2 else math.inf,
    )  # fmt: skip
    ax = fig12.axes[0]
    best = analysis.comparison.ranking[0]
    ax.plot(
        analysis.curve.weight_kg, analysis.fitted_norm()[best], color="k", lw=1.0, ls=(0, (2, 2)),
        label=f"best fit incl. R_s ({model_label(best)})",
    )  # fmt: skip
    ax.legend()
    out["fig12_normalised"] = save_figure(fig12, directory, f"{pre}fig12_normalised", formats)
    out["fit_residuals"] = save_figure(
        figure_fit(analysis.comparison, title=f"{title}: R = R_s + s·x(A), x = {_x_name(analysis.conversion)}"),
        directory, f"{pre}fit_residuals", formats,
    )  # fmt: skip
    return out


def _x_name(conversion: str) -> str:
    return "h/A (eq. 23)" if conversion == "bulk" else "√π/(2√A) (Holm)"


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


def _fit_section(a: Any) -> str:
    cmp = a.comparison
    rows = []
    lvl = round(next(iter(cmp.fits.values())).ci_level * 100)
    for name in cmp.ranking:
        f = cmp.fits[name]
        rows.append(
            [
                model_label(name),
                f"{f.R_series_ohm * 1e3:.4g} ± {f.R_series_se * 1e3:.2g}",
                f"[{_g(f.R_series_ci[0] * 1e3, 3)}, {_g(f.R_series_ci[1] * 1e3, 3)}]",
                f"[{_g(f.R_series_boot_ci[0] * 1e3, 3)}, {_g(f.R_series_boot_ci[1] * 1e3, 3)}]",
                f"{f.scale:.4g} ± {f.scale_se:.2g}",
                f"[{_g(f.scale_boot_ci[0], 3)}, {_g(f.scale_boot_ci[1], 3)}]",
                f"{f.chi2:.3g}",
                f"{f.reduced_chi2:.3g}",
                _g(f.p_value, 2),
                f"{f.aic:.2f}",
                f"{cmp.delta_aic[name]:.3g}",
                f"{cmp.akaike_weights[name]:.2f}",
                f"{cmp.first_fraction.get(name, math.nan):.0%}" if cmp.first_fraction else "–",
                f"{f.rmse_ohm * 1e3:.3g}",
            ]
        )
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
    first = next(iter(cmp.fits.values()))
    text = _table(headers, rows)
    text += (
        f"\n\nModel: R = R_s + s·x(A(W)), x = {_x_name(a.conversion)}, h = {a.circuit.contact_height_m:g} m; "
        f"weights 1/σ² with σ {_WEIGHTING_TEXT.get(first.weighting, first.weighting)}; {first.n_boot} bootstrap "
        f"resamples of the repeats ({_BOOTSTRAP_TEXT.get(first.bootstrap, first.bootstrap)}), "
        f"{first.boot_interval} intervals; t-intervals with {first.ci_dof[0]:.3g} degrees of freedom; p: "
        f"goodness of fit against {first.gof_reference}. k = 2 for every model, so ΔAIC = ΔBIC = Δχ².\n\n"
        f"**{cmp.statement}**\n"
    )
    notes = [f"- {model_label(n)}: {note}" for n in cmp.ranking for note in cmp.fits[n].notes]
    diag = [
        f"- {model_label(n)}: nfev = {cmp.fits[n].nfev}, status = {cmp.fits[n].status} ({cmp.fits[n].message}), "
        f"cost = {cmp.fits[n].cost:.4g}, closed-form check {cmp.fits[n].linear_check:.1e}"
        for n in cmp.ranking
    ]
    if notes:
        text += "\nNotes:\n\n" + "\n".join(notes) + "\n"
    text += "\nSolver diagnostics (scipy.optimize.least_squares):\n\n" + "\n".join(diag) + "\n"
    truth = _simulated_truth(a)
    if truth:
        text += "\n" + truth
    return text


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
        f = a.comparison.fits[model]
        lines.append(
            f" Its fit recovers R_s = {f.R_series_ohm * 1e3:.4g} ± {f.R_series_se * 1e3:.2g} mΩ and "
            f"s = {f.scale:.4g} ± {f.scale_se:.2g} Ω·m."
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
            lines.append(f"- session {k}: `{json.dumps(start[k], default=str)[:400]}`")
    stop = info.get("stop")
    if stop:
        lines.append(f"- stop record: `{json.dumps(stop, default=str)[:300]}`")
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
        parts.append("### Measured resistance\n\n" + _measured_section(a))
        parts.append(_img(figs, "fig09_measured", "Measured resistance against weight", directory))
        parts.append("### Simulated real contact area\n\n" + _area_section(a))
        parts.append(_img(figs, "fig11_area", "Simulated contact area", directory))
        if "fig02_database" in figs:
            parts.append(_img(figs, "fig02_database", "Contact database", directory))
        parts.append(
            "### Normalised curves (seed Fig. 12)\n\nColoured: each model's R_T/R_T₀ by the conversion (ζ and h "
            "cancel); black dotted: the best fit's R/R₀ including the series resistance R_s, which is what a "
            "measurement normalises. Error bars: the repeats' uncertainty of R/R₀ (R₀/R₀ = 1 exactly).\n"
        )
        parts.append(_img(figs, "fig12_normalised", "Normalised resistance", directory))
        parts.append("### Fit and model comparison\n\n" + _fit_section(a))
        parts.append(_img(figs, "fit_residuals", "Fit and residuals", directory))
    return "\n".join(parts)


def _img(figs: dict[str, list[Path]], key: str, alt: str, directory: Path) -> str:
    paths = figs.get(key)
    if not paths:
        return ""
    png = next((p for p in paths if p.suffix == ".png"), paths[0])
    vector = [p for p in paths if p.suffix in (".svg", ".pdf")]
    rel = png.relative_to(directory).as_posix()
    extra = f" ([{vector[0].suffix[1:].upper()}]({vector[0].relative_to(directory).as_posix()}))" if vector else ""
    return f"![{alt}]({rel}){extra}\n"


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
