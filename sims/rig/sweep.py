"""The load sweep of the rig model: real contact area against added weight, per model (seed section 2.1, Fig. 11).

A piston lies in a horizontal liner; the weight presses its skirt down onto the liner's bottom. Piston and liner are
rigid, the asperities deform (the paper's MBS assumption), and the contact law of each model — nominal pressure and
real-area fraction against mean-plane separation, from :mod:`sims.database` — gives the load and the real area on a
mesh of the skirt. :func:`sweep` solves the static equilibrium of every weight for every model a configuration asks
for (:func:`sims.rig.equilibrium.batch_equilibrium`, all weights of a model at once). The damped release-to-rest
dynamics of seed eq. 22 are in :mod:`sims.rig.dynamics`; the HDF5 file of a sweep is :mod:`daq.sweep_file`.

Load convention: ``W = (weight_kg + piston_mass_kg)·g`` with standard gravity. The paper's "255 N (26 kg)" is
25.966 kg × g, i.e. its Tab. 1 weights are the whole load on the skirt; the default scene therefore sets
``piston_mass_kg = 0``.

Contract (used by ``daq`` and ``analysis``)::

    config = SimConfig.from_scene(scene)
    result = sweep(config, models=["greenwood_tripp"], weights_kg=None)   # None → config.rig.weights_kg
    result.models["greenwood_tripp"].weight_kg, .contact_area_m2, .min_separation_m, .force_n   # numpy arrays
    result.warnings      # list[str]
    result.provenance    # dict: scene text, database provenance, software version
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from contactrig.core.provenance import software_version
from sims.budget import check_specimen
from sims.rig.equilibrium import (
    ALPHA_WARN,
    BatchEquilibrium,
    RigLoadError,
    batch_equilibrium,
    preload_note,
    roughness_parameter,
)
from sims.rig.law import ContactLaw, check_law
from sims.rig.settings import STANDARD_GRAVITY, RigSettings, check_weights

if TYPE_CHECKING:
    from sims.config import SimConfig

__all__ = ["ModelSweep", "SweepResult", "roughness_and_modulus", "sweep"]


@dataclass(frozen=True)
class ModelSweep:
    """A(W) of one contact model: one entry per weight, in the order the weights were given.

    ``weight_kg`` added weight [kg]; ``force_n`` contact force at equilibrium [N] (= load ``(weight + piston
    mass)·g``); ``contact_area_m2`` real contact area [m²]; ``min_separation_m`` minimum gap h0 [m];
    ``peak_pressure_pa`` nominal pressure at the minimum gap [Pa]; ``contact_width_m`` nominal contact width [m];
    ``n_nodes`` mesh nodes used; ``converged`` mesh and root both converged.
    """

    name: str
    weight_kg: np.ndarray
    contact_area_m2: np.ndarray
    min_separation_m: np.ndarray
    force_n: np.ndarray
    peak_pressure_pa: np.ndarray
    contact_width_m: np.ndarray
    n_nodes: np.ndarray
    converged: np.ndarray

    #: Array fields and their units (HDF5 ``units`` attributes).
    UNITS: ClassVar[dict[str, str]] = {
        "weight_kg": "kg",
        "contact_area_m2": "m^2",
        "min_separation_m": "m",
        "force_n": "N",
        "peak_pressure_pa": "Pa",
        "contact_width_m": "m",
        "n_nodes": "1",
        "converged": "1",
    }

    @classmethod
    def from_batch(cls, name: str, batch: BatchEquilibrium) -> ModelSweep:
        """The sweep of model ``name`` from its batch equilibria (arrays copied where shared)."""
        n = batch.weight_kg.size
        return cls(
            name=name,
            weight_kg=batch.weight_kg.copy(),
            contact_area_m2=batch.contact_area_m2,
            min_separation_m=batch.min_separation_m,
            force_n=batch.contact_force_n,
            peak_pressure_pa=batch.peak_pressure_pa,
            contact_width_m=batch.contact_width_m,
            n_nodes=np.full(n, batch.n_nodes, dtype=int),
            converged=np.asarray(batch.converged, dtype=bool),
        )


@dataclass(frozen=True)
class SweepResult:
    """Load sweep of every requested model: ``models[name]`` → :class:`ModelSweep`, plus warnings and provenance."""

    models: dict[str, ModelSweep]
    warnings: list[str] = field(default_factory=list)
    provenance: dict[str, Any] = field(default_factory=dict)

    def to_json_dict(self) -> dict[str, Any]:
        """``{"models": {name: {"weight_kg", "contact_area_m2", "min_separation_m"}}, "warnings": [...]}`` (lists)."""
        return {
            "models": {
                name: {
                    "weight_kg": m.weight_kg.tolist(),
                    "contact_area_m2": m.contact_area_m2.tolist(),
                    "min_separation_m": m.min_separation_m.tolist(),
                }
                for name, m in self.models.items()
            },
            "warnings": list(self.warnings),
        }


def sweep(
    config: SimConfig | None = None,
    models: Sequence[str] | None = None,
    weights_kg: Sequence[float] | None = None,
    *,
    laws: Mapping[str, ContactLaw] | None = None,
    database: Any = None,
    settings: RigSettings | None = None,
    roughness_m: float | None = None,
    composite_modulus_pa: float | None = None,
    elastic: bool = False,
) -> SweepResult:
    """Contact area against weight for every model: static equilibrium per (model, weight).

    All weights of a model are solved together on a shared mesh (:func:`sims.rig.equilibrium.batch_equilibrium`);
    the per-model solver diagnostics are in ``provenance["solver"]``; ``provenance["notes"]`` says when the clearance
    lies inside a law's contact range (a pre-loaded fit: zero clearance, or roughness comparable with it).

    ``config`` (a :class:`sims.config.SimConfig`, e.g. ``SimConfig.from_scene(scene)``; None → the packaged default
    scene's) gives the rig settings (unless ``settings`` is given) and the database settings. ``models`` restricts the
    models (registered keys, :mod:`sims.models`; None → ``config.database.models``); only those curves are built
    (:func:`sims.database.build_database`). ``weights_kg`` [kg] overrides ``config.rig.weights_kg``. ``laws`` (name →
    contact law) or a prebuilt ``database`` replace the database build (and its automatic extension when a load
    leaves the tabulated range). ``roughness_m`` [m] / ``composite_modulus_pa`` [Pa] (default: from the database or
    the configuration) drive the roughness-parameter check. Raises :class:`RigLoadError` when a law cannot carry a
    load. ``elastic=True`` (opt-in) couples the asperity law to the bodies' bulk elasticity
    (:func:`sims.rig.elastic.apply_bulk_elasticity`): areas and peak pressures carry the computed change and the
    roughness-parameter warnings become the computed effect (``provenance["bulk_elasticity"]``).
    """
    config = _config(config)
    settings = settings if settings is not None else config.rig
    weights = check_weights(weights_kg, "weights_kg") if weights_kg is not None else settings.weights_kg
    names = _checked_models(models)
    building = laws is None and database is None  # the whole sweep's memory is checked before any of it is built
    check_specimen(config.with_changes(rig=settings, press=None), names, weights, build_database=building)
    provenance: dict[str, Any] = {
        "software_version": software_version(),
        **config.provenance(),
        "rig_settings": settings.as_dict(),
        "weights_kg": list(weights),
        "gravity_m_per_s2": STANDARD_GRAVITY,
    }
    law_map, database, built_here = _contact_laws(config, names, laws, database, provenance)
    warnings: list[str] = []
    if roughness_m is None or composite_modulus_pa is None:
        sigma, modulus = roughness_and_modulus(config, database) if laws is None else (None, None)
        roughness_m = roughness_m if roughness_m is not None else sigma
        composite_modulus_pa = composite_modulus_pa if composite_modulus_pa is not None else modulus
    if roughness_m is not None and composite_modulus_pa is not None:
        _check_roughness(settings, weights, roughness_m, composite_modulus_pa, provenance, warnings)
    batches = {name: batch_equilibrium(law, settings, weights, name=name) for name, law in law_map.items()}
    if built_here:
        _extend_database(config, database, law_map, batches, settings, weights, provenance, warnings)
    if roughness_m is not None and composite_modulus_pa is not None:
        provenance["bulk_deflection"] = {
            name: _bulk_deflection(law_map[name], settings, batches[name], roughness_m, composite_modulus_pa)
            for name in batches
        }
    notes = [note for name, law in law_map.items() if (note := preload_note(name, law, settings))]
    if notes:
        provenance["notes"] = notes
    result = _collect(batches, provenance, warnings)
    if elastic:  # opt-in: bulk elasticity (sims.rig.elastic) replaces the roughness-parameter warnings by its effect
        from sims.rig.elastic import apply_bulk_elasticity

        modulus = composite_modulus_pa if composite_modulus_pa is not None else config.materials.E_star
        models_el = apply_bulk_elasticity(result.models, law_map, settings, modulus, provenance, result.warnings)
        result = replace(result, models=models_el)
    return result


def _config(config: Any) -> SimConfig:
    """``config`` checked, or the packaged default scene's when None."""
    from sims.config import SimConfig

    if config is None:
        from contactrig.core.scene import load_scene

        return SimConfig.from_scene(load_scene(None))
    if not isinstance(config, SimConfig):
        raise TypeError(
            f"sweep takes a sims.config.SimConfig (SimConfig.from_scene(scene)), not {type(config).__name__}"
        )
    return config


def _checked_models(models: Sequence[str] | None) -> list[str] | None:
    """A non-empty list of model names without repeats (order kept), or None."""
    if models is None:
        return None
    if isinstance(models, str) or not all(isinstance(m, str) for m in models) or len(models) == 0:
        raise RigLoadError(f"models = {models!r} is not allowed: expected a non-empty list of model names")
    return list(dict.fromkeys(models))


def _contact_laws(
    config: SimConfig,
    models: list[str] | None,
    laws: Mapping[str, ContactLaw] | None,
    database: Any,
    provenance: dict[str, Any],
) -> tuple[dict[str, ContactLaw], Any, bool]:
    """The law of every model (given, from ``database``, or from a database built here), each checked.

    Returns ``(law by name, database, built here)`` and records the database's provenance.
    """
    built_here = False
    if laws is not None:
        names = list(laws) if models is None else models
        unknown = [n for n in names if n not in laws]
        if unknown:
            raise RigLoadError(f"models {unknown} are not among the given laws {list(laws)}")
        law_map = {n: laws[n] for n in names}
        provenance["database"] = {"source": "contact laws given by the caller", "models": names}
    else:
        if database is None:
            from sims.database import build_database

            database = build_database(config, models=models)
            built_here = True
        names = list(models) if models is not None else _database_names(database, config)
        law_map = {n: database[n] for n in names}
        provenance["database"] = dict(getattr(database, "provenance", {}) or {})
    for n, law in law_map.items():
        check_law(law, n)
    return law_map, database, built_here


def _database_names(database: Any, config: SimConfig) -> list[str]:
    """The models a database holds (its keys), else the configuration's ``[database] models``."""
    if isinstance(database, Mapping):
        return list(database.keys())
    return list(config.database.models)


def _database_sigma(database: Any) -> float | None:
    """Combined RMS roughness σ = √(Sq1² + Sq2²) [m] (seed eq. 3) of the surfaces a database was built from."""
    prov = dict(getattr(database, "provenance", {}) or {})
    surfaces = prov.get("surfaces")
    if not isinstance(surfaces, dict):
        return None
    sq = [s.get("sq_m") if isinstance(s, dict) else None for s in (surfaces.get("liner"), surfaces.get("piston"))]
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in sq):
        return None
    return math.hypot(*(float(v) for v in sq if v is not None))


