"""Comparison figures (seed Figs. 2, 9, 11, 12, fit residuals, error against run time) with one style.

Every function takes plain data (arrays, :class:`~analysis.measured.MeasuredCurve`, results of
:mod:`analysis.fit`) and returns a :class:`matplotlib.figure.Figure` built without pyplot (so no GUI backend is
involved and figures can be drawn from threads); :func:`save_figure` writes it as PNG and a vector format.
matplotlib is imported only inside these functions. Units are on every axis; a model has the same colour and
name in every figure: label and style come from the contact-model registry (:mod:`sims.models`), see
:func:`model_style`; legends list models in registry order (:func:`registry_order`). Fonts, unit style and the
repeat palette are :mod:`analysis.figure_style`. Models that coincide (:func:`coinciding`, within
:data:`COINCIDE_REL`) are named together in the legend with their largest relative difference, and Figs. 2, 11 and 12
(and the model ranking) show each model's difference to a reference model in a panel of their own. The experiment
design's discrimination map is :func:`figure_discrimination`.

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

from analysis.figure_style import DIMENSIONLESS, MEASURED_COLOUR, RC, mathtext, repeat_style, wrap_title
from analysis.fit import regressor_label
from analysis.measured import MeasuredCurve
from analysis.resistance import resistance_unit
from contactrig.core.files import atomic_write, output_folder
from contactrig.core.registry import Registry
from contactrig.core.text import escape_terminal
from contactrig.core.validation import SettingError, check_choice
from sims.models import get_model, model_label, model_names, models

__all__ = [
    "COINCIDE_REL",
    "ERROR_BARS",
    "FigureSpec",
    "coinciding",
    "figure_database",
    "figure_discrimination",
    "figure_error_vs_time",
    "figure_fit",
    "figure_measured",
    "figure_normalised",
    "figure_simulated_area",
    "figure_specs",
    "get_figure",
    "max_relative_difference",
    "model_style",
    "planned_figures",
    "register",
    "registry_order",
    "repeat_names",
    "save_figure",
    "save_figure_file",
    "unregister",
    "write_database_figure",
    "write_discrimination_figure",
    "write_figures",
]

# Colours, line styles and markers for models whose registration (sims.models) gives no style: matplotlib's
# "tab10" cycle, minus the colours that registered styles take.
_COLOUR_CYCLE = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
)  # fmt: skip
_LINESTYLE_CYCLE = ("-", "--", "-.", ":")
_MARKER_CYCLE = ("o", "s", "^", "v", "D", "x", "P", "*")

#: Models whose curves differ nowhere by more than this (relative) are said to coincide: the figure names them in
#: the legend with their largest relative difference, and the differences panel shows them.
COINCIDE_REL = 0.01


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

    matplotlib.rcParams.update(RC)
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


# ---- what every model figure shares: registry order, coinciding models, the differences panel --------------------
def registry_order(names: Iterable[str]) -> list[str]:
    """``names`` in the contact-model registry's order (names it does not know after, as given): the legend order of
    every figure."""
    known = list(model_names())
    given = list(dict.fromkeys(names))
    return sorted(given, key=lambda n: known.index(n) if n in known else len(known) + given.index(n))


def max_relative_difference(a: Any, b: Any) -> float:
    """max |a − b| / max(|a|, |b|) over the points where both are finite and not both zero (inf when there is no
    such point)."""
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = np.maximum(np.abs(x), np.abs(y))
    ok = np.isfinite(x) & np.isfinite(y) & (scale > 0)
    if not ok.any():
        return math.inf
    return float(np.max(np.abs(x[ok] / scale[ok] - y[ok] / scale[ok])))  # scaled first: no overflow near 1e308


def coinciding(series: Mapping[str, Any], tol: float = COINCIDE_REL) -> list[tuple[tuple[str, ...], float]]:
    """Groups of two or more models whose curves (name → values at the same points) differ by at most ``tol``
    (relative, :func:`max_relative_difference`; a model joins a group when it is that close to one member), each in
    registry order with the largest relative difference between two of its members."""
    names = registry_order(series)
    diff = {frozenset((a, b)): max_relative_difference(series[a], series[b]) for a in names for b in names if a != b}
    groups: list[list[str]] = []
    for n in names:
        linked = [g for g in groups if any(diff[frozenset((m, n))] <= tol for m in g)]
        groups = [g for g in groups if g not in linked] + [[m for g in linked for m in g] + [n]]
    out = []
    for g in groups:
        if len(g) > 1:
            members = registry_order(g)
            worst = max(diff[frozenset((a, b))] for a in members for b in members if a != b)
            out.append((tuple(members), worst))
    return out


def _percent(x: float) -> str:
    return "0 % (identical)" if x == 0 else f"{100 * x:.2g} %"


def _coincide_note(groups: Sequence[tuple[tuple[str, ...], float]]) -> str:
    """The legend note naming models that coincide: never starts with a model's name (it is not that model's
    entry)."""
    lines = []
    for members, worst in groups:
        names = ", ".join(model_label(m).replace(" ", "\u00a0") for m in members)  # a name is never broken
        lines.append(wrap_title(f"coincide within {_percent(worst)}: {names}", 2.3, 8.0))
    return "\n".join(lines)


def _note(ax: Any, groups: Sequence[tuple[tuple[str, ...], float]]) -> None:
    if groups:
        ax.plot([], [], " ", label=_coincide_note(groups), gid="coincide-note")


def _reference(names: Sequence[str], groups: Sequence[tuple[tuple[str, ...], float]]) -> str:
    """The differences panel's reference: the first model of the largest coinciding group (so its members' small
    differences show), else the first model."""
    if groups:
        return max(groups, key=lambda g: len(g[0]))[0][0]
    return registry_order(names)[0]


def _differences(
    ax: Any, series: Mapping[str, tuple[Any, Any]], reference: str, quantity: str, *, markers: bool = True
) -> None:
    """Bottom panel: 100·(y/y_ref − 1) [%] of every model against ``reference`` on a symmetric-log scale, so
    differences of 0.01 % and of 10 % both show; curves on other x are interpolated to the reference's x."""
    xr, yr = (np.asarray(v, dtype=float) for v in series[reference])
    drawn = {}
    for name in registry_order(series):
        x, y = (np.asarray(v, dtype=float) for v in series[name])
        yi = y if x.shape == xr.shape and np.array_equal(x, xr) else np.interp(xr, x, y, left=np.nan, right=np.nan)
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.where((yr > 0) & (yi > 0), 100.0 * (yi / yr - 1.0), np.nan)
        drawn[name] = d
        style = {**model_style(name), "label": f"_{name}", "mfc": "none"}
        if not markers:
            style["marker"] = None
        ax.plot(xr, d, **style)
    _symlog(ax, list(drawn.values()))
    ax.set_ylabel(f"{quantity} / {quantity}$_\\mathrm{{ref}}$ − 1 [%]")
    ax.set_title(f"difference to the reference, {model_label(reference)}", fontsize=8.0)


