"""Recording on the simulated bench and replaying without it gives the identical block."""

from __future__ import annotations

import numpy as np
import pytest

from instruments.delta import DeltaSettings
from instruments.errors import InstrumentTimeout, ReplayMismatch
from instruments.k6221 import Keithley6221
from instruments.simulated import GPIB_ADDRESS, SimulatedBench, simulated_resource_manager
from instruments.transport import Exchange, RecordingTransport, ReplayTransport, VisaTransport

from .conftest import FakeClock


def record(settings, bench=None):
    bench = bench or SimulatedBench(resistance_ohm=4e-3, seed=11)
    bench.faults.overflow_readings.add(1)
    rec = RecordingTransport(VisaTransport.open(GPIB_ADDRESS, simulated_resource_manager(bench), 2000))
    with Keithley6221(rec, chunk_size=4) as k:
        ident = k.identify()
        block = k.run_delta(settings)
    return rec.exchanges, ident, block


@pytest.mark.filterwarnings("ignore::instruments.errors.InvalidReadingsWarning")  # expected: overflow injected
def test_round_trip_identical_block():
    s = DeltaSettings(high_a=1e-3, count=10)
    exchanges, ident, block = record(s)
    replay = ReplayTransport(exchanges)
    clock = FakeClock()
    with Keithley6221(replay, clock=clock, sleep=clock.sleep, chunk_size=4) as k:
        assert k.identify() == ident
        again = k.run_delta(s)
    assert replay.remaining == 0 and replay.closed
    np.testing.assert_array_equal(again.readings, block.readings)
    np.testing.assert_array_equal(again.timestamps_s, block.timestamps_s)
    assert again.n_invalid == block.n_invalid == 1
    assert clock.t == 0.0  # nothing waited


@pytest.mark.filterwarnings("ignore::instruments.errors.InvalidReadingsWarning")  # expected: overflow injected
def test_replay_detects_divergence():
    exchanges, _, _ = record(DeltaSettings(high_a=1e-3, count=10))
    with pytest.raises(ReplayMismatch, match=r"SOUR:DELT:HIGH 0\.002"):
        with Keithley6221(ReplayTransport(exchanges), chunk_size=4) as k:
            k.identify()
            k.run_delta(DeltaSettings(high_a=2e-3, count=10))
    with pytest.raises(ReplayMismatch, match="exhausted"):
        ReplayTransport([]).query("*IDN?")


def test_replay_non_strict_and_recorded_timeout():
    ex = [Exchange("query", "*IDN?", "X", 0.0), Exchange("query", "TRAC:POIN:ACT?", None, 0.1, "timeout")]
    r = ReplayTransport(ex, strict=False)
    assert r.query("anything") == "X"
    with pytest.raises(InstrumentTimeout):
        r.query("TRAC:POIN:ACT?")