def roughness_and_modulus(config: SimConfig, database: Any = None) -> tuple[float | None, float | None]:
    """Combined RMS roughness σ [m] (seed eq. 3) and composite modulus E* [Pa] (seed eq. 4) for the α check.

    From the database's provenance when it has them (its surfaces' ``sq_m``, ``materials.E_star_pa``), else from the
    configuration (generated surfaces' ``sq_m``; a measured surface's Sq is only known once it is read: None).
    """
    prov = dict(getattr(database, "provenance", {}) or {})
    sigma = _database_sigma(database)
    modulus = prov.get("materials", {}).get("E_star_pa") if isinstance(prov.get("materials"), dict) else None
    if sigma is None and "file" not in (config.liner.kind, config.piston.kind):
        sigma = math.hypot(config.liner.sq_m, config.piston.sq_m)
    if modulus is None:
        modulus = config.materials.E_star
    return (None if sigma is None else float(sigma)), (None if modulus is None else float(modulus))


def _check_roughness(
    settings: RigSettings,
    weights: tuple[float, ...],
    roughness_m: float,
    composite_modulus_pa: float,
    provenance: dict[str, Any],
    warnings: list[str],
) -> None:
    """Roughness parameter α of every weight against :data:`ALPHA_WARN`, and the line-contact check of the heaviest."""
    provenance["roughness_m"] = roughness_m
    provenance["composite_modulus_pa"] = composite_modulus_pa
    for w in weights:
        alpha = roughness_parameter(settings.load_n(w), settings.skirt_length_m, roughness_m, composite_modulus_pa)
        if alpha < ALPHA_WARN:
            warnings.append(
                f"weight {w:g} kg: roughness parameter σ·R_eff/b² = {alpha:.3g} < {ALPHA_WARN:g}: bulk elastic "
                "deformation is no longer small against asperity deformation (rigid-body model)"
            )
    provenance["line_contact_check"] = _line_contact_check(settings, max(weights), composite_modulus_pa, warnings)


