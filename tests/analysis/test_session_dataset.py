"""``contactrig export SESSION --to netcdf`` and :func:`analysis.session_dataset.session_dataset` (issue 29).

The file is checked from the outside: opened with xarray (h5netcdf engine) and with h5py as a plain HDF5 file whose
netCDF-4 dimensions are HDF5 dimension scales, and through h5netcdf's netCDF4-python-compatible API; every value is
compared with the session as our checking reader (:func:`daq.session_file.load_session`) returns it, never with an
earlier output of ours. Sessions: one with flagged readings (2182A overflows and a block in compliance), one acquired
with overrides, an adaptive one (schema 4) and an old one (schema 1)."""

from __future__ import annotations

import dataclasses
import datetime
import hashlib
import json
import math
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

from contactrig.cli.main import main
from daq.plan import SessionPlan
from tests.daq.conftest import make_link, small_scene
from tests.daq.sessions import load_quietly, unseal, write_session

xr = pytest.importorskip("xarray", reason="the netcdf extra (xarray, h5netcdf) is not installed")
pytest.importorskip("h5netcdf", reason="the netcdf extra (xarray, h5netcdf) is not installed")

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def flagged(tmp_path_factory) -> Path:
    """A session with overflow readings (+9.9E37 at positions 2 and 5 of every block) and, at the second weight, the
    source in compliance (20 Ω × 10 mA > 0.1 V): both kinds of flagged readings."""
    from instruments.simulated import Faults

    plan = SessionPlan.from_scene(small_scene())
    settings = dataclasses.replace(plan.block_settings)
    object.__setattr__(settings, "compliance_abort", False)
    object.__setattr__(settings, "compliance_v", 0.1)
    plan = dataclasses.replace(plan, block_settings=settings)
    link = make_link(plan, faults=Faults(overflow_readings={2, 5}))
    bench = link.bench
    link._place_weight = lambda w: setattr(bench, "resistance_ohm", 20.0 if w == plan.session.weights_kg[1] else 1e-3)
    path = tmp_path_factory.mktemp("flagged") / "flagged.h5"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # compliance and invalid readings on purpose
        outcome, _ = write_session(plan, path, link=link)
    assert outcome.stop.status == "success"
    return path


def _export(session: Path, out: Path, *extra: str) -> Path:
    assert main(["export", str(session), "--to", "netcdf", "-o", str(out), *extra]) == 0
    return out


def _same(a, b) -> bool:
    """Equal arrays, NaN where the other has NaN."""
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=a.dtype.kind == "f"))


