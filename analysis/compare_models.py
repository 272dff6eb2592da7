"""Which contact model the boundary-element reference favours on a scene's surface (issue #14): table, verdicts, figure.

:func:`compare_models` runs :func:`sims.ensemble.run_comparison` — every compared model's real-area fraction A/A₀,
mean gap and interfacial stiffness K = −dp/dū at the same mean nominal pressures as the periodic FFT-BEM solution of
the scene's composite surface (:mod:`sims.bem`, the reference), over N surface realisations. Here the numbers become
answers:

* per model and pressure, the ratio model/BEM of A/A₀ and of K, and the mean-gap difference (h_model − ū_BEM)/ū_BEM,
  averaged over the realisations, with the realisations' min–max band;
* :func:`verdicts` — one line per model, e.g. ``"Hertz summation: area −12 % ± 3 % vs BEM over 0.1–30 MPa; mean
  gap +9 %; stiffness 0.93–0.59× BEM"``: the mean over the pressures of the area deviation ± its SD over the
  pressures (its drift with load), then the mean-gap deviation and the stiffness ratio at the lowest and highest
  pressure; points outside a model's tabulated curve are left out and counted;
* :func:`favoured` — the model the reference favours: the smallest RMS of ln(A_model/A_BEM) over the pressures (the
  real area is what the rig and eq. 23 use), and by how much;
* :func:`comparison_table` — the numbers as text; :func:`figure_compare_models` — the figure (matplotlib imported
  only when drawing), registered as the ``model_ranking`` :class:`~analysis.figures.FigureSpec` (drawn for an
  analysis that carries a ``model_ranking`` attribute, a :class:`~sims.ensemble.Comparison`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sims.ensemble import BEM, CompareSettings, Comparison, geometric_pressures, run_comparison

__all__ = [
    "DEFAULT_PRESSURES_PA",
    "ModelVerdict",
    "compare_models",
    "comparison_dict",
    "comparison_table",
    "favoured",
    "figure_compare_models",
    "model_verdicts",
    "report_lines",
    "verdicts",
]

#: 12 mean pressures, 0.1–30 MPa (geometric): the range of the reference notes.
DEFAULT_PRESSURES_PA = geometric_pressures(0.1e6, 30e6, 12)


@dataclass(frozen=True)
class ModelVerdict:
    """One model against BEM over the compared pressures (realisation means).

    ``area_dev`` mean over the pressures of A_model/A_BEM − 1, ``area_sd`` its SD over the pressures, ``area_band``
    (min, max) over the realisations of that mean; ``gap_dev`` mean of (h_model − ū_BEM)/ū_BEM; ``stiffness_lo_hi``
    K_model/K_BEM at the lowest and highest pressure in range; ``rms_log_area`` RMS of ln(A_model/A_BEM);
    ``n_in_range``/``n_points`` pressures used / compared; ``p_range_pa`` (lowest, highest) pressure used, Pa.
    """

    model: str
    label: str
    area_dev: float
    area_sd: float
    area_band: tuple[float, float]
    gap_dev: float
    stiffness_lo_hi: tuple[float, float]
    rms_log_area: float
    n_in_range: int
    n_points: int
    p_range_pa: tuple[float, float]
    realisations: int

    def line(self) -> str:
        """The one-line verdict."""
        if self.n_in_range == 0:
            return f"{self.label}: no compared pressure inside its tabulated curve"
        lo, hi = (v / 1e6 for v in self.p_range_pa)
        text = (
            f"{self.label}: area {_pct(self.area_dev)} ± {100 * self.area_sd:.0f} % vs BEM over {lo:.3g}–{hi:.3g} MPa"
        )
        if self.realisations > 1:
            text += f" (realisations {_pct(self.area_band[0])} … {_pct(self.area_band[1])}, N = {self.realisations})"
        k_lo, k_hi = self.stiffness_lo_hi
        text += f"; mean gap {_pct(self.gap_dev)}; stiffness {k_lo:.2f}–{k_hi:.2f}× BEM"
        if self.n_in_range < self.n_points:
            out = self.n_points - self.n_in_range
            text += f"; {out} {'pressure' if out == 1 else 'pressures'} beyond its curve left out"
        return text


def _pct(x: float) -> str:
    """A signed percentage to the unit; one that rounds to zero is "0 %" (no "−0 %" from round-off)."""
    text = f"{100 * x:+.0f}"
    return ("0" if text in ("+0", "-0") else text.replace("-", "−")) + " %"


def _label(key: str) -> str:
    from sims.models import get_model, model_label

    try:
        summed = get_model(key).needs_surface
    except KeyError:
        summed = False
    return model_label(key) + (" summation" if summed else "")


# ---------------------------------------------------------------------------------------------------------------
# Numbers.


def ratios(cmp: Comparison, model: str) -> dict[str, NDArray[np.float64]]:
    """Per realisation × pressure: ``area`` A/A_BEM, ``stiffness`` K/K_BEM, ``gap`` (h − ū_BEM)/ū_BEM; ``mask`` the
    points inside the model's curve."""
    a_ref = cmp.quantity(BEM, "area_fraction")
    k_ref = cmp.quantity(BEM, "stiffness_pa_per_m")
    g_ref = cmp.quantity(BEM, "mean_gap_m")
    return {
        "area": cmp.quantity(model, "area_fraction") / a_ref,
        "stiffness": cmp.quantity(model, "stiffness_pa_per_m") / k_ref,
        "gap": cmp.quantity(model, "mean_gap_m") / g_ref - 1.0,
        "mask": cmp.quantity(model, "in_range").astype(bool),
    }