def _collect(batches: dict[str, BatchEquilibrium], provenance: dict[str, Any], warnings: list[str]) -> SweepResult:
    """The sweep result: one :class:`ModelSweep` per model, the solvers' warnings (once each) and diagnostics."""
    result_models: dict[str, ModelSweep] = {}
    for name, batch in batches.items():
        warnings.extend(w for w in batch.warnings if w not in warnings)
        result_models[name] = ModelSweep.from_batch(name, batch)
        provenance.setdefault("solver", {})[name] = {
            "law_calls": batch.law_calls,
            "iterations": batch.iterations,
            "mesh_levels": batch.mesh_levels,
            "mesh_change": batch.mesh_change,
            "n_nodes": batch.n_nodes,
            "max_abs_residual_n": float(np.max(np.abs(batch.residual_n))),
        }
    return SweepResult(models=result_models, warnings=warnings, provenance=provenance)


def _extend_database(
    config: SimConfig,
    database: Any,
    law_map: dict[str, ContactLaw],
    batches: dict[str, BatchEquilibrium],
    settings: RigSettings,
    weights: tuple[float, ...],
    provenance: dict[str, Any],
    warnings: list[str],
) -> None:
    """Rebuild the curves whose minimum gap fell below their range, deeper (``[database] h_min_sigma``), and re-solve.

    The database allows ``h_min_sigma`` down to −3; a load that needs more stays extrapolated (its warning stays).
    ``law_map`` and ``batches`` are updated in place; the extension is recorded in ``provenance``.
    """
    from sims.database import build_database

    low = {n: float(b.min_separation_m.min()) for n, b in batches.items() if not np.all(b.in_range)}
    sigma = _database_sigma(database)
    if not low or not sigma:
        return
    current = config.database.h_min_sigma
    needed = max(-3.0, math.floor(min(low.values()) / sigma - 0.25))
    if needed >= current:
        return
    deeper = config.with_changes(database=replace(config.database, h_min_sigma=float(needed)))
    extended = build_database(deeper, models=list(low))
    for name in low:
        law_map[name] = extended[name]
        batches[name] = batch_equilibrium(extended[name], settings, weights, name=name)
    provenance["database_extension"] = {
        "models": list(low),
        "h_min_sigma": {"scene": current, "used": float(needed)},
        "reason": "a minimum gap fell below the database's separation range",
    }
    warnings.append(
        f"database extended for {', '.join(low)}: separations down to {needed:g}·σ (scene: {current:g}·σ) because "
        "a load pushed the minimum gap below the tabulated range"
    )


