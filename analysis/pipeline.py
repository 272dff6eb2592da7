"""Session + simulation → comparison: the steps behind ``contactrig fit``, ``figures``, ``report`` and ``demo``.

:func:`analyse` works on objects already in memory (a :class:`~analysis.measured.MeasuredCurve` and a rig sweep
result with ``models[name].weight_kg`` / ``.contact_area_m2``); :func:`analyse_session` and :func:`analyse_tab1`
load them first. When no simulation file is given, the rig is simulated for the measured weights with the scene
recorded in the session (the packaged default scene when the session has none), so the areas need no
interpolation; a given sweep is interpolated in log–log onto the measured weights
(:func:`analysis.fit.area_at_weights`).

Three checks run on every path (``fit``, ``figures``, ``report``, ``demo`` and notebooks alike), in :func:`analyse`:

* **Same scene.** The fingerprint of the measurement's scene (:func:`daq.sweep_file.config_fingerprint`) is compared
  with the simulation's (:func:`daq.sweep_file.sweep_fingerprint`); a difference is a ``ValueError`` naming every
  key that differs (``[rig] clearance_m differs: session 2e-05, simulation 2.5e-05``), and a simulation that records
  no fingerprint cannot be checked and is refused too. ``allow_mismatch=True`` (``--allow-mismatch``) goes on and
  records the override in :attr:`Analysis.fingerprint` (the report shows it).
* **What the data allow.** Weights with a single repeat (a partial last weight) are left out of the fit and of the
  normalised curve (weighting ``"blocks"`` excepted), and fewer than 3 usable weights mean no fit at all
  (:attr:`Analysis.comparison` None); :attr:`Analysis.left_out` says what was left out and why. Fig. 9 is always drawn.
* **Model validity.** The simulation's warnings and :func:`daq.sweep_file.validity_warnings` (plasticity index > 1
  with an elastic-only model, nominal pressure above the hardness) travel in :attr:`Analysis.warnings`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from analysis.circuit import CircuitSettings
from analysis.fit import ModelComparison, area_at_weights, compare_models, independent_series, regressor
from analysis.measured import MeasuredCurve, load_tab1
from analysis.normalisation import NormalisedCurve, normalise_measured, normalise_simulated
from contactrig.core.fingerprint import differences, has_tables

#: Fewest weights a fit is made with (two parameters and one degree of freedom for the goodness of fit).
MIN_FIT_WEIGHTS = 3

#: Mean nominal pressures of the report's boundary-element comparison (:func:`rank_against_bem`): 5, geometric,
#: 0.3–30 MPa — a short run (≈ 5–10 s on 2 cores for the default scene's 256² composite surface).
RANKING_PRESSURES_PA = (0.3e6, 0.9487e6, 3.0e6, 9.487e6, 30.0e6)

__all__ = [
    "RANKING_PRESSURES_PA",
    "Analysis",
    "analyse",
    "analyse_session",
    "analyse_tab1",
    "compare_models_by_default",
    "rank_against_bem",
    "resistance_statement",
    "simulate",
    "specimen_sweep",
    "with_report_extras",
]


@dataclass(frozen=True)
class Analysis:
    """Everything a report needs about one measured curve against the simulated models.

    ``areas_m2[name]`` each model's contact area at ``curve.weight_kg``; ``measured_norm`` and
    ``simulated_norm[name]`` R/R₀ (simulated: the chosen conversion, so A₀/A for eq. 23); ``comparison`` the fits;
    ``measured_info`` / ``sim_info`` provenance of both inputs; ``database`` the contact database when it was built
    here (for seed Fig. 2), else None. ``comparison`` is None when the data allow no fit (``left_out`` says why);
    ``fit_curve`` the weights the fit and the normalised curve use; ``warnings`` the simulation's and the models'
    validity warnings; ``left_out`` what was left out of the analysis and why; ``fingerprint`` both inputs'
    fingerprints, their ``differences`` and whether a mismatch was ``allowed`` (module docstring).
    """

    title: str
    curve: MeasuredCurve
    scene: Any
    circuit: CircuitSettings
    sweep: Any
    areas_m2: dict[str, np.ndarray]
    measured_norm: NormalisedCurve
    simulated_norm: dict[str, NormalisedCurve]
    comparison: ModelComparison | None
    conversion: str
    measured_info: dict[str, Any] = field(default_factory=dict)
    sim_info: dict[str, Any] = field(default_factory=dict)
    database: Any = None
    fit_curve: MeasuredCurve | None = None
    warnings: tuple[str, ...] = ()
    left_out: tuple[str, ...] = ()
    fingerprint: dict[str, Any] = field(default_factory=dict)
    model_ranking: Any = None
    model_ranking_note: str = ""
    resistance_statement: str = ""

    def fitted_norm(self) -> dict[str, np.ndarray]:
        """Each model's fitted R(W)/R(W₀), series resistance included (empty without a fit)."""
        if self.comparison is None:
            return {}
        return {n: f.points.fitted_ohm / f.points.fitted_ohm[0] for n, f in self.comparison.fits.items()}