def _symlog(ax: Any, values: list[Any]) -> None:
    """A symmetric-log y axis from the smallest non-zero |value| (linear below it) to the largest, labelled at 0
    and at most three decades each way from the smallest (every second or third decade when the range is wide)."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

    finite = np.abs(np.concatenate([np.ravel(v) for v in values])) if values else np.zeros(0)
    finite = finite[np.isfinite(finite) & (finite > 0)]
    if not finite.size:
        return
    lo = int(np.clip(math.floor(math.log10(finite.min())), -4, 0))
    hi = max(math.floor(math.log10(finite.max())), lo)
    decades_shown = math.log10(finite.max()) - lo
    # the linear part (0 to ±10^lo) gets at least about 1/8 of the height, so 0 and ±10^lo never touch
    ax.set_yscale("symlog", linthresh=10.0**lo, linscale=max(1.0, decades_shown / 3.0))
    step = max(1, math.ceil((hi - lo + 1) / 3))
    decades = [10.0**e for e in range(lo, hi + 1, step)]
    ax.yaxis.set_major_locator(FixedLocator(sorted([*(-d for d in decades), 0.0, *decades])))
    ax.yaxis.set_minor_locator(NullLocator())
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}".replace("-", "−")))


def _legend(ax: Any, host: Any = None, **kw: Any) -> None:
    """One legend of ``ax``'s entries right of ``host`` (default ``ax``; the top-right panel of a grid), outside the
    data: models in registry order first (as drawn), other entries after, the note on coinciding models last."""
    handles, labels = ax.get_legend_handles_labels()
    order = sorted(range(len(labels)), key=lambda i: getattr(handles[i], "get_gid", lambda: None)() == "coincide-note")
    host = ax if host is None else host
    host.legend([handles[i] for i in order], [labels[i] for i in order], loc="upper left", bbox_to_anchor=(1.02, 1.0),
                borderaxespad=0.0, **kw)  # fmt: skip


def _title(ax: Any, text: str, width_in: float) -> None:
    ax.set_title(wrap_title(text, width_in))


# ---- seed Fig. 2: contact database ---------------------------------------------------------------------------
def _common_grid(curves: Mapping[str, Any], attr: str) -> dict[str, np.ndarray]:
    """Each curve's ``attr`` on 200 separations spanning the range where every curve is tabulated (NaN ≤ 0)."""
    lo = max(float(np.min(c.separation_m)) for c in curves.values())
    hi = min(float(np.max(c.separation_m)) for c in curves.values())
    h = np.linspace(lo, hi, 200) if hi > lo else np.array([lo])
    out = {}
    for name, c in curves.items():
        v = np.interp(h, np.asarray(c.separation_m, dtype=float), np.asarray(getattr(c, attr), dtype=float))
        out[name] = np.where(v > 0, v, np.nan)
    return out


