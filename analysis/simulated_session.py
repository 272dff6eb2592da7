"""Simulated sessions (``contactrig acquire --sim``): the instrument pair's simulated bench with the rig behind it.

For block b (repeat k at weight W_i) the bench's sample resistance is the resistance model of the design and of the
physical fit (:func:`analysis.resistance_model.bench_resistance_ohm`), the contact re-made with a factor f_b::

    R_b = R_s + f_b · (σ_f / A(W) + R_Barber(W) + R_macro(W)),      σ_f = ζ·h_R

(:class:`analysis.circuit.CircuitSettings`: ζ, h_R and R_s from the scene's ``[circuit]``), with A(W) and the
clean-metal terms those of :func:`analysis.resistance_model.specimen_resistance_terms` — the function the physical
conversion (``fit --conversion physical``) subtracts — for the one model ``[session].sim_model`` (the rig, or the
press of a press scene). A scene without both bodies' resistivities has no clean-metal terms (film and series only,
said in the session's notes).

Why f_b: on the real bench the contact is made again for every repeat (the weight is lifted and re-placed, the
piston re-seats, oxide and contamination films differ), so repeats scatter far more than the instrument noise, and
Tab. 1's fits are over-dispersed (χ²/ν = 3 for its independent series M1–M3). f_b follows the noise model of
:mod:`analysis.noise_model` — the one ``contactrig design`` uses — chosen by ``[session].sim_noise``:

* ``"tab1"`` (default): ln f_ik = a_k + b_i + e_ik, a per-series offset (SD 9.6 %), a per-weight lack of fit common
  to every series (14.5 %) and per-weight re-seating (13.2 %), estimated from Tab. 1 (:func:`analysis.noise_model.
  tab1_noise`). A session of r repeats then fits with E[χ²/ν] ≈ (σ_e² + r·σ_b²)/(σ_a² + σ_e²): 3.0 for r = 3, 5.4
  for r = 6, as on the real rig;
* ``"iid"``: independent re-seating of SD ``[session].sim_repeat_sd`` (0 switches it off; χ²/ν ≈ 1).

f is log-normal (a resistance factor, always > 0) with mean 1, so E[R_b] = R_s + σ_f/A + R_clean. The series
resistance (leads, bodies) is not re-made and stays fixed. A block repeated at the present seating (an adaptive
session's "repeat", :class:`daq.plan.Measure`'s ``seating_block``) keeps that seating's factor: only the instruments'
noise differs. The factors are drawn from their own generator seeded by ``[session].sim_seed``, for the whole plan
at once (weights × repeats, in block order), so a resumed or partly skipped session gets the same factor for the
same block; they are recorded with the noise model's parameters in the start record's ``simulation``. Noise, thermal
EMF and drift come from the simulated instruments. Only the requested model is built.

:class:`SimulatedRigBench` is the :class:`daq.link.Bench` that ``daq.acquire.acquire`` runs ``--sim`` sessions on
(this composition lives here, above ``daq``, because it needs the rig and the circuit). Replay serves the
recorded instrument replies, so it reproduces a simulated session exactly whatever f_b was.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from analysis.noise_model import NoiseModel, noise_model
from contactrig.core.validation import SettingError
from daq.link import OpenedBench, open_visa_link
from daq.plan import SessionPlan
from instruments.transport import TERMINATORS

__all__ = [
    "DEFAULT_SIM_SPEED",
    "NOISE_SEED_RULE",
    "SimulatedRigBench",
    "repeat_factors",
    "run_noise_seed",
    "session_factors",
    "simulated_resistances",
]

#: Default ``--sim-speed``: the simulated instruments run this many times faster than real ones.
DEFAULT_SIM_SPEED = 1000.0
#: Second word of the seed of the re-seating factors' generator (the bench's noise uses ``sim_seed`` alone).
_FACTOR_STREAM = 0x5EA7


#: How a run's instrument-noise seed is derived (recorded in each run's start record beside the seed).
NOISE_SEED_RULE = "numpy SeedSequence(entropy=sim_seed, spawn_key=(run,)).generate_state(1)[0] (uint32)"


def run_noise_seed(sim_seed: int, run: int) -> int:
    """The seed of the simulated instruments' noise in run ``run`` of a session with ``sim_seed``: the ``run``-th
    child of ``SeedSequence(sim_seed)`` (what ``SeedSequence(sim_seed).spawn(run + 1)[run]`` gives), as one
    32-bit integer (:data:`NOISE_SEED_RULE`; exact in JSON and JavaScript). Independent streams per run; the same
    (seed, run) always gives the same."""
    child = np.random.SeedSequence(int(sim_seed), spawn_key=(int(run),))
    return int(child.generate_state(1)[0])


def session_factors(noise: NoiseModel, n_weights: int, repeats: int, seed: int) -> np.ndarray:
    """The contact factors f_b of one session, blocks 0 … n_weights·repeats − 1 in plan order (weight index ×
    repeats + repeat − 1) [-]: ``noise.factors`` for one session, seeded by ``seed`` on a stream of its own."""
    rng = np.random.default_rng([int(seed), _FACTOR_STREAM])
    return noise.factors(rng, (1, n_weights, repeats)).reshape(-1)


def repeat_factors(n_blocks: int, sd: float, seed: int) -> np.ndarray:
    """Independent mean-one log-normal factors f_b = exp(σ·z_b − σ²/2) for blocks 0 … n_blocks − 1 (σ = ``sd``, the
    SD of ln f): :func:`session_factors` of ``NoiseModel.iid(sd)``; factor b depends only on (seed, b)."""
    return session_factors(NoiseModel.iid(sd), n_blocks, 1, seed)


def simulated_resistances(plan: SessionPlan, terms: Any = None) -> dict[str, Any]:
    """Contact area (m²) per weight and bench resistance (Ω) per planned block, for ``[session].sim_model``.

    Per weight: ``contact_area_m2``, ``film_resistance_ohm`` σ_f/A, ``clean_terms_ohm`` (Barber, macro) and
    ``resistance_ohm`` (R_s + σ_f/A + R_clean, the expected value). Per block (position in the plan):
    ``contact_factor`` f_b and ``block_resistance_ohm`` R_b; ``noise`` the noise model's parameters. Recorded as the
    start record's ``simulation``. ``terms``: the model's :class:`analysis.resistance_model.SpecimenTerms` at the
    plan's weights when already computed (many seeds of one plan; the rig's warnings are then not collected).
    """
    from analysis.circuit import CircuitSettings
    from analysis.resistance_model import bench_resistance_ohm, specimen_resistance_terms
    from sims.config import SimConfig
    from sims.specimen import sweep_specimen

    model = plan.session.sim_model
    weights = list(plan.session.weights_kg)
    config = SimConfig.from_scene(plan.scene)
    from sims.database import build_database

    notes: list[str] = []
    if terms is None:
        laws = build_database(config, models=[model])
        notes = list(sweep_specimen(config, models=[model], weights_kg=weights, database=laws).warnings)
        terms = specimen_resistance_terms(config, [model], weights, laws=laws, require=False)[model]
    area = np.asarray(terms.area_m2, dtype=float)
    if area.shape != (len(weights),) or not np.all(np.isfinite(area)) or np.any(area <= 0):
        raise RuntimeError(
            f"the specimen simulation gave no positive contact area for every weight with model {model!r} "
            f"(areas {area.tolist()} m²): the simulated bench cannot compute R = R_s + σ_f/A"
        )
    circuit = CircuitSettings.from_scene(plan.scene)
    film = circuit.resistivity_ohm_m * circuit.contact_height_m  # σ_f = ζh [Ω·m²], seed eq. 23 read as a film
    noise = noise_model(plan.session.sim_noise, plan.session.sim_repeat_sd)
    factors = session_factors(noise, len(weights), plan.session.repeats, plan.session.sim_seed)
    blocks = bench_resistance_ohm(
        circuit.series_resistance_ohm, film, area, terms.clean_ohm, factors.reshape(len(weights), -1)
    ).reshape(-1)
    if not terms.terms:
        notes.append("no clean-metal terms (the scene gives no resistivities): R = R_s + σ_f/A only")
    return {
        "model": model,
        "weights_kg": weights,
        "contact_area_m2": area.tolist(),
        "film_resistance_ohm": (film / area).tolist(),
        "contact_resistance_ohm": (film / area + terms.clean_ohm).tolist(),
        "clean_terms_ohm": {k: np.asarray(v, dtype=float).tolist() for k, v in terms.terms.items()},
        "resistance_ohm": (circuit.series_resistance_ohm + film / area + terms.clean_ohm).tolist(),
        "noise": {"name": plan.session.sim_noise, **noise.as_dict()},
        "repeat_sd": plan.session.sim_repeat_sd,
        "contact_factor": factors.tolist(),
        "block_resistance_ohm": blocks.tolist(),
        "circuit": {
            "resistivity_ohm_m": circuit.resistivity_ohm_m,
            "contact_height_m": circuit.contact_height_m,
            "film_ohm_m2": film,
            "series_resistance_ohm": circuit.series_resistance_ohm,
        },
        "rig_warnings": notes,
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

    def open(self, plan: SessionPlan, *, run: int = 0) -> OpenedBench:
        """Simulate the rig for the plan's weights, build the simulated pair and open the plan's address on it (any
        valid VISA resource name: the simulated pair answers there). The instruments' noise of run ``run`` (0 =
        the first, 1 = the first ``--resume`` …) is drawn from a stream of its own, :func:`run_noise_seed`, so a
        resumed session never repeats an earlier run's noise; the seed is recorded (``simulation.noise_seed``)."""
        info = simulated_resistances(plan)
        by_block = info["block_resistance_ohm"]
        noise_seed = run_noise_seed(plan.session.sim_seed, run)
        sim = plan.pair.simulate(resistance_ohm=by_block[0], seed=noise_seed, time_scale=self.time_scale)

        def prepare(block: int) -> None:  # the contact of this block's seating (the engine passes its first block)
            sim.bench.resistance_ohm = by_block[block]

        sim.bench.any_address = True  # rehearsed at the address the real bench will use
        sim.bench.serial_terminator = TERMINATORS[plan.instrument.terminator]  # used at an ASRL address only
        link = open_visa_link(
            plan.instrument.address, plan.instrument.timeout_ms, sim.resource_manager, pair=plan.pair,
            prepare_block=prepare, serial=plan.instrument.serial,
        )  # fmt: skip
        record = {**info, "sim_speed": float(self.sim_speed), "time_scale": self.time_scale}
        record["seed"] = plan.session.sim_seed
        record["run"] = int(run)
        record["noise_seed"] = noise_seed
        record["noise_seed_rule"] = NOISE_SEED_RULE
        notes = tuple(f"rig simulation: {w}" for w in info["rig_warnings"])
        return OpenedBench(link, simulation=record, notes=notes)
