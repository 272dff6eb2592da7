"""A second instrument pair, registered inside this test, runs a whole session: scene → plan → acquire → session
file → replay, without editing any module of daq or instruments (the pair registry at work).

The toy pair is a four-wire ohmmeter answering ``READ? n`` with n resistance readings; its settings live in its own
scene table ``[toy]`` (a new table is also named in ``contactrig.core.validation.SCENE_TABLES``: patched here).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import pytest

from contactrig.core.scene import parse_scene
from contactrig.core.validation import SettingError, check_int, check_keys
from daq.acquire import acquire
from daq.link import VisaBench
from daq.plan import SessionPlan
from daq.replay import replay_session
from instruments.block import block_statistics
from instruments.pairs import Identity, InstrumentPair, SimulatedPair, register, unregister

from .conftest import SMALL_SCENE
from .sessions import load_quietly


@dataclasses.dataclass(frozen=True)
class ToySettings:
    count: int = 4

    def __post_init__(self) -> None:
        object.__setattr__(self, "count", check_int("count", self.count, 1, 100))


@dataclasses.dataclass(frozen=True)
class ToyBlock:
    readings: np.ndarray
    timestamps_s: np.ndarray
    unit: str = "OHMS"

    @property
    def valid(self) -> np.ndarray:
        return np.isfinite(self.readings)

    def resistance_ohm(self) -> np.ndarray:
        return self.readings.copy()


class ToyOhmmeter:
    """The toy pair's driver: ``*IDN?``, ``READ? n``; ``IDLE`` on close."""

    def __init__(self, transport: Any, *, clock: Callable[[], float], sleep: Callable[[float], None]) -> None:
        self.transport = transport
        self.closed = False

    def identify(self) -> Identity:
        idn = self.transport.query("*IDN?").strip()
        return Identity(source=idn, voltmeter=idn)

    def run_block(self, settings: ToySettings) -> ToyBlock:
        reply = self.transport.query(f"READ? {settings.count}")
        values = np.array([float(x) for x in reply.split(",")])
        return ToyBlock(values, 0.1 * np.arange(values.size))

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.transport.write("IDLE")
            self.transport.close()

    def __enter__(self) -> ToyOhmmeter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclasses.dataclass
class ToySample:
    resistance_ohm: float = 3e-3


class ToyResource:
    """A VISA-like resource: the ohmmeter reads the sample's resistance with 1 % seeded noise."""

    def __init__(self, sample: ToySample, seed: int) -> None:
        self.sample = sample
        self.rng = np.random.default_rng(seed)
        self.read_termination = self.write_termination = "\n"
        self.timeout = 1000

    def write(self, message: str) -> None:
        pass

    def query(self, message: str) -> str:
        if message == "*IDN?":
            return "TOY,OHM-1,0001,1.0"
        n = int(message.split()[1])
        r = self.sample.resistance_ohm * (1 + 0.01 * self.rng.standard_normal(n))
        return ",".join(f"{x:.9e}" for x in r)

    def read(self) -> str:
        raise AssertionError("the toy driver never reads")

    def close(self) -> None:
        pass


class ToyResourceManager:
    def __init__(self, sample: ToySample, seed: int) -> None:
        self.sample, self.seed = sample, seed

    def open_resource(self, address: str, **kwargs: Any) -> ToyResource:
        return ToyResource(self.sample, self.seed)


def _toy_settings(table: Mapping[str, Any]) -> ToySettings:
    check_keys("toy", table, ["count"])
    try:
        return ToySettings(**table)
    except SettingError as exc:
        raise SettingError(f"toy.{exc.field}", exc.value, exc.allowed) from None


def _simulate(*, resistance_ohm: float | None = None, seed: int = 0, time_scale: float = 0.0) -> SimulatedPair:
    sample = ToySample() if resistance_ohm is None else ToySample(resistance_ohm)
    return SimulatedPair(bench=sample, resource_manager=ToyResourceManager(sample, seed))


TOY = InstrumentPair(
    key="toy_ohmmeter",
    description="a four-wire ohmmeter that exists only in this test",
    source_name="toy ohmmeter",
    settings_table="toy",
    parse_settings=_toy_settings,
    reading_unit=lambda settings: "OHMS",
    open_driver=ToyOhmmeter,
    simulate=_simulate,
)


@pytest.fixture
def toy(monkeypatch):
    import contactrig.core.scene as scene_module
    import contactrig.core.validation as validation_module

    monkeypatch.setattr(validation_module, "SCENE_TABLES", (*validation_module.SCENE_TABLES, "toy"))
    monkeypatch.setattr(scene_module, "KNOWN_TABLES", validation_module.SCENE_TABLES)
    register(TOY)
    yield TOY
    unregister(TOY.key)


def _toy_scene(count: str = "count = 5"):
    text = SMALL_SCENE.replace("timeout_ms = 500\n", 'timeout_ms = 500\npair = "toy_ohmmeter"\n')
    return parse_scene(text + f"\n[toy]\n{count}\n", "<toy>")


def test_a_registered_pair_runs_a_whole_session_and_replays(toy, tmp_path):
    plan = SessionPlan.from_scene(_toy_scene())
    assert plan.pair is toy and plan.block_settings == ToySettings(count=5)
    path = tmp_path / "toy.h5"
    sim = toy.simulate(resistance_ohm=3e-3, seed=4)
    result = acquire(_toy_scene(), path, bench=VisaBench(sim.resource_manager), yes=True, quiet=True)
    assert result.status == "success" and result.blocks_done == plan.blocks_planned == 6
    s = load_quietly(path)
    assert s.start["plan"]["toy"] == {"count": 5} and s.start["plan"]["instrument"]["pair"] == "toy_ohmmeter"
    assert s.start["instrument"]["source"] == "TOY,OHM-1,0001,1.0"
    assert len(s.readings) == 30 and s.readings.resistance_ohm.between(2.8e-3, 3.2e-3).all()
    # the summary is the one block-statistics function over each block's readings, bit for bit
    first = s.readings[s.readings.block == 0]
    st = block_statistics(first.resistance_ohm.to_numpy(), first.valid.to_numpy())
    assert (s.summary.mean_ohm[0], s.summary.sd_ohm[0], s.summary.sem_ohm[0]) == (st.mean, st.sd, st.sem)
    # the driver was closed (its IDLE is the last command) and replay reproduces every block through the toy driver
    assert s.exchanges.message.iloc[-1] == "IDLE"
    report = replay_session(path)
    assert report.identical and report.blocks_replayed == 6, report.differences


def test_a_pairs_settings_errors_name_its_table(toy):
    with pytest.raises(SettingError, match=r"\[toy\] count = 0"):
        SessionPlan.from_scene(_toy_scene("count = 0"))
    with pytest.raises(SettingError, match=r"\[instrument\] pair = 'nope'"):
        text = SMALL_SCENE.replace("timeout_ms = 500\n", 'timeout_ms = 500\npair = "nope"\n')
        SessionPlan.from_scene(parse_scene(text))