def figure_database(curves: Mapping[str, Any], sigma_m: float | None = None) -> Any:
    """Seed Fig. 2: contact pressure p(h) (log scale) and real-area fraction A/A₀(h) per model (top), and each
    model's relative difference to a reference model (bottom, %); models that coincide are named in the legend.

    ``curves`` name → object with ``separation_m``, ``pressure_pa``, ``area_fraction`` arrays (a
    ``sims.database.ContactCurve``). With ``sigma_m`` the separation axis is h/σ instead of µm.
    """
    fig, ax = _figure(2, 2, size=(9.0, 5.6), sharex="col", height_ratios=[2.2, 1.0])
    names = registry_order(curves)
    scale = 1.0 / sigma_m if sigma_m else 1e6
    panels = (("pressure_pa", 1e-6, "contact pressure p [MPa]", "p", "Pressure"),
              ("area_fraction", 1.0, f"real area fraction A/A₀ {DIMENSIONLESS}", "A", "Real contact area"))  # fmt: skip
    on_grid = [_common_grid({n: curves[n] for n in names}, attr) for attr, *_ in panels]
    groups = coinciding({n: np.concatenate([g[n] for g in on_grid]) for n in names})
    reference = _reference(names, groups)
    for col, (attr, k, ylabel, symbol, title) in enumerate(panels):
        series = {}
        for name in names:
            c = curves[name]
            x = np.asarray(c.separation_m, dtype=float) * scale
            y = np.asarray(getattr(c, attr), dtype=float) * k
            pos = y > 0
            ax[0, col].plot(x[pos], y[pos], **{**model_style(name), "marker": None})
            series[name] = (x[pos], y[pos])
        ax[0, col].set(ylabel=ylabel, yscale="log", title=title)
        _differences(ax[1, col], series, reference, symbol, markers=False)
        ax[1, col].set_xlabel(f"separation h/σ {DIMENSIONLESS}" if sigma_m else "separation h [µm]")
    _note(ax[0, 0], groups)
    _legend(ax[0, 0], host=ax[0, 1])
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
    """Seed Fig. 9: every repeat (thin lines, one colour and marker each from a qualitative palette:
    :func:`analysis.figure_style.repeat_style`; labelled M1…Mn in the legend, in order) and the mean ± 1 SEM over
    repeats (:data:`ERROR_BARS`, black), in the unit the data call for (µΩ, mΩ or Ω:
    :func:`analysis.resistance.resistance_unit`)."""
    fig, axes = _figure(size=(6.4, 4.2))
    ax = axes[0, 0]
    w = curve.weight_kg
    k_unit, unit = resistance_unit(curve.values_ohm)
    v = curve.values_ohm * k_unit
    names = repeat_names(curve)
    for k, (label, name) in enumerate(zip(curve.repeat_labels, names, strict=True)):
        ok = np.isfinite(v[:, k])
        ax.plot(
            w[ok], v[ok, k], "-", **repeat_style(k), lw=0.9, ms=3.5, alpha=0.85, label=_legend_text(name),
            gid=f"repeat-{label}",
        )  # fmt: skip
    sem = np.nan_to_num(curve.sem_ohm * k_unit)
    ax.errorbar(w, curve.mean_ohm * k_unit, yerr=sem, fmt="s-", color=MEASURED_COLOUR, capsize=3, label="mean ± 1 SEM",
                zorder=3)  # fmt: skip
    ax.set(xlabel="weight W [kg]", ylabel=f"resistance R [{unit}]")
    _title(ax, title or "Measured resistance (seed Fig. 9)", 5.0)
    ax.set_ylim(bottom=0)
    _legend(ax, ncols=2 if len(names) > 12 else 1, fontsize=7.5)
    return fig


