"""Comparison figures (seed Figs. 2, 9, 11, 12, fit residuals, error against run time) with one style.

Every function takes plain data (arrays, :class:`~analysis.measured.MeasuredCurve`, results of
:mod:`analysis.fit`) and returns a :class:`matplotlib.figure.Figure` built without pyplot (so no GUI backend is
involved and figures can be drawn from threads); :func:`save_figure` writes it as PNG and a vector format.
matplotlib is imported only inside these functions. Units are on every axis; a model has the same colour and
name in every figure: label and style come from the contact-model registry (:mod:`sims.models`), see
:func:`model_style`.

The figures of an analysis are a registry of :class:`FigureSpec` (key, title, draw function, caption, report
section, file name): :func:`register` adds one, :func:`write_figures` draws every registered figure (``contactrig
figures``) and :mod:`analysis.report` places each in its section. Seed Fig. 2 of a contact database alone:
:func:`figure_database`, or :func:`write_database_figure` to a file (``contactrig database --plot``).
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from analysis.fit import regressor_label
from analysis.measured import MeasuredCurve
from analysis.resistance import resistance_unit
from contactrig.core.files import atomic_write, output_folder
from contactrig.core.registry import Registry
from contactrig.core.text import escape_terminal
from contactrig.core.validation import SettingError, check_choice
from sims.models import get_model, model_label, model_names, models

__all__ = [
    "ERROR_BARS",
    "FigureSpec",
    "figure_database",
    "figure_error_vs_time",
    "figure_fit",
    "figure_measured",
    "figure_normalised",
    "figure_simulated_area",
    "figure_specs",
    "get_figure",
    "model_style",
    "planned_figures",
    "register",
    "repeat_names",
    "save_figure",
    "save_figure_file",
    "unregister",
    "write_database_figure",
    "write_figures",
]

# Colours, line styles and markers for models whose registration (sims.models) gives no style: matplotlib's
# "tab10" cycle, minus the colours that registered styles take.
_COLOUR_CYCLE = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
)  # fmt: skip
_LINESTYLE_CYCLE = ("-", "--", "-.", ":")
_MARKER_CYCLE = ("o", "s", "^", "v", "D", "x", "P", "*")
MEASURED_COLOUR = "#222222"

_RC: dict[Any, Any] = {
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


def model_style(key: str) -> dict[str, Any]:
    """Colour, line style, marker and label of contact model ``key``, the same in every figure.

    Label and style come from the model registry (:func:`sims.models.get_model`: ``.label``, ``.style``); what a
    registration leaves out comes from a cycle indexed by the model's place among the registered models without a
    style (a key that is not registered: by a stable hash of the key), so models that coincide stay visible.
    """
    try:
        registered = dict(get_model(key).style)
    except KeyError:
        registered = {}
    i = _cycle_index(key)
    used = _styled_colours()
    free = [c for c in _COLOUR_CYCLE if c not in used] or list(_COLOUR_CYCLE)
    style = {
        "color": free[i % len(free)],
        "linestyle": _LINESTYLE_CYCLE[i % len(_LINESTYLE_CYCLE)],
        "marker": _MARKER_CYCLE[i % len(_MARKER_CYCLE)],
    }
    style.update(registered)
    style["label"] = model_label(key)
    return style


def _cycle_index(key: str) -> int:
    unstyled = [m.key for m in models() if not m.style]
    if key in unstyled:
        return unstyled.index(key)
    if key in model_names():
        return 0
    return len(unstyled) + zlib.crc32(key.encode("utf-8"))


def _styled_colours() -> set[str]:
    return {str(m.style["color"]) for m in models() if "color" in m.style}


def _figure(ncols: int = 1, nrows: int = 1, size: tuple[float, float] = (6.0, 4.0), **kw: Any):
    import matplotlib
    from matplotlib.figure import Figure

    matplotlib.rcParams.update(_RC)
    fig = Figure(figsize=size, layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, **kw)
    return fig, axes


def save_figure(
    fig: Any, directory: str | Path, stem: str, formats: Sequence[str] = ("png", "svg"), *, force: bool = False
) -> list[Path]:
    """Write ``fig`` as ``directory/stem.<fmt>`` for each of ``formats`` (png, svg, pdf); returns the paths. The
    folder is created when missing; an existing file is refused unless ``force`` (:mod:`contactrig.core.files`)."""
    out = output_folder(directory)
    for fmt in formats:
        check_choice("format", fmt, _FORMATS)
    return [save_figure_file(fig, out / f"{stem}.{fmt}", force=force) for fmt in formats]


def save_figure_file(fig: Any, path: str | Path, *, force: bool = False) -> Path:
    """Write ``fig`` to ``path`` atomically, the format from its suffix (.png, .svg or .pdf); returns the path. An
    existing file is refused unless ``force``."""
    path = Path(path)
    fmt = path.suffix[1:].lower()
    check_choice("format", fmt, _FORMATS)
    with atomic_write(path, force=force) as tmp:
        fig.savefig(tmp, format=fmt, metadata=_metadata(fmt))
    return path


_FORMATS = ("png", "svg", "pdf")


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


def write_database_figure(
    curves: Mapping[str, Any], path: str | Path, sigma_m: float | None = None, *, force: bool = False
) -> Path:
    """Seed Fig. 2 of a contact database (``sims.database.ContactDatabase`` or any name → curve mapping) drawn by
    :func:`figure_database` and written to ``path`` (.png, .svg or .pdf; refused if it exists, unless ``force``)."""
    return save_figure_file(figure_database(curves, sigma_m=sigma_m), path, force=force)


# ---- seed Fig. 9: measured R against weight ------------------------------------------------------------------
#: The one error-bar convention of every figure with error bars (and of every caption that has them): the standard
#: error of the mean over the repeats. Fig. 12 propagates it to R/R₀ (with the series' covariance).
ERROR_BARS = "error bars: ± 1 SEM of the repeats (standard error of the mean, SD/√n)"


def repeat_names(curve: MeasuredCurve) -> tuple[str, ...]:
    """The repeats' names in figures: the curve's own labels (Tab. 1's M1…M6), or M1…Mn for numbered repeats (a
    session's repeat index 0…n−1)."""
    labels = tuple(str(x) for x in curve.repeat_labels)
    if all(x.strip().isdigit() for x in labels):
        return tuple(f"M{k + 1}" for k in range(len(labels)))
    return labels


def figure_measured(curve: MeasuredCurve, title: str = "") -> Any:
    """Seed Fig. 9: every repeat (thin lines with markers, one per series, each labelled M1…Mn in the legend) and
    the mean ± 1 SEM over repeats (:data:`ERROR_BARS`), in the unit the data call for (µΩ, mΩ or Ω:
    :func:`analysis.resistance.resistance_unit`)."""
    fig, axes = _figure(size=(6.4, 4.2))
    ax = axes[0, 0]
    w = curve.weight_kg
    k_unit, unit = resistance_unit(curve.values_ohm)
    v = curve.values_ohm * k_unit
    names = repeat_names(curve)
    greys = _repeat_colours(len(names))
    for k, (label, name) in enumerate(zip(curve.repeat_labels, names, strict=True)):
        ok = np.isfinite(v[:, k])
        ax.plot(
            w[ok], v[ok, k], "o-", color=greys[k], lw=0.8, ms=3, alpha=0.9, label=_legend_text(name),
            gid=f"repeat-{label}",
        )  # fmt: skip
    sem = np.nan_to_num(curve.sem_ohm * k_unit)
    ax.errorbar(w, curve.mean_ohm * k_unit, yerr=sem, fmt="s-", color=MEASURED_COLOUR, capsize=3, label="mean ± 1 SEM")
    ax.set(xlabel="weight W [kg]", ylabel=f"resistance R [{unit}]", title=title or "Measured resistance (seed Fig. 9)")
    ax.set_ylim(bottom=0)
    ax.legend(ncols=2 if len(names) > 6 else 1, fontsize=7)
    return fig


def _repeat_colours(n: int) -> list[Any]:
    """Distinguishable muted colours for n repeats (a slice of the "viridis" map, lightened)."""
    from matplotlib import colormaps

    cmap = colormaps["viridis"]
    return [tuple(0.35 + 0.65 * c for c in cmap(0.1 + 0.8 * k / max(n - 1, 1))[:3]) for k in range(n)]


def _legend_text(text: str) -> str:
    """A label from a file shown as text by matplotlib: control characters visible, ``$`` not starting mathtext."""
    return escape_terminal(text).replace("$", r"\$")


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
def figure_normalised(measured: Any, simulated: Mapping[str, Any], title: str = "") -> Any:
    """Seed Fig. 12: R/R₀ (dimensionless) of the measurement and of each model against weight [kg].

    ``measured`` and the values of ``simulated`` are :class:`~analysis.normalisation.NormalisedCurve`; the
    measured error bars are ± 1 standard error of R/R₀ propagated from the repeats (:data:`ERROR_BARS`).
    """
    fig, axes = _figure()
    ax = axes[0, 0]
    for name, nc in simulated.items():
        ax.plot(nc.weight_kg, nc.ratio, mfc="none", **model_style(name))
    ax.errorbar(
        measured.weight_kg, measured.ratio, yerr=measured.se, fmt="s", color=MEASURED_COLOUR, capsize=3,
        label="measured ± 1 SEM",
    )  # fmt: skip
    ax.set(
        xlabel="weight W [kg]",
        ylabel="normalised resistance R/R₀ [–]",
        title=title or "Normalised to the first weight (seed Fig. 12)",
    )
    ax.legend()
    return fig


# ---- fits ---------------------------------------------------------------------------------------------------
def figure_fit(comparison: Any, title: str = "", sem_ohm: Any = None) -> Any:
    """Fits R = R_s + s·x(A) (seed eq. 23 plus R_s): measured mean (± 1 SEM of the repeats when ``sem_ohm`` [Ω] is
    given, :data:`ERROR_BARS`) and each model's fitted R (unit from the data) against weight [kg] (top; an
    unphysical fit is marked so); residuals (measured − fitted)/σ with σ the fit's weighting, dimensionless, per
    model (bottom)."""
    fig, axes = _figure(1, 2, size=(6.0, 5.6), sharex=True, height_ratios=[2.2, 1.0])
    top, bottom = axes[0, 0], axes[1, 0]
    first = next(iter(comparison.fits.values())).points
    w = first.weight_kg
    k_unit, unit = resistance_unit(first.measured_ohm)
    yerr = None if sem_ohm is None else np.nan_to_num(np.asarray(sem_ohm, dtype=float) * k_unit)
    top.errorbar(
        w, first.measured_ohm * k_unit, yerr=yerr, fmt="s", color=MEASURED_COLOUR, capsize=3,
        label="measured mean" + (" ± 1 SEM" if yerr is not None else ""), zorder=3,
    )  # fmt: skip
    n = len(comparison.fits)
    width = 0.6 * (np.min(np.diff(w)) if w.size > 1 else 1.0) / max(n, 1)
    for i, name in enumerate(comparison.ranking):
        f = comparison.fits[name]
        crit = getattr(comparison, "criterion", "AIC")  # the fit's criterion: QAIC when over-dispersed
        label = f"{model_label(name)}: Δ{crit} {comparison.delta_aic[name]:.1f}" + ("" if f.physical else " UNPHYSICAL")
        style = {**model_style(name), "label": label}
        top.plot(w, f.points.fitted_ohm * k_unit, mfc="none", **style)
        bottom.bar(w + (i - (n - 1) / 2) * width, f.points.normalised_residuals, width, color=style["color"])
    bottom.axhline(0.0, color="k", lw=0.8)
    for y in (-2.0, 2.0):
        bottom.axhline(y, color="k", lw=0.6, ls=":")
    top.set(ylabel=f"resistance R [{unit}]", title=title or "Fit R = R_s + s·h/A(W) per model")
    bottom.set(xlabel="weight W [kg]", ylabel="residual / σ of the fit [–]")
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
    known = set(model_names())
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
            colour = model_style(method)["color"] if method in known else f"C{j % 10}"
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


# ---- the figure registry ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FigureSpec:
    """One figure of an analysis, declared once: ``contactrig figures`` draws every registered spec and the report
    shows each in its ``section``.

    ``key``: the name printed by ``contactrig figures`` and the file stem unless ``filename`` is given. ``title``:
    what the figure shows (the report's alt text). ``draw(analysis) -> Figure | None``: the figure of one
    :class:`~analysis.pipeline.Analysis`, None when the analysis lacks its data (``missing`` says why).
    ``caption``: text under the figure in the report. ``section``: the report section it belongs to
    (``"measured"``, ``"area"``, ``"normalised"``, ``"fit"``; any other value, or none, puts it under "Further
    figures").
    """

    key: str
    title: str
    draw: Callable[[Any], Any]
    caption: str = ""
    section: str = ""
    filename: str = ""
    missing: str = ""

    @property
    def stem(self) -> str:
        """File name without the format suffix."""
        return self.filename or self.key


_FIGURES: Registry[FigureSpec] = Registry("figure")


def register(spec: FigureSpec, *, replace: bool = False) -> FigureSpec:
    """Add ``spec`` to the figure registry (a second spec with the same key is an error unless ``replace``)."""
    return _FIGURES.register(spec, replace=replace)


def unregister(key: str) -> None:
    """Remove a figure (tests use it to clean up a toy figure)."""
    _FIGURES.unregister(key)


def figure_specs() -> tuple[FigureSpec, ...]:
    """Every registered figure, in registration order."""
    return tuple(_FIGURES)


def get_figure(key: str) -> FigureSpec:
    """The figure ``key``; an unknown key is a :class:`KeyError` naming the known ones."""
    return _FIGURES.get(key)


def planned_figures(directory: str | Path, prefix: str = "", formats: Sequence[str] = ("png", "svg")) -> list[Path]:
    """Every file :func:`write_figures` may write (checked for existing files before any work is done)."""
    pre = f"{prefix}-" if prefix else ""
    return [Path(directory) / f"{pre}{spec.stem}.{fmt}" for spec in figure_specs() for fmt in formats]


def write_figures(
    analysis: Any,
    directory: str | Path,
    prefix: str = "",
    formats: Sequence[str] = ("png", "svg"),
    *,
    force: bool = False,
) -> dict[str, list[Path]]:
    """Draw every registered figure of ``analysis`` into ``directory`` as ``[prefix-]stem.<fmt>``; returns key →
    written paths. A figure whose ``draw`` returns None (data missing) is left out of the result. Every file is
    checked first: an existing one is refused unless ``force`` (nothing is drawn then)."""
    from contactrig.core.files import refuse_existing

    refuse_existing(planned_figures(directory, prefix, formats), force=force)
    out: dict[str, list[Path]] = {}
    pre = f"{prefix}-" if prefix else ""
    for spec in figure_specs():
        fig = spec.draw(analysis)
        if fig is not None:
            out[spec.key] = save_figure(fig, directory, f"{pre}{spec.stem}", formats, force=force)
    return out


def _draw_measured(a: Any) -> Any:
    return figure_measured(a.curve, title=f"{_legend_text(a.title)}: measured resistance (seed Fig. 9)")


def _draw_area(a: Any) -> Any:
    return figure_simulated_area({n: (a.curve.weight_kg, area) for n, area in a.areas_m2.items()})


def _draw_database(a: Any) -> Any:
    if a.database is None:
        return None
    return figure_database({name: a.database[name] for name in a.areas_m2})


def _draw_normalised(a: Any) -> Any:
    fig = figure_normalised(
        a.measured_norm, a.simulated_norm, title=f"{_legend_text(a.title)}: normalised (seed Fig. 12)"
    )
    if a.comparison is None:
        return fig
    ax = fig.axes[0]
    best = a.comparison.ranking[0]
    ax.plot(
        a.comparison.best.points.weight_kg, a.fitted_norm()[best], color="k", lw=1.0, ls=(0, (2, 2)),
        label=f"best fit incl. R_s ({model_label(best)})",
    )  # fmt: skip
    ax.legend()
    return fig


def _draw_fit(a: Any) -> Any:
    if a.comparison is None:
        return None
    from analysis.fit import independent_series  # the series the fit counts (copies of others once)

    sem = independent_series(a.fit_curve)[0].sem_ohm if a.fit_curve is not None else None
    return figure_fit(
        a.comparison, title=f"{_legend_text(a.title)}: R = R_s + s·x(A), x = {regressor_label(a.conversion)}",
        sem_ohm=sem,
    )  # fmt: skip


for _spec in (
    FigureSpec(
        "fig09_measured",
        "Measured resistance against weight",
        _draw_measured,
        section="measured",
        caption=f"Seed Fig. 9: every repeat (M1…Mn, labelled) and their mean; {ERROR_BARS}.",
    ),
    FigureSpec("fig11_area", "Simulated contact area", _draw_area, section="area"),
    FigureSpec(
        "fig02_database",
        "Contact database",
        _draw_database,
        section="area",
        caption="Seed Fig. 2: nominal contact pressure p(h) and real-area fraction A/A₀(h) of every model.",
        missing="the contact database is built only when the rig is simulated now; omit --sim",
    ),
    FigureSpec(
        "fig12_normalised",
        "Normalised resistance",
        _draw_normalised,
        section="normalised",
        caption="Coloured: each model's R_T/R_T₀ by the conversion (ζ and h cancel); black dotted: the best fit's "
        "R/R₀ including the series resistance R_s, which is what a measurement normalises; "
        f"{ERROR_BARS}, propagated to R/R₀ with the series' covariance (R₀/R₀ = 1 exactly, no bar).",
    ),
    FigureSpec(
        "fit_residuals",
        "Fit and residuals",
        _draw_fit,
        section="fit",
        caption=f"Top: measured mean and each model's fit, {ERROR_BARS}; bottom: residuals (measured − fitted)/σ "
        "with σ the fit's weighting.",
        missing="no fit: the data allow none (fewer than 3 weights with >= 2 repeats)",
    ),
):
    register(_spec)
del _spec


# ---- the physical resistance model's terms (issue 21 §2; owned by analysis.resistance_model's fit) -------------
def _draw_physical_terms(a: Any) -> Any:
    """The best model's physical fit as stacked terms against weight [kg]: R_s, σ_f/A, Barber, band constriction
    (unit from the data), with the measured mean; None unless ``--conversion physical``."""
    if a.comparison is None or a.conversion != "physical":
        return None
    f = a.comparison.best
    pts, est = f.points, f.estimate
    k_unit, unit = resistance_unit(pts.measured_ohm)
    terms = {"R_s": np.full(pts.weight_kg.shape, est.R_series_ohm), "film σ_f/A": est.scale * pts.regressor_per_m}
    terms.update({name: share * pts.measured_ohm for name, share in f.shares.items() if name not in ("series", "film")})
    fig, axes = _figure(size=(6.0, 4.0))
    ax = axes[0, 0]
    ax.stackplot(pts.weight_kg, *[v * k_unit for v in terms.values()], labels=list(terms), alpha=0.8)
    ax.plot(pts.weight_kg, pts.measured_ohm * k_unit, "s", color=MEASURED_COLOUR, label="measured mean")
    ax.set(
        xlabel="weight W [kg]", ylabel=f"resistance R [{unit}]",
        title=f"{_legend_text(a.title)}: R = R_s + σ_f/A + Barber + band ({model_label(f.model)})",
    )  # fmt: skip
    ax.legend(fontsize=7)
    return fig


register(
    FigureSpec(
        "physical_terms",
        "Physical resistance model, term by term",
        _draw_physical_terms,
        section="fit",
        caption="The best model's fit of R = R_s + σ_f/A + R_Barber + R_macro stacked per weight (R_Barber and "
        "R_macro computed from the scene's resistivities, σ_f and R_s fitted); squares: the measured mean.",
        missing="drawn with --conversion physical only",
    )
)
