"""Damaged, altered and hostile sweep and contact-database files (``contactrig simulate -o`` / ``database -o``):
bounded time, one-line errors naming the file, no silent wrong; their seal (daq.file_seal) on the reading side."""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from contactrig.core.validation import SettingError
from daq import file_seal
from daq.database_file import load_database, save_database
from daq.sweep_file import load_sweep, save_sweep

from .hostile import _copy_then, _delete, _fifo, _foreign_hdf5, _replace, _truncate, _write, _zero_page


@pytest.fixture(scope="module")
def sweep_file(tmp_path_factory) -> Path:
    from sims.rig.sweep import ModelSweep, SweepResult

    w = np.array([5.44, 10.526, 25.966])
    m = ModelSweep("hertz", w, w * 1e-6, w * 1e-7, w * 9.8, w * 1e5, w * 1e-4, np.full(3, 64), np.ones(3, bool))
    result = SweepResult({"hertz": m}, ["a warning"], {"scene_text": "[rig]\n", "software_version": "test"})
    return save_sweep(result, tmp_path_factory.mktemp("sweep") / "sim.h5")


@pytest.fixture(scope="module")
def database_file(tmp_path_factory) -> Path:
    from sims.database import ContactCurve, ContactDatabase

    h = np.linspace(1e-7, 1e-6, 12)
    curve = ContactCurve("hertz", h, 1e6 * (1e-6 - h) + 1.0, 0.1 * (1e-6 - h) / 1e-6 + 1e-3, {"k": 1})
    return save_database(ContactDatabase({"hertz": curve}, {"models": ["hertz"], "scene_name": "t"}),
                         tmp_path_factory.mktemp("db") / "db.h5")  # fmt: skip


def _sealed(good: Path, out: Path) -> None:
    shutil.copyfile(good, out)
    with h5py.File(out, "a") as f:
        file_seal.seal(f)


def _sealed_then(edit):
    def make(good: Path, out: Path) -> None:
        _sealed(good, out)
        with h5py.File(out, "a") as f:
            edit(f)

    return make


COMMON = [
    ("truncated", "error", _truncate(0.5)),
    ("zeroed-page-0", "error", _zero_page(0)),
    ("zeroed-page-1", "any", _zero_page(1)),
    ("random-bytes", "error", _write(os.urandom(20_000))),
    ("empty", "error", _write(b"")),
    ("foreign-hdf5", "error", _foreign_hdf5),
    ("fifo", "error", _fifo),
    ("sealed", "same", _sealed),
]
SWEEP = [
    *COMMON,
    ("area-2d", "error", _copy_then(_replace("models/hertz/contact_area_m2", np.ones((3, 2))))),
    ("area-as-strings", "error", _copy_then(_replace("models/hertz/contact_area_m2", np.array([b"1", b"2", b"3"])))),
    ("provenance-json-list", "error", _copy_then(_replace("provenance_json", "[1]", h5py.string_dtype()))),
    ("provenance-as-int", "error", _copy_then(_replace("provenance_json", 5))),
    ("warnings-as-int", "error", _copy_then(_replace("warnings", np.arange(3)))),
    ("models-deleted", "error", _copy_then(_delete("models"))),
    ("force-deleted", "error", _copy_then(_delete("models/hertz/force_n"))),
    ("sealed-area-altered", "error", _sealed_then(lambda f: f["models/hertz/contact_area_m2"].__setitem__(0, 1.0))),
    (
        "sealed-scene-altered",
        "error",
        _sealed_then(_replace("scene_text", "[rig]\nclearance_m = 1\n", h5py.string_dtype())),
    ),
    ("sealed-member-added", "error", _sealed_then(lambda f: f.create_dataset("extra", data=1))),
]
DATABASE = [
    *COMMON,
    ("pressure-2d", "error", _copy_then(_replace("hertz/pressure_pa", np.ones((12, 2))))),
    ("pressure-as-strings", "error", _copy_then(_replace("hertz/pressure_pa", np.array([b"1"] * 12)))),
    ("pressure-increasing", "error", _copy_then(_replace("hertz/pressure_pa", np.linspace(1, 2, 12)))),
    ("separation-deleted", "error", _copy_then(_delete("hertz/separation_m"))),
    ("provenance-json-list", "error", _copy_then(lambda f: f.attrs.__setitem__("provenance", "[1, 2]"))),
    ("parameters-not-json", "error", _copy_then(lambda f: f["hertz"].attrs.__setitem__("parameters", "{oops"))),
    ("sealed-pressure-altered", "error", _sealed_then(lambda f: f["hertz/pressure_pa"].__setitem__(0, 2000000.0))),
]


def _check(load, good: Path, tmp_path: Path, name: str, expect: str, make, same) -> None:
    out = tmp_path / f"{name}.h5"
    make(good, out)
    t0 = time.monotonic()
    try:
        back = load(out, timeout=3.0)
    except (ValueError, OSError) as exc:
        assert expect in ("error", "any"), f"{name}: refused: {exc}"
        assert "\n" not in str(exc) and str(out) in str(exc), str(exc)
        assert time.monotonic() - t0 < 6
        return
    assert expect != "error", f"{name}: accepted"
    same(back, load(good))
    assert back.provenance["sealed"] == (name == "sealed")
    assert name == "sealed" or "UNSEALED" in back.provenance["file_notes"][0]


def _same_sweep(a, b) -> None:
    assert a.warnings == b.warnings and list(a.models) == list(b.models)
    for attr in ("weight_kg", "contact_area_m2", "force_n", "converged"):
        np.testing.assert_array_equal(getattr(a.models["hertz"], attr), getattr(b.models["hertz"], attr))


def _same_database(a, b) -> None:
    assert list(a) == list(b)
    for key in ("separation_m", "pressure_pa", "area_fraction"):
        np.testing.assert_array_equal(getattr(a["hertz"], key), getattr(b["hertz"], key))


@pytest.mark.parametrize(("name", "expect", "make"), SWEEP, ids=[v[0] for v in SWEEP])
def test_load_sweep_on_damaged_files(sweep_file, tmp_path, name, expect, make):
    _check(load_sweep, sweep_file, tmp_path, name, expect, make, _same_sweep)


@pytest.mark.parametrize(("name", "expect", "make"), DATABASE, ids=[v[0] for v in DATABASE])
def test_load_database_on_damaged_files(database_file, tmp_path, name, expect, make):
    _check(load_database, database_file, tmp_path, name, expect, make, _same_database)


def test_database_errors_stay_setting_errors(database_file, tmp_path):
    (tmp_path / "x.h5").write_bytes(b"junk")
    with pytest.raises(SettingError, match="not a readable HDF5"):
        load_database(tmp_path / "x.h5")
    with pytest.raises(SettingError, match="file not found"):
        load_database(tmp_path / "missing.h5")