def _bulk_deflection(
    law: ContactLaw, settings: RigSettings, batch: BatchEquilibrium, roughness_m: float, composite_modulus_pa: float
) -> dict[str, Any]:
    """Elastic bulk deflection under the rigid-body pressure of the heaviest weight, against σ (the model's premise).

    The nominal pressure along the circumference at the skirt's middle, ``p(h(θ))``, is applied to an elastic
    half-plane (:func:`sims.line_contact.influence_matrix`, Johnson eq. 2.25b); the spread of the surface
    displacement over the loaded arc (``p > 1 %`` of the peak) is what the rigid-body model neglects. It should be
    small against σ; it grows as ``1/α``.
    """
    from sims.line_contact import influence_matrix
    from sims.rig.geometry import gap_m

    i = int(np.argmax(batch.load_n))
    width = float(batch.contact_width_m[i])
    if batch.load_n[i] <= 0 or width <= 0:
        return {"status": "no load"}
    r_l = settings.liner_radius_m
    half = min(0.5 * width, 0.5 * math.pi * r_l)
    x = np.linspace(-half, half, 201)
    p = np.asarray(law.pressure(gap_m(x / r_l, float(batch.min_separation_m[i]), r_l, settings.clearance_m)))
    u = influence_matrix(x, float(x[1] - x[0]), composite_modulus_pa) @ p
    loaded = p > 0.01 * p.max()
    spread = float(u[loaded].max() - u[loaded].min())
    return {
        "weight_kg": float(batch.weight_kg[i]),
        "deflection_spread_m": spread,
        "relative_to_sigma": spread / roughness_m,
    }


