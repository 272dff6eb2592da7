"""The HDF5 session file: layout, records, checksums, and one clear error per fault."""

from __future__ import annotations

import errno
import os
import resource
import signal
import subprocess
import sys
import warnings

import h5py
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import daq
from contactrig.core.validation import SettingError
from daq import session_file
from daq.errors import (
    ChecksumError,
    FileLockingError,
    IncompleteSessionWarning,
    NewerSchemaError,
    SessionExistsError,
    SessionFileError,
    SessionWriteError,
)
from daq.records import BlockRecord, StopRecord, now_iso
from daq.session_file import SCHEMA_VERSION, SessionFile, load_session
from daq.writers import FileWriter

from .sessions import unseal, write_session


@pytest.fixture
def session_path(plan, tmp_path):
    path = tmp_path / "s.h5"
    outcome, _ = write_session(plan, path)
    assert outcome.stop.status == "success", outcome.stop.reason
    return path


def test_roundtrip_contract(session_path, plan):
    s = daq.load_session(session_path)
    assert s.complete and not s.imported and s.status == "success"
    assert list(s.summary.columns[:9]) == [
        "block", "run", "weight_kg", "repeat", "mean_ohm", "sd_ohm", "sem_ohm", "n", "n_invalid",
    ]  # fmt: skip
    assert len(s.summary) == plan.blocks_planned
    assert len(s.readings) == plan.blocks_planned * plan.block_settings.count
    assert set(s.readings.columns) >= {"weight_kg", "repeat", "index", "time_s", "resistance_ohm", "valid"}
    # summary statistics recomputed independently with pandas from the readings
    g = s.readings[s.readings.valid].groupby("block").resistance_ohm
    np.testing.assert_allclose(g.mean().to_numpy(), s.summary.mean_ohm.to_numpy(), rtol=1e-12)
    np.testing.assert_allclose(g.std(ddof=1).to_numpy(), s.summary.sd_ohm.to_numpy(), rtol=1e-9)
    np.testing.assert_allclose((g.std(ddof=1) / np.sqrt(g.count())).to_numpy(), s.summary.sem_ohm.to_numpy(), rtol=1e-9)
    assert s.stop["blocks_in_file"] == plan.blocks_planned


def test_simulated_readings_measure_the_bench_resistance(session_path):
    """The V readings divided by ΔI give the resistance the simulated bench was set to (within its noise)."""
    from .conftest import resistance_at

    s = load_session(session_path)
    for w, mean in s.summary.groupby("weight_kg").mean_ohm.mean().items():
        assert mean == pytest.approx(resistance_at(w), rel=1e-3)
    means = s.summary.groupby("weight_kg").mean_ohm.mean().to_numpy()
    assert np.all(np.diff(means) < 0)  # heavier weight, lower resistance (like Tab. 1)


def test_nexus_layout_and_units(session_path):
    with h5py.File(session_path, "r") as h5:
        assert h5.attrs["default"] == "entry"
        assert h5.attrs["contactrig_schema"] == SCHEMA_VERSION
        entry = h5["entry"]
        assert entry.attrs["NX_class"] == "NXentry" and entry.attrs["default"] == "summary"
        summary = entry["summary"]
        assert summary.attrs["NX_class"] == "NXdata" and summary.attrs["signal"] == "mean_ohm"
        assert list(summary.attrs["axes"]) == ["weight_kg"]
        for name in ("weight_kg", "mean_ohm", "sd_ohm", "sem_ohm"):
            assert summary[name].attrs["units"] in ("kg", "ohm")
        assert summary["mean_ohm_errors"].id == summary["sem_ohm"].id
        readings = entry["readings"]
        assert readings.attrs["signal"] == "resistance_ohm"
        assert readings["resistance_ohm"].attrs["units"] == "ohm" and readings["time_s"].attrs["units"] == "s"
        assert readings["reading"].attrs["units"] == "V"
        assert readings["resistance_ohm"].maxshape == (None,) and readings["resistance_ohm"].chunks
        assert "scene_text" in entry["start"] and "T" in entry["start_time"].asstr()[()]
        assert entry["stop"].attrs["status"] == "success"


def test_exchanges_recorded_per_block(session_path, plan):
    s = load_session(session_path)
    ex = s.exchanges
    assert set(ex.block) == {-1, *range(plan.blocks_planned)}
    assert "*IDN?" in set(ex[ex.block == -1].message)
    for b in range(plan.blocks_planned):
        msgs = list(ex[ex.block == b].message)
        assert "INIT:IMM" in msgs and msgs[-1] == "SOUR:SWE:ABOR"
    assert ex.message.iloc[-1] == "SOUR:SWE:ABOR"  # closing leaves the source idle