def _legend_text(text: str) -> str:
    """A label from a file shown as text by matplotlib: control characters visible, ``$`` not starting mathtext,
    ``_`` shown as it is."""
    return escape_terminal(text).replace("$", r"\$")


# ---- seed Fig. 11: simulated contact area -----------------------------------------------------------------------
def figure_simulated_area(models: Mapping[str, tuple[np.ndarray, np.ndarray]], title: str = "") -> Any:
    """Seed Fig. 11: simulated real contact area [mm²] against weight [kg] (top) and each model's relative
    difference to a reference model [%] (bottom); ``models`` name → (W, A [m²]). Models that coincide (within
    :data:`COINCIDE_REL`) are named in the legend with their largest relative difference."""
    fig, axes = _figure(1, 2, size=(6.8, 5.0), sharex=True, height_ratios=[2.2, 1.0])
    top, bottom = axes[0, 0], axes[1, 0]
    names = registry_order(models)
    series = {n: (np.asarray(models[n][0], dtype=float), np.asarray(models[n][1], dtype=float) * 1e6) for n in names}
    for name in names:
        top.plot(*series[name], mfc="none", **model_style(name))
    groups = coinciding({n: series[n][1] for n in names}) if _same_x(series) else []
    _note(top, groups)
    top.set(ylabel="real contact area A [mm²]")
    _title(top, title or "Simulated area (seed Fig. 11)", 4.5)
    _differences(bottom, series, _reference(names, groups), "A")
    bottom.set_xlabel("weight W [kg]")
    _legend(top)
    return fig


def _same_x(series: Mapping[str, tuple[Any, Any]]) -> bool:
    xs = [np.asarray(x, dtype=float) for x, _ in series.values()]
    return all(x.shape == xs[0].shape and np.allclose(x, xs[0]) for x in xs)


