"""Small session files written directly for analysis tests (no bench): one helper instead of a loop per test file."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np


def model_resistance(weight_kg: float, rng: np.random.Generator, scatter: float) -> np.ndarray:
    """Five readings [Ω] of a made-up contact: 0.2 mΩ in series with 5 mΩ·(W/5 kg)^-0.8, repeat scatter
    ``scatter`` (relative) and 0.1 µΩ of reading noise."""
    return 2e-4 + 5e-10 / (1e-7 * (weight_kg / 5) ** 0.8) * (1 + scatter * rng.normal()) + 1e-7 * rng.normal(size=5)


def write_session(
    path: str | Path,
    blocks: Iterable[tuple[float, int, np.ndarray]],
    *,
    start: Mapping[str, Any] | None = None,
    scene_text: str = "",
    stop: Callable[[int], Any] | None = None,
) -> Path:
    """Write ``blocks`` (weight [kg], repeat, readings [Ω]) as a session; ``stop(n_blocks)`` makes the stop record
    (None: no stop record, as a killed run leaves it)."""
    from daq.records import BlockRecord, now_iso
    from daq.session_file import SessionFile

    with SessionFile.create(path) as sf:
        sf.write_start(dict(start) if start is not None else {"started": now_iso(), "operator": "tester"}, scene_text)
        n = 0
        for n, (weight, repeat, readings) in enumerate(blocks, start=1):
            r = np.asarray(readings, dtype=float)
            sf.append_block(
                BlockRecord(
                    block=n - 1, run=0, weight_kg=float(weight), repeat=repeat, unit="V", reading=r,
                    time_s=np.arange(float(r.size)), resistance_ohm=r, valid=np.ones(r.size, bool), started=now_iso(),
                )
            )  # fmt: skip
        if stop is not None:
            sf.write_stop(stop(n))
    return Path(path)


def write_toy_sweep(
    path: str | Path,
    weights_kg: Any,
    *,
    scene: Any = None,
    peak_pa: float = 1e6,
    warnings: Iterable[str] = (),
    provenance_extra: Mapping[str, Any] | None = None,
) -> Path:
    """A toy sweep file (A ∝ W^0.8 for greenwood_tripp, W^(2/3) for hertz, 0.1 mm² at 5 kg) fingerprinted as a
    simulation of ``scene`` (the packaged default scene when None), so fit/report accept it for that scene."""
    from contactrig.core.scene import load_scene
    from daq.sweep_file import config_fingerprint, save_sweep
    from sims.config import SimConfig
    from sims.rig import ModelSweep, SweepResult

    w = np.asarray(weights_kg, dtype=float)
    n = w.size
    models = {
        name: ModelSweep(
            name=name, weight_kg=w, contact_area_m2=1e-7 * (w / 5) ** expo, min_separation_m=np.full(n, 1e-6),
            force_n=w * 9.80665, peak_pressure_pa=np.full(n, peak_pa), contact_width_m=np.full(n, 1e-3),
            n_nodes=np.full(n, 10), converged=np.ones(n, bool),
        )
        for name, expo in (("greenwood_tripp", 0.8), ("hertz", 2 / 3))
    }  # fmt: skip
    fingerprint = config_fingerprint(SimConfig.from_scene(scene if scene is not None else load_scene()))
    provenance = {"software_version": "test", "fingerprint": fingerprint, **(provenance_extra or {})}
    return save_sweep(SweepResult(models=models, warnings=list(warnings), provenance=provenance), path)