def _rows(n=3):
    out = []
    for b in range(n):
        r = np.linspace(1e-3, 2e-3, 5) + b * 1e-4
        out.append(
            BlockRecord(
                block=b, run=0, weight_kg=1.0 + b, repeat=1, unit="V", reading=r, time_s=np.arange(5.0),
                resistance_ohm=r, valid=np.ones(5, bool), started=now_iso(),
            )
        )  # fmt: skip
    return out


def test_incomplete_session_says_so(tmp_path):
    path = tmp_path / "inc.h5"
    with SessionFile.create(path) as sf:
        sf.write_start({"started": now_iso()}, "")
        for rec in _rows():
            sf.append_block(rec)
    with pytest.warns(IncompleteSessionWarning, match="INCOMPLETE"):
        s = load_session(path)
    assert not s.complete and s.status == "incomplete" and s.stop is None and len(s.summary) == 3
    assert any("INCOMPLETE" in w for w in s.warnings)


def test_trailing_readings_of_an_unfinished_block_are_ignored(tmp_path):
    path = tmp_path / "cut.h5"
    with SessionFile.create(path) as sf:
        sf.write_start({"started": now_iso()}, "")
        for rec in _rows(2):
            sf.append_block(rec)
    with h5py.File(path, "a") as h5:  # what a kill between readings and summary leaves
        for name in ("block", "index", "time_s", "reading", "resistance_ohm", "valid"):
            h5["entry/readings"][name].resize((13,))
    with pytest.warns(IncompleteSessionWarning, match="3 readings of an unfinished block ignored"):
        s = load_session(path)
    assert len(s.readings) == 10


@pytest.mark.parametrize("target", ["entry/readings/resistance_ohm", "entry/summary/mean_ohm", "entry/readings/valid"])
def test_corrupted_values_fail_the_checksum(session_path, target):
    with h5py.File(session_path, "a") as h5:
        ds = h5[target]
        ds[1] = 0 if ds.dtype.kind == "u" else ds[1] * 1.0000001 + 1e-12
    with pytest.raises(ChecksumError, match=r"SHA-256 mismatch in block [12] "):
        load_session(session_path)


def test_removed_block_fails_the_stop_record_check(session_path):
    with h5py.File(session_path, "a") as h5:
        for name in h5["entry/summary"]:
            ds = h5["entry/summary"][name]
            ds.resize((ds.shape[0] - 1,))
    with pytest.raises(ChecksumError, match="stop record counts"):
        load_session(session_path)


def test_truncated_file(session_path):
    size = session_path.stat().st_size
    with open(session_path, "r+b") as fh:
        fh.truncate(size // 2)
    with pytest.raises(SessionFileError, match=r"truncated or corrupted|damaged"):
        load_session(session_path)


def test_garbage_and_foreign_files(tmp_path):
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"not an hdf5 file at all" * 10)
    with pytest.raises(SessionFileError, match="truncated or corrupted"):
        load_session(junk)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as h5:
        h5["x"] = 1
    with pytest.raises(SessionFileError, match="not a contactrig session"):
        load_session(other)
    with pytest.raises(FileNotFoundError, match="no such session file"):
        load_session(tmp_path / "missing.h5")


def test_newer_schema_is_refused_with_advice(session_path):
    with h5py.File(session_path, "a") as h5:
        h5.attrs["contactrig_schema"] = SCHEMA_VERSION + 1
    with pytest.raises(NewerSchemaError, match=rf"schema {SCHEMA_VERSION + 1}.*upgrade contactrig"):
        load_session(session_path)


def test_older_schema_goes_through_upgrade_functions(session_path, monkeypatch):
    unseal(session_path)
    with h5py.File(session_path, "a") as h5:
        h5.attrs["contactrig_schema"] = 0
    with pytest.raises(SessionFileError, match="no upgrade path"):
        load_session(session_path)

    def upgrade(raw):  # runs in the reading child process: it leaves its mark on what comes back
        return {**raw, "scene_text": raw["scene_text"] + "# upgraded from 0\n"}

    monkeypatch.setitem(session_file.UPGRADES, 0, upgrade)
    with pytest.warns(UserWarning, match="UNSEALED"):
        s = load_session(session_path)
    assert s.scene_text.endswith("# upgraded from 0\n") and s.schema_version == 0 and not s.sealed


def _as_schema_1(path):
    """Turn a file written now into what schema 1 wrote: no compliance column, schema attribute 1."""
    if "stop" in h5py.File(path, "r")["entry"]:
        unseal(path)
    with h5py.File(path, "a") as h5:
        del h5["entry/summary/compliance"]
        h5.attrs["contactrig_schema"] = 1


