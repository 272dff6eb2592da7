"""The second specimen geometry: a rough sphere pressed onto a rough flat in a press, with bulk elasticity.

Greenwood & Tripp (1967) / Johnson *Contact Mechanics* §13.5: the asperity law of the scene's surface pair (the
contact database, :mod:`sims.database`: nominal pressure P(h) [Pa] and real-area fraction a(h) against mean-plane
separation h [m]) is a nonlinear layer between a sphere of radius R [m] and a flat; the bodies deform as elastic
half-spaces of composite modulus E* (seed eq. 4). Rings ``[s−, s+]`` of uniform pressure over the nominal contact,
influence coefficients from Johnson eq. 3.39 (:func:`sims.rig.elastic.axisymmetric_influence`), the rigid gap
``r²/(2R)``, and the load balance ``Σ p_i π(s+² − s−²) = W``; solved by :func:`sims.rig.elastic.solve_layer`
(Newton, SciPy-style diagnostics). Real area ``A = Σ a(h_i) π(s+² − s−²)`` [m²], interfacial stiffness
``K = Σ −P′(h_i) π(s+² − s−²)`` [N/m] (Barber's resistance, :mod:`analysis.resistance_model`).

As the load grows the asperities go from elastic to fully plastic (the plastic asperity models then part from the
elastic ones); the bulk is elastic: a warning is kept when the nominal peak pressure exceeds 1.6 × the softer body's
yield strength (Johnson §6.2: first yield below the surface of a Hertz contact at p0 ≈ 1.6 Y).

Scene table ``[press]`` (a scene with it is a press scene; ``[rig]`` is then unused):

==================  ==============================================================================================
``sphere_radius_m`` radius R of the sphere, (0, 10] m
``weights_kg``      loads of the sweep as masses on the press (kg), each in (0, 1e6]; W = weight·g
``n_rings``         rings over the nominal contact, 20 … 5000 (default 60)
==================  ==============================================================================================

Physics only: returns :class:`sims.rig.sweep.SweepResult` (``contact_width_m`` is the nominal contact diameter), so
files, fits and figures take a press sweep like a rig sweep.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from contactrig.core.provenance import software_version
from contactrig.core.validation import SettingError, check_int, check_keys, check_range
from sims.budget import check_specimen
from sims.rig.elastic import LayerSolution, axisymmetric_influence, solve_layer
from sims.rig.settings import STANDARD_GRAVITY, check_weights
from sims.rig.sweep import ModelSweep, SweepResult

__all__ = ["PressContact", "PressSettings", "press_equilibrium", "press_sweep"]

#: Johnson §6.2: first yield of a Hertz contact at p0 ≈ 1.6 Y.
YIELD_FACTOR = 1.6


@dataclass(frozen=True)
class PressSettings:
    """The ``[press]`` table: sphere radius [m], load sweep [kg], rings; validated on construction."""

    sphere_radius_m: float = 0.05
    weights_kg: tuple[float, ...] = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0)
    n_rings: int = 60

    def __post_init__(self) -> None:
        r = check_range("press.sphere_radius_m", self.sphere_radius_m, 0.0, 10.0, lo_open=True, unit="m")
        object.__setattr__(self, "sphere_radius_m", r)
        w = check_weights(self.weights_kg, "press.weights_kg")
        if min(w) <= 0:
            raise SettingError("press.weights_kg", list(w), "expected weights > 0 kg")
        object.__setattr__(self, "weights_kg", w)
        object.__setattr__(self, "n_rings", check_int("press.n_rings", self.n_rings, 20, 5000))

    def load_n(self, weight_kg: float) -> float:
        """W = weight·g [N]."""
        return weight_kg * STANDARD_GRAVITY

    @classmethod
    def from_table(cls, table: Mapping[str, Any]) -> PressSettings:
        """From a ``[press]`` table; unknown keys are errors naming the key."""
        if not isinstance(table, Mapping):
            raise SettingError("press", table, "expected a TOML table")
        check_keys("press", table, [f.name for f in fields(cls)])
        return cls(**dict(table))

    @classmethod
    def from_scene(cls, scene: Any) -> PressSettings | None:
        """The scene's ``[press]`` table, or None when the scene has none (a rig scene)."""
        data = getattr(scene, "data", {})
        if "press" not in data:
            return None
        return cls.from_table(data["press"])

    def as_dict(self) -> dict[str, Any]:
        """Plain values for provenance."""
        return {"sphere_radius_m": self.sphere_radius_m, "weights_kg": list(self.weights_kg), "n_rings": self.n_rings}


@dataclass(frozen=True)
class PressContact:
    """One load of the press: ``load_n`` [N], ``contact_area_m2`` real area [m²], ``nominal_radius_m`` radius of
    the loaded rings [m], ``peak_pressure_pa`` [Pa], ``stiffness_n_per_m`` K [N/m], ``solution`` the layer solve."""

    weight_kg: float
    load_n: float
    contact_area_m2: float
    nominal_radius_m: float
    peak_pressure_pa: float
    stiffness_n_per_m: float
    solution: LayerSolution = field(repr=False)


