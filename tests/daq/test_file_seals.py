"""Sweep and database files are sealed when written: a value changed afterwards is reported, never used (#16)."""

from __future__ import annotations

import warnings

import h5py
import pytest

from contactrig.core.scene import load_scene
from daq.database_file import load_database, save_database
from daq.sweep_file import load_sweep, save_sweep
from sims.config import SimConfig
from sims.database import build_database
from sims.rig import sweep


@pytest.fixture(scope="module")
def config():
    return SimConfig.from_scene(load_scene())


def test_a_sweep_file_altered_after_writing_is_refused(config, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        result = sweep(config, models=["greenwood_tripp"], weights_kg=[5.44, 10.526])
    path = save_sweep(result, tmp_path / "sweep.h5")
    back = load_sweep(path)
    assert back.provenance["sealed"] is True
    gt = "greenwood_tripp"
    assert list(back.models[gt].contact_area_m2) == list(result.models[gt].contact_area_m2)
    with h5py.File(path, "r+") as f:
        area = f["models/greenwood_tripp/contact_area_m2"]
        area[0] = area[0] * 1.1  # a 10 % larger area: a plausible, silent-looking change
    with pytest.raises(ValueError, match="contact_area_m2 changed after the sweep file was sealed"):
        load_sweep(path)


def test_a_database_file_altered_after_writing_is_refused(config, tmp_path):
    path = save_database(build_database(config, ["greenwood_tripp"]), tmp_path / "db.h5")
    assert load_database(path).provenance["sealed"] is True
    with h5py.File(path, "r+") as f:
        f["greenwood_tripp"].attrs["parameters"] = '{"E_star_pa": 1}'
    with pytest.raises(ValueError, match="changed after the contact database was sealed"):
        load_database(path)