def _check_against_reader(nc: Path, session_path: Path) -> xr.Dataset:
    """Every variable of the file, opened with xarray, equals what the checking reader returns; the flags are
    derived here from the reader's columns."""
    s = load_quietly(session_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no decoding surprise (e.g. a unit taken for a time delta)
        ds = xr.open_dataset(nc, engine="h5netcdf").load()
    assert dict(ds.sizes) == {"block": len(s.summary), "reading": len(s.readings)}
    assert _same(ds["block"], s.summary["block"].to_numpy() + 1)  # 1-based, as every output
    for var, col in (("weight", "weight_kg"), ("repeat", "repeat"), ("run", "run"), ("mean_resistance", "mean_ohm"),
                     ("sd_resistance", "sd_ohm"), ("sem_resistance", "sem_ohm"), ("n_valid", "n"),
                     ("n_invalid", "n_invalid")):  # fmt: skip
        assert _same(ds[var], s.summary[col].to_numpy()), var
    assert _same(ds["compliance"], s.summary["compliance"].to_numpy().astype(np.uint8))
    assert list(ds["block_started"].values) == [str(t) for t in s.summary["started"]]
    r = s.readings
    assert _same(ds["reading_block"], r["block"].to_numpy() + 1)
    for var, col in (("reading_index", "index"), ("time", "time_s"), ("raw_reading", "reading"),
                     ("resistance", "resistance_ohm")):  # fmt: skip
        assert _same(ds[var], r[col].to_numpy()), var
    assert _same(ds["valid"], r["valid"].to_numpy().astype(np.uint8))
    expected = (
        np.where(r["valid"].to_numpy(), 0, 1)
        + np.where(np.isnan(r["reading"].to_numpy()), 2, 0)
        + np.where(r["block"].isin(s.compliant_blocks).to_numpy(), 4, 0)
    )
    assert _same(ds["reading_flag"], expected)
    flags = ds["reading_flag"].attrs
    assert list(flags["flag_masks"]) == [1, 2, 4] and flags["flag_meanings"].split() == ["invalid", "no_value",
                                                                                          "compliance"]  # fmt: skip
    units = {k: v.attrs.get("units") for k, v in ds.variables.items()}
    assert units["weight"] == "kg" and units["time"] == "s" and units["raw_reading"] == "V"
    assert {units[k] for k in ("mean_resistance", "sd_resistance", "sem_resistance", "resistance")} == {"ohm"}
    assert all(units[k] == "1" for k in ("block", "n_valid", "n_invalid", "reading_flag", "compliance", "valid"))
    assert all(isinstance(v.attrs.get("long_name"), str) for v in ds.variables.values())
    start, stop = s.start, s.stop or {}
    assert ds.attrs["status"] == s.status and ds.attrs["schema_version"] == s.schema_version
    assert ds.attrs["start_time"] == start["started"] and ds.attrs["end_time"] == stop.get("stopped", "")
    assert ds.attrs["scene_sha256"] == hashlib.sha256(s.scene_text.encode()).hexdigest()
    assert ds.attrs["scene_text"] == s.scene_text and ds.attrs["sealed"] == int(s.sealed)
    assert ds.attrs["instrument_source_idn"] == start["instrument"]["source"]
    assert ds.attrs["instrument_voltmeter_idn"] == start["instrument"]["voltmeter"]
    assert json.loads(ds.attrs["instrument_settings"])["delta"] == start["plan"]["delta"]
    assert json.loads(ds.attrs["overrides"]) == start.get("overrides", {})
    assert json.loads(ds.attrs["runs"]) == json.loads(json.dumps(s.runs))
    assert ds.attrs["Conventions"].startswith("CF-")
    return ds


def test_flagged_readings_are_kept_with_their_flags(flagged, tmp_path):
    """Overflows and the compliance block's readings are all in the file, flagged; nothing is dropped."""
    ds = _check_against_reader(_export(flagged, tmp_path / "f.nc"), flagged)
    flag = ds["reading_flag"].values
    assert np.count_nonzero(flag & 2) == 2 * 6  # two overflows (+9.9E37) in each of the six blocks
    assert int(ds["compliance"].sum()) == 2 and np.count_nonzero(flag & 4) == 2 * 8  # both repeats, second weight
    assert np.count_nonzero(flag) == 4 * 2 + 2 * 8 and ds.sizes["reading"] == 6 * 8  # every reading kept
    assert np.isnan(ds["mean_resistance"].values[ds["compliance"].values == 1]).all()
    assert ds.attrs["sample"] == "test sample" and ds.attrs["operator"] == "tester"
    assert ds.attrs["scene_name"] == "daq-test"


def test_plain_hdf5_and_netcdf4_readers_see_the_dimensions(flagged, tmp_path):
    """Without xarray: h5py finds every variable's dimensions as HDF5 dimension scales named block and reading (how
    netCDF-4 stores them), the units attributes, and the values; h5netcdf's netCDF4-python API lists the same."""
    import h5netcdf.legacyapi as nc4

    nc = _export(flagged, tmp_path / "f.nc")
    s = load_quietly(flagged)
    with h5py.File(nc, "r") as h5:
        assert "_NCProperties" in h5.attrs  # written by a netCDF-4 writer
        for name, dim in (("resistance", "reading"), ("mean_resistance", "block"), ("reading_flag", "reading")):
            scales = h5[name].dims[0]
            assert len(scales) == 1 and scales[0].name == f"/{dim}", name
            assert h5[dim].attrs["CLASS"] == b"DIMENSION_SCALE"
        assert h5["resistance"].attrs["units"] in (b"ohm", "ohm")
        assert _same(h5["resistance"][()], s.readings["resistance_ohm"].to_numpy())
        assert _same(h5["block"][()], s.summary["block"].to_numpy() + 1)
    with nc4.Dataset(nc, "r") as d:
        assert {k: len(v) for k, v in d.dimensions.items()} == {"block": len(s.summary), "reading": len(s.readings)}
        assert d.variables["weight"].dimensions == ("block",) and d.variables["weight"].units == "kg"
        assert d.getncattr("sample") == "test sample"


def test_acquired_session_with_overrides(tmp_path):
    """A session acquired through the real path (software versions recorded) with overrides."""
    from daq.acquire import acquire
    from daq.link import VisaBench
    from instruments.simulated import SimulatedBench, simulated_resource_manager

    path = tmp_path / "s.h5"
    given = {"session.sample": "steel B", "session.operator": "ann", "session.notes": "new liner"}
    bench = VisaBench(simulated_resource_manager(bench=SimulatedBench(resistance_ohm=5e-3, seed=1, time_scale=0.0)))
    acquire(small_scene(), path, yes=True, bench=bench, quiet=True, overrides=given)
    ds = _check_against_reader(_export(path, tmp_path / "s.nc"), path)
    s = load_quietly(path)
    assert json.loads(ds.attrs["overrides"]) == given
    assert (ds.attrs["sample"], ds.attrs["operator"], ds.attrs["notes"]) == ("steel B", "ann", "new liner")
    assert ds.attrs["software_version"] == s.start["software"]["contactrig"] != ""
    assert ds.attrs["start_time"][-6] in "+-" and ds.attrs["end_time"][-6] in "+-"  # with their UTC offset


def test_adaptive_session_schema_4(tmp_path):
    """An adaptive session: its records (settings, every suggestion and the stop decision) are attributes."""
    from analysis.adaptive_session import adaptive_source
    from analysis.simulated_session import SimulatedRigBench
    from daq.acquire import acquire
    from tests.analysis.test_adaptive_session import _scene

    path = tmp_path / "press.h5"
    acquire(_scene(), path, bench=SimulatedRigBench(math.inf), yes=True, quiet=True,
            adaptive=adaptive_source(30.0, simulated=True))  # fmt: skip
    ds = _check_against_reader(_export(path, tmp_path / "press.nc"), path)
    s = load_quietly(path)
    assert s.schema_version >= 4 and ds.attrs["schema_version"] == s.schema_version
    assert json.loads(ds.attrs["adaptive_start"]) == json.loads(json.dumps(s.start["adaptive"]))
    assert json.loads(ds.attrs["adaptive_stop"]) == json.loads(json.dumps(s.stop["adaptive"]))


def test_old_schema_session(tmp_path):
    """A schema-1 file (no compliance column, no seal) exports through the reader's upgrade chain."""
    plan = SessionPlan.from_scene(small_scene())
    path = tmp_path / "old.h5"
    write_session(plan, path)
    unseal(path)
    with h5py.File(path, "a") as h5:
        del h5["entry/summary/compliance"]
        h5.attrs["contactrig_schema"] = 1
    ds = _check_against_reader(_export(path, tmp_path / "old.nc"), path)
    assert ds.attrs["schema_version"] == 1 and ds.attrs["sealed"] == 0 and int(ds["compliance"].sum()) == 0
    assert "adaptive_stop" not in ds.attrs


def test_existing_output_and_links_are_not_replaced(flagged, tmp_path, capsys):
    out = tmp_path / "f.nc"
    out.write_text("mine")
    assert main(["export", str(flagged), "--to", "netcdf", "-o", str(out)]) == 2
    assert "exists; use --force" in capsys.readouterr().err and out.read_text() == "mine"
    target = tmp_path / "target.txt"
    target.write_text("keep")
    link = tmp_path / "link.nc"
    link.symlink_to(target)
    assert main(["export", str(flagged), "--to", "netcdf", "-o", str(link)]) == 2
    _export(flagged, link, "--force")  # the link is replaced by the file, its target untouched
    assert not link.is_symlink() and target.read_text() == "keep"
    assert main(["export", str(flagged), "--to", "netcdf", "-o", str(flagged), "--force"]) == 2  # not the session
    assert "a file other than the input" in capsys.readouterr().err and load_quietly(flagged).complete
    assert main(["export", str(flagged), "--to", "netcdf", "--fit"]) == 2
    assert "--to netcdf exports a session file" in capsys.readouterr().err


def test_default_output_is_beside_the_session(flagged, tmp_path):
    session = tmp_path / "run.h5"
    session.write_bytes(flagged.read_bytes())
    assert main(["export", str(session), "--to", "netcdf"]) == 0
    assert xr.open_dataset(tmp_path / "run.nc", engine="h5netcdf").sizes["block"] == 6


def test_without_xarray_one_line_naming_the_extra_and_analysis_still_imports(flagged, tmp_path):
    code = (
        "import sys\n"
        "sys.modules['xarray'] = None\n"  # as if not installed: `import xarray` raises ImportError
        "import analysis, analysis.session_dataset, analysis.pipeline, sims\n"
        "from contactrig.cli.main import main\n"
        "sys.exit(main(['export', sys.argv[1], '--to', 'netcdf', '-o', sys.argv[2]]))\n"
    )
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    out = subprocess.run([sys.executable, "-c", code, str(flagged), str(tmp_path / "x.nc")], capture_output=True,
                         text=True, env=env)  # fmt: skip
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "xarray" in lines[0] and "contactrig[netcdf]" in lines[0], out.stderr
    assert not (tmp_path / "x.nc").exists()


def test_paused_session_keeps_its_pauses(tmp_path):
    """A session paused by the operator (schema 5, daq.pause): the pause records are an attribute, as the run
    record in the file holds them (read here with h5py)."""
    import threading
    import time

    from daq.pause import PauseControl
    from tests.daq.test_pause import _run

    plan = SessionPlan.from_scene(small_scene())
    control = PauseControl()
    control.request("check the liner", "ann")

    def resume_when_paused():
        while not control.paused:
            time.sleep(0.01)
        control.resume("bob")

    go, _, _ = _run(plan, tmp_path / "p.h5", control)
    threading.Thread(target=resume_when_paused).start()
    go()
    ds = _check_against_reader(_export(tmp_path / "p.h5", tmp_path / "p.nc"), tmp_path / "p.h5")
    with h5py.File(tmp_path / "p.h5", "r") as h5:
        recorded = json.loads(h5["entry/runs/run_0/record"][()])["pauses"]
    assert json.loads(ds.attrs["pauses"]) == [{**p, "run": 0} for p in recorded]
    assert recorded[0]["reason"] == "check the liner" and recorded[0]["resumed_by"] == "bob"


# --- QCoDeS (issue 29: "readable by xarray and the QCoDeS/xarray tool chain") ---------------------------------------
# What QCoDeS 0.58.0 needs, read from its source (written out here: QCoDeS is not a dependency):
# - qcodes/dataset/data_set_in_memory.py, DataSetInMem._load_from_netcdf: the global attributes guid,
#   captured_run_id, captured_counter (int()), ds_name, exp_name, sample_name, run_description, snapshot,
#   run_timestamp_raw and completed_timestamp_raw (float(); -1 for none), parent_dataset_links and export_info (JSON);
#   _from_xarray_dataset_to_qcodes_raw_data: every dimension of every data variable has an index (a coordinate);
# - qcodes/dataset/descriptions/versioning/rundescribertypes.py and rundescriber.py (RunDescriber._from_dict):
#   run_description of version >= 3 is read from "interdependencies_" (parameters, dependencies, inferences,
#   standalones) and "shapes"; versions 2 and 3 carry "interdependencies" (the ParamSpec list) too;
# - qcodes/parameters/_paramspec.py, ParamSpecBase: paramtype one of array, numeric, text, complex; the name a
#   Python identifier;
# - qcodes/dataset/guids.py, _guid_pattern (validate_guid_format) and parse_guid (sample 8, location 2, work station
#   6, time 16 hex digits: ms since the epoch);
# - qcodes/dataset/exporters/export_to_xarray.py, _add_metadata_to_xarray: the format QCoDeS writes these in.
QCODES_GUID = re.compile(r"^[\da-f]{8}-([\da-f]{4}-){3}[\da-f]{12}$")
QCODES_PARAMTYPES = ("array", "numeric", "text", "complex")


def _epoch(iso: str) -> float:
    """Seconds since 1970-01-01T00:00:00Z of an ISO-8601 instant with its offset, counted here from its parts."""
    t = datetime.datetime.fromisoformat(iso)
    epoch = datetime.datetime(1970, 1, 1, tzinfo=datetime.UTC)
    return (t - epoch) / datetime.timedelta(seconds=1)


def test_qcodes_netcdf_attributes_as_its_loader_reads_them(flagged, tmp_path):
    """The attributes QCoDeS's load_from_netcdf reads (QCoDeS 0.58.0, see above), checked without QCoDeS: present
    with their types, the guid in its format and derived from the session (the same for a copy under another
    name, another for another session), the timestamps the session's start and end, the run description naming
    every variable with its dimensions as setpoints, the snapshot's instruments the session's *IDN? replies."""
    ds = xr.open_dataset(_export(flagged, tmp_path / "f.nc"), engine="h5netcdf")
    s = load_quietly(flagged)
    a = ds.attrs
    for key in ("ds_name", "exp_name", "sample_name", "guid", "run_description", "snapshot", "parent_dataset_links",
                "export_info"):  # fmt: skip
        assert isinstance(a[key], str), key
    assert int(a["captured_run_id"]) == a["captured_run_id"] and int(a["captured_counter"]) == a["captured_counter"]
    assert (a["sample_name"], a["exp_name"], a["ds_name"]) == ("test sample", "daq-test", "flagged")
    assert json.loads(a["parent_dataset_links"]) == [] and isinstance(json.loads(a["export_info"])["export_paths"],
                                                                       dict)  # fmt: skip
    # timestamps: the session's start and end, counted independently
    assert a["run_timestamp_raw"] == pytest.approx(_epoch(s.start["started"]), abs=1e-6)
    assert a["completed_timestamp_raw"] == pytest.approx(_epoch(s.stop["stopped"]), abs=1e-6)
    # guid: QCoDeS's format; time field = the start in ms; the rest from the content id; stable, per session
    guid = a["guid"]
    assert QCODES_GUID.match(guid), guid
    digits = guid.replace("-", "")
    assert int(digits[16:], 16) == round(_epoch(s.start["started"]) * 1000)
    assert digits[:16] == a["content_id"].removeprefix("sha256:")[:16]
    copy = tmp_path / "renamed.h5"
    copy.write_bytes(flagged.read_bytes())
    assert xr.open_dataset(_export(copy, tmp_path / "c.nc"), engine="h5netcdf").attrs["guid"] == guid
    other = tmp_path / "other.h5"
    write_session(SessionPlan.from_scene(small_scene()), other)
    assert xr.open_dataset(_export(other, tmp_path / "o.nc"), engine="h5netcdf").attrs["guid"] != guid
    # run description: every variable a parameter; every data variable depends on its dimensions' coordinates
    rd = json.loads(a["run_description"])
    assert rd["version"] == 3
    new = rd["interdependencies_"]
    assert set(new["parameters"]) == {str(v) for v in ds.variables} and new["inferences"] == {}
    assert new["standalones"] == []
    assert new["dependencies"] == {str(v): list(ds[v].dims) for v in ds.data_vars}
    assert all(dim in ds.indexes for v in ds.data_vars for dim in ds[v].dims)  # an index per dimension
    for name, spec in new["parameters"].items():
        assert spec["name"] == name and name.isidentifier() and spec["paramtype"] in QCODES_PARAMTYPES
        assert (spec["label"], spec["unit"]) == (ds[name].attrs["long_name"], ds[name].attrs.get("units", ""))
    assert new["parameters"]["block_started"]["paramtype"] == "text"
    assert new["parameters"]["resistance"]["paramtype"] == "numeric"
    old = {p["name"]: p for p in rd["interdependencies"]["paramspecs"]}
    assert {n: p["depends_on"] for n, p in old.items()} == {n: new["dependencies"].get(n, []) for n in old}
    assert rd["shapes"] == {str(v): list(ds[v].shape) for v in ds.data_vars}
    # snapshot: a station snapshot whose instruments carry the recorded *IDN? replies (QCoDeS's IDN value)
    instruments = json.loads(a["snapshot"])["station"]["instruments"]
    for role in ("source", "voltmeter"):
        reply = s.start["instrument"][role]
        idn = instruments[role]["parameters"]["IDN"]
        assert idn["raw_value"] == reply
        assert [idn["value"][k] for k in ("vendor", "model", "serial", "firmware")] == [p.strip() for p in
                                                                                        reply.split(",")]  # fmt: skip
    # the reading dimension's coordinate (QCoDeS needs one): 0, 1, … in the order of the readings table
    assert _same(ds["reading"], np.arange(len(s.readings)))


def test_qcodes_loads_the_export(flagged, tmp_path):
    """The round trip through QCoDeS itself, where it is installed (it is not a dependency; CI skips this):
    load_from_netcdf, the guid and sample, to_xarray_dataset with the reader's values, the pandas frames.

    Checked once here (2026-11-27) with QCoDeS 0.58.0 in a venv of its own that also sees the project's packages:
      python3 -m venv /tmp/qcvenv && /tmp/qcvenv/bin/pip install qcodes h5netcdf
      echo /work/main/.venv/lib/python3.11/site-packages > /tmp/qcvenv/lib/python3.11/site-packages/zz_main.pth
      PYTHONPATH=$PWD /tmp/qcvenv/bin/python -m pytest -q tests/analysis/test_session_dataset.py -k qcodes"""
    pytest.importorskip("qcodes", reason="QCoDeS is not installed (not a dependency: the round trip is optional)")
    from qcodes.dataset import load_from_netcdf
    from qcodes.dataset.guids import parse_guid, validate_guid_format

    nc = _export(flagged, tmp_path / "f.nc")
    guid = xr.open_dataset(nc, engine="h5netcdf").attrs["guid"]
    s = load_quietly(flagged)
    q = load_from_netcdf(nc, path_to_db=tmp_path / "qcodes.db")
    validate_guid_format(q.guid)
    assert q.guid == guid and parse_guid(q.guid)["time"] == round(_epoch(s.start["started"]) * 1000)
    assert q.sample_name == "test sample" and q.exp_name == "daq-test" and q.name == "flagged"
    assert q.run_timestamp_raw == pytest.approx(_epoch(s.start["started"]))
    assert q.completed_timestamp_raw == pytest.approx(_epoch(s.stop["stopped"]))
    assert q.snapshot["station"]["instruments"]["voltmeter"]["parameters"]["IDN"]["value"]["model"] == "MODEL 2182A"
    assert q.metadata["operator"] == "tester" and q.metadata["scene_sha256"] == hashlib.sha256(
        s.scene_text.encode()).hexdigest()  # fmt: skip
    x = q.to_xarray_dataset()
    for var, col in (("weight", "weight_kg"), ("mean_resistance", "mean_ohm"), ("sem_resistance", "sem_ohm"),
                     ("n_valid", "n")):  # fmt: skip
        assert _same(x[var], s.summary[col].to_numpy()), var
    assert _same(x["resistance"], s.readings["resistance_ohm"].to_numpy())
    assert _same(x["raw_reading"], s.readings["reading"].to_numpy())  # NaN where the 2182A overflowed
    assert x["weight"].attrs["units"] == "kg"
    frames = q.to_pandas_dataframe_dict()
    assert set(frames) == {str(v) for v in x.data_vars}
    assert list(frames["mean_resistance"].index) == list(s.summary["block"].to_numpy() + 1)
    assert _same(frames["resistance"]["resistance"].to_numpy(), s.readings["resistance_ohm"].to_numpy())
    with pytest.warns(UserWarning, match="setpoints are not equal"):  # one frame for both dimensions: QCoDeS
        one = q.to_pandas_dataframe()  # joins block and reading numbers on one index, and says so
    assert set(one.index) == set(s.summary["block"].to_numpy() + 1) | set(range(len(s.readings)))


def test_qcodes_unfinished_session_has_no_completed_timestamp(tmp_path):
    """A session without a stop record (killed or still running): completed_timestamp_raw is QCoDeS's sentinel
    for none, -1 (export_to_xarray.py writes it, _load_from_netcdf reads it back as None); loaded by QCoDeS where
    installed, its completed timestamp is None."""
    from tests.analysis.sessions import model_resistance
    from tests.analysis.sessions import write_session as write_rows

    rng = np.random.default_rng(0)
    path = write_rows(tmp_path / "inc.h5", ((w, 1, model_resistance(w, rng, 0.01)) for w in (5.0, 10.0, 20.0)))
    s = load_quietly(path)
    assert not s.complete
    nc = _export(path, tmp_path / "inc.nc")
    a = xr.open_dataset(nc, engine="h5netcdf").attrs
    assert a["completed_timestamp_raw"] == -1
    assert a["run_timestamp_raw"] == pytest.approx(_epoch(s.start["started"]), abs=1e-6)
    try:
        from qcodes.dataset import load_from_netcdf
    except ImportError:
        return  # QCoDeS is not a dependency
    q = load_from_netcdf(nc, path_to_db=tmp_path / "qcodes.db")
    assert q.completed_timestamp_raw is None and q.run_timestamp_raw == pytest.approx(a["run_timestamp_raw"])


def test_qcodes_imported_table_has_no_instruments(tmp_path):
    """An imported table (``contactrig import --tab1``) records no *IDN? reply: its snapshot's station holds no
    instrument (none is invented), and its run description still names every variable."""
    path = tmp_path / "tab1.h5"
    assert main(["import", "--tab1", "-o", str(path)]) == 0
    ds = xr.open_dataset(_export(path, tmp_path / "tab1.nc"), engine="h5netcdf")
    assert json.loads(ds.attrs["snapshot"])["station"]["instruments"] == {}
    assert set(json.loads(ds.attrs["run_description"])["interdependencies_"]["dependencies"]) == set(ds.data_vars)
    assert QCODES_GUID.match(ds.attrs["guid"]) and ds.sizes["reading"] == 8 * 6  # Tab. 1: 8 weights × 6 repeats