def simulate(scene: Any, weights_kg: Any, models: list[str] | None = None, *, elastic: bool = False) -> tuple[Any, Any]:
    """Build the contact database once and load the scene's specimen at ``weights_kg`` (None: the scene's own load
    sweep, ``[rig]`` or ``[press] weights_kg``): the rig, or the press for a scene with ``[press]``
    (:func:`sims.specimen.sweep_specimen`). Returns (sweep result, database). ``models``: registered model keys
    (None: the scene's ``[database] models``); ``elastic``: the rig's bulk elasticity (the press always has it)."""
    from sims.config import SimConfig
    from sims.database import build_database

    config = SimConfig.from_scene(scene)
    database = build_database(config, models)
    weights = None if weights_kg is None else [float(w) for w in weights_kg]
    result = specimen_sweep(config, models, weights, database=database, elastic=elastic)
    return result, database


def specimen_sweep(
    config: Any, models: Any = None, weights_kg: Any = None, *, database: Any = None, elastic: bool = False
) -> Any:
    """:func:`sims.specimen.sweep_specimen` (rig or press) whose provenance always carries a checkable fingerprint:
    when the solver's provenance gives none (the press records no database provenance), the fingerprint of
    ``config`` (:func:`daq.sweep_file.config_fingerprint`) is recorded, so ``fit``/``report`` can check the scene."""
    from contactrig.core.fingerprint import has_tables
    from daq.sweep_file import config_fingerprint, sweep_fingerprint
    from sims.specimen import sweep_specimen

    result = sweep_specimen(config, models=models, weights_kg=weights_kg, database=database, elastic=elastic)
    if not has_tables(sweep_fingerprint(result.provenance)):
        result.provenance["fingerprint"] = config_fingerprint(config)
    return result


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
    allow_mismatch: bool = False,
) -> Analysis:
    """Check, normalise, fit and rank every model of ``sweep_result`` against ``curve`` (module docstring)."""
    measured_info, sim_info = dict(measured_info or {}), dict(sim_info or {})
    fingerprint = check_same_scene(scene, sweep_result, measured_info, sim_info, allow_mismatch=allow_mismatch)
    circuit = CircuitSettings.from_scene(scene)
    areas: dict[str, np.ndarray] = {}
    for name, m in sweep_result.models.items():
        areas[name] = area_at_weights(np.asarray(m.weight_kg), np.asarray(m.contact_area_m2), curve.weight_kg)
    fit_curve, keep, left_out = _fittable(curve, weighting)
    comparison = None
    if fit_curve is not None:
        terms = physical_terms(scene, list(areas), fit_curve.weight_kg, database) if conversion == "physical" else None
        comparison = compare_models(
            fit_curve, {n: a[keep] for n, a in areas.items()}, height_m=circuit.contact_height_m,
            conversion=conversion, weighting=weighting, ci_level=ci_level, n_boot=n_boot, seed=seed,
            boot_interval=boot_interval, offset_terms=terms,
        )  # fmt: skip
    # R/R₀ and its error from the independent series, as the fit (copies of other series counted once)
    measured_norm, norm_keep, norm_notes = _normalised(independent_series(curve)[0], keep)
    sim_norm = {
        n: normalise_simulated(
            curve.weight_kg[norm_keep], regressor(a[norm_keep], circuit.contact_height_m, conversion)
        )
        for n, a in areas.items()
    }
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
        measured_info=measured_info,
        sim_info=sim_info,
        database=database,
        fit_curve=fit_curve,
        warnings=tuple(model_warnings(sweep_result)),
        left_out=tuple(left_out + norm_notes),
        fingerprint=fingerprint,
    )


