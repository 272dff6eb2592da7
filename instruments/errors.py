"""Typed errors of the instrument layer.

Every error a user can act on subclasses :class:`RuntimeError`, so the ``contactrig`` dispatcher prints it as one
line (exit 2) instead of a traceback. Invalid *settings* raise
:class:`contactrig.core.validation.SettingError` (a ValueError)
before anything is sent to an instrument.
"""

from __future__ import annotations

__all__ = [
    "CommunicationError",
    "ComplianceWarning",
    "InstrumentError",
    "InstrumentTimeout",
    "InvalidReadingsWarning",
    "NanovoltmeterMissing",
    "ReplayMismatch",
    "ReplyError",
    "SweepAborted",
    "SweepStalled",
]


class CommunicationError(RuntimeError):
    """The VISA layer failed: the address cannot be opened, or a transfer failed for a reason other than a timeout."""


class InvalidReadingsWarning(RuntimeWarning):
    """Some Delta readings came back invalid (+9.9E37: 2182A overflow or no reading). They are NaN in the block,
    counted in ``n_invalid`` and never averaged; with none valid the block's mean is NaN (no value)."""


class ComplianceWarning(RuntimeWarning):
    """The 6221 went into compliance during a block (``STAT:MEAS:EVEN?`` bit 3) with compliance abort off: the
    sweep completed, but the source could not drive the set current, so the readings are wrong by an unknown
    amount. The block is kept, flagged ``compliance``, and none of its readings counts as valid."""


class InstrumentError(RuntimeError):
    """The instrument reported an error in its queue (``SYST:ERR?``): ``code`` and ``message`` as it gave them.

    ``others`` holds any further errors drained from the queue at the same time, as ``(code, message)`` pairs.
    """

    def __init__(self, code: int, message: str, others: tuple[tuple[int, str], ...] = ()) -> None:
        self.code = int(code)
        self.message = message
        self.others = tuple(others)
        text = f"instrument error {self.code}: {message}"
        if self.others:
            text += " (and " + "; ".join(f"{c}: {m}" for c, m in self.others) + ")"
        super().__init__(text)


class InstrumentTimeout(RuntimeError):
    """No (complete) answer in time. ``command`` is the command that was waiting for it."""

    def __init__(self, command: str, timeout_s: float, detail: str = "") -> None:
        self.command = command
        self.timeout_s = float(timeout_s)
        text = f"timeout after {self.timeout_s:g} s waiting for {command!r}"
        if detail:
            text += f": {detail}"
        super().__init__(text)


class NanovoltmeterMissing(RuntimeError):
    """``SOUR:DELT:NVPR?`` says no 2182A answers on the 6221's serial link."""

    def __init__(self, reply: str = "0") -> None:
        self.reply = reply
        super().__init__(
            f"the 6221 does not see a 2182A nanovoltmeter (SOUR:DELT:NVPR? answered {reply!r}): check that the "
            "2182A is switched on and that BOTH the RS-232 cable and the Trigger Link cable connect it to the 6221"
        )


class ReplyError(RuntimeError):
    """The instrument answered something that cannot be parsed as the expected value."""

    def __init__(self, command: str, reply: str, expected: str) -> None:
        self.command = command
        self.reply = reply
        shown = reply if len(reply) <= 80 else reply[:77] + "..."
        super().__init__(f"{command!r} answered {shown!r}, expected {expected}")


class SweepAborted(RuntimeError):
    """The Delta sweep was aborted by the instrument (status bit 2), e.g. on compliance with compliance abort on."""

    def __init__(self, reason: str, n_stored: int = 0) -> None:
        self.reason = reason
        self.n_stored = int(n_stored)
        super().__init__(f"Delta sweep aborted by the 6221: {reason} ({self.n_stored} readings stored)")


class ReplayMismatch(RuntimeError):
    """A replayed session diverged: the driver sent something other than what was recorded."""


class SweepStalled(InstrumentTimeout, InstrumentError):
    """The Delta sweep stopped making progress: ``TRAC:POIN:ACT?`` did not grow for ``timeout_s`` while the sweep
    had not finished. Both an :class:`InstrumentTimeout` (``command`` is the progress query) and an
    :class:`InstrumentError` (``code`` 0: not from the instrument's error queue)."""

    def __init__(self, stored: int, count: int, timeout_s: float) -> None:
        self.stored = int(stored)
        self.count = int(count)
        self.code = 0
        self.message = (
            f"the Delta sweep stalled: no new reading for {timeout_s:g} s ({self.stored} of {self.count} readings "
            "stored); check the Trigger Link cable and the 2182A"
        )
        self.others = ()
        self.command = "TRAC:POIN:ACT?"
        self.timeout_s = float(timeout_s)
        RuntimeError.__init__(self, self.message)
