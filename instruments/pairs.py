"""Instrument pairs: a source and a voltmeter that together measure a resistance block by block, registered by key.

A bench session (``daq``) talks to the instruments only through an :class:`InstrumentPair`: how to read the pair's
block settings from their scene table, which unit its readings come in, how to open its driver on a transport
(a :class:`PairDriver`: identify, run one block returning an :class:`instruments.block.Block`, close), and how to
build its simulated bench. The scene's ``[instrument].pair`` picks one (default :data:`DEFAULT_PAIR`).

Adding a pair (e.g. a four-wire source-meter) is a driver module plus one :func:`register` call here; the
session plan, engine, link, replay and session file take it from the registry. Its settings table must also be a
known scene table (``contactrig.core.validation.SCENE_TABLES``). The Keithley 6221 with a 2182A in Delta mode
is registered below; drivers and simulators are imported only when a pair is opened.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from contactrig.core.registry import Registry
from contactrig.core.validation import SettingError, check_keys
from instruments.block import Block
from instruments.delta import DeltaSettings
from instruments.transport import Transport

if TYPE_CHECKING:
    from instruments.k6221 import Keithley6221

__all__ = [
    "DEFAULT_PAIR",
    "Identity",
    "InstrumentPair",
    "PairDriver",
    "SimulatedPair",
    "SimulatedSample",
    "get_pair",
    "pair_names",
    "register",
    "unregister",
]

#: The pair a scene gets when ``[instrument]`` names none.
DEFAULT_PAIR = "k6221_2182a"


@dataclass(frozen=True)
class Identity:
    """``*IDN?`` replies of the source and of the voltmeter (the same text twice for a single instrument)."""

    source: str
    voltmeter: str


class PairDriver(Protocol):
    """What a session needs from a pair's driver. ``close`` leaves the source idle and is safe to call twice; as a
    context manager the driver closes on every exit."""

    def identify(self) -> Identity: ...

    def run_block(self, settings: Any) -> Block: ...

    def close(self) -> None: ...

    def __enter__(self) -> PairDriver: ...

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: object) -> None: ...


class DriverFactory(Protocol):
    """Opens a pair's driver on ``transport``; time comes from ``clock`` and ``sleep`` (replay injects them).
    Driver options (e.g. ``chunk_size`` over a slow serial line) come as further keywords, only when there are any."""

    def __call__(
        self, transport: Transport, *, clock: Callable[[], float], sleep: Callable[[float], None], **options: Any
    ) -> PairDriver: ...


class SimulatedSample(Protocol):
    """The sample of a simulated bench: its resistance (Ω) can be set between blocks; ``any_address``: the pair
    answers at any valid VISA resource name (else only at its listed ones); ``serial_terminator``: the message
    terminator its source uses at an ``ASRL`` (RS-232) address, as the scene's ``[instrument].terminator``."""

    resistance_ohm: float
    any_address: bool
    serial_terminator: str


@dataclass(frozen=True)
class SimulatedPair:
    """A simulated bench (``bench``) and a pyvisa resource manager (``resource_manager``) on which the pair's
    VISA address answers from it."""

    bench: SimulatedSample
    resource_manager: Any  # a pyvisa.ResourceManager (pyvisa ships no type information)


class SimulatorFactory(Protocol):
    """Builds a simulated bench: sample resistance (Ω; None = the simulator's default), noise seed, and
    ``time_scale`` real seconds per instrument second (0 = instant)."""

    def __call__(
        self, *, resistance_ohm: float | None = None, seed: int = 0, time_scale: float = 0.0
    ) -> SimulatedPair: ...