def physical_terms(
    scene: Any, models: list[str], weights_kg: np.ndarray, database: Any = None
) -> dict[str, dict[str, np.ndarray]]:
    """The computed terms of the physical model (``--conversion physical``) per model and weight [Ω]: Barber's
    clean-metal constriction and the macro-constriction — on the rig the band's
    (:func:`analysis.resistance_model.rig_resistance_terms`), on the press Holm's circular spot of the contact radius
    with Barber's term from the press stiffness (:func:`analysis.resistance_model.specimen_resistance_terms`, the
    design's and the simulated bench's model). A scene without both resistivities, or a model that is not registered,
    is a SettingError naming what is missing."""
    from analysis.resistance_model import rig_resistance_terms, specimen_resistance_terms
    from contactrig.core.validation import SettingError
    from sims.config import SimConfig
    from sims.models import model_names

    config = SimConfig.from_scene(scene)
    for name in models:
        if name not in model_names():
            raise SettingError("conversion", "physical", f"model {name!r} is not registered: its stiffness is needed")
    weights = [float(w) for w in weights_kg]
    if config.press is not None:
        laws = {n: database[n] for n in models if database is not None and n in database}
        missing = [n for n in models if n not in laws]
        if missing:
            from sims.database import build_database

            built = build_database(config, models=missing)
            laws.update({n: built[n] for n in missing})
        return {n: t.terms for n, t in specimen_resistance_terms(config, models, weights, laws=laws).items()}
    out = {}
    for name in models:
        law = database[name] if database is not None and name in database else None
        out[name] = rig_resistance_terms(config, name, weights, law=law).known_terms()
    return out


def _sim_ratio(weight_kg: np.ndarray, area_m2: np.ndarray, height_m: float, conversion: str) -> NormalisedCurve:
    return normalise_simulated(weight_kg, regressor(area_m2, height_m, conversion))


def model_warnings(sweep_result: Any) -> list[str]:
    """The simulation's own warnings and where its models are used outside their validity
    (:func:`daq.sweep_file.validity_warnings`), each once."""
    from daq.sweep_file import validity_warnings

    out: list[str] = []
    for w in list(getattr(sweep_result, "warnings", []) or []) + validity_warnings(sweep_result):
        if w not in out:
            out.append(w)
    return out


def scene_fingerprint(scene: Any) -> dict[str, Any]:
    """The fingerprint of what a simulation of ``scene`` would be computed from
    (:func:`daq.sweep_file.config_fingerprint`)."""
    from contactrig.core.fingerprint import fingerprint
    from contactrig.core.validation import SettingError
    from daq.sweep_file import config_fingerprint
    from sims.config import SimConfig

    try:
        return config_fingerprint(SimConfig.from_scene(scene))
    except SettingError:  # e.g. a measured height map a recorded scene names but does not carry: its tables as written
        tables = {t: scene.data.get(t) for t in ("materials", "surfaces", "database", "rig")}
        return fingerprint(tables, scene_text=scene.text)


