"""Small session files for the run-index tests and benchmark, written through the real acquisition path (drive +
FileWriter, the simulated bench): start records with the fields an acquisition records."""

from __future__ import annotations

import os
import time
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


def age(path: Path) -> None:
    """``path`` modified an hour ago: settled (a file changed in the last 2 s is read again at every refresh)."""
    t = time.time() - 3600
    os.utime(path, (t, t))


def build_lab(folder: Path, n: int, distinct: int) -> None:
    """``n`` session files under ``folder`` (100 a sub-folder ``dayNNN/runNNNNN.h5``; 1 % damaged: ``k % 100 == 37``
    a truncated copy, ``k % 100 == 73`` garbage), hard links of ``distinct`` real sessions kept in ``folder/.sources``
    (sample ``sample-{i % 7}``, operator ann/bob/chen, notes "liner re-honed" for every fifth, start days 1–28 with
    UTC offsets +00:00, -05:00, +09:00, NPLC 2 for every fourth, 1 otherwise), all settled. The run-index
    benchmark's folder and the console's 10 000-file browser test."""
    src = folder / ".sources"
    src.mkdir()
    sources = []
    for i in range(distinct):
        offset = ("+00:00", "-05:00", "+09:00")[i % 3]
        sources.append(write_run(
            src / f"s{i}.h5", sample=f"sample-{i % 7}", operator=("ann", "bob", "chen")[i % 3],
            notes="liner re-honed" if i % 5 == 0 else "", started=f"2026-01-{1 + i % 28:02d}T10:00:00.000{offset}",
            nplc="2.0" if i % 4 == 3 else "1.0",
        ))  # fmt: skip
    data = sources[0].read_bytes()
    for k in range(n):
        sub = folder / f"day{k // 100:03d}"
        sub.mkdir(exist_ok=True)
        out = sub / f"run{k:05d}.h5"
        if k % 100 == 37:
            out.write_bytes(data[: len(data) // 2])  # truncated: damaged
        elif k % 100 == 73:
            out.write_bytes(os.urandom(4096))  # garbage
        else:
            os.link(sources[k % distinct], out)
    for p in [*src.iterdir(), *folder.rglob("*.h5")]:
        age(p)
