"""The session plan: what to measure, from the scene's ``[instrument]``, the pair's settings table (``[delta]``)
and ``[session]``.

A plan is data (a frozen dataclass, validated on construction) plus :func:`session_steps`, a pure generator of the
steps the acquisition engine carries out — ask the operator to place a weight, then run its blocks — so
a plan can be inspected and tested without any instrument (after Bluesky's plans).

Scene keys (SI units; every key validated, unknown keys are errors naming the key):

``[instrument]``
    ``address``     VISA resource of the instrument the PC talks to (e.g. the 6221's ``GPIB0::12::INSTR``,
                    ``TCPIP0::<ip>::1394::SOCKET``)
    ``visa_library``  VISA library to open it with (e.g. ``"@py"`` for pyvisa-py; default ``""``: the system's)
    ``timeout_ms``  VISA I/O timeout, 100 … 600 000 ms (over RS-232 raised if the baud rate needs it)
    ``pair``        the instrument pair (:mod:`instruments.pairs`; default ``"k6221_2182a"``, the Keithley 6221
                    with a 2182A in Delta mode)
    RS-232 only (``ASRL…::INSTR`` addresses; they must match the 6221's front-panel settings):
    ``baud_rate``   300, 600, 1200, 2400, 4800, 9600, 19200 (default), 38400, 57600 or 115200
    ``flow_control``  ``"none"`` (default) or ``"xon_xoff"``
    ``terminator``  the 6221's RS-232 terminator: ``"LF"`` (default), ``"CR"``, ``"CRLF"`` or ``"LFCR"``
    ``data_bits``   8 (default) or 7;  ``parity``  ``"none"`` (default), ``"odd"`` or ``"even"``
    Buffer reads are chunked so that each reply takes at most a quarter of the timeout at the baud rate
    (:meth:`instruments.transport.SerialSettings.chunk_size`).
the pair's settings table — ``[delta]`` for the Keithley pair
    validated by the pair (``instruments.delta.DeltaSettings``: ``high_a``, ``low_a``, ``delay_s``, ``count``,
    ``nplc``, ``unit``, ``compliance_v``, ``compliance_abort`` …); ``count`` = readings per block
``[session]``
    ``repeats``     blocks per weight, 1 … 1000
    ``weights_kg``  weights placed in the piston, in order (optional: default ``[press].weights_kg`` for a press
                    scene — one with a ``[press]`` table, :attr:`sims.config.SimConfig.press` —, else
                    ``[rig].weights_kg``), each in (0, 1000] kg
    ``operator``    who runs the session (empty: the login name is recorded)
    ``sample``      free-text sample description
    ``notes``       free-text notes on the session
    ``rig``         free-text rig description
    ``sim_model``   contact model whose simulated contact area drives ``--sim`` (one of ``[database].models``)
    ``sim_seed``    seed of the simulated bench's noise and re-seating factors (whole number ≥ 0; default 1)
    ``sim_noise``   ``--sim``: the noise model of the contact term (the mean-one log-normal factor f applied to
                    σ_f/A(W) + the clean-metal terms for each block), ``"tab1"`` (default: Tab. 1's structure —
                    per-series offset 9.6 %, per-weight re-seating 13.2 %, lack of fit common to every series
                    14.5 %, estimated from Tab. 1's independent series; a fit's χ²/ν ≈ 5 with six repeats, as on
                    the real rig) or ``"iid"`` (independent re-seating of SD ``sim_repeat_sd`` only; χ²/ν ≈ 1).
                    The same noise model as ``contactrig design`` (:mod:`analysis.noise_model`).
    ``sim_repeat_sd``  ``sim_noise = "iid"`` only: the SD of ln f (0 … 1; default 0.15, from the scatter of
                    Tab. 1's independent repeats M1–M3; 0 = instrument noise only). See
                    :mod:`analysis.simulated_session`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

from contactrig.core.scene import Scene
from contactrig.core.validation import SettingError, check_choice, check_int, check_keys, check_range
from instruments.pairs import DEFAULT_PAIR, InstrumentPair, get_pair
from instruments.transport import SerialSettings

__all__ = [
    "INSTRUMENT_KEYS",
    "SESSION_KEYS",
    "SIM_NOISE_KINDS",
    "DurationEstimate",
    "InstrumentSettings",
    "Measure",
    "PlaceWeight",
    "SessionPlan",
    "SessionSettings",
    "estimate_duration",
    "loading_order",
    "session_steps",
    "settings_from_record",
]

INSTRUMENT_KEYS = (
    *("address", "visa_library", "timeout_ms", "pair"),
    *("baud_rate", "flow_control", "terminator", "data_bits", "parity"),
)
SESSION_KEYS = (
    *("repeats", "weights_kg", "operator", "sample", "notes", "rig"),
    *("sim_model", "sim_seed", "sim_noise", "sim_repeat_sd"),
)
#: ``[session].sim_noise`` choices (the models of :data:`analysis.noise_model.NOISE_MODELS`; daq may not import it).
SIM_NOISE_KINDS = ("tab1", "iid")
#: Default ``[session].sim_repeat_sd``: Tab. 1's repeats M1–M3 scatter by 15–16 % at each weight
#: (analysis.simulated_session).
DEFAULT_SIM_REPEAT_SD = 0.15
MAX_WEIGHT_KG = 1000.0
#: Assumed instrument time per Delta conversion beyond delay and integration (trigger, A/D, the 6221 ↔ 2182A link):
#: an allowance for the duration estimate, not a measured value.
CONVERSION_OVERHEAD_S = 0.005
#: Time allowed per weight for the operator to place it (the duration estimate states it as such).
OPERATOR_ALLOWANCE_S = 60.0


def _check_str(field: str, value: Any, *, nonempty: bool = False) -> str:
    if not isinstance(value, str):
        raise SettingError(field, value, "expected a text string")
    if nonempty and not value.strip():
        raise SettingError(field, value, "expected a non-empty text string")
    return value


@dataclass(frozen=True)
class InstrumentSettings:
    """How to reach the instruments: VISA ``address`` (opened with ``visa_library``), I/O ``timeout_ms`` (ms),
    which registered ``pair``, and the RS-232 parameters (used with ``ASRL`` addresses only; see the module
    docstring)."""

    address: str = "GPIB0::12::INSTR"
    visa_library: str = ""
    timeout_ms: int = 5000
    pair: str = DEFAULT_PAIR
    baud_rate: int = 19200
    flow_control: str = "none"
    terminator: str = "LF"
    data_bits: int = 8
    parity: str = "none"

    def __post_init__(self) -> None:
        _check_str("instrument.address", self.address, nonempty=True)
        if "::" not in self.address:
            raise SettingError(
                "instrument.address", self.address, "expected a VISA resource such as 'GPIB0::12::INSTR'"
            )
        _check_str("instrument.visa_library", self.visa_library)
        object.__setattr__(self, "timeout_ms", check_int("instrument.timeout_ms", self.timeout_ms, 100, 600_000))
        get_pair(self.pair)  # an unknown pair is an error naming [instrument] pair and the registered ones
        self.serial  # noqa: B018 -- validates the RS-232 keys, errors naming [instrument] <key>

    @property
    def serial(self) -> SerialSettings:
        """The RS-232 parameters, validated."""
        return SerialSettings(
            baud_rate=self.baud_rate,
            flow_control=self.flow_control,
            terminator=self.terminator,
            data_bits=self.data_bits,
            parity=self.parity,
            prefix="instrument.",
        )

    @classmethod
    def from_table(cls, table: Mapping[str, Any]) -> InstrumentSettings:
        check_keys("instrument", table, INSTRUMENT_KEYS)
        return cls(**table)


@dataclass(frozen=True)
class SessionSettings:
    """The ``[session]`` table: repeats per weight, weights (kg) in order, who and what, simulated-bench options
    (``sim_model``, ``sim_seed``, ``sim_noise``, ``sim_repeat_sd``: see the module docstring)."""

    weights_kg: tuple[float, ...]
    repeats: int = 6
    operator: str = ""
    sample: str = ""
    notes: str = ""
    rig: str = ""
    sim_model: str = "greenwood_tripp"
    sim_seed: int = 1
    sim_noise: str = "tab1"
    sim_repeat_sd: float = DEFAULT_SIM_REPEAT_SD

    def __post_init__(self) -> None:
        object.__setattr__(self, "repeats", check_int("session.repeats", self.repeats, 1, 1000))
        if isinstance(self.weights_kg, (str, bytes)) or not hasattr(self.weights_kg, "__iter__"):
            raise SettingError("session.weights_kg", self.weights_kg, "expected a list of weights in kg")
        weights = tuple(
            check_range(f"session.weights_kg[{i}]", w, 0.0, MAX_WEIGHT_KG, lo_open=True, unit="kg")
            for i, w in enumerate(self.weights_kg)
        )
        if not weights:
            raise SettingError("session.weights_kg", list(self.weights_kg), "expected at least one weight")
        object.__setattr__(self, "weights_kg", weights)
        for name in ("operator", "sample", "notes", "rig"):
            _check_str(f"session.{name}", getattr(self, name))
        _check_str("session.sim_model", self.sim_model, nonempty=True)
        object.__setattr__(self, "sim_seed", check_int("session.sim_seed", self.sim_seed, 0, 2**63 - 1))
        check_choice("session.sim_noise", self.sim_noise, SIM_NOISE_KINDS)
        object.__setattr__(self, "sim_repeat_sd", check_range("session.sim_repeat_sd", self.sim_repeat_sd, 0.0, 1.0))


@dataclass(frozen=True)
class SessionPlan:
    """Everything a session needs, validated: instrument, the pair's block settings (``block_settings``, e.g. a
    :class:`~instruments.delta.DeltaSettings`), session settings and the scene itself."""

    instrument: InstrumentSettings
    block_settings: Any
    session: SessionSettings
    scene: Scene

    @property
    def pair(self) -> InstrumentPair:
        """The registered instrument pair that runs the blocks."""
        return get_pair(self.instrument.pair)

    @property
    def blocks_planned(self) -> int:
        return len(self.session.weights_kg) * self.session.repeats

    @classmethod
    def from_scene(cls, scene: Scene) -> SessionPlan:
        """Validate the scene's ``[instrument]``, the pair's settings table and ``[session]`` into a plan."""
        instrument = InstrumentSettings.from_table(scene.table("instrument"))
        pair = get_pair(instrument.pair)
        block_settings = pair.parse_settings(scene.table(pair.settings_table))
        return cls(instrument=instrument, block_settings=block_settings, session=_session(scene), scene=scene)

    def describe(self) -> dict[str, Any]:
        """The plan as plain JSON-able data, for the start record (block settings under their table's name)."""
        return {
            "instrument": dataclasses.asdict(self.instrument),
            self.pair.settings_table: dataclasses.asdict(self.block_settings),
            "session": {**dataclasses.asdict(self.session), "weights_kg": list(self.session.weights_kg)},
            "blocks_planned": self.blocks_planned,
        }


def _session(scene: Scene) -> SessionSettings:
    """``[session]``, its weights defaulting to the specimen's (:func:`_default_weights`); ``sim_model`` one of
    ``[database].models``."""
    table = dict(scene.table("session"))
    check_keys("session", table, SESSION_KEYS)
    if "weights_kg" not in table:
        table["weights_kg"], origin = _default_weights(scene)
        try:
            return _checked_session(scene, table)
        except SettingError as exc:  # the weights came from another table: say which
            if exc.field.startswith("session.weights_kg"):
                raise SettingError(origin, table["weights_kg"], f"as the session's weights: {exc.allowed}") from None
            raise
    return _checked_session(scene, table)


def _checked_session(scene: Scene, table: dict[str, Any]) -> SessionSettings:
    session = SessionSettings(**table)
    models = scene.table("database").get("models")
    if isinstance(models, list) and models:
        check_choice("session.sim_model", session.sim_model, models)
    return session


def _default_weights(scene: Scene) -> tuple[Any, str]:
    """The session's weights when ``[session]`` gives none, and where they came from: a press scene's
    ``[press].weights_kg`` (the press specimen's load sweep, :attr:`sims.config.SimConfig.press`), else
    ``[rig].weights_kg``."""
    from sims.press import PressSettings

    press = PressSettings.from_scene(scene)
    if press is not None:
        return list(press.weights_kg), "press.weights_kg"
    rig_weights = scene.table("rig").get("weights_kg")
    if rig_weights is None:
        raise SettingError("session.weights_kg", None, "give the weights here or in [rig].weights_kg")
    return rig_weights, "rig.weights_kg"


def settings_from_record(plan_record: Mapping[str, Any]) -> tuple[InstrumentPair, Any]:
    """The pair and its block settings from a start record's ``plan`` (:meth:`SessionPlan.describe`).

    Records written before pairs were named hold no ``instrument.pair``: they were taken with the default pair.
    """
    pair = get_pair(plan_record.get("instrument", {}).get("pair", DEFAULT_PAIR))
    return pair, pair.parse_settings(plan_record[pair.settings_table])


# ---- steps -----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PlaceWeight:
    """Ask the operator to place weight number ``weight_index`` (``weight_kg``) in the piston."""

    weight_index: int
    weight_kg: float
    repeats_left: int


@dataclass(frozen=True)
class Measure:
    """Run one block: block number ``block`` (position in the plan), ``repeat`` 1 … repeats; ``adaptive``: the
    record of the suggestion that led to it (an adaptive session), written with the block; ``seating_block``: for a
    block repeated at the present seating (an adaptive session's "repeat", same weight and ``repeat`` number as the
    block before it, the weight not lifted), the number of that seating's first block, whose contact it measures
    again (the simulated bench keeps that block's contact factor); None: a new seating."""

    block: int
    weight_index: int
    weight_kg: float
    repeat: int
    adaptive: dict[str, Any] | None = dataclasses.field(default=None, compare=False)
    seating_block: int | None = None


def session_steps(
    plan: SessionPlan,
    done: set[int] | frozenset[int] = frozenset(),
    *,
    first: tuple[int, ...] = (),
    leave_out: frozenset[int] = frozenset(),
) -> Iterator[PlaceWeight | Measure]:
    """The steps of ``plan`` in order, leaving out blocks whose number is in ``done`` (for ``--resume``).

    Block numbers are positions in the full plan (weight index × repeats + repeat − 1), so a resumed session
    numbers its blocks exactly as an uninterrupted one would. ``first``: weight indices to measure before all others
    (a skipped weight the operator chose to measure now, on ``--resume``); ``leave_out``: weight indices not to
    measure at all (a skipped weight kept skipped).
    """
    repeats = plan.session.repeats
    for wi in loading_order(plan, first=first, leave_out=leave_out):
        weight = plan.session.weights_kg[wi]
        todo = [r for r in range(1, repeats + 1) if wi * repeats + r - 1 not in done]
        if not todo:
            continue
        yield PlaceWeight(weight_index=wi, weight_kg=weight, repeats_left=len(todo))
        for r in todo:
            yield Measure(block=wi * repeats + r - 1, weight_index=wi, weight_kg=weight, repeat=r)


def loading_order(
    plan: SessionPlan, *, first: tuple[int, ...] = (), leave_out: frozenset[int] = frozenset()
) -> list[int]:
    """Weight indices in the order they are placed: ``first``, then the plan's order; ``leave_out`` left out."""
    rest = [i for i in range(len(plan.session.weights_kg)) if i not in first]
    return [i for i in (*first, *rest) if i not in leave_out]


@dataclass(frozen=True)
class DurationEstimate:
    """A session's expected duration: ``block_s`` per block from the block settings (None when the pair's settings
    do not say), ``blocks`` to take, ``weights`` to place, and the operator's allowance per weight."""

    block_s: float | None
    blocks: int
    weights: int
    operator_allowance_s: float

    @property
    def measuring_s(self) -> float | None:
        return None if self.block_s is None else self.block_s * self.blocks

    @property
    def operator_s(self) -> float:
        return self.operator_allowance_s * self.weights

    @property
    def total_s(self) -> float | None:
        return None if self.measuring_s is None else self.measuring_s + self.operator_s


def block_duration_s(settings: Any) -> float | None:
    """count × (delay + NPLC / line frequency + :data:`CONVERSION_OVERHEAD_S`) in s for Delta-like settings; None
    for settings without these fields."""
    try:
        count, delay = float(settings.count), float(settings.delay_s)
        integration = float(settings.nplc) / float(settings.line_frequency_hz)
    except (AttributeError, TypeError, ValueError, ZeroDivisionError):
        return None
    return count * (delay + integration + CONVERSION_OVERHEAD_S)


def estimate_duration(
    plan: SessionPlan, steps: Iterable[PlaceWeight | Measure], *, attended: bool, time_scale: float = 1.0
) -> DurationEstimate:
    """The duration of ``steps``: blocks × :func:`block_duration_s` (× ``time_scale``, a simulated bench's real
    seconds per instrument second), plus :data:`OPERATOR_ALLOWANCE_S` per weight when an operator places them."""
    steps = list(steps)
    block_s = block_duration_s(plan.block_settings)
    return DurationEstimate(
        block_s=None if block_s is None else block_s * time_scale,
        blocks=sum(isinstance(s, Measure) for s in steps),
        weights=sum(isinstance(s, PlaceWeight) for s in steps),
        operator_allowance_s=OPERATOR_ALLOWANCE_S if attended else 0.0,
    )
