"""The acquisition's connection to the bench: the 6221 driver on a recording transport.

Whatever is underneath — a VISA resource, the simulated bench, or a replay of a recorded session — the
acquisition engine talks to one :class:`InstrumentLink`, so acquisition and replay run the same code. Every
exchange is recorded; the engine takes them block by block and hands them to the session file.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from instruments.delta import DeltaBlock, DeltaSettings
from instruments.errors import InstrumentTimeout, ReplyError
from instruments.k6221 import Identity, Keithley6221
from instruments.transport import Exchange, RecordingTransport, Transport, VisaTransport

__all__ = ["InstrumentLink", "UnreachableInstrument", "open_visa_link"]


class UnreachableInstrument(RuntimeError):
    """The VISA address cannot be opened (wrong address, instrument off, cable, or no VISA library)."""


class InstrumentLink:
    """A :class:`~instruments.k6221.Keithley6221` whose every exchange is recorded.

    ``place_weight(weight_kg)`` is called when the operator has placed a weight, ``prepare_block(block)`` just
    before block number ``block`` starts (the simulated bench uses them to set its resistance; on real hardware
    and in replay they do nothing). ``clock``/``sleep`` go to the driver (replay injects them).
    """

    def __init__(
        self,
        transport: Transport,
        *,
        address: str = "",
        place_weight: Callable[[float], None] | None = None,
        prepare_block: Callable[[int], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        driver_options: dict[str, Any] | None = None,
    ) -> None:
        self.address = address
        self.recorder = RecordingTransport(transport, clock=clock)
        self.driver = Keithley6221(self.recorder, clock=clock, sleep=sleep, **(driver_options or {}))
        self._place_weight = place_weight
        self._prepare_block = prepare_block
        self._taken = 0

    def identify(self) -> Identity:
        """Both instruments' ``*IDN?`` (and the check that the 2182A answers on the serial link).

        No answer at all to the first ``*IDN?`` (a timeout or an empty reply — what a GPIB address with nothing
        behind it gives) raises :class:`UnreachableInstrument`.
        """
        first = len(self.recorder.exchanges)
        try:
            return self.driver.identify()
        except (InstrumentTimeout, ReplyError) as exc:
            answered = any(e.reply for e in self.recorder.exchanges[first:])
            if answered:
                raise
            raise UnreachableInstrument(
                f"no answer from a 6221 at {self.address or 'the given address'!r} ({exc}): check the address in "
                "[instrument].address, that the 6221 is switched on and its GPIB/LAN/RS-232 cable; "
                "`--sim` runs without hardware"
            ) from exc

    def place_weight(self, weight_kg: float) -> None:
        if self._place_weight is not None:
            self._place_weight(weight_kg)

    def prepare_block(self, block: int) -> None:
        if self._prepare_block is not None:
            self._prepare_block(block)

    def run_block(self, settings: DeltaSettings) -> DeltaBlock:
        """One Delta block; the driver leaves the source idle whatever happens."""
        return self.driver.run_delta(settings)

    def take_exchanges(self) -> list[Exchange]:
        """The exchanges recorded since the previous call."""
        ex = self.recorder.exchanges[self._taken :]
        self._taken = len(self.recorder.exchanges)
        return ex

    def close(self) -> None:
        """Leave the source idle (``SOUR:SWE:ABOR``) and close the connection."""
        self.driver.close()


def open_visa_link(address: str, timeout_ms: int, resource_manager: Any = None, **kwargs: Any) -> InstrumentLink:
    """Open the 6221 at ``address``; an unreachable address raises :class:`UnreachableInstrument` with advice."""
    try:
        transport = VisaTransport.open(address, resource_manager, timeout_ms)
    except Exception as exc:  # the driver's CommunicationError; raw pyvisa/backends raise ValueError or OSError
        detail = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        detail = detail.split(": check")[0]  # keep one piece of advice, ours
        raise UnreachableInstrument(
            f"cannot open the 6221 at {address!r} ({detail}): check the address in [instrument].address, that the "
            "6221 is switched on and cabled, and that a VISA library is installed; `--sim` runs without hardware"
        ) from exc
    return InstrumentLink(transport, address=address, **kwargs)
