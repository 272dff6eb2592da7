"""Fixtures for daq tests: small scenes and a simulated bench whose resistance follows the placed weight."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from contactrig.core.scene import parse_scene
from daq.link import open_visa_link
from daq.plan import SessionPlan

ROOT = Path(__file__).resolve().parents[2]

SMALL_SCENE = """
[scene]
name = "daq-test"

[database]
models = ["greenwood_tripp"]

[rig]
weights_kg = [5.44, 10.526, 25.966]

[instrument]
address = "GPIB0::12::INSTR"
timeout_ms = 500

[delta]
high_a = 0.01
delay_s = 0.002
count = 8
unit = "V"
nplc = 1.0

[session]
repeats = 2
operator = "tester"
sample = "test sample"
rig = "test rig"
sim_model = "greenwood_tripp"
sim_seed = 7
"""


def sim_scene_text(repeat_sd: float | None = None) -> str:
    """The packaged default scene (materials, surfaces, rig, circuit) with a small session: 3 weights × 2 × 8;
    ``repeat_sd`` replaces ``[session].sim_repeat_sd`` and selects ``sim_noise = "iid"`` (independent re-seating)."""
    import re

    from contactrig.core.scene import default_scene_text

    text = default_scene_text()
    text = re.sub(r"(?m)^count = .*$", "count = 8", text)
    text = re.sub(r"(?m)^repeats = .*$", "repeats = 2", text)
    text = re.sub(r"(?m)^timeout_ms = .*$", "timeout_ms = 1000", text)
    if repeat_sd is not None:
        text, n = re.subn(r"(?m)^sim_repeat_sd = .*$", f"sim_repeat_sd = {repeat_sd!r}", text)
        assert n == 1
        text, n = re.subn(r'(?m)^sim_noise = .*$', 'sim_noise = "iid"', text)
        assert n == 1
    return text.replace("[session]\n", "[session]\nweights_kg = [5.44, 10.526, 25.966]\n")


def small_sim_scene(folder: Path, count: int = 20, repeats: int = 4) -> Path:
    """The simulated-bench scene with short blocks (``count`` readings) and ``repeats`` per weight, in ``folder``."""
    import re

    text = re.sub(r"(?m)^count = .*$", f"count = {count}", sim_scene_text())
    text = re.sub(r"(?m)^repeats = .*$", f"repeats = {repeats}", text)
    path = Path(folder) / "scene.toml"
    path.write_text(text)
    return path


def small_scene(**replace: str):
    """The small test scene, with whole lines replaced: ``small_scene(count="count = 3")``."""
    text = SMALL_SCENE
    for key, line in replace.items():
        lines = text.splitlines()
        lines = [line if ln.split("=")[0].strip() == key else ln for ln in lines]
        text = "\n".join(lines) + "\n"
    return parse_scene(text, "<test>")


def resistance_at(weight_kg: float) -> float:
    """Test bench resistance (Ω): falls with weight like Tab. 1 (an arbitrary smooth law, not physics under test)."""
    return 2e-4 + 4e-2 / weight_kg


def make_link(plan: SessionPlan, *, seed: int = 3, faults=None, wrapper=None):
    """An InstrumentLink to a fresh simulated bench (time_scale 0) whose resistance follows the placed weight."""
    from instruments.simulated import SimulatedBench, simulated_resource_manager

    bench = SimulatedBench(resistance_ohm=resistance_at(plan.session.weights_kg[0]), seed=seed, time_scale=0.0)
    if faults is not None:
        bench.faults = faults

    def place(w: float) -> None:
        bench.resistance_ohm = resistance_at(w)

    rm = simulated_resource_manager(bench=bench)
    link = open_visa_link(plan.instrument.address, plan.instrument.timeout_ms, rm, place_weight=place)
    if wrapper is not None:
        from daq.link import InstrumentLink

        link = InstrumentLink(wrapper(link.recorder.inner), address=link.address, place_weight=place)
    link.bench = bench
    return link


@pytest.fixture
def plan():
    return SessionPlan.from_scene(small_scene())


@pytest.fixture
def python():
    return sys.executable