def test_schema_1_file_loads_with_no_block_flagged_and_its_checksums_hold(session_path, plan):
    _as_schema_1(session_path)
    with pytest.warns(UserWarning, match="UNSEALED"):
        s = load_session(session_path)  # checksums verified: schema 1 digests are unchanged for unflagged blocks
    assert s.schema_version == 1 and len(s.summary) == plan.blocks_planned
    assert s.summary["compliance"].dtype == bool and not s.compliance.any() and s.compliant_blocks == []


def test_resuming_a_schema_1_file_upgrades_it_in_place(tmp_path):
    path = tmp_path / "old.h5"
    rows = _rows(4)
    with SessionFile.create(path) as sf:
        sf.write_start({"started": now_iso()}, "")
        for rec in rows[:2]:
            sf.append_block(rec)
    _as_schema_1(path)
    with SessionFile.open_for_resume(path) as sf:
        for rec in rows[2:]:
            sf.append_block(_compliant(rec) if rec.block == 3 else rec)
        sf.write_stop(StopRecord("success", "done", now_iso(), 4, 4, 20))
    s = load_session(path)
    assert s.schema_version == SCHEMA_VERSION and s.compliant_blocks == [3]
    with h5py.File(path, "r") as h5:
        assert h5["entry/summary/compliance"].shape == (4,)
        assert h5["entry/summary/compliance"].attrs["units"] == "1"


def _compliant(rec):
    return BlockRecord(
        block=rec.block, run=rec.run, weight_kg=rec.weight_kg, repeat=rec.repeat, unit=rec.unit, reading=rec.reading,
        time_s=rec.time_s, resistance_ohm=rec.resistance_ohm, valid=np.ones(rec.reading.size, bool),
        started=rec.started, compliance=True,
    )  # fmt: skip


def test_compliant_block_is_flagged_excluded_and_checksummed(tmp_path):
    path = tmp_path / "c.h5"
    rows = _rows(3)
    rows[1] = _compliant(rows[1])
    with SessionFile.create(path) as sf:
        sf.write_start({"started": now_iso()}, "")
        for rec in rows:
            sf.append_block(rec)
        sf.write_stop(StopRecord("success", "done", now_iso(), 3, 3, 15))
    s = load_session(path)
    assert s.compliance.tolist() == [False, True, False] and s.compliant_blocks == [1]
    row = s.summary.iloc[1]
    # the readings are kept as taken, but none counts: no mean, every reading invalid
    assert np.isnan(row.mean_ohm) and np.isnan(row.sd_ohm) and row.n == 0 and row.n_invalid == 5
    assert not s.readings[s.readings.block == 1].valid.any()
    np.testing.assert_array_equal(s.readings[s.readings.block == 1].reading, rows[1].reading)
    assert np.isfinite(s.summary.mean_ohm[[0, 2]]).all()
    # clearing the flag on disk (to slip the block back in) breaks its checksum
    with h5py.File(path, "a") as h5:
        h5["entry/summary/compliance"][1] = 0
    with pytest.raises(ChecksumError, match="block 2 "):
        load_session(path)


def test_existing_file_is_never_overwritten_without_force(session_path):
    before = session_path.read_bytes()
    with pytest.raises(SessionExistsError, match="--force"):
        SessionFile.create(session_path)
    assert session_path.read_bytes() == before
    SessionFile.create(session_path, force=True).close()  # never given its name: nothing replaced
    assert session_path.read_bytes() == before
    with SessionFile.create(session_path, force=True) as sf:
        sf.write_start({"started": now_iso()}, "")  # the start record on disk: now it takes the name
    assert session_path.read_bytes() != before
    assert [p.name for p in session_path.parent.iterdir()] == [session_path.name]  # no temporary file left


def test_unwritable_paths(tmp_path):
    (tmp_path / "afile").write_bytes(b"")
    with pytest.raises(SettingError, match="expected a folder; a file of that name exists"):
        SessionFile.create(tmp_path / "afile" / "s.h5")
    with pytest.raises(SessionWriteError, match="folder, not a file"):
        SessionFile.create(tmp_path, force=True)
    if os.path.isdir("/sys/kernel"):
        with pytest.raises(SessionWriteError, match="no permission to write"):
            SessionFile.create("/sys/kernel/contactrig-test.h5")


