"""A real acquisition process for the kill and Ctrl-C tests: ``python -m tests.daq.acquire_script OUT TIME_SCALE``.

Runs ``daq.acquire.acquire`` (the code behind ``contactrig acquire``) on the simulated instruments through the
ordinary VISA path (``VisaBench``), unattended, printing one line per block; exit code as the CLI's.
"""

from __future__ import annotations

import sys

from daq.acquire import acquire
from daq.link import VisaBench
from instruments.simulated import SimulatedBench, simulated_resource_manager

from .conftest import small_scene


def main(argv: list[str]) -> int:
    out, time_scale = argv[0], float(argv[1])
    resume = "--resume" in argv
    scene = small_scene(count="count = 20", repeats="repeats = 4")
    bench = SimulatedBench(resistance_ohm=5e-3, seed=1, time_scale=time_scale)
    try:
        result = acquire(
            None if resume else scene,
            out,
            yes=True,
            resume=resume,
            bench=VisaBench(simulated_resource_manager(bench=bench)),
            stream=sys.stdout,
        )
    except Exception as exc:
        print(f"error: {exc}", flush=True)
        return 2
    return 0 if result.status == "success" else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