def _verdict(cmp: Comparison, model: str) -> ModelVerdict:
    r = ratios(cmp, model)
    cols = np.all(r["mask"], axis=0)  # pressures inside the curve in every realisation
    p = cmp.pressures_pa[cols]
    n_real = cmp.settings.realisations
    if not cols.any():
        nan2 = (math.nan, math.nan)
        return ModelVerdict(model, _label(model), math.nan, math.nan, nan2, math.nan, nan2, math.inf, 0,
                            cols.size, nan2, n_real)  # fmt: skip
    area = r["area"][:, cols]
    dev = area.mean(axis=0) - 1.0
    per_real = area.mean(axis=1) - 1.0
    stiff = r["stiffness"][:, cols].mean(axis=0)
    return ModelVerdict(
        model=model,
        label=_label(model),
        area_dev=float(dev.mean()),
        area_sd=float(dev.std()),
        area_band=(float(per_real.min()), float(per_real.max())),
        gap_dev=float(r["gap"][:, cols].mean()),
        stiffness_lo_hi=(float(stiff[0]), float(stiff[-1])),
        rms_log_area=float(np.sqrt(np.mean(np.log(area) ** 2))),
        n_in_range=int(cols.sum()),
        n_points=int(cols.size),
        p_range_pa=(float(p[0]), float(p[-1])),
        realisations=n_real,
    )


def model_verdicts(cmp: Comparison) -> list[ModelVerdict]:
    """Every compared model's verdict, best first (smallest RMS of ln(A_model/A_BEM))."""
    return sorted((_verdict(cmp, m) for m in cmp.models), key=lambda v: v.rms_log_area)


def verdicts(cmp: Comparison) -> list[str]:
    """One line per model (see the module doc), best first."""
    return [v.line() for v in model_verdicts(cmp)]


def favoured(cmp: Comparison) -> str:
    """Which model the reference favours on this surface, and by how much (one line)."""
    ranked = [v for v in model_verdicts(cmp) if v.n_in_range > 0]
    if not ranked:
        return "BEM favours no model: no compared pressure lies inside any model's curve"
    best = ranked[0]
    text = (
        f"BEM favours {best.label} on this surface: real area {_pct(best.area_dev)} "
        f"(RMS |ln A/A_BEM| = {best.rms_log_area:.3f})"
    )
    if len(ranked) > 1:
        nxt = ranked[1]
        text += f"; next {nxt.label} {_pct(nxt.area_dev)} (RMS {nxt.rms_log_area:.3f})"
    return text


def _realisations(n: int) -> str:
    return "one surface realisation" if n == 1 else f"{n} surface realisations"


def report_lines(cmp: Comparison) -> list[str]:
    """What the report and the demo print: the favoured model, then one verdict per model."""
    head = (
        f"Contact models vs boundary elements (periodic FFT-BEM of the composite surface, "
        f"{'hardness-capped' if cmp.settings.plastic else 'elastic'}, {cmp.settings.area} area, "
        f"{_realisations(cmp.settings.realisations)}):"
    )
    return [head, favoured(cmp), *verdicts(cmp)]


