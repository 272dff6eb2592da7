"""Session + simulation → comparison: the steps behind ``contactrig fit``, ``figures``, ``report`` and ``demo``.

:func:`analyse` works on objects already in memory (a :class:`~analysis.measured.MeasuredCurve` and a rig sweep
result with ``models[name].weight_kg`` / ``.contact_area_m2``); :func:`analyse_session` and :func:`analyse_tab1`
load them first. When no simulation file is given, the rig is simulated for the measured weights with the scene
recorded in the session (the packaged default scene when the session has none), so the areas need no
interpolation; a given sweep is interpolated in log–log onto the measured weights
(:func:`analysis.fit.area_at_weights`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from analysis.circuit import CircuitSettings
from analysis.fit import ModelComparison, area_at_weights, compare_models, regressor
from analysis.measured import MeasuredCurve, load_tab1
from analysis.normalisation import NormalisedCurve, normalise_measured, normalise_simulated

__all__ = ["Analysis", "analyse", "analyse_session", "analyse_tab1", "simulate"]


@dataclass(frozen=True)
class Analysis:
    """Everything a report needs about one measured curve against the simulated models.

    ``areas_m2[name]`` each model's contact area at ``curve.weight_kg``; ``measured_norm`` and
    ``simulated_norm[name]`` R/R₀ (simulated: the chosen conversion, so A₀/A for eq. 23); ``comparison`` the fits;
    ``measured_info`` / ``sim_info`` provenance of both inputs; ``database`` the contact database when it was built
    here (for seed Fig. 2), else None.
    """

    title: str
    curve: MeasuredCurve
    scene: Any
    circuit: CircuitSettings
    sweep: Any
    areas_m2: dict[str, np.ndarray]
    measured_norm: NormalisedCurve
    simulated_norm: dict[str, NormalisedCurve]
    comparison: ModelComparison
    conversion: str
    measured_info: dict[str, Any] = field(default_factory=dict)
    sim_info: dict[str, Any] = field(default_factory=dict)
    database: Any = None

    def fitted_norm(self) -> dict[str, np.ndarray]:
        """Each model's fitted R(W)/R(W₀), series resistance included."""
        return {n: f.points.fitted_ohm / f.points.fitted_ohm[0] for n, f in self.comparison.fits.items()}


def simulate(scene: Any, weights_kg: Any, models: list[str] | None = None) -> tuple[Any, Any]:
    """Build the contact database once and sweep the rig at ``weights_kg`` (None: the scene's ``[rig]`` weights);
    returns (sweep result, database). ``models``: registered model keys (None: the scene's ``[database] models``)."""
    from sims.config import SimConfig
    from sims.database import build_database
    from sims.rig import sweep

    config = SimConfig.from_scene(scene)
    database = build_database(config, models)
    weights = None if weights_kg is None else [float(w) for w in weights_kg]
    result = sweep(config, models=models, weights_kg=weights, database=database)
    return result, database


def analyse(
    curve: MeasuredCurve,
    sweep_result: Any,
    scene: Any,
    *,
    title: str = "",
    conversion: str = "bulk",
    weighting: str = "relative",
    n_boot: int = 2000,
    seed: int | None = 0,
    ci_level: float = 0.95,
    boot_interval: str = "studentized",
    measured_info: dict[str, Any] | None = None,
    sim_info: dict[str, Any] | None = None,
    database: Any = None,
) -> Analysis:
    """Normalise, fit and rank every model of ``sweep_result`` against ``curve`` (module docstring)."""
    circuit = CircuitSettings.from_scene(scene)
    areas: dict[str, np.ndarray] = {}
    for name, m in sweep_result.models.items():
        areas[name] = area_at_weights(np.asarray(m.weight_kg), np.asarray(m.contact_area_m2), curve.weight_kg)
    comparison = compare_models(
        curve, areas, height_m=circuit.contact_height_m, conversion=conversion, weighting=weighting,
        ci_level=ci_level, n_boot=n_boot, seed=seed, boot_interval=boot_interval,
    )  # fmt: skip
    sim_norm = {
        n: normalise_simulated(curve.weight_kg, regressor(a, circuit.contact_height_m, conversion))
        for n, a in areas.items()
    }
    try:
        measured_norm = normalise_measured(curve)
    except ValueError:
        # single repeats: ratios without uncertainty rather than no Fig. 12 at all
        measured_norm = normalise_simulated(curve.weight_kg, curve.mean_ohm)
    return Analysis(
        title=title or curve.source or "measurement",
        curve=curve,
        scene=scene,
        circuit=circuit,
        sweep=sweep_result,
        areas_m2=areas,
        measured_norm=measured_norm,
        simulated_norm=sim_norm,
        comparison=comparison,
        conversion=conversion,
        measured_info=dict(measured_info or {}),
        sim_info=dict(sim_info or {}),
        database=database,
    )


def _scene_for(session: Any) -> Any:
    from contactrig.core.scene import load_scene, parse_scene

    text = getattr(session, "scene_text", "") or ""
    if text.strip():
        return parse_scene(text, f"{session.path} (recorded scene)")
    return load_scene(None)


