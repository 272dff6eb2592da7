"""Simulated sessions (``--sim``): the simulated 6221/2182A bench with the rig simulation behind it.

For block b (repeat k at weight W) the bench's sample resistance is the measured resistance of seed eq. 23 with a
series term, and a re-seating factor on the contact term,

    R_b = R_s + f_b · ζ · h_R / A(W),     f_b = exp(σ·z_b − σ²/2),  z_b ~ N(0, 1)

(``analysis.circuit.CircuitSettings``: ζ, h_R and R_s from the scene's ``[circuit]``), with A(W) the real contact
area the rig simulation (``sims.rig.sweep``) finds at that weight for the one model ``[session].sim_model``.

Why f_b: on the real bench the contact is made again for every repeat (the weight is lifted and re-placed, the
piston re-seats, oxide and contamination films differ), so repeats at one weight scatter far more than the
instrument noise — the seed paper's Tab. 1 repeats M1–M3 scatter by 15–16 % (relative SD at each weight: mean
0.156, median 0.148; pooled SD of ln R 0.163). The series resistance (leads, bodies) is not re-made and stays
fixed. f_b is log-normal (a resistance factor, always > 0) with mean 1, so E[R_b] = R_s + ζh/A(W) and a fit
of the session recovers ζ without bias; σ = ``[session].sim_repeat_sd`` (0 switches it off). The factors are drawn
from their own generator seeded by ``[session].sim_seed`` and indexed by block number (position in the full plan),
so a resumed or partly skipped session gets the same factor for the same block. Noise, thermal EMF and drift
come from the simulated 2182A. Only the requested model is built.

Replay serves the recorded instrument replies, so it reproduces a simulated session exactly whatever f_b was.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from daq.link import InstrumentLink, open_visa_link
from daq.plan import SessionPlan

__all__ = ["open_sim_link", "repeat_factors", "simulated_resistances"]

#: Second word of the seed of the re-seating factors' generator (the bench's noise uses ``sim_seed`` alone).
_FACTOR_STREAM = 0x5EA7


def repeat_factors(n_blocks: int, sd: float, seed: int) -> np.ndarray:
    """Mean-one log-normal contact factors f_b = exp(σ·z_b − σ²/2) for blocks 0 … n_blocks − 1 (σ = ``sd``).

    ``sd`` is the SD of ln f (for small σ, the relative SD of f). Seeded by ``seed`` on a stream of its own, and
    drawn in block order, so factor b depends only on (seed, b) and not on which blocks are measured.
    """
    if sd == 0:
        return np.ones(n_blocks)
    z = np.random.default_rng([int(seed), _FACTOR_STREAM]).standard_normal(n_blocks)
    return np.exp(sd * z - 0.5 * sd * sd)


def simulated_resistances(plan: SessionPlan) -> dict[str, Any]:
    """Contact area (m²) per weight and bench resistance (Ω) per planned block, for ``[session].sim_model``.

    Per weight: ``contact_area_m2``, ``contact_resistance_ohm`` (ζh/A) and ``resistance_ohm`` (R_s + ζh/A, the
    expected value). Per block (position in the plan): ``contact_factor`` f_b and ``block_resistance_ohm`` R_b.
    """
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
    contact = np.asarray(circuit.contact_resistance_ohm(area), dtype=float)
    sd = plan.session.sim_repeat_sd
    factors = repeat_factors(plan.blocks_planned, sd, plan.session.sim_seed)
    per_block_contact = np.repeat(contact, plan.session.repeats)
    return {
        "model": model,
        "weights_kg": weights,
        "contact_area_m2": area.tolist(),
        "contact_resistance_ohm": contact.tolist(),
        "resistance_ohm": (circuit.series_resistance_ohm + contact).tolist(),
        "repeat_sd": sd,
        "contact_factor": factors.tolist(),
        "block_resistance_ohm": (circuit.series_resistance_ohm + factors * per_block_contact).tolist(),
        "circuit": {
            "resistivity_ohm_m": circuit.resistivity_ohm_m,
            "contact_height_m": circuit.contact_height_m,
            "series_resistance_ohm": circuit.series_resistance_ohm,
        },
        "rig_warnings": list(getattr(result, "warnings", [])),
    }


def open_sim_link(
    plan: SessionPlan, *, sim_speed: float = 1000.0, link_wrapper: Any = None
) -> tuple[InstrumentLink, dict[str, Any]]:
    """An :class:`InstrumentLink` to a simulated bench whose resistance follows the weight and the repeat.

    ``sim_speed``: instrument time runs this many times faster than real time (1 = real pace; ``inf`` = instant).
    ``link_wrapper(transport) -> transport`` wraps the VISA transport (fault injection in tests).
    Returns the link and the simulation details recorded in the start record.
    """
    from instruments.simulated import SimulatedBench, simulated_resource_manager

    info = simulated_resistances(plan)
    by_block = info["block_resistance_ohm"]
    time_scale = 0.0 if math.isinf(sim_speed) else 1.0 / float(sim_speed)
    bench = SimulatedBench(resistance_ohm=by_block[0], seed=plan.session.sim_seed, time_scale=time_scale)

    def prepare(block: int) -> None:  # the contact as it was made for this repeat
        bench.resistance_ohm = by_block[block]

    rm = simulated_resource_manager(bench=bench)
    link = open_visa_link(plan.instrument.address, plan.instrument.timeout_ms, rm, prepare_block=prepare)
    if link_wrapper is not None:
        link = InstrumentLink(link_wrapper(link.recorder.inner), address=link.address, prepare_block=prepare)
    info = {**info, "sim_speed": float(sim_speed), "time_scale": time_scale, "seed": plan.session.sim_seed}
    link.bench = bench  # type: ignore[attr-defined]  # tests inject faults through it
    return link, info