#: Width of the text table (:func:`comparison_table`): it fits a 100-column terminal whatever the number of models.
TABLE_WIDTH = 100
_P_COLUMN = 8  # "p [MPa]" column
_CELL = 17  # one model's column: its label (registered labels have ≤ 17 characters), or a number and its flag


def comparison_table(cmp: Comparison, width: int = TABLE_WIDTH) -> str:
    """The numbers as text, at most ``width`` columns wide: BEM's A/A₀, ū, K and spots per pressure, then one block
    per quantity (A/A_BEM, (h − ū_BEM)/ū_BEM in %, K/K_BEM) with a row per pressure and a column per model
    (realisation means; ``*`` beyond the model's curve). More models than fit are continued in a further block.
    Full precision: ``contactrig compare-models --json`` (:func:`comparison_dict`)."""
    ref_a = cmp.quantity(BEM, "area_fraction").mean(axis=0)
    ref_g = cmp.quantity(BEM, "mean_gap_m").mean(axis=0)
    ref_k = cmp.quantity(BEM, "stiffness_pa_per_m").mean(axis=0)
    spots = _bem_spots(cmp)
    lines = ["BEM reference (realisation means):",
             f"{'p [MPa]':>{_P_COLUMN}} {'A/A0':>10} {'ū [µm]':>10} {'K [Pa/m]':>11} {'spots':>7}"]  # fmt: skip
    for j, p in enumerate(cmp.pressures_pa):
        lines.append(f"{p / 1e6:{_P_COLUMN}.3g} {ref_a[j]:10.4g} {ref_g[j] * 1e6:10.4g} {ref_k[j]:11.4g} "
                     f"{spots[j]:7.0f}")  # fmt: skip
    rs = {m: ratios(cmp, m) for m in cmp.models}
    per_block = max(1, (width - _P_COLUMN) // (_CELL + 1))
    quantities = (("area", "A/A_BEM: real area against BEM", "{:.3f}", 1.0),
                  ("gap", "(h − ū_BEM)/ū_BEM [%]: mean gap against BEM", "{:+.1f}", 100.0),
                  ("stiffness", "K/K_BEM: interfacial stiffness against BEM", "{:.3f}", 1.0))  # fmt: skip
    for key, title, fmt, scale in quantities:
        for first in range(0, len(cmp.models), per_block):
            models = cmp.models[first : first + per_block]
            lines += ["", title]
            lines.append(f"{'p [MPa]':>{_P_COLUMN}}" + "".join(" " + _short(m) for m in models))
            for j, p in enumerate(cmp.pressures_pa):
                row = f"{p / 1e6:{_P_COLUMN}.3g}"
                for m in models:
                    r = rs[m]
                    flag = " " if r["mask"][:, j].all() else "*"
                    cell = fmt.format(scale * r[key][:, j].mean())
                    cell = cell.replace("-", "+") if float(cell) == 0 else cell  # round-off: no "-0.0"
                    row += " " + f"{cell}{flag}".rjust(_CELL)
                lines.append(row)
    lines.append("* beyond the model's tabulated curve; full precision: --json")
    return "\n".join(line.rstrip() for line in lines)


#: Units of the numbers in :func:`comparison_dict` (also in each key's suffix; "1": a dimensionless ratio).
JSON_UNITS = {"pressure": "Pa", "mean_gap": "m", "stiffness": "Pa/m", "area_fraction": "1", "area_ratio": "1",
              "mean_gap_deviation": "1", "stiffness_ratio": "1", "time": "s"}  # fmt: skip


def _floats(a: Any) -> list[float | None]:
    """JSON numbers at full precision (JSON has no NaN: null)."""
    return [float(x) if math.isfinite(float(x)) else None for x in np.asarray(a, dtype=float).ravel()]


def comparison_dict(cmp: Comparison) -> dict[str, Any]:
    """Everything :func:`comparison_table` and :func:`report_lines` show, at full precision, with units
    (``contactrig compare-models --json``; schema ``contactrig/schemas/compare-models.json``). Per model, arrays
    over the pressures are realisation means of A/A_BEM, (h − ū_BEM)/ū_BEM and K/K_BEM, null where a
    realisation is beyond the model's curve."""
    st = cmp.settings
    spots = _bem_spots(cmp)
    models: dict[str, Any] = {}
    for m in cmp.models:
        r = ratios(cmp, m)
        inside = [bool(v) for v in np.asarray(r["mask"]).all(axis=0).ravel()]
        models[m] = {
            "label": _label(m),
            "in_range": inside,
            **{name: [v if ok else None for v, ok in zip(_floats(r[key].mean(axis=0)), inside, strict=True)]
               for key, name in (("area", "area_ratio"), ("gap", "mean_gap_deviation"),
                                 ("stiffness", "stiffness_ratio"))},
        }  # fmt: skip
    verdict = [
        {"model": v.model, "label": v.label, "area_deviation": _floats([v.area_dev])[0],
         "area_deviation_sd": _floats([v.area_sd])[0], "mean_gap_deviation": _floats([v.gap_dev])[0],
         "stiffness_ratio_low_high": _floats(v.stiffness_lo_hi), "rms_log_area": _floats([v.rms_log_area])[0],
         "pressures_used": v.n_in_range, "pressures_compared": v.n_points, "line": v.line()}
        for v in model_verdicts(cmp)
    ]  # fmt: skip
    prov = {k: v for k, v in cmp.provenance.items() if isinstance(v, (str, int, float, bool, type(None)))}
    return {
        "units": dict(JSON_UNITS),
        "scene": str(cmp.provenance.get("scene_name", "")),
        "settings": {"pressures_pa": _floats(st.pressures_pa), "models": list(st.models),
                     "realisations": st.realisations, "plastic": st.plastic, "area": st.area,
                     "stiffness": st.stiffness, "refine": st.refine},
        "reference": {"model": BEM, "area_fraction": _floats(cmp.quantity(BEM, "area_fraction").mean(axis=0)),
                      "mean_gap_m": _floats(cmp.quantity(BEM, "mean_gap_m").mean(axis=0)),
                      "stiffness_pa_per_m": _floats(cmp.quantity(BEM, "stiffness_pa_per_m").mean(axis=0)),
                      "spots": _floats(spots)},
        "models": models,
        "verdicts": verdict,
        "favoured": favoured(cmp),
        "provenance": prov,
    }  # fmt: skip


def _short(key: str) -> str:
    """A model's column header: its label, at most one cell wide."""
    from sims.models import model_label

    label = model_label(key)
    if len(label) >= _CELL:  # over the flag column
        return label[:_CELL] if len(label) == _CELL else label[: _CELL - 1] + "…"
    return label.rjust(_CELL - 1) + " "


def _bem_spots(cmp: Comparison) -> NDArray[np.float64]:
    out = np.zeros(len(cmp.settings.pressures_pa))
    index = {p: j for j, p in enumerate(cmp.settings.pressures_pa)}
    for r in cmp.results:
        if r.model == BEM:
            for p, s in zip(r.pressure_pa, r.info["n_spots"], strict=True):
                out[index[float(p)]] += s / cmp.settings.realisations
    return out


# ---------------------------------------------------------------------------------------------------------------
# Running it.


def compare_models(
    scene: Any = None,
    models: Any = None,
    *,
    pressures_pa: Any = None,
    realisations: int = 1,
    plastic: bool = True,
    area: str = "corrected",
    refine: int = 1,
    scheduler: str | None = None,
    jobs: int | None = None,
    progress: Any = None,
) -> Comparison:
    """Compare ``models`` (registered keys; default: the scene's ``[database] models``) with BEM on ``scene`` (a
    :class:`~contactrig.core.scene.Scene`, a :class:`~sims.config.SimConfig`, a path, or None for the packaged
    default) at ``pressures_pa`` (Pa; default :data:`DEFAULT_PRESSURES_PA`). ``progress(done, total)``: called as
    the tasks finish (:func:`sims.ensemble.run_comparison`)."""
    from sims.config import SimConfig
    from sims.database import check_models

    config = scene if isinstance(scene, SimConfig) else _config(scene)
    names = tuple(m for m in check_models("--models", models or config.database.models) if m != BEM)
    settings = CompareSettings(
        pressures_pa=tuple(pressures_pa) if pressures_pa is not None else DEFAULT_PRESSURES_PA,
        models=names,
        realisations=realisations,
        plastic=plastic,
        area=area,
        refine=refine,
    )
    return run_comparison(config, settings, scheduler=scheduler, jobs=jobs, progress=progress)


def _config(scene: Any) -> Any:
    from contactrig.core.scene import Scene, load_scene
    from sims.config import SimConfig

    return SimConfig.from_scene(scene if isinstance(scene, Scene) else load_scene(scene))


# ---------------------------------------------------------------------------------------------------------------
# The figure.


_PANELS = (
    ("area", "Real contact area", "A / A$_\\mathrm{BEM}$ [–]", 1.0),
    ("gap", "Mean gap", "(h − ū$_\\mathrm{BEM}$) / ū$_\\mathrm{BEM}$ [–]", 0.0),
    ("stiffness", "Interfacial stiffness K = −dp̄/dū", "K / K$_\\mathrm{BEM}$ [–]", 1.0),
)


def _suptitle(cmp: Comparison) -> str:
    n = cmp.settings.realisations
    scene = str(cmp.provenance.get("scene_name", "") or "").replace("$", r"\$")
    where = f"{scene}: " if scene else ""
    mean = "" if n == 1 else "mean of "
    band = "" if n == 1 else " (bands: min–max)"
    return f"{where}contact models against BEM, {mean}{_realisations(n)}{band}"


def figure_compare_models(cmp: Comparison) -> Any:
    """Panels against mean nominal pressure p̄ [MPa, log]: A/A_BEM, (h − ū_BEM)/ū_BEM and K/K_BEM per model
    (K = −dp̄/dū, the interfacial stiffness); lines are realisation means, shaded bands their min–max (N > 1); the
    dashed line is BEM. The fourth panel shows each model's real area relative to a reference model [%]. Models in
    registry order; models whose area ratios coincide (within :data:`analysis.figures.COINCIDE_REL`) are named in
    the legend with their largest relative difference."""
    from analysis.figures import (
        _differences,
        _figure,
        _legend,
        _note,
        _reference,
        coinciding,
        model_style,
        registry_order,
    )

    fig, grid = _figure(2, 2, size=(9.6, 6.6), sharex=True)
    axes = [grid[0, 0], grid[0, 1], grid[1, 1]]
    p = cmp.pressures_pa / 1e6
    names = registry_order(cmp.models)
    means: dict[str, Any] = {}
    for m in names:
        r = ratios(cmp, m)
        style = model_style(m)
        for ax, (name, _, _, _) in zip(axes, _PANELS, strict=True):
            # points beyond the model's curve are left out
            vals = np.ma.masked_array(r[name], mask=np.logical_not(r["mask"]))
            mean = vals.mean(axis=0).filled(np.nan)
            if name == "area":
                means[m] = mean
            ax.plot(p, mean, **style)
            if cmp.settings.realisations > 1:
                lo, hi = vals.min(axis=0).filled(np.nan), vals.max(axis=0).filled(np.nan)
                ax.fill_between(p, lo, hi, color=style["color"], alpha=0.15)
    for ax, (_, title, ylabel, ref) in zip(axes, _PANELS, strict=True):
        ax.axhline(ref, color="black", linestyle="--", linewidth=1.0, label="BEM" if ax is axes[0] else "_BEM")
        ax.set(xscale="log", ylabel=ylabel, title=title)
    groups = coinciding(means)
    if names:
        _differences(grid[1, 0], {m: (p, means[m]) for m in names}, _reference(names, groups), "A")
    for ax in grid[1]:
        ax.set_xlabel("mean nominal pressure p̄ [MPa]")
    _note(axes[0], groups)
    _legend(axes[0], host=axes[1])
    fig.suptitle(_suptitle(cmp))
    return fig


def _draw_ranking(analysis: Any) -> Any:
    cmp = getattr(analysis, "model_ranking", None)
    return None if cmp is None else figure_compare_models(cmp)


def _register_figure() -> None:
    from analysis.figures import FigureSpec, register

    register(
        FigureSpec(
            "model_ranking",
            "Contact models against the boundary-element reference",
            _draw_ranking,
            caption="Real area, mean gap and interfacial stiffness of each model relative to the periodic FFT-BEM "
            "solution of the composite surface, over mean nominal pressure.",
            section="area",
            missing="the analysis carries no model_ranking (run analysis.compare_models.compare_models)",
        ),
        replace=True,
    )


_register_figure()
