"""The acquisition's connection to the bench: an instrument pair's driver on a recording transport.

Whatever is underneath — a VISA resource, the simulated bench, or a replay of a recorded session — the
acquisition engine talks to one :class:`InstrumentLink`, so acquisition and replay run the same code. Every
exchange is recorded; the engine takes them block by block and hands them to the session file. The driver comes
from the plan's instrument pair (:mod:`instruments.pairs`); nothing here knows which instruments they are.

A :class:`Bench` is how :func:`daq.acquire.acquire` gets its link: :class:`VisaBench` opens the plan's VISA
address; a layer above daq supplies others (``analysis.simulated_session`` builds the ``--sim`` bench, whose
resistance follows the rig simulation).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from daq.plan import SessionPlan
from instruments.block import Block
from instruments.errors import InstrumentTimeout, ReplyError
from instruments.pairs import Identity, InstrumentPair, PairDriver, get_pair
from instruments.transport import Exchange, RecordingTransport, SerialSettings, Transport, VisaTransport, is_serial

__all__ = ["Bench", "InstrumentLink", "OpenedBench", "UnreachableInstrument", "VisaBench", "open_visa_link"]


class UnreachableInstrument(RuntimeError):
    """The VISA address cannot be opened (wrong address, instrument off, cable, or no VISA library)."""


class InstrumentLink:
    """The driver of ``pair`` (default: the default pair) on ``transport``, every exchange recorded.

    ``place_weight(weight_kg)`` is called when the operator has placed a weight, ``prepare_block(block)`` just
    before a block starts, with the number of the block whose contact it measures — its own, or for a block repeated
    at the present seating the seating's first block — (the simulated bench uses them to set its resistance; on real
    hardware and in replay they do nothing). ``clock``/``sleep`` go to the driver (replay injects them), and so do
    ``driver_options`` (e.g. ``chunk_size`` over RS-232; replay passes the recorded ones). ``connection`` is what the
    start record keeps about how the instrument was reached (VISA library, Nagle, serial parameters, chunk size).
    """

    def __init__(
        self,
        transport: Transport,
        *,
        pair: InstrumentPair | None = None,
        address: str = "",
        place_weight: Callable[[float], None] | None = None,
        prepare_block: Callable[[int], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        driver_options: dict[str, Any] | None = None,
        connection: dict[str, Any] | None = None,
    ) -> None:
        self.pair = pair if pair is not None else get_pair()
        self.address = address
        self.recorder = RecordingTransport(transport, clock=clock)
        options = dict(driver_options or {})
        self.driver: PairDriver = self.pair.open_driver(self.recorder, clock=clock, sleep=sleep, **options)
        self.connection: dict[str, Any] = {**(connection or {}), **options}
        self._place_weight = place_weight
        self._prepare_block = prepare_block
        self._taken = 0

    def identify(self) -> Identity:
        """Both instruments' ``*IDN?`` (and whatever presence check the pair's driver makes).

        No answer at all to the first query (a timeout or an empty reply — what a GPIB address with nothing
        behind it gives) raises :class:`UnreachableInstrument`.
        """
        first = len(self.recorder.exchanges)
        try:
            return self.driver.identify()
        except (InstrumentTimeout, ReplyError) as exc:
            answered = any(e.reply for e in self.recorder.exchanges[first:])
            if answered:
                raise
            name = self.pair.source_name
            raise UnreachableInstrument(
                f"no answer from a {name} at {self.address or 'the given address'!r} ({exc}): check the address in "
                f"[instrument].address, that the {name} is switched on and its GPIB/LAN/RS-232 cable; "
                "`--sim` runs without hardware"
            ) from exc

    def place_weight(self, weight_kg: float) -> None:
        if self._place_weight is not None:
            self._place_weight(weight_kg)

    def prepare_block(self, block: int) -> None:
        if self._prepare_block is not None:
            self._prepare_block(block)

    def run_block(self, settings: object) -> Block:
        """One block with the pair's ``settings``; the driver leaves the source idle whatever happens."""
        return self.driver.run_block(settings)

    def take_exchanges(self) -> list[Exchange]:
        """The exchanges recorded since the previous call."""
        ex = self.recorder.exchanges[self._taken :]
        self._taken = len(self.recorder.exchanges)
        return ex

    def close(self) -> None:
        """Leave the source idle and close the connection."""
        self.driver.close()

    def pinned_state(self) -> dict[str, Any]:
        """What the driver sets besides the block settings (empty for pairs that do not say)."""
        pinned = getattr(self.driver, "pinned_state", None)
        return dict(pinned()) if callable(pinned) else {}