def _extent(law: Any, radius: float, load: float, modulus: float) -> float:
    """A first domain radius [m]: 1.5× the larger of Hertz's a and the rigid onset radius √(2R (h_max − h_min))."""
    a_hertz = (3.0 * load * radius / (4.0 * modulus)) ** (1.0 / 3.0)
    span = float(law.h_max) - float(law.h_min)
    return 1.5 * max(a_hertz, math.sqrt(2.0 * radius * span))


def press_equilibrium(law: Any, settings: PressSettings, weight_kg: float, composite_modulus_pa: float) -> PressContact:
    """Rough sphere on a rough flat under ``weight_kg`` [kg], bulk elastic (module docstring); E* [Pa]."""
    radius = settings.sphere_radius_m
    load = settings.load_n(weight_kg)
    extent = _extent(law, radius, load, composite_modulus_pa)
    for _ in range(8):  # widen until the outermost ring carries (almost) nothing
        edges = np.linspace(0.0, extent, settings.n_rings + 1)
        r = 0.5 * (edges[1:] + edges[:-1])
        ring = math.pi * np.diff(edges**2)
        sol = solve_layer(law, r * r / (2 * radius), axisymmetric_influence(edges, composite_modulus_pa), ring, load)
        p = sol.pressure_pa
        if p[-1] <= 1e-6 * p.max():
            break
        extent *= 2.0
    loaded = p > (0.0 if float(p.min()) == 0.0 else 1e-6 * float(p.max()))
    return PressContact(
        weight_kg=float(weight_kg),
        load_n=load,
        contact_area_m2=float(np.sum(sol.area_fraction * ring)),
        nominal_radius_m=float(edges[1:][loaded].max()) if loaded.any() else 0.0,
        peak_pressure_pa=float(p.max()),
        stiffness_n_per_m=float(np.sum(sol.stiffness_pa_per_m * ring)),
        solution=sol,
    )


def press_sweep(
    config: Any,
    settings: PressSettings,
    models: Sequence[str] | None = None,
    weights_kg: Sequence[float] | None = None,
    *,
    laws: Mapping[str, Any] | None = None,
) -> SweepResult:
    """A(W) of the press for every model (the press's :func:`sims.rig.sweep`): a :class:`SweepResult`.

    ``config`` a :class:`sims.config.SimConfig` (materials, surfaces, database); ``laws`` prebuilt contact laws
    (else the database is built for ``models``). ``provenance["press"]`` holds the settings, the stiffness K(W)
    [N/m] per model and the solver diagnostics.
    """
    weights = check_weights(weights_kg, "weights_kg") if weights_kg is not None else settings.weights_kg
    check_specimen(config.with_changes(press=settings), models, weights, build_database=laws is None)
    if laws is None:
        from sims.database import build_database

        db = build_database(config, models=None if models is None else list(models))
        names = list(models) if models is not None else list(config.database.models)
        laws = {n: db[n] for n in names}
    names = list(models) if models is not None else list(laws)
    modulus = float(config.materials.E_star)
    yield_pa = float(config.materials.softer.yield_strength_pa)
    out: dict[str, ModelSweep] = {}
    record: dict[str, Any] = {}
    warnings: list[str] = []
    for name in names:
        rows = [press_equilibrium(laws[name], settings, w, modulus) for w in weights]
        out[name] = ModelSweep(
            name=name,
            weight_kg=np.asarray(weights, dtype=float),
            contact_area_m2=np.array([c.contact_area_m2 for c in rows]),
            min_separation_m=np.array([float(c.solution.gap_m.min()) for c in rows]),
            force_n=np.array([c.solution.load_n for c in rows]),
            peak_pressure_pa=np.array([c.peak_pressure_pa for c in rows]),
            contact_width_m=np.array([2.0 * c.nominal_radius_m for c in rows]),
            n_nodes=np.full(len(rows), settings.n_rings, dtype=int),
            converged=np.array([c.solution.success for c in rows]),
        )
        record[name] = {
            "stiffness_n_per_m": [c.stiffness_n_per_m for c in rows],
            "nit": [c.solution.nit for c in rows],
            "messages": [c.solution.message for c in rows],
        }
        for c in rows:
            if c.peak_pressure_pa > YIELD_FACTOR * yield_pa:
                warnings.append(
                    f"{name}: weight {c.weight_kg:g} kg: nominal peak pressure {c.peak_pressure_pa:.3g} Pa exceeds "
                    f"1.6 × the yield strength ({YIELD_FACTOR * yield_pa:.3g} Pa): the bulk yields (not modelled)"
                )
    provenance = {
        "software_version": software_version(),
        **config.provenance(),
        "geometry": "press: rough sphere on rough flat, bulk elastic",
        "press": {**settings.as_dict(), "models": record},
        "weights_kg": list(weights),
        "gravity_m_per_s2": STANDARD_GRAVITY,
    }
    return SweepResult(models=out, warnings=warnings, provenance=provenance)
