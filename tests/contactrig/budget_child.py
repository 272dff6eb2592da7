"""Child process of ``test_budget.py``: runs one stage at one size and prints, as JSON, its measured peak memory
(bytes: the peak resident size, VmHWM reset just before the stage, above the resident size then) and the stage's
estimate (``sims.budget``).

Usage: ``python budget_child.py STAGE SIZE``.
"""

from __future__ import annotations

import json
import re
import resource
import sys
from collections.abc import Callable
from typing import Any

from contactrig.core.scene import default_scene_text, parse_scene
from sims import budget
from sims.config import SimConfig
from sims.database import build_database

UNIFORM = (('mesh = "variable"', 'mesh = "uniform"'), ("n_axial = 8 ", "n_axial = 100 "))


def _config(stage: str, size: int) -> SimConfig:
    text = default_scene_text()
    if stage in ("database_hertz", "database_gt", "surfaces", "bem"):
        text = re.sub(r"\nn = 512", f"\nn = {size}", text)
    if stage == "rig":
        for old, new in (*UNIFORM, ("n_theta = 16 ", f"n_theta = {size} ")):
            text = text.replace(old, new)
    if stage == "press":
        text += f"\n[press]\nsphere_radius_m = 0.05\nn_rings = {size}\nweights_kg = [10.0]\n"
    return SimConfig.from_scene(parse_scene(text))


def _work(stage: str, config: SimConfig) -> tuple[Any, Callable[[], object]]:
    """The stage's estimate and the work itself (prebuilt inputs made here, before the measurement)."""
    if stage.startswith("database"):
        models = ["hertz"] if stage == "database_hertz" else ["greenwood_tripp"]
        return budget.database(config, models), lambda: build_database(config, models)
    if stage == "surfaces":
        return budget.surfaces(config), lambda: (config.liner.heights(), config.piston.heights())
    law = {"greenwood_tripp": build_database(config, ["greenwood_tripp"])["greenwood_tripp"]}
    if stage == "rig":
        from sims.rig import sweep

        return budget.rig(config), lambda: sweep(config, ["greenwood_tripp"], laws=law)
    if stage == "press":
        from sims.press import press_sweep

        assert config.press is not None
        return budget.press(config), lambda: press_sweep(config, config.press, ["greenwood_tripp"], laws=law)
    from sims.ensemble import CompareSettings, Task, run_task

    settings = CompareSettings(pressures_pa=(1e6,), models=("hertz",), refine=2)
    return budget.bem(config, refine=2, jobs=1), lambda: run_task(config, settings, Task(0, "bem", (1e6,)), 1)


def _status(field: str) -> int:
    with open("/proc/self/status", encoding="ascii") as fh:
        return next(int(line.split()[1]) * 1024 for line in fh if line.startswith(field + ":"))


def _measure(work: Callable[[], object]) -> int:
    try:  # reset the peak (VmHWM) to the current resident size: the stage's peak is measured from here
        with open("/proc/self/clear_refs", "w", encoding="ascii") as fh:
            fh.write("5")
        base = _status("VmRSS")
        work()
        return _status("VmHWM") - base
    except OSError:  # no reset: the peak so far is the baseline (an underestimate of the stage's own peak)
        base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        work()
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 - base


if __name__ == "__main__":
    name, n = sys.argv[1], int(sys.argv[2])
    est, run = _work(name, _config(name, n))
    print(json.dumps({"measured": _measure(run), "estimate": est.peak_bytes}))
