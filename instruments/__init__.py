"""Instrument drivers: the registry of instrument pairs, and the Keithley 6221 current source with a 2182A
nanovoltmeter in Delta mode (driver and simulated bench).

Modules: :mod:`instruments.pairs` (the pair registry: what a bench session needs from a pair),
:mod:`instruments.block` (a block of readings and its statistics, common to every pair),
:mod:`instruments.delta` (Delta settings, block, formula), :mod:`instruments.k6221` (driver),
:mod:`instruments.transport` (VISA, recording and replay transports), :mod:`instruments.simulated`
(pyvisa-sim bench), :mod:`instruments.scpi` (SCPI parsing for the simulator), :mod:`instruments.errors`.

Importing this package is light: the names below are loaded on first use, and pyvisa only with the simulator or a
VISA connection.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "Block": "instruments.block",
    "BlockStatistics": "instruments.block",
    "block_statistics": "instruments.block",
    "InstrumentPair": "instruments.pairs",
    "Identity": "instruments.pairs",
    "get_pair": "instruments.pairs",
    "pair_names": "instruments.pairs",
    "DeltaSettings": "instruments.delta",
    "DeltaBlock": "instruments.delta",
    "Keithley6221": "instruments.k6221",
    "VisaTransport": "instruments.transport",
    "RecordingTransport": "instruments.transport",
    "ReplayTransport": "instruments.transport",
    "Exchange": "instruments.transport",
    "SimulatedBench": "instruments.simulated",
    "simulated_resource_manager": "instruments.simulated",
    "CommunicationError": "instruments.errors",
    "InstrumentError": "instruments.errors",
    "InstrumentTimeout": "instruments.errors",
    "NanovoltmeterMissing": "instruments.errors",
    "ReplayMismatch": "instruments.errors",
    "ReplyError": "instruments.errors",
    "SweepAborted": "instruments.errors",
    "SweepStalled": "instruments.errors",
    "ComplianceWarning": "instruments.errors",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'instruments' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(list(globals()) + __all__)