def test_file_in_use_by_another_process(session_path):
    holder = subprocess.Popen(
        [sys.executable, "-c", f"import h5py,sys; f=h5py.File({str(session_path)!r},'a'); print('ok', flush=True); "
         "sys.stdin.read()"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert holder.stdout.readline().strip() == "ok"
        # readers are not locked out (a session is readable while written), but told the file may change …
        with pytest.warns(UserWarning, match="open for writing in another process"):
            s = load_session(session_path)
        assert s.complete and s.status == "success"
        # … while a second writer is refused
        with pytest.raises(FileLockingError, match="open in another process"):
            SessionFile.open_for_resume(session_path)
    finally:
        holder.stdin.close()
        holder.wait(timeout=10)


def test_network_share_refusing_locks(tmp_path, monkeypatch):
    """NFS/SMB without lock support: ``flock`` fails with ENOLCK (HDF5 says 'unable to lock file … No locks
    available', errno 37): one line saying to write locally, and no file left behind."""
    from daq import session_lock

    def refuse(fd, op):
        raise OSError(errno.ENOLCK, "No locks available")

    monkeypatch.setattr(session_lock.fcntl, "flock", refuse)
    with pytest.raises(FileLockingError, match="write the session to a local disk"):
        SessionFile.create(tmp_path / "s.h5")
    assert list(tmp_path.iterdir()) == []
    monkeypatch.undo()
    with pytest.raises(FileLockingError, match="write the session to a local disk"):  # HDF5's own wording
        raise session_file_error(tmp_path / "s.h5")


def session_file_error(path):
    from daq.errors import hdf5_error

    return hdf5_error(
        path,
        OSError(errno.ENOLCK, "Unable to synchronously create file (unable to lock file, errno = 37, error message = "
                "'No locks available')"),
        writing=True,
    )  # fmt: skip


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_full_disk_keeps_written_blocks_and_rescues_the_failing_one(tmp_path):
    """A file-size limit (RLIMIT_FSIZE) makes writes fail like a full disk, mid-session."""
    path = tmp_path / "full.h5"
    sf = SessionFile.create(path)
    sf.write_start({"started": now_iso()}, "")
    writer = FileWriter(sf)
    small = _rows(2)
    for rec in small:
        writer.block(rec)
    big = np.linspace(1.0, 2.0, 40_000)
    huge = BlockRecord(
        block=2, run=0, weight_kg=3.0, repeat=1, unit="V", reading=big, time_s=big, resistance_ohm=big,
        valid=np.ones(big.size, bool), started=now_iso(),
    )  # fmt: skip
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    old = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    limit = 25 * big.size + path.stat().st_size // 2  # the HDF5 append cannot fit, the rescue file can
    try:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))
        with pytest.raises(SessionWriteError, match=r"refuses to let .* grow.*saved to .*rescue\.npz"):
            writer.block(huge)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, old)
        try:
            sf.close()
        except OSError:
            pass
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = load_session(path)
    assert len(s.summary) == 2 and not s.complete
    rescue = np.load(_rescue_file(path))
    np.testing.assert_array_equal(rescue["resistance_ohm"], big)


def _rescue_file(path):

    return path.parent / f"{path.stem}.block3.rescue.npz"


def test_stop_record_counts(tmp_path):
    path = tmp_path / "stop.h5"
    with SessionFile.create(path) as sf:
        sf.write_start({"started": now_iso()}, "")
        for rec in _rows(2):
            sf.append_block(rec)
        sf.write_stop(StopRecord("aborted", "test stop", now_iso(), 5, 2, 10, (3.0,)))
    with pytest.warns(UserWarning, match="aborted: test stop"):
        s = load_session(path)
    assert s.complete and s.status == "aborted"
    assert s.stop["blocks_planned"] == 5 and s.stop["weights_skipped"] == [3.0] and s.stop["readings_in_file"] == 10