def _load_sim(sim_path: str | Path | None, scene: Any, weights: np.ndarray, models: list[str] | None):
    if sim_path is not None:
        from daq.sweep_file import load_sweep

        result = load_sweep(sim_path)
        if models:
            missing = [m for m in models if m not in result.models]
            if missing:
                raise ValueError(f"{sim_path} has no models {missing}; it has {list(result.models)}")
            result = type(result)(
                models={m: result.models[m] for m in models}, warnings=result.warnings, provenance=result.provenance
            )
        info = {"source": str(sim_path), "warnings": list(result.warnings), "provenance": result.provenance}
        return result, None, info
    result, database = simulate(scene, weights, models)
    info = {
        "source": f"simulated now from scene {scene.name!r} ({scene.source})",
        "warnings": list(result.warnings),
        "provenance": result.provenance,
    }
    return result, database, info


def analyse_session(
    session_path: str | Path,
    sim_path: str | Path | None = None,
    *,
    models: list[str] | None = None,
    **kw: Any,
) -> Analysis:
    """Load a session file (``daq.load_session``) and the simulation (``sim_path`` or simulated now), analyse.

    ``kw`` goes to :func:`analyse` (conversion, weighting, n_boot, seed, ci_level, boot_interval, title).
    """
    from daq import load_session

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        session = load_session(session_path)
    if len(session.summary) == 0:
        state = "a complete session" if session.complete else "an incomplete session: no stop record"
        raise ValueError(f"{session_path}: no measurement block on disk ({state}); nothing to analyse")
    curve = MeasuredCurve.from_summary(session.summary, source=str(session_path))
    scene = _scene_for(session)
    sweep_result, database, sim_info = _load_sim(sim_path, scene, curve.weight_kg, models)
    measured_info = {
        "kind": "session",
        "path": str(session_path),
        "complete": bool(session.complete),
        "status": session.status,
        "imported": bool(session.imported),
        "start": session.start,
        "stop": session.stop,
        "warnings": list(session.warnings) + [str(w.message) for w in caught if str(w.message) not in session.warnings],
        "scene_source": scene.source,
    }
    kw.setdefault("title", f"Session {Path(session_path).name}")
    return analyse(curve, sweep_result, scene, measured_info=measured_info, sim_info=sim_info, database=database, **kw)


def analyse_tab1(
    sweep_result: Any = None,
    scene: Any = None,
    *,
    series: list[str] | None = None,
    models: list[str] | None = None,
    database: Any = None,
    sim_info: dict[str, Any] | None = None,
    sim_path: str | Path | None = None,
    **kw: Any,
) -> Analysis:
    """The seed paper's Tab. 1 against the simulated models: ``sweep_result``, else the sweep file ``sim_path``,
    else simulated now with ``scene`` (the packaged default scene when None).

    ``series`` selects columns (e.g. ``["M1", "M2", "M3"]``, the ones that are not copies of others).
    """
    from contactrig.core.scene import load_scene

    curve = load_tab1()
    notes = tab1_integrity_notes(curve)
    if series:
        missing = [s for s in series if s not in curve.repeat_labels]
        if missing:
            raise ValueError(f"Tab. 1 has no series {missing}; it has {list(curve.repeat_labels)}")
        idx = [curve.repeat_labels.index(s) for s in series]
        curve = MeasuredCurve(
            curve.weight_kg, curve.values_ohm[:, idx], repeat_labels=tuple(series), paired=True,
            source=f"seed paper Tab. 1, series {', '.join(series)}",
        )  # fmt: skip
    scene = scene if scene is not None else load_scene(None)
    if sweep_result is None:
        sweep_result, database, sim_info = _load_sim(sim_path, scene, curve.weight_kg, models)
    measured_info = {
        "kind": "table",
        "path": "daq/data/tab1.csv",
        "complete": True,
        "status": "published table",
        "imported": True,
        "warnings": notes,
    }
    kw.setdefault("title", "Seed paper Tab. 1" + (f" ({', '.join(series)})" if series else ""))
    return analyse(
        curve, sweep_result, scene, measured_info=measured_info, sim_info=dict(sim_info or {}), database=database,
        **kw,
    )  # fmt: skip


def tab1_integrity_notes(curve: MeasuredCurve) -> list[str]:
    """Checks of Tab. 1's series against each other: columns that are arithmetic copies of others are not
    independent repeats, which shrinks the real repeat count behind any standard error."""
    v = curve.values_ohm * 1e3  # mΩ, as printed
    labels = curve.repeat_labels
    notes = []
    if v.shape[1] >= 4:
        d = v[:, 3] - v[:, :3].mean(axis=1)
        same = np.abs(d) <= 1.5e-4
        if np.sum(same) >= v.shape[0] - 1:
            odd = [f"{curve.weight_kg[i]:g} kg ({d[i]:+.4f} mΩ)" for i in np.flatnonzero(~same)]
            notes.append(
                f"{labels[3]} equals the mean of {', '.join(labels[:3])} to the printed 4 decimals at "
                f"{int(np.sum(same))} of {v.shape[0]} weights" + (f"; off at {', '.join(odd)}" if odd else "")
                + ": it is not an independent repeat."
            )  # fmt: skip
    for k in range(v.shape[1]):
        for j in range(k + 1, v.shape[1]):
            diff = v[:, j] - v[:, k]
            # offsets with at most 3 decimals (in mΩ) at every weight: one column derived from the other
            if np.all(np.abs(diff * 1000 - np.round(diff * 1000)) < 0.02) and not np.allclose(diff, 0):
                notes.append(
                    f"{labels[j]} − {labels[k]} is a number with at most 3 decimals (mΩ) at every weight "
                    f"({', '.join(f'{x:+.3f}' for x in diff)}; by chance (1/10)^{v.shape[0]}): {labels[j]} looks "
                    f"derived from {labels[k]}."
                )
    return notes