# ---- seed Fig. 12: normalised measured vs simulated ------------------------------------------------------------
def figure_normalised(
    measured: Any, simulated: Mapping[str, Any], title: str = "", best_fit: tuple[str, Any, Any] | None = None
) -> Any:
    """Seed Fig. 12: R/R₀ (dimensionless) of the measurement and of each model against weight [kg] (top) and the
    relative difference of each model to a reference model [%] (bottom, when models are shown). Models that
    coincide are named in the legend.

    ``measured`` and the values of ``simulated`` are :class:`~analysis.normalisation.NormalisedCurve`; the
    measured error bars are ± 1 standard error of R/R₀ propagated from the repeats (:data:`ERROR_BARS`).
    ``best_fit`` (model key, W [kg], R/R₀): the best fit's R/R₀ including the series resistance, dotted black.
    """
    names = registry_order(simulated)
    fig, axes = _figure(1, 2 if names else 1, size=(6.8, 5.0 if names else 3.8), sharex=True,
                        **({"height_ratios": [2.2, 1.0]} if names else {}))  # fmt: skip
    top = axes[0, 0]
    series = {n: (np.asarray(simulated[n].weight_kg, dtype=float), np.asarray(simulated[n].ratio)) for n in names}
    for name in names:
        top.plot(*series[name], mfc="none", **model_style(name))
    top.errorbar(
        measured.weight_kg, measured.ratio, yerr=measured.se, fmt="s", color=MEASURED_COLOUR, capsize=3,
        label="measured ± 1 SEM",
    )  # fmt: skip
    if best_fit is not None:
        key, w_fit, r_fit = best_fit
        top.plot(w_fit, r_fit, color="k", lw=1.0, ls=(0, (2, 2)), label=f"best fit incl. R$_s$ ({model_label(key)})")
    _title(top, title or "Normalised to the first weight (seed Fig. 12)", 4.5)
    top.set(ylabel=f"normalised resistance R/R₀ {DIMENSIONLESS}")
    if names:
        groups = coinciding({n: series[n][1] for n in names}) if _same_x(series) else []
        _note(top, groups)
        reference = _reference(names, groups)
        _differences(axes[1, 0], series, reference, "(R/R₀)")
    axes[-1, 0].set_xlabel("weight W [kg]")
    _legend(top)
    return fig


# ---- fits ---------------------------------------------------------------------------------------------------
def figure_fit(comparison: Any, title: str = "", sem_ohm: Any = None) -> Any:
    """Fits R = R_s + s·x(A) (seed eq. 23 plus R_s): measured mean (± 1 SEM of the repeats when ``sem_ohm`` [Ω] is
    given, :data:`ERROR_BARS`) and each model's fitted R (unit from the data) against weight [kg] (top; models in
    registry order, each with its ΔAIC; an unphysical fit is marked so; fits that coincide are named); residuals
    (measured − fitted)/σ with σ the fit's weighting, dimensionless, per model (bottom)."""
    fig, axes = _figure(1, 2, size=(7.2, 5.6), sharex=True, height_ratios=[2.2, 1.0])
    top, bottom = axes[0, 0], axes[1, 0]
    first = next(iter(comparison.fits.values())).points
    w = first.weight_kg
    k_unit, unit = resistance_unit(first.measured_ohm)
    yerr = None if sem_ohm is None else np.nan_to_num(np.asarray(sem_ohm, dtype=float) * k_unit)
    names = registry_order(comparison.fits)
    n = len(names)
    width = 0.6 * (np.min(np.diff(w)) if w.size > 1 else 1.0) / max(n, 1)
    for i, name in enumerate(names):
        f = comparison.fits[name]
        crit = getattr(comparison, "criterion", "AIC")  # the fit's criterion: QAIC when over-dispersed
        label = f"{model_label(name)}: Δ{crit} {comparison.delta_aic[name]:.1f}" + ("" if f.physical else " UNPHYSICAL")
        style = {**model_style(name), "label": label}
        top.plot(w, f.points.fitted_ohm * k_unit, mfc="none", **style)
        bottom.bar(w + (i - (n - 1) / 2) * width, f.points.normalised_residuals, width, color=style["color"])
    top.errorbar(
        w, first.measured_ohm * k_unit, yerr=yerr, fmt="s", color=MEASURED_COLOUR, capsize=3,
        label="measured mean" + (" ± 1 SEM" if yerr is not None else ""), zorder=3,
    )  # fmt: skip
    _note(top, coinciding({m: comparison.fits[m].points.fitted_ohm for m in names}))
    bottom.axhline(0.0, color="k", lw=0.8)
    for y in (-2.0, 2.0):
        bottom.axhline(y, color="k", lw=0.6, ls=":")
    top.set(ylabel=f"resistance R [{unit}]")
    _title(top, title or "Fit R = R$_s$ + s·h/A(W) per model", 4.8)
    bottom.set(xlabel="weight W [kg]", ylabel=f"residual / σ of the fit {DIMENSIONLESS}")
    _legend(top)
    return fig