@settings(max_examples=15, deadline=None)
@given(
    blocks=st.lists(
        st.tuples(
            st.floats(1e-3, 1e3),
            st.lists(
                st.one_of(st.floats(-1e3, 1e3, allow_subnormal=True), st.just(float("nan"))), min_size=1, max_size=40
            ),
        ),
        min_size=1,
        max_size=5,
    )
)
def test_roundtrip_is_bit_exact_for_any_readings(tmp_path_factory, blocks):
    """Whatever the readings (tiny, huge, negative, invalid), the file gives back exactly what was written and
    statistics that agree with numpy over the valid ones."""
    path = tmp_path_factory.mktemp("h") / "x.h5"
    recs = []
    with SessionFile.create(path) as sf:
        sf.write_start({"started": now_iso()}, "")
        for b, (w, values) in enumerate(blocks):
            r = np.asarray(values, dtype=float)
            rec = BlockRecord(
                block=b, run=0, weight_kg=w, repeat=1, unit="V", reading=r, time_s=np.arange(r.size) * 0.02,
                resistance_ohm=r, valid=np.isfinite(r), started=now_iso(),
            )  # fmt: skip
            sf.append_block(rec)
            recs.append(rec)
        sf.write_stop(StopRecord("success", "ok", now_iso(), len(recs), len(recs), sum(r.reading.size for r in recs)))
    s = load_session(path)
    for rec, (_, row) in zip(recs, s.summary.iterrows(), strict=True):
        got = s.readings[s.readings.block == rec.block]
        np.testing.assert_array_equal(got.resistance_ohm.to_numpy(), rec.resistance_ohm)
        good = rec.resistance_ohm[np.isfinite(rec.resistance_ohm)]
        assert row.n == good.size and row.n_invalid == rec.reading.size - good.size
        if good.size:
            assert row.mean_ohm == pytest.approx(np.mean(good), rel=1e-12, abs=1e-300)
        else:
            assert np.isnan(row.mean_ohm)
        if good.size > 1:
            assert row.sd_ohm == pytest.approx(np.std(good, ddof=1), rel=1e-9, abs=1e-300)
        else:
            assert np.isnan(row.sd_ohm) and np.isnan(row.sem_ohm)


def test_a_batch_of_blocks_is_written_as_block_by_block(tmp_path):
    """append_blocks (an imported table, one flush) writes the rows, statistics and SHA-256 that append_block
    writes one block at a time — including NaN (invalid) readings and blocks of one reading; block_digests (the
    reader's vectorised check) gives block_digest's digests."""
    from daq.records import block_digest, block_digests
    from daq.session_writer import BlockBatch
    from instruments.block import block_statistics

    rng = np.random.default_rng(5)
    count = np.array([1, 3, 1, 5, 2])
    r = 1e-3 * (1 + 0.1 * rng.standard_normal(count.sum()))
    valid = np.ones(r.size, bool)
    valid[[2, 6]] = False
    t = 0.02 * np.arange(r.size)
    weight, repeat = np.array([5.0, 5.0, 7.0, 7.0, 9.0]), np.array([1, 2, 1, 2, 1], np.int32)
    ends = np.cumsum(count)
    starts = ends - count
    one, batch = tmp_path / "one.h5", tmp_path / "batch.h5"
    with SessionFile.create(one, reading_unit="ohm") as sf:
        sf.write_start({"started": "x"}, "")
        for k, (a, b) in enumerate(zip(starts, ends, strict=True)):
            sf.append_block(BlockRecord(
                block=k, run=0, weight_kg=float(weight[k]), repeat=int(repeat[k]), unit="ohm", reading=r[a:b],
                time_s=t[a:b], resistance_ohm=r[a:b], valid=valid[a:b], started="x",
            ))  # fmt: skip
    with SessionFile.create(batch, reading_unit="ohm") as sf:
        sf.write_start({"started": "x"}, "")
        sf.append_blocks(BlockBatch(
            block=np.arange(5, dtype=np.int32), weight_kg=weight, repeat=repeat, count=count.astype(np.int32),
            reading=r, time_s=t, resistance_ohm=r, valid=valid, started="x",
        ))  # fmt: skip
    with h5py.File(one, "r") as a, h5py.File(batch, "r") as b:
        for group in ("summary", "readings"):
            for name in a[f"entry/{group}"]:
                x, y = a[f"entry/{group}/{name}"][:], b[f"entry/{group}/{name}"][:]
                if x.dtype.kind == "f":
                    np.testing.assert_allclose(x, y, rtol=1e-15, atol=0, equal_nan=True, err_msg=name)
                else:
                    np.testing.assert_array_equal(x, y, err_msg=name)
    with pytest.warns(UserWarning, match="INCOMPLETE"):
        s = load_session(batch)
    assert len(s.summary) == 5 and s.complete is False
    for k, (a, b) in enumerate(zip(starts, ends, strict=True)):  # the statistics are instruments.block's
        st = block_statistics(r[a:b], valid[a:b])
        assert s.summary["n"][k] == st.n and s.summary["mean_ohm"][k] == pytest.approx(st.mean, rel=1e-15)
    digests = block_digests(
        {c: s.summary[c].to_numpy() for c in s.summary} | {"count": count, "first_reading": starts},
        {c: s.readings[c].to_numpy() for c in ("reading", "time_s", "resistance_ohm", "valid")},
    )
    st = block_statistics(r[1:4], valid[1:4])
    assert digests[1] == block_digest(1, 5.0, 2, r[1:4], t[1:4], r[1:4], valid[1:4], st) == s.summary["sha256"][1]
