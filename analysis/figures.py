"""Comparison figures (seed Figs. 2, 9, 11, 12, fit residuals, error against run time) with one style.

Every function takes plain data (arrays, :class:`~analysis.measured.MeasuredCurve`, results of
:mod:`analysis.fit`) and returns a :class:`matplotlib.figure.Figure` built without pyplot (so no GUI backend is
involved and figures can be drawn from threads); :func:`save_figure` writes it as PNG and a vector format.
matplotlib is imported only inside these functions. Units are on every axis; a model has the same colour and
name in every figure.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from analysis.measured import MeasuredCurve
from contactrig.core.validation import SettingError, check_choice

__all__ = [
    "MODEL_LABELS",
    "figure_database",
    "figure_error_vs_time",
    "figure_fit",
    "figure_measured",
    "figure_normalised",
    "figure_simulated_area",
    "model_colour",
    "model_label",
    "model_style",
    "save_figure",
]

MODEL_LABELS = {
    "greenwood_tripp": "Greenwood–Tripp",
    "hertz": "Hertz",
    "lagemann": "Lagemann",
    "pasaribu_schipper": "Pasaribu–Schipper",
    "jackson_green": "Jackson–Green",
}
_MODEL_COLOURS = {
    "greenwood_tripp": "#1f77b4",
    "hertz": "#d62728",
    "lagemann": "#2ca02c",
    "pasaribu_schipper": "#9467bd",
    "jackson_green": "#ff7f0e",
}
_EXTRA_COLOURS = ("#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f")
MEASURED_COLOUR = "#222222"

_RC = {
    "font.size": 9.0,
    "axes.titlesize": 10.0,
    "axes.labelsize": 9.0,
    "legend.fontsize": 8.0,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.6,
    "lines.linewidth": 1.6,
    "lines.markersize": 4.5,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "savefig.dpi": 150,
    "figure.dpi": 100,
    "svg.fonttype": "none",
}


def model_label(name: str) -> str:
    """Display name of a contact model."""
    return MODEL_LABELS.get(name, name.replace("_", " "))


_MODEL_STYLES = {
    "greenwood_tripp": ("-", "o"),
    "hertz": ("--", "s"),
    "lagemann": ("-.", "^"),
    "pasaribu_schipper": (":", "v"),
    "jackson_green": ((0, (6, 2, 1, 2, 1, 2)), "D"),
}


def model_style(name: str) -> dict[str, Any]:
    """Colour, line style and marker of a model, the same in every figure (models that coincide stay visible)."""
    ls, marker = _MODEL_STYLES.get(name, ("-", "x"))
    return {"color": model_colour(name), "linestyle": ls, "marker": marker, "label": model_label(name)}


def model_colour(name: str) -> str:
    """The colour a model has in every figure."""
    if name in _MODEL_COLOURS:
        return _MODEL_COLOURS[name]
    return _EXTRA_COLOURS[sum(map(ord, name)) % len(_EXTRA_COLOURS)]


def _figure(ncols: int = 1, nrows: int = 1, size: tuple[float, float] = (6.0, 4.0), **kw: Any):
    import matplotlib
    from matplotlib.figure import Figure

    matplotlib.rcParams.update(_RC)
    fig = Figure(figsize=size, layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, **kw)
    return fig, axes


def save_figure(fig: Any, directory: str | Path, stem: str, formats: Sequence[str] = ("png", "svg")) -> list[Path]:
    """Write ``fig`` as ``directory/stem.<fmt>`` for each of ``formats`` (png, svg, pdf); returns the paths."""
    out = Path(directory)
    if out.exists() and not out.is_dir():
        raise SettingError("output", str(out), "expected a directory; a file of that name exists")
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for fmt in formats:
        check_choice("format", fmt, ("png", "svg", "pdf"))
        path = out / f"{stem}.{fmt}"
        fig.savefig(path, format=fmt, metadata=_metadata(fmt))
        paths.append(path)
    return paths


def _metadata(fmt: str) -> dict[str, Any]:
    # No creation date: the same data give byte-identical vector files.
    if fmt == "svg":
        return {"Date": None}
    if fmt == "pdf":
        return {"CreationDate": None}
    return {}


# ---- seed Fig. 2: contact database ---------------------------------------------------------------------------
def figure_database(curves: Mapping[str, Any], sigma_m: float | None = None) -> Any:
    """Seed Fig. 2: contact pressure p(h) (log scale) and real-area fraction A/A₀(h) per model.

    ``curves`` name → object with ``separation_m``, ``pressure_pa``, ``area_fraction`` arrays (a
    ``sims.database.ContactCurve``). With ``sigma_m`` the separation axis is h/σ instead of µm.
    """
    fig, ax = _figure(2, 1, size=(8.0, 3.6))
    for name, c in curves.items():
        h = np.asarray(c.separation_m, dtype=float)
        x = h / sigma_m if sigma_m else h * 1e6
        p = np.asarray(c.pressure_pa, dtype=float)
        a = np.asarray(c.area_fraction, dtype=float)
        kw = model_style(name)
        kw["marker"] = None
        pos = p > 0
        ax[0, 0].plot(x[pos], p[pos] * 1e-6, **kw)
        ax[0, 1].plot(x[a > 0], a[a > 0], **kw)
    xlabel = "separation h/σ [–]" if sigma_m else "separation h [µm]"
    ax[0, 0].set(xlabel=xlabel, ylabel="contact pressure p [MPa]", yscale="log", title="Pressure")
    ax[0, 1].set(xlabel=xlabel, ylabel="real area fraction A/A₀ [–]", yscale="log", title="Real contact area")
    ax[0, 0].legend()
    fig.suptitle("Contact database (seed Fig. 2)")
    return fig


# ---- seed Fig. 9: measured R against weight ------------------------------------------------------------------
def figure_measured(curve: MeasuredCurve, title: str = "") -> Any:
    """Seed Fig. 9: every repeat (thin lines with markers, one per series) and the mean ± SD over repeats [mΩ]."""
    fig, axes = _figure()
    ax = axes[0, 0]
    w = curve.weight_kg
    v = curve.values_ohm * 1e3
    for k, label in enumerate(curve.repeat_labels):
        ok = np.isfinite(v[:, k])
        ax.plot(
            w[ok], v[ok, k], "o-", color="#9a9a9a", lw=0.7, ms=3, alpha=0.8,
            label=f"repeats ({len(curve.repeat_labels)})" if k == 0 else None, gid=f"repeat-{label}",
        )  # fmt: skip
    sd = np.nan_to_num(curve.sd_ohm * 1e3)
    ax.errorbar(w, curve.mean_ohm * 1e3, yerr=sd, fmt="s-", color=MEASURED_COLOUR, capsize=3, label="mean ± SD")
    ax.set(xlabel="weight W [kg]", ylabel="resistance R [mΩ]", title=title or "Measured resistance (seed Fig. 9)")
    ax.set_ylim(bottom=0)
    ax.legend()
    return fig


# ---- seed Fig. 11: simulated contact area -----------------------------------------------------------------------
def figure_simulated_area(models: Mapping[str, tuple[np.ndarray, np.ndarray]], title: str = "") -> Any:
    """Seed Fig. 11: simulated real contact area [mm²] against weight [kg]; ``models`` name → (W, A [m²])."""
    fig, axes = _figure()
    ax = axes[0, 0]
    for name, (w, a) in models.items():
        ax.plot(np.asarray(w), np.asarray(a) * 1e6, mfc="none", **model_style(name))
    ax.set(xlabel="weight W [kg]", ylabel="real contact area A [mm²]", title=title or "Simulated area (seed Fig. 11)")
    ax.legend()
    return fig


# ---- seed Fig. 12: normalised measured vs simulated ------------------------------------------------------------
def figure_normalised(
    measured: Any, simulated: Mapping[str, Any], title: str = "", level: float = 0.95, dof: float = math.inf
) -> Any:
    """Seed Fig. 12: R/R₀ (dimensionless) of the measurement and of each model against weight [kg].

    ``measured`` and the values of ``simulated`` are :class:`~analysis.normalisation.NormalisedCurve`; the
    measured error bars are ± ``level`` Student-t intervals with ``dof`` degrees of freedom (repeats − 1; inf:
    normal quantile).
    """
    from scipy.special import ndtri, stdtrit

    q = 0.5 + level / 2
    z = float(ndtri(q)) if not math.isfinite(dof) else float(stdtrit(dof, q))
    fig, axes = _figure()
    ax = axes[0, 0]
    for name, nc in simulated.items():
        ax.plot(nc.weight_kg, nc.ratio, mfc="none", **model_style(name))
    ax.errorbar(
        measured.weight_kg, measured.ratio, yerr=z * measured.se, fmt="s", color=MEASURED_COLOUR, capsize=3,
        label=f"measured ± {level:.0%} CI" + (f" (t, {dof:g} dof)" if math.isfinite(dof) else ""),
    )  # fmt: skip
    ax.set(
        xlabel="weight W [kg]",
        ylabel="normalised resistance R/R₀ [–]",
        title=title or "Normalised to the first weight (seed Fig. 12)",
    )
    ax.legend()
    return fig


# ---- fits ---------------------------------------------------------------------------------------------------
def figure_fit(comparison: Any, title: str = "") -> Any:
    """Fits R = R_s + s·x(A) (seed eq. 23 plus R_s): measured mean ± σ (the fit's weighting) and each model's fitted
    R [mΩ] against weight [kg] (top); residuals (measured − fitted)/σ, dimensionless, per model (bottom)."""
    fig, axes = _figure(1, 2, size=(6.0, 5.6), sharex=True, height_ratios=[2.2, 1.0])
    top, bottom = axes[0, 0], axes[1, 0]
    first = next(iter(comparison.fits.values()))
    w = first.weight_kg
    top.errorbar(
        w, first.measured_ohm * 1e3, yerr=first.sigma_ohm * 1e3, fmt="s", color=MEASURED_COLOUR, capsize=3,
        label="measured mean ± σ", zorder=3,
    )  # fmt: skip
    n = len(comparison.fits)
    width = 0.6 * (np.min(np.diff(w)) if w.size > 1 else 1.0) / max(n, 1)
    for i, name in enumerate(comparison.ranking):
        f = comparison.fits[name]
        label = f"{model_label(name)}: ΔAIC {comparison.delta_aic[name]:.1f}"
        top.plot(w, f.fitted_ohm * 1e3, mfc="none", **{**model_style(name), "label": label})
        bottom.bar(w + (i - (n - 1) / 2) * width, f.normalised_residuals, width, color=model_colour(name))
    bottom.axhline(0.0, color="k", lw=0.8)
    for y in (-2.0, 2.0):
        bottom.axhline(y, color="k", lw=0.6, ls=":")
    top.set(ylabel="resistance R [mΩ]", title=title or "Fit R = R_s + s·h/A(W) per model")
    bottom.set(xlabel="weight W [kg]", ylabel="residual / σ [–]")
    top.legend()
    return fig


# ---- error against run time ----------------------------------------------------------------------------------
def _row_get(row: Any, key: str) -> Any:
    return row[key] if isinstance(row, Mapping) else getattr(row, key)


def figure_error_vs_time(
    rows: Iterable[Any], study: str | None = None, title: str = "", ylabel: str = "relative error [–]"
) -> Any:
    """Error against run time, log–log: one line per method through its settings, one panel per study.

    ``rows``: mappings or objects with ``study``, ``method``, ``setting``, ``error``, ``seconds``
    (``analysis.studies.Row``). ``study`` selects one study. Rows whose error or time is zero, negative or not
    finite cannot be drawn on log axes; they are counted in the panel title rather than dropped silently.
    """
    table = [{k: _row_get(r, k) for k in ("study", "method", "setting", "error", "seconds")} for r in rows]
    if study is not None:
        table = [r for r in table if r["study"] == study]
    if not table:
        raise SettingError("rows", study or "[]", "expected at least one row to plot")
    studies = list(dict.fromkeys(r["study"] for r in table))
    ncols = min(len(studies), 3)
    nrows = math.ceil(len(studies) / ncols)
    fig, axes = _figure(ncols, nrows, size=(4.2 * ncols, 3.4 * nrows))
    for ax in axes.ravel()[len(studies) :]:
        ax.set_visible(False)
    for ax, name in zip(axes.ravel(), studies, strict=False):
        sub = [r for r in table if r["study"] == name]
        drawable = [r for r in sub if _positive(r["error"]) and _positive(r["seconds"])]
        methods = list(dict.fromkeys(r["method"] for r in sub))
        for j, method in enumerate(methods):
            pts = sorted((r for r in drawable if r["method"] == method), key=lambda r: r["seconds"])
            if not pts:
                continue
            colour = model_colour(method) if method in _MODEL_COLOURS else f"C{j % 10}"
            ax.plot([r["seconds"] for r in pts], [r["error"] for r in pts], "o-", color=colour, label=method)
            for r in pts:
                ax.annotate(str(r["setting"]), (r["seconds"], r["error"]), xytext=(3, 3),
                            textcoords="offset points", fontsize=6)  # fmt: skip
        skipped = len(sub) - len(drawable)
        plural = "s" if skipped != 1 else ""
        suffix = f" ({skipped} row{plural} with error or time ≤ 0 not shown)" if skipped else ""
        ax.set(xscale="log", yscale="log", xlabel="run time [s]", ylabel=ylabel, title=f"{name}{suffix}")
        if drawable:
            ax.legend()
    if title:
        fig.suptitle(title)
    return fig


def _positive(x: Any) -> bool:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return False
    return math.isfinite(v) and v > 0