def check_same_scene(
    scene: Any, sweep_result: Any, measured_info: dict[str, Any], sim_info: dict[str, Any], *, allow_mismatch: bool
) -> dict[str, Any]:
    """Compare the measurement's scene with the simulation's fingerprint; refuse a difference or an unverifiable
    simulation unless ``allow_mismatch``. Returns what was compared, the differences and whether they were allowed."""
    from daq.sweep_file import sweep_fingerprint

    measured = scene_fingerprint(scene)
    simulated = sweep_fingerprint(getattr(sweep_result, "provenance", {}) or {})
    kind = "session" if measured_info.get("kind", "session") == "session" else "table"
    where_m = measured_info.get("path") or "the measurement"
    where_s = sim_info.get("source") or "the simulation"
    if not has_tables(simulated):
        diffs = [f"{where_s} records no fingerprint of the scene it was simulated for"]
        message = (
            f"cannot check that {where_s} was simulated for the scene of {where_m}: it records no fingerprint "
            "(written by an older contactrig?); re-run contactrig simulate, or pass --allow-mismatch"
        )
    else:
        diffs = differences(measured, simulated, (kind, "simulation"))
        shown = "; ".join(diffs[:6]) + (f"; and {len(diffs) - 6} more" if len(diffs) > 6 else "")
        message = (
            f"{where_s} was simulated for a different scene than {where_m}: {shown}; pass --allow-mismatch to "
            "compare them anyway"
        )
    if diffs and not allow_mismatch:
        raise ValueError(message)
    return {"measured": measured, "simulation": simulated, "differences": diffs, "allowed": bool(diffs)}


def _fittable(curve: MeasuredCurve, weighting: str) -> tuple[MeasuredCurve | None, np.ndarray, list[str]]:
    """The weights a fit can use (>= 2 repeats unless weighting by the blocks' own errors), as a curve, the mask
    over ``curve``'s weights, and what was left out and why; no curve when fewer than 3 weights remain."""
    keep = np.ones(curve.weight_kg.size, bool) if weighting == "blocks" else curve.n >= 2
    notes = [
        f"{w:g} kg has {int(n)} repeat: left out of the fit and of the normalised curve (Fig. 12), shown in Fig. 9 "
        "(a weight needs >= 2 repeats for its scatter)"
        for w, n, k in zip(curve.weight_kg, curve.n, keep, strict=True)
        if not k
    ]
    if int(np.sum(keep)) < MIN_FIT_WEIGHTS:
        notes.append(
            f"no fit: {int(np.sum(keep))} weight(s) usable, a two-parameter fit with a goodness-of-fit test needs "
            f">= {MIN_FIT_WEIGHTS}; the fit table, fit figure and verdict are left out"
        )
        return None, keep, notes
    if bool(np.all(keep)):
        return curve, keep, notes
    sub = MeasuredCurve(
        curve.weight_kg[keep], curve.values_ohm[keep], repeat_labels=curve.repeat_labels,
        block_sem_ohm=None if curve.block_sem_ohm is None else curve.block_sem_ohm[keep], paired=True,
        source=curve.source, provenance=curve.provenance,
    )  # fmt: skip
    return sub, keep, notes


def _normalised(curve: MeasuredCurve, keep: np.ndarray) -> tuple[NormalisedCurve, np.ndarray, list[str]]:
    """R/R₀ of the weights with an uncertainty (``keep``); with none, every weight's ratio without one (said so)."""
    if np.any(keep):
        sub = curve if bool(np.all(keep)) else MeasuredCurve(
            curve.weight_kg[keep], curve.values_ohm[keep], repeat_labels=curve.repeat_labels, paired=True,
        )  # fmt: skip
        try:
            return normalise_measured(sub), keep, []
        except ValueError:
            pass
    every = np.ones(curve.weight_kg.size, bool)
    note = "normalised curve (Fig. 12) without error bars: single repeats carry no scatter to propagate"
    return normalise_simulated(curve.weight_kg, curve.mean_ohm), every, [note]


def _session_note(caught: warnings.WarningMessage) -> bool:
    """A warning :func:`daq.load_session` raised for a note that ``Session.warnings`` already holds."""
    from daq.errors import SessionNoteWarning

    return issubclass(caught.category, SessionNoteWarning)