# ---- error against run time ----------------------------------------------------------------------------------
def _row_get(row: Any, key: str) -> Any:
    return row[key] if isinstance(row, Mapping) else getattr(row, key)


def figure_error_vs_time(
    rows: Iterable[Any], study: str | None = None, title: str = "", ylabel: str = f"relative error {DIMENSIONLESS}"
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
    fig, axes = _figure(ncols, nrows, size=(4.6 * ncols, 3.6 * nrows))
    for ax in axes.ravel()[len(studies) :]:
        ax.set_visible(False)
    for ax, name in zip(axes.ravel(), studies, strict=False):
        _study_panel(ax, name, [r for r in table if r["study"] == name], ylabel)
    if title:
        fig.suptitle(_legend_text(title))
    _keep_labels_with_room(fig)
    return fig


def _display_key(text: str) -> str:
    """A study's method or setting as a reader sees it: registered model keys by their labels, other underscores
    (code names such as ``n_theta``) as spaces, ``$`` not starting mathtext."""
    out = str(text)
    for key in sorted(model_names(), key=len, reverse=True):
        out = out.replace(key, model_label(key))
    return _legend_text(out.replace("_", " "))


def _keep_labels_with_room(fig: Any) -> None:
    """Hide every point label (annotation) that would overlap another text or leave the canvas once the figure is
    laid out: greedily, in drawing order, against the titles, tick labels, legends and the labels kept so far."""
    from matplotlib.text import Annotation

    fig.draw_without_rendering()
    renderer = fig._get_renderer()
    notes = [t for ax in fig.axes for t in ax.texts if isinstance(t, Annotation)]
    others = [t for t in fig.findobj(lambda a: hasattr(a, "get_text") and not isinstance(a, Annotation))
              if t.get_visible() and t.get_text().strip()]  # fmt: skip
    taken = [t.get_window_extent(renderer) for t in others]
    canvas = fig.bbox
    for note in notes:
        box = note.get_window_extent(renderer)
        inside = canvas.x0 <= box.x0 and box.x1 <= canvas.x1 and canvas.y0 <= box.y0 and box.y1 <= canvas.y1
        if not inside or any(box.overlaps(b) for b in taken):
            note.set_visible(False)
        else:
            taken.append(box)


def _study_panel(ax: Any, name: str, sub: list[dict[str, Any]], ylabel: str) -> None:
    known = set(model_names())
    drawable = [r for r in sub if _positive(r["error"]) and _positive(r["seconds"])]
    methods = list(dict.fromkeys(r["method"] for r in sub))
    for j, method in enumerate(methods):
        pts = sorted((r for r in drawable if r["method"] == method), key=lambda r: r["seconds"])
        if not pts:
            continue
        colour = model_style(method)["color"] if method in known else f"C{j % 10}"
        label = model_label(method) if method in known else _display_key(method)
        ax.plot([r["seconds"] for r in pts], [r["error"] for r in pts], "o-", color=colour, label=label)
        for r in pts:
            note = ax.annotate(_display_key(r["setting"]), (r["seconds"], r["error"]), xytext=(3, 3),
                               textcoords="offset points", fontsize=7)  # fmt: skip
            note.set_in_layout(False)  # labels that find no room are hidden after layout: they must not move it
    skipped = len(sub) - len(drawable)
    suffix = f" ({skipped} {'row' if skipped == 1 else 'rows'} with error or time ≤ 0 not shown)" if skipped else ""
    ax.set(xscale="log", yscale="log", xlabel="run time [s]")
    ax.set_ylabel(ylabel)
    ax.set_title(wrap_title(_display_key(name) + suffix, 4.2))
    if drawable:
        ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.18), fontsize=7.5)


