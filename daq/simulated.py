"""Simulated sessions (``--sim``): the simulated 6221/2182A bench with the rig simulation behind it.

At weight W the bench's sample resistance is the measured resistance of seed eq. 23 with a series term,

    R(W) = R_s + ζ · h_R / A(W)

(``analysis.circuit.CircuitSettings.measured_resistance_ohm``: ζ, h_R and R_s from the scene's ``[circuit]``),
with A(W) the real contact area the rig simulation (``sims.rig.sweep``) finds at that weight for the one model
``[session].sim_model``. Noise, thermal EMF and drift come from the simulated 2182A, so a simulated session looks
like the seed paper's Tab. 1: mΩ values falling with weight. Only the requested model is built.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from daq.link import InstrumentLink, open_visa_link
from daq.plan import SessionPlan

__all__ = ["open_sim_link", "simulated_resistances"]


def simulated_resistances(plan: SessionPlan) -> dict[str, Any]:
    """Contact area (m²) and bench resistance (Ω) at each of the plan's weights, for ``[session].sim_model``."""
    from analysis.circuit import CircuitSettings
    from sims.rig import sweep

    model = plan.session.sim_model
    weights = list(plan.session.weights_kg)
    result = sweep(plan.scene, models=[model], weights_kg=weights)
    curve = result.models[model]
    area = np.asarray(curve.contact_area_m2, dtype=float)
    if area.shape != (len(weights),) or not np.all(np.isfinite(area)) or np.any(area <= 0):
        raise RuntimeError(
            f"the rig simulation gave no positive contact area for every weight with model {model!r} "
            f"(areas {area.tolist()} m²): the simulated bench cannot compute R = R_s + ζh/A"
        )
    circuit = CircuitSettings.from_scene(plan.scene)
    resistance = np.asarray(circuit.measured_resistance_ohm(area), dtype=float)
    return {
        "model": model,
        "weights_kg": weights,
        "contact_area_m2": area.tolist(),
        "resistance_ohm": resistance.tolist(),
        "circuit": {
            "resistivity_ohm_m": circuit.resistivity_ohm_m,
            "contact_height_m": circuit.contact_height_m,
            "series_resistance_ohm": circuit.series_resistance_ohm,
        },
        "rig_warnings": list(getattr(result, "warnings", [])),
    }


def open_sim_link(
    plan: SessionPlan, *, sim_speed: float = 1000.0, link_wrapper: Any = None, bench: Any = None
) -> tuple[InstrumentLink, dict[str, Any]]:
    """An :class:`InstrumentLink` to a simulated bench whose resistance follows the weight the operator places.

    ``sim_speed``: instrument time runs this many times faster than real time (1 = real pace; ``inf`` = instant).
    Returns the link and the simulation details recorded in the start record.
    """
    from instruments.simulated import SimulatedBench, simulated_resource_manager

    info = simulated_resistances(plan)
    by_weight = dict(zip(info["weights_kg"], info["resistance_ohm"], strict=True))
    time_scale = 0.0 if math.isinf(sim_speed) else 1.0 / float(sim_speed)
    if bench is None:
        bench = SimulatedBench(
            resistance_ohm=info["resistance_ohm"][0], seed=plan.session.sim_seed, time_scale=time_scale
        )
    else:
        bench.resistance_ohm = info["resistance_ohm"][0]

    def place(weight_kg: float) -> None:
        bench.resistance_ohm = by_weight[weight_kg]

    rm = simulated_resource_manager(bench=bench)
    link = open_visa_link(plan.instrument.address, plan.instrument.timeout_ms, rm, place_weight=place)
    if link_wrapper is not None:
        link = InstrumentLink(link_wrapper(link.recorder.inner), address=link.address, place_weight=place)
    info = {**info, "sim_speed": float(sim_speed), "time_scale": time_scale, "seed": plan.session.sim_seed}
    link.bench = bench  # type: ignore[attr-defined]  # tests inject faults through it
    return link, info