def _line_contact_check(
    settings: RigSettings, weight_kg: float, composite_modulus_pa: float, warnings: list[str]
) -> dict[str, Any]:
    """Smooth elastic half-width of the heaviest load from the line-contact solver on the exact gap, vs Johnson's.

    The roughness parameter uses Johnson's b (``α = πσE*/(4P′)``); this records how well Johnson's formula holds
    for the rig's conformal geometry, and warns when it does not (contact wider than a small angle).
    """
    from sims.line_contact import conformal_line_contact, hertz_line_contact
    from sims.rig.geometry import effective_radius_m

    load = settings.load_n(weight_kg)
    if load <= 0 or settings.clearance_m <= 0:
        return {"weight_kg": weight_kg, "status": "not applicable (zero load or zero clearance)"}
    p_line = load / settings.skirt_length_m
    b_johnson, p0 = hertz_line_contact(
        p_line, effective_radius_m(settings.liner_radius_m, settings.clearance_m), composite_modulus_pa
    )
    sol = conformal_line_contact(
        settings.liner_radius_m, settings.clearance_m, p_line, composite_modulus_pa, n_strips=101
    )
    if not sol.converged or abs(sol.half_width_m - b_johnson) > max(2 * sol.dx_m, 0.05 * b_johnson):
        warnings.append(
            f"weight {weight_kg:g} kg: the smooth elastic contact of the conformal gap (half-width "
            f"{sol.half_width_m:.3g} m, {sol.status}) departs from Johnson's line contact (b = {b_johnson:.3g} m): "
            "the roughness parameter is only indicative"
        )
    return {
        "weight_kg": weight_kg,
        "johnson_half_width_m": b_johnson,
        "johnson_peak_pressure_pa": p0,
        "solver_half_width_m": float(sol.half_width_m),
        "solver_peak_pressure_pa": sol.peak_pressure_pa,
        "solver_strip_m": sol.dx_m,
        "status": sol.status,
    }