def _positive(x: Any) -> bool:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return False
    return math.isfinite(v) and v > 0


# ---- experiment design: discrimination map ------------------------------------------------------------------
def figure_discrimination(result: Any) -> Any:
    """``contactrig design``'s map: for every candidate plan (rows, cheapest first) and model pair (columns, display
    names) the probability that a session's fit tells the pair apart by ΔAIC ≥ the design's threshold both ways
    (colour, dimensionless 0–1); a star marks each pair's cheapest plan reaching the target probability.

    ``result`` an :class:`analysis.design.DesignResult` (``plans``, ``pair_score``, ``cheapest``, ``target``,
    ``geometry``).
    """
    from analysis.design import DELTA_AIC

    pairs = list(result.pair_score)
    grid = np.array([result.pair_score[p] for p in pairs]).T
    width = 3.4 + 0.62 * len(pairs)
    fig, axes = _figure(size=(max(width, 6.0), max(4.6, 2.9 + 0.15 * len(result.plans))))
    ax = axes[0, 0]
    ax.grid(False)
    im = ax.imshow(grid, aspect="auto", vmin=0.0, vmax=1.0, cmap="viridis", interpolation="nearest")
    ax.set_xticks(range(len(pairs)), [f"{model_label(a)}\nvs {model_label(b)}" for a, b in pairs], rotation=90,
                  fontsize=7.5)  # fmt: skip
    labels = [f"{len(p.weights_kg)} loads × {p.repeats} repeats, {p.weights_kg[0]:.3g}–{p.weights_kg[-1]:.3g} kg, "
              f"{p.cost_s / 60:.0f} min" for p in result.plans]  # fmt: skip
    ax.set_yticks(range(len(labels)), labels, fontsize=7.5)
    stars = [(j, i) for j, p in enumerate(pairs) if (i := result.cheapest.get(p)) is not None]
    if stars:
        ax.plot([j for j, _ in stars], [i for _, i in stars], "*", color="white", mec="black", ms=9, ls="none",
                label=f"cheapest plan with P ≥ {result.target:.2g}")  # fmt: skip
        fig.legend(loc="outside lower left", fontsize=7.5)
    ax.set_xlabel("model pair")
    ax.set_ylabel("plan (cheapest first)")
    ax.set_title(wrap_title(f"{result.geometry}: which plan tells the contact models apart", width - 3.0))
    bar = fig.colorbar(im, ax=ax, fraction=0.05, pad=0.02)
    bar.set_label(f"P(ΔAIC ≥ {DELTA_AIC:g} both ways) {DIMENSIONLESS}")
    return fig


def write_discrimination_figure(result: Any, path: str | Path, *, force: bool = False) -> Path:
    """:func:`figure_discrimination` written to ``path`` (.png, .svg or .pdf; refused if it exists, unless
    ``force``)."""
    return save_figure_file(figure_discrimination(result), path, force=force)


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
    best = None
    if a.comparison is not None:
        key = a.comparison.ranking[0]
        best = (key, a.comparison.best.points.weight_kg, a.fitted_norm()[key])
    return figure_normalised(
        a.measured_norm, a.simulated_norm, title=f"{_legend_text(a.title)}: normalised (seed Fig. 12)", best_fit=best
    )