@dataclass(frozen=True)
class InstrumentPair:
    """One registered instrument pair.

    key: the name ``[instrument].pair`` gives. description: one line for help texts.
    source_name: how messages name the instrument the PC talks to (e.g. ``"6221"``).
    settings_table: the scene table of its block settings (e.g. ``"delta"``); ``parse_settings(table)`` validates
    it into a frozen dataclass (errors name ``[table] key``) and also reads back the copy recorded in a session.
    reading_unit(settings): the unit of the readings as returned (``"V"``, ``"OHMS"``), for the session file.
    open_driver: a :class:`DriverFactory`. simulate: a :class:`SimulatorFactory`.
    """

    key: str
    description: str
    source_name: str
    settings_table: str
    parse_settings: Callable[[Mapping[str, Any]], Any]
    reading_unit: Callable[[Any], str]
    open_driver: DriverFactory
    simulate: SimulatorFactory


_REGISTRY: Registry[InstrumentPair] = Registry("instrument pair")


def register(pair: InstrumentPair, *, replace: bool = False) -> InstrumentPair:
    """Add ``pair`` under ``pair.key`` (an existing key only with ``replace``); return it."""
    if not pair.key or not pair.key.isidentifier():
        raise ValueError(f"instrument pair key {pair.key!r}: expected a name such as 'k6221_2182a'")
    if pair.key in _REGISTRY and not replace:
        raise ValueError(f"instrument pair {pair.key!r} is registered already (replace=True to replace it)")
    return _REGISTRY.register(pair, replace=replace)


def unregister(key: str) -> None:
    """Remove the pair ``key`` (nothing happens if it is not registered)."""
    _REGISTRY.unregister(key)


def pair_names() -> list[str]:
    """The keys of every registered pair, in registration order."""
    return list(_REGISTRY.names())


def get_pair(key: str = DEFAULT_PAIR) -> InstrumentPair:
    """The pair registered as ``key``; an unknown key is a :class:`SettingError` naming ``[instrument] pair``."""
    pair = _REGISTRY.find(key) if isinstance(key, str) else None
    if pair is None:
        raise SettingError("instrument.pair", key, "expected one of " + ", ".join(repr(k) for k in _REGISTRY.names()))
    return pair


# ---- Keithley 6221 + 2182A in Delta mode ------------------------------------------------------------------------


def delta_settings_from_table(table: Mapping[str, Any]) -> DeltaSettings:
    """:class:`~instruments.delta.DeltaSettings` from the ``[delta]`` table; unknown keys are errors naming the key,
    and every error names it as ``[delta] key``."""
    check_keys("delta", table, [f.name for f in dataclasses.fields(DeltaSettings)])
    if "high_a" not in table:
        raise SettingError("delta.high_a", None, "required: the source high level in A (|I| <= 0.105 A)")
    try:
        return DeltaSettings(**table)
    except SettingError as exc:
        raise SettingError(f"delta.{exc.field}", exc.value, exc.allowed) from None


def _delta_unit(settings: DeltaSettings) -> str:
    return settings.unit


def _open_k6221(
    transport: Transport,
    *,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
    **options: Any,
) -> Keithley6221:
    """The Keithley driver; ``options`` are :class:`~instruments.k6221.Keithley6221` keywords (e.g. ``chunk_size``)."""
    from instruments.k6221 import Keithley6221

    return Keithley6221(transport, clock=clock, sleep=sleep, **options)


def _simulate_k6221(*, resistance_ohm: float | None = None, seed: int = 0, time_scale: float = 0.0) -> SimulatedPair:
    from instruments.simulated import SimulatedBench, simulated_resource_manager

    bench = SimulatedBench(seed=seed, time_scale=time_scale)
    if resistance_ohm is not None:
        bench.resistance_ohm = resistance_ohm
    return SimulatedPair(bench=bench, resource_manager=simulated_resource_manager(bench))


register(
    InstrumentPair(
        key=DEFAULT_PAIR,
        description="Keithley 6221 current source with a 2182A nanovoltmeter in Delta mode",
        source_name="6221",
        settings_table="delta",
        parse_settings=delta_settings_from_table,
        reading_unit=_delta_unit,
        open_driver=_open_k6221,
        simulate=_simulate_k6221,
    )
)
