"""Small session files for the run-index tests and benchmark, written through the real acquisition path (drive +
FileWriter, the simulated bench): start records with the fields an acquisition records."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from daq.acquire import drive
from daq.plan import SessionPlan, session_steps
from daq.session_file import SessionFile
from daq.writers import FileWriter

from .conftest import make_link, small_scene


def write_run(
    path: Path,
    *,
    sample: str = "bronze",
    operator: str = "ann",
    notes: str = "",
    started: str = "2026-01-01T10:00:00.000+00:00",
    nplc: str = "1.0",
    overrides: dict[str, Any] | None = None,
) -> Path:
    """One small finished session (3 weights × 2 repeats, 8 readings a block) at ``path``."""
    plan = SessionPlan.from_scene(small_scene(nplc=f"nplc = {nplc}"))
    link = make_link(plan)
    start = {
        "started": started, "operator": operator, "sample": sample, "notes": notes, "host": "test",
        "scene_name": plan.scene.name, "plan": plan.describe(), "overrides": overrides or {},
        "software": {"contactrig": "0.1.0", "h5py": "3"},
        "instrument": {"address": plan.instrument.address, "pinned_state": link.pinned_state()},
    }  # fmt: skip
    sf = SessionFile.create(path)
    try:
        drive(link, plan.block_settings, session_steps(plan), [FileWriter(sf)], start, plan.scene.text,
              run=sf.run, blocks_planned=plan.blocks_planned)  # fmt: skip
    finally:
        sf.close()
    return path