def _scene_for(session: Any) -> Any:
    from contactrig.core.scene import load_scene, parse_scene

    text = getattr(session, "scene_text", "") or ""
    if text.strip():
        label = f"{session.path} (recorded scene)"
        return parse_scene(text, label, base_dir=_height_map_folder(session, text))
    return load_scene(None)


def _names_height_maps(text: str) -> bool:
    """Whether the scene ``text`` (TOML) has a ``[surfaces.*]`` table of ``kind = "file"`` (however it is spelled)."""
    import tomllib

    try:
        surfaces = tomllib.loads(text).get("surfaces", {})
    except tomllib.TOMLDecodeError:
        return False
    return isinstance(surfaces, dict) and any(
        isinstance(t, dict) and t.get("kind") == "file" for t in surfaces.values()
    )


def _height_map_folder(session: Any, text: str) -> Path | None:
    """Where the recorded scene's measured height maps are (``kind = "file"`` paths are relative to the scene file):
    the folder of the scene file the session was started from, if that file still holds exactly the recorded text;
    else None (the maps are not read: the fingerprint then compares the tables as written)."""
    from contactrig.core.inputs import read_text_file
    from contactrig.core.validation import SettingError

    if not _names_height_maps(text):
        return None
    source = (getattr(session, "start", None) or {}).get("scene_source")
    if not isinstance(source, str) or not source or source.startswith("<"):
        return None
    try:
        if read_text_file("scene", source) != text:
            return None
    except SettingError:
        return None
    return Path(source).resolve().parent


def _load_sim(
    sim_path: str | Path | None,
    scene: Any,
    weights: np.ndarray,
    models: list[str] | None,
    database_path: str | Path | None = None,
) -> tuple[Any, Any, dict[str, Any]]:
    if sim_path is not None and database_path is not None:
        raise ValueError("give a rig sweep (--sim SIM.h5) or a contact database (--database DB.h5), not both")
    if database_path is not None:
        return _sweep_on_database(database_path, scene, _simulated_weights(weights), models)
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
    result, database = simulate(scene, _simulated_weights(weights), models)
    info = {
        "source": f"simulated now from scene {scene.name!r} ({scene.source})",
        "warnings": list(result.warnings),
        "provenance": result.provenance,
    }
    return result, database, info


#: At most this many distinct weights are simulated for one analysis; a curve with more (an imported table of 10 000
#: weights) is simulated on a geometric grid over its range and the contact area interpolated (PCHIP in log–log,
#: :func:`analysis.fit.area_at_weights`): the simulation's time and memory stay those of a bench session.
SIM_WEIGHTS_MAX = 128


def _simulated_weights(weights: np.ndarray) -> np.ndarray:
    """The weights to simulate for a curve at ``weights`` (kg): its own, or a grid of :data:`SIM_WEIGHTS_MAX`."""
    w = np.unique(np.asarray(weights, dtype=float))
    if w.size <= SIM_WEIGHTS_MAX or w[0] <= 0:
        return w
    grid = np.geomspace(w[0], w[-1], SIM_WEIGHTS_MAX)
    grid[0], grid[-1] = w[0], w[-1]  # the ends exactly: no extrapolation
    return grid


def _sweep_on_database(
    path: str | Path, scene: Any, weights: np.ndarray, models: list[str] | None
) -> tuple[Any, Any, dict[str, Any]]:
    """The scene's specimen (rig or press) loaded at ``weights`` on the contact database file at ``path`` (written
    by ``contactrig database -o``) instead of a database built now. The sweep's fingerprint is the database's scene
    (materials, surfaces, database) with the rig of ``scene``, so :func:`check_same_scene` refuses a database made
    for other surfaces unless the mismatch is allowed."""
    from daq.database_file import load_database
    from sims.config import SimConfig

    database = load_database(path)
    if models:
        missing = [m for m in models if m not in database]
        if missing:
            raise ValueError(f"{path} has no models {missing}; it has {list(database)}")
    names = list(models) if models else list(database)
    result = specimen_sweep(SimConfig.from_scene(scene), names, [float(w) for w in weights], database=database)
    info = {
        "source": f"{path} (contact database; the specimen of scene {scene.name!r} simulated now on it)",
        "warnings": list(result.warnings),
        "provenance": result.provenance,
    }
    return result, database, info