def _draw_fit(a: Any) -> Any:
    if a.comparison is None:
        return None
    from analysis.fit import independent_series  # the series the fit counts (copies of others once)

    sem = independent_series(a.fit_curve)[0].sem_ohm if a.fit_curve is not None else None
    return figure_fit(
        a.comparison,
        title=f"{_legend_text(a.title)}: R = R$_s$ + s·x(A), x = {mathtext(regressor_label(a.conversion))}",
        sem_ohm=sem,
    )  # fmt: skip


_COINCIDE_CAPTION = (
    f"Models whose curves differ nowhere by more than {100 * COINCIDE_REL:g} % are named together in the legend with "
    "their largest relative difference."
)

for _spec in (
    FigureSpec(
        "fig09_measured",
        "Measured resistance against weight",
        _draw_measured,
        section="measured",
        caption=f"Seed Fig. 9: every repeat (M1…Mn, labelled; one colour and marker each) and their mean (black); "
        f"{ERROR_BARS}.",
    ),
    FigureSpec(
        "fig11_area",
        "Simulated contact area",
        _draw_area,
        section="area",
        caption=f"Seed Fig. 11: each model's real contact area; bottom: its relative difference to the reference model "
        f"named above the panel, on a symmetric-log scale. {_COINCIDE_CAPTION}",
    ),
    FigureSpec(
        "fig02_database",
        "Contact database",
        _draw_database,
        section="area",
        caption="Seed Fig. 2: nominal contact pressure p(h) and real-area fraction A/A₀(h) of every model; bottom: "
        f"relative differences to the reference model. {_COINCIDE_CAPTION}",
        missing="the contact database is built only when the rig is simulated now; omit --sim",
    ),
    FigureSpec(
        "fig12_normalised",
        "Normalised resistance",
        _draw_normalised,
        section="normalised",
        caption="Coloured: each model's R_T/R_T₀ by the conversion (ζ and h cancel); black dotted: the best fit's "
        "R/R₀ including the series resistance R_s, which is what a measurement normalises; "
        f"{ERROR_BARS}, propagated to R/R₀ with the series' covariance (R₀/R₀ = 1 exactly, no bar); bottom: each "
        f"model's relative difference to the reference model. {_COINCIDE_CAPTION}",
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
    """The best model's physical fit as stacked terms against weight [kg]: R_s, σ_f/A, Barber, macro-constriction (the
    rig's band, the press's spot; unit from the data), with the measured mean; None unless ``--conversion physical``."""
    if a.comparison is None or a.conversion != "physical":
        return None
    f = a.comparison.best
    pts, est = f.points, f.estimate
    k_unit, unit = resistance_unit(pts.measured_ohm)
    terms = {"R_s": np.full(pts.weight_kg.shape, est.R_series_ohm), "film σ_f/A": est.scale * pts.regressor_per_m}
    not_terms = ("series", "film", "residual")  # residual: measured − fitted, not a term of the model
    terms.update({name: share * pts.measured_ohm for name, share in f.shares.items() if name not in not_terms})
    fig, axes = _figure(size=(6.0, 4.0))
    ax = axes[0, 0]
    ax.stackplot(pts.weight_kg, *[v * k_unit for v in terms.values()], labels=[mathtext(t) for t in terms], alpha=0.8)
    ax.plot(pts.weight_kg, pts.measured_ohm * k_unit, "s", color=MEASURED_COLOUR, label="measured mean")
    ax.set(
        xlabel="weight W [kg]", ylabel=f"resistance R [{unit}]",
        title=f"{_legend_text(a.title)}: R = R$_s$ + σ$_f$/A + Barber + macro ({model_label(f.model)})",
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