def open_visa_link(
    address: str,
    timeout_ms: int,
    resource_manager: Any = None,
    *,
    pair: InstrumentPair | None = None,
    place_weight: Callable[[float], None] | None = None,
    prepare_block: Callable[[int], None] | None = None,
    visa_library: str = "",
    serial: SerialSettings | None = None,
) -> InstrumentLink:
    """Open ``pair`` at ``address`` on ``resource_manager`` (None: a new one on ``visa_library``, "" = the system's
    VISA library); an unreachable address raises :class:`UnreachableInstrument` with advice. Over RS-232 the
    ``serial`` parameters are set and the buffer is read in chunks sized to the baud rate."""
    pair = pair if pair is not None else get_pair()
    serial = (serial if serial is not None else SerialSettings()) if is_serial(address) else None
    try:
        transport = VisaTransport.open(address, resource_manager, timeout_ms, visa_library=visa_library, serial=serial)
    except Exception as exc:  # the driver's CommunicationError; raw pyvisa/backends raise ValueError or OSError
        detail = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        detail = detail.split(": check")[0]  # keep one piece of advice, ours
        name = pair.source_name
        raise UnreachableInstrument(
            f"cannot open the {name} at {address!r} ({detail}): check the address in [instrument].address, that the "
            f"{name} is switched on and cabled, and that a VISA library is installed; `--sim` runs without hardware"
        ) from exc
    options: dict[str, Any] = {}
    connection: dict[str, Any] = {
        "visa_library": visa_library or _library_name(transport.resource),
        "timeout_ms_effective": int(transport.resource.timeout),
    }
    if transport.nodelay:
        connection["tcp_nodelay"] = transport.nodelay
    if serial is not None:
        options["chunk_size"] = serial.chunk_size(timeout_ms)
        connection["serial"] = serial.as_dict()
    return InstrumentLink(
        transport,
        pair=pair,
        address=address,
        place_weight=place_weight,
        prepare_block=prepare_block,
        driver_options=options,
        connection=connection,
    )


def _library_name(resource: Any) -> str:
    """Which VISA library a resource is open on (its class and path), for the start record."""
    lib = getattr(resource, "visalib", None)
    if lib is None:
        return ""
    return f"{type(lib).__name__}:{getattr(lib, 'library_path', '')}"


@dataclass(frozen=True)
class OpenedBench:
    """An open bench: the ``link``, what the start record keeps about a simulation (``simulation``; empty on
    hardware), and ``notes`` shown to the operator before the first block."""

    link: InstrumentLink
    simulation: dict[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()


class Bench(Protocol):
    """Where a session's blocks are taken. ``simulated`` is recorded in the start record (``sim``), and a session
    resumes only on the same kind of bench."""

    @property
    def simulated(self) -> bool: ...

    def open(self, plan: SessionPlan, *, run: int = 0) -> OpenedBench:
        """Open the bench for run ``run`` of the session (0 = the first; a simulated bench draws each run's noise
        from a stream of its own)."""
        ...


@dataclass(frozen=True)
class VisaBench:
    """The instruments at the plan's ``[instrument].address``, through ``resource_manager`` (None: a new one on
    ``visa_library``, e.g. ``"@py"`` for pyvisa-py; "" = the plan's ``[instrument].visa_library``, else the system's
    VISA library; tests give a simulated one and still take the hardware path)."""

    resource_manager: Any = None  # a pyvisa.ResourceManager (pyvisa ships no type information)
    visa_library: str = ""

    @property
    def simulated(self) -> bool:
        return False

    def open(self, plan: SessionPlan, *, run: int = 0) -> OpenedBench:
        link = open_visa_link(
            plan.instrument.address,
            plan.instrument.timeout_ms,
            self.resource_manager,
            pair=plan.pair,
            visa_library=self.visa_library or plan.instrument.visa_library,
            serial=plan.instrument.serial,
        )
        return OpenedBench(link)