def analyse_session(
    session_path: str | Path,
    sim_path: str | Path | None = None,
    *,
    models: list[str] | None = None,
    database_path: str | Path | None = None,
    **kw: Any,
) -> Analysis:
    """Load a session file (``daq.load_session``) and the simulation (``sim_path``; or the specimen simulated now on
    the contact database file ``database_path``; or everything simulated now), analyse.

    ``kw`` goes to :func:`analyse` (conversion, weighting, n_boot, seed, ci_level, boot_interval, title).
    """
    from daq import load_session
    from daq.records import session_history

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        session = load_session(session_path)
    if len(session.summary) == 0:
        state = "a complete session" if session.complete else "an incomplete session: no stop record"
        raise ValueError(f"{session_path}: no measurement block on disk ({state}); nothing to analyse")
    curve = MeasuredCurve.from_session(session, source=str(session_path))
    scene = _scene_for(session)
    sweep_result, database, sim_info = _load_sim(sim_path, scene, curve.weight_kg, models, database_path)
    measured_info = {
        "kind": "session",
        "path": str(session_path),
        "complete": bool(session.complete),
        "status": session.status,
        "imported": bool(session.imported),
        "start": session.start,
        "stop": session.stop,
        "warnings": list(session.warnings) + [str(w.message) for w in caught if not _session_note(w)],
        "scene_source": scene.source,
        "history": session_history(session),  # loading order, skips, resumes, interruptions (text from the file)
        "runs": session.runs,  # every run's start record: the report counts them and shows each run's notes
    }
    from contactrig.core.text import shown

    kw.setdefault("title", f"Session {shown(Path(session_path).name)}")  # a name that is not UTF-8: visible escapes
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
    database_path: str | Path | None = None,
    **kw: Any,
) -> Analysis:
    """The seed paper's Tab. 1 against the simulated models: ``sweep_result``, else the sweep file ``sim_path``,
    else the rig simulated now on the contact database file ``database_path``, else everything simulated now with
    ``scene`` (the packaged default scene when None).

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
        sweep_result, database, sim_info = _load_sim(sim_path, scene, curve.weight_kg, models, database_path)
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
    """Checks of Tab. 1's series against each other, in words: columns that are arithmetic copies of others are not
    independent repeats, which shrinks the real repeat count behind any standard error. The series detector's
    findings (:func:`analysis.fit.series_dependence`, the one implementation the fit uses too)."""
    from analysis.fit import series_dependence

    dep = series_dependence(curve)
    if not dep.dropped:
        return list(dep.notes)
    labels = curve.repeat_labels or tuple(f"series {k + 1}" for k in range(curve.values_ohm.shape[1]))
    dropped = ", ".join(labels[k] for k in dep.dropped)
    return [f"{note}." for note in dep.notes] + [
        f"{dropped} {'is' if len(dep.dropped) == 1 else 'are'} not independent repeats: the fit counts "
        f"{dep.n_independent} independent series ({', '.join(labels[k] for k in dep.keep)})."
    ]


# ---------------------------------------------------------------------------------------------------------------
# What the report adds: the boundary-element reference (issue #14) and the resistance model's sentence (issue #15).


def compare_models_by_default(a: Analysis) -> tuple[bool, str]:
    """Whether ``contactrig report`` runs the boundary-element comparison when neither ``--compare-models`` nor
    ``--no-compare-models`` is given, and why: yes when the surfaces the fit's contact areas were computed on are
    the scene's — the simulation's fingerprint records ``[surfaces]`` and it equals the measurement scene's (so BEM
    and the models' database see the same composite surface); no after an allowed mismatch of the surfaces, or for
    a simulation without a fingerprint."""
    tables = (a.fingerprint.get("simulation") or {}).get("tables") or {}
    if "surfaces" not in tables:
        return False, "the simulation records no fingerprint of its surfaces (pass --compare-models to run it anyway)"
    if any(d.startswith("[surfaces") for d in a.fingerprint.get("differences", [])):
        return False, "the simulation's surfaces differ from the scene's (--allow-mismatch); pass --compare-models"
    return True, ""


def rank_against_bem(
    scene: Any, models: Any = None, *, pressures_pa: Any = RANKING_PRESSURES_PA, jobs: int = 1, progress: Any = None
) -> Any:
    """The boundary-element comparison of ``scene``'s composite surface (:func:`analysis.compare_models.
    compare_models`, one realisation, hardness-capped, at ``pressures_pa``) for the registered ``models`` among
    ``models`` (None: the scene's), in this process (``jobs`` 1: every core as FFT threads); ``progress(done,
    total)`` as its tasks finish."""
    from analysis.compare_models import compare_models
    from sims.ensemble import BEM
    from sims.models import model_names

    names = None if models is None else [m for m in models if m in model_names() and m != BEM]
    if names is not None and not names:
        raise ValueError("no registered contact model to compare with the boundary-element reference")
    return compare_models(scene, names, pressures_pa=pressures_pa, jobs=jobs, progress=progress)


def with_report_extras(a: Analysis, *, ranking: Any = None, ranking_note: str = "", statement: bool = True) -> Analysis:
    """``a`` with what the report shows beyond the fit: ``ranking`` (a comparison from :func:`rank_against_bem`) or
    ``ranking_note`` (why there is none), and the resistance model's sentence (:func:`resistance_statement`)."""
    import dataclasses

    text = resistance_statement(a) if statement else ""
    return dataclasses.replace(a, model_ranking=ranking, model_ranking_note=ranking_note, resistance_statement=text)


def _statement_model(a: Analysis) -> str:
    """The model whose contact area the resistance model uses: the best physical fit among registered models."""
    from sims.models import model_names

    ranked = list(a.comparison.ranking) if a.comparison is not None else []
    for name in ranked:
        if name in model_names() and a.comparison is not None and a.comparison.fits[name].physical:
            return name
    return "greenwood_tripp"


def resistance_statement(a: Analysis) -> str:
    """The resistance model's plain sentence (:mod:`analysis.resistance_model`): fitted σ_f, R_s and the
    clean-metal fraction — for Tab. 1 :func:`~analysis.resistance_model.tab1_statement`, for a session the same from
    :func:`~analysis.resistance_model.fit_measured` on the session's curve; "" with a reason when it cannot be
    fitted (a press scene, no resistivities, fewer than 2 complete repeats at every weight)."""
    from contactrig.core.validation import SettingError
    from sims.config import SimConfig

    curve = a.fit_curve
    if curve is None or a.comparison is None:
        return ""
    try:
        config = SimConfig.from_scene(a.scene)
        if config.press is not None:
            return "Resistance model not fitted: it describes the piston/liner rig; this is a press scene."
        if not curve.paired or np.any(curve.n < 2):
            return "Resistance model not fitted: it needs >= 2 repeats at every weight."
        return _resistance_sentence(a, config, curve, _statement_model(a))
    except (SettingError, ValueError, KeyError) as exc:
        return f"Resistance model not fitted: {exc}"


def _resistance_sentence(a: Analysis, config: Any, curve: MeasuredCurve, model: str) -> str:
    from analysis.resistance_model import fit_measured, physical_sentence, rig_resistance_terms
    from sims.models import model_label

    is_tab1 = a.measured_info.get("kind") == "table" and str(a.measured_info.get("path", "")).endswith("tab1.csv")
    terms = rig_resistance_terms(config, model, [float(w) for w in curve.weight_kg])
    return physical_sentence(fit_measured(curve, terms), model_label(model), "Tab. 1" if is_tab1 else "this session")
