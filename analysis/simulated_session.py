"""Simulated sessions (``contactrig acquire --sim``): the instrument pair's simulated bench with the rig behind it.

For block b (repeat k at weight W) the bench's sample resistance is the measured resistance of seed eq. 23 with a
series term, and a re-seating factor on the contact term,

    R_b = R_s + f_b · ζ · h_R / A(W),     f_b = exp(σ·z_b − σ²/2),  z_b ~ N(0, 1)

(:class:`analysis.circuit.CircuitSettings`: ζ, h_R and R_s from the scene's ``[circuit]``), with A(W) the real
contact area the specimen simulation (:func:`sims.specimen.sweep_specimen`: the rig, or the press of a press scene)
finds at that weight for the one model ``[session].sim_model``.

Why f_b: on the real bench the contact is made again for every repeat (the weight is lifted and re-placed, the
piston re-seats, oxide and contamination films differ), so repeats at one weight scatter far more than the
instrument noise — the seed paper's Tab. 1 repeats M1–M3 scatter by 15–16 % (relative SD at each weight: mean
0.156, median 0.148; pooled SD of ln R 0.163). The series resistance (leads, bodies) is not re-made and stays
fixed. f_b is log-normal (a resistance factor, always > 0) with mean 1, so E[R_b] = R_s + ζh/A(W) and a fit
of the session recovers ζ without bias; σ = ``[session].sim_repeat_sd`` (0 switches it off). The factors are drawn
from their own generator seeded by ``[session].sim_seed`` and indexed by block number (position in the full plan),
so a resumed or partly skipped session gets the same factor for the same block. Noise, thermal EMF and drift
come from the simulated instruments. Only the requested model is built.

:class:`SimulatedRigBench` is the :class:`daq.link.Bench` that ``daq.acquire.acquire`` runs ``--sim`` sessions on
(this composition lives here, above ``daq``, because it needs the rig and the circuit). Replay serves the
recorded instrument replies, so it reproduces a simulated session exactly whatever f_b was.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from contactrig.core.validation import SettingError
from daq.link import OpenedBench, open_visa_link
from daq.plan import SessionPlan

__all__ = ["DEFAULT_SIM_SPEED", "SimulatedRigBench", "repeat_factors", "simulated_resistances"]

#: Default ``--sim-speed``: the simulated instruments run this many times faster than real ones.
DEFAULT_SIM_SPEED = 1000.0
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

    Per weight: ``contact_area_m2``, ``contact_resistance_ohm`` (ζh/A, seed eq. 23) and ``resistance_ohm``
    (R_s + ζh/A, the expected value). Per block (position in the plan): ``contact_factor`` f_b and
    ``block_resistance_ohm`` R_b. Recorded as the start record's ``simulation``.
    """
    from analysis.circuit import CircuitSettings
    from sims.config import SimConfig
    from sims.specimen import sweep_specimen

    model = plan.session.sim_model
    weights = list(plan.session.weights_kg)
    result = sweep_specimen(SimConfig.from_scene(plan.scene), models=[model], weights_kg=weights)
    area = np.asarray(result.models[model].contact_area_m2, dtype=float)
    if area.shape != (len(weights),) or not np.all(np.isfinite(area)) or np.any(area <= 0):
        raise RuntimeError(
            f"the specimen simulation gave no positive contact area for every weight with model {model!r} "
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
        "resistance_ohm": np.asarray(circuit.measured_resistance_ohm(area), dtype=float).tolist(),
        "repeat_sd": sd,
        "contact_factor": factors.tolist(),
        "block_resistance_ohm": (circuit.series_resistance_ohm + factors * per_block_contact).tolist(),
        "circuit": {
            "resistivity_ohm_m": circuit.resistivity_ohm_m,
            "contact_height_m": circuit.contact_height_m,
            "series_resistance_ohm": circuit.series_resistance_ohm,
        },
        "rig_warnings": list(result.warnings),
    }


@dataclass(frozen=True)
class SimulatedRigBench:
    """The ``--sim`` bench (a :class:`daq.link.Bench`): the plan's instrument pair simulated, its sample resistance
    set before every block to R_b of :func:`simulated_resistances`.

    ``sim_speed``: instrument time runs this many times faster than real time (1 = real pace; ``inf`` = instant).
    """

    sim_speed: float = DEFAULT_SIM_SPEED

    def __post_init__(self) -> None:
        if not (self.sim_speed > 0):  # NaN fails too
            raise SettingError("--sim-speed", self.sim_speed, "expected a number > 0 (1 = real pace, inf)")

    @property
    def simulated(self) -> bool:
        return True

    @property
    def time_scale(self) -> float:
        """Real seconds per instrument second."""
        return 0.0 if math.isinf(self.sim_speed) else 1.0 / float(self.sim_speed)

    def check(self, plan: SessionPlan) -> None:
        """What the simulation will need, checked before ``acquire`` prints the plan or makes a file: the scene's
        simulation and circuit tables, and the memory of the sweep (``sims.budget``; ``--max-memory``)."""
        from analysis.circuit import CircuitSettings
        from sims.budget import check_specimen
        from sims.config import SimConfig

        config = SimConfig.from_scene(plan.scene)
        CircuitSettings.from_scene(plan.scene)
        check_specimen(config, [plan.session.sim_model], list(plan.session.weights_kg))

    def open(self, plan: SessionPlan) -> OpenedBench:
        """Simulate the rig for the plan's weights, build the simulated pair and open the plan's address on it."""
        info = simulated_resistances(plan)
        by_block = info["block_resistance_ohm"]
        sim = plan.pair.simulate(resistance_ohm=by_block[0], seed=plan.session.sim_seed, time_scale=self.time_scale)

        def prepare(block: int) -> None:  # the contact as it was made for this repeat
            sim.bench.resistance_ohm = by_block[block]

        link = open_visa_link(
            plan.instrument.address, plan.instrument.timeout_ms, sim.resource_manager, pair=plan.pair,
            prepare_block=prepare,
        )  # fmt: skip
        record = {**info, "sim_speed": float(self.sim_speed), "time_scale": self.time_scale}
        record["seed"] = plan.session.sim_seed
        notes = tuple(f"rig simulation: {w}" for w in info["rig_warnings"])
        return OpenedBench(link, simulation=record, notes=notes)
