"""Issue 29: the run index (daq.run_index), tags and remarks, --where search and --diff of two sessions."""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import sqlite3
from importlib import resources
from pathlib import Path

import pytest

from contactrig.cli.main import main
from daq import run_index as ri
from daq.session_diff import session_diff

from .run_files import write_run


def _idns() -> list[str]:
    """The *IDN? replies of the simulated instruments, from their pyvisa-sim dialogue file (not from contactrig)."""
    text = (Path(__file__).parents[2] / "instruments" / "k6221_sim.yaml").read_text(encoding="utf-8")
    return re.findall(r'r: "(KEITHLEY[^"]*)"', text)


def _serials() -> list[str]:
    """IEEE 488.2 *IDN?: maker, model, serial, firmware."""
    return sorted(s.split(",")[2].strip() for s in _idns())


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """Three sessions (one in a sub-folder, one started at a UTC offset) and two damaged files."""
    base = tmp_path_factory.mktemp("runs")
    write_run(base / "a.h5", sample="Bronze ring", operator="ann", notes="liner re-honed before the run")
    (base / "sub").mkdir()
    write_run(base / "sub" / "b.h5", sample="steel", operator="bob", started="2026-01-01T23:30:00.000-05:00")
    write_run(base / "c.h5", sample="steel", operator="ann", nplc="2.0", started="2025-12-31T08:00:00.000+01:00")
    return base


@pytest.fixture
def folder(made, tmp_path):
    """A fresh copy of the sessions, plus a file of garbage and a truncated session (damaged)."""
    f = tmp_path / "runs"
    shutil.copytree(made, f)
    (f / "garbage.h5").write_bytes(b"not an hdf5 file " * 64)
    raw = (f / "a.h5").read_bytes()
    (f / "cut.h5").write_bytes(raw[: len(raw) // 2])
    for g in f.rglob("*.h5"):
        _age(g)
    return f


def _age(path):
    """Back-date a file by a minute: the index trusts the size and times only of files that settled (a change
    within the file system's time resolution would not show in them)."""
    t = path.stat().st_mtime - 60
    os.utime(path, (t, t))
    return path


def _by_name(rows):
    return {os.path.basename(r["path"]): r for r in rows}


def test_the_index_holds_what_each_session_records(folder):
    rows, refreshed = ri.query(folder)
    assert refreshed.index == folder / ri.INDEX_NAME and refreshed.read == 5 and not refreshed.notes
    got = _by_name(rows)
    a = got["a.h5"]
    assert (a["sample"], a["operator"], a["notes"], a["status"]) == (
        "Bronze ring", "ann", "liner re-honed before the run", "success"
    )  # fmt: skip
    assert a["blocks_done"] == a["blocks_planned"] == 6 and a["invalid_readings"] == 0  # 3 weights × 2 repeats
    # identities as the simulated instruments answer *IDN?; the serial is the third field of the reply
    assert sorted(a["instruments"].values()) == sorted(_idns()) and len(_idns()) == 2
    assert a["serials"] == _serials()
    assert a["settings"]["delta"]["nplc"] == 1.0 and a["settings"]["pinned_state"]
    assert a["software_version"] == "0.1.0" and a["fit"] is None and a["end_time"]
    assert a["content_id"].startswith("sha256:") and a["scene"] == "daq-test"
    # damaged files: listed with the reader's reason, last, never fatal
    assert {os.path.basename(r["path"]) for r in rows[-2:]} == {"garbage.h5", "cut.h5"}
    assert got["garbage.h5"]["status"] == got["cut.h5"]["status"] == "corrupt"
    assert got["garbage.h5"]["note"] and got["cut.h5"]["note"]
    # sorted by the UTC instant: 2025-12-31T07:00Z < 2026-01-01T10:00Z < 2026-01-02T04:30Z
    assert [os.path.basename(r["path"]) for r in rows[:3]] == ["c.h5", "a.h5", "b.h5"]
    assert got["b.h5"]["start_utc"] == "2026-01-02T04:30:00.000000+00:00"


def test_a_refresh_reads_only_what_changed_and_a_move_keeps_the_row(folder):
    ri.query(folder)
    assert ri.refresh(folder).read == 0
    _age(write_run(folder / "d.h5", sample="new"))
    r = ri.refresh(folder)
    assert (r.read, r.kept) == (1, 5)
    before = _by_name(ri.query(folder)[0])["d.h5"]["content_id"]
    os.rename(folder / "d.h5", folder / "sub" / "moved.h5")
    r = ri.refresh(folder)
    assert (r.read, r.moved) == (0, 1)
    assert _by_name(ri.query(folder)[0])["moved.h5"]["content_id"] == before
    os.unlink(folder / "sub" / "moved.h5")
    assert ri.refresh(folder).removed == 1
    # damaged in place, same size, its time of modification put back: the time of change still tells
    st = (folder / "c.h5").stat()
    with open(folder / "c.h5", "r+b") as f:
        f.write(b"\0" * 512)
    os.utime(folder / "c.h5", ns=(st.st_atime_ns, st.st_mtime_ns))
    assert ri.refresh(folder).read == 1
    assert _by_name(ri.query(folder)[0])["c.h5"]["status"] == "corrupt"
    assert ri.indexed_rows(folder) == ri.fresh_scan(folder)


def test_tags_and_remarks_follow_the_content_and_survive_deleting_the_index(folder):
    ri.add_mark(folder / "a.h5", "tag", "rehoned", who="ann")
    ri.add_mark(folder / "a.h5", "remark", "the liner was re-honed afterwards", who="bob")
    ri.add_mark(folder / "cut.h5", "tag", "broken", who="ann")  # a damaged file can be tagged too
    shutil.copy(folder / "a.h5", folder / "sub" / "copy-of-a.h5")  # a copy: read, recognised by its content id
    for index in (True, False):
        rows = _by_name(ri.query(folder, ["tag=rehoned"])[0])
        assert set(rows) == {"a.h5", "copy-of-a.h5"}
        assert rows["a.h5"]["tags"][0]["who"] == "ann" and rows["a.h5"]["remarks"][0]["who"] == "bob"
        assert set(_by_name(ri.query(folder, ["text~honed afterwards"])[0])) == {"a.h5", "copy-of-a.h5"}
        assert set(_by_name(ri.query(folder, ["tag=broken"])[0])) == {"cut.h5"}
        if index:
            for f in folder.glob(ri.INDEX_NAME + "*"):
                f.unlink()
    lines = (folder / ri.SIDECAR_NAME).read_text().splitlines()
    assert len(lines) == 3 and all(json.loads(ln)["at"] for ln in lines)


def test_where_filters(folder):
    def names(*where):
        return sorted(_by_name(ri.query(folder, list(where))[0]))

    assert names("sample=steel") == ["b.h5", "c.h5"]
    assert names("sample~RING") == ["a.h5"]
    assert names("operator=ann", "sample=steel") == ["c.h5"]
    assert names("status=corrupt") == ["cut.h5", "garbage.h5"]
    assert names("text~re-honed") == ["a.h5"]  # the notes, full text
    assert names("start>=2026-01-02") == ["b.h5"]  # 23:30 at −05:00 is 04:30 UTC the next day
    assert names("start<=2025-12-31") == ["c.h5"]
    assert names("start>=2026-01-01T11:00:00+01:00", "start<=2026-01-01") == ["a.h5"]
    assert names(f"serial={_serials()[0]}") == ["a.h5", "b.h5", "c.h5"] and names("serial=999") == []
    assert names("scene=daq-test") == ["a.h5", "b.h5", "c.h5"]
    first = ri.query(folder, ["scene=daq-test"], limit=2)[0]  # one page, in start order (UTC)
    assert [os.path.basename(r["path"]) for r in first] == ["c.h5", "a.h5"]


def test_pages_by_offset_and_the_count_of_matches(folder):
    """``offset`` skips rows of the same order (start instant in UTC, unreadable files last, by path) and the
    ``Refresh`` counts every match, whatever the page (the console's pages and their count)."""

    def page(*where, **kw):
        rows, result = ri.query(folder, list(where), detail=False, **kw)
        return [os.path.basename(r["path"]) for r in rows], result.matched

    # c: 2025-12-31 07:00Z, a: 2026-01-01 10:00Z, b: 2026-01-02 04:30Z; then cut.h5 and garbage.h5 (damaged)
    assert [page(limit=2, offset=k) for k in (0, 2, 4, 6)] == [
        (["c.h5", "a.h5"], 5), (["b.h5", "cut.h5"], 5), (["garbage.h5"], 5), ([], 5)
    ]  # fmt: skip
    assert page("sample=steel", descending=True, limit=1, offset=1) == (["c.h5"], 2)
    assert page("sample=steel", offset=1) == (["b.h5"], 2) and page("operator=nobody", limit=3) == ([], 0)


@pytest.mark.parametrize(
    "bad", ["sample", "color=red", "start=2026-01-01", "start>=yesterday", "sample>=a", "text~!!", "status=done"]
)
def test_a_bad_where_is_one_line_exit_2(folder, bad, capsys):
    assert main(["sessions", str(folder), "--where", bad]) == 2
    err = capsys.readouterr().err
    assert "--where" in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_the_cli_searches_tags_and_remarks(folder, capsys):
    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads(resources.files("contactrig").joinpath("schemas", "sessions.json").read_text("utf-8"))
    assert main(["sessions", str(folder / "c.h5"), "--tag", "nplc2", "--remark", "NPLC raised to 2"]) == 0
    assert "nplc2" in capsys.readouterr().err
    assert main(["sessions", str(folder), "--where", "tag=nplc2", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    jsonschema.validate(rows, schema)
    assert [os.path.basename(r["path"]) for r in rows] == ["c.h5"] and rows[0]["remarks"][0][
        "text"
    ] == "NPLC raised to 2"
    assert main(["sessions", str(folder), "--where", "text~raised"]) == 0
    out = capsys.readouterr().out
    assert "c.h5" in out and "a.h5" not in out and "NPLC raised to 2" in out
    assert main(["sessions", str(folder), "--tag", "x"]) == 2  # a folder cannot be tagged
    assert main(["sessions", str(folder / "a.h5"), "--tag", "two words"]) == 2


def test_diff_names_the_one_instrument_setting_that_differs(folder, capsys):
    diff = session_diff(folder / "a.h5", folder / "c.h5")
    settings = [d for d in diff["differences"] if d["field"].startswith(("settings", "instruments", "overrides"))]
    assert settings == [{"field": "settings.delta.nplc", "a": 1.0, "b": 2.0}]
    assert any("nplc" in ln for ln in diff["scene_lines"])
    assert main(["sessions", str(folder / "a.h5"), "--diff", str(folder / "c.h5")]) == 0
    assert "settings.delta.nplc" in capsys.readouterr().out
    assert main(["sessions", str(folder / "a.h5"), "--diff", str(folder / "garbage.h5")]) == 2


def test_an_index_that_cannot_be_kept_falls_back_to_a_scan(folder, monkeypatch, tmp_path):
    target = tmp_path / "elsewhere.sqlite"
    os.symlink(target, folder / ri.INDEX_NAME)
    rows, refreshed = ri.query(folder)
    assert len(rows) == 5 and refreshed.index is None and "symbolic link" in refreshed.notes[0]
    assert not target.exists()  # never followed
    os.unlink(folder / ri.INDEX_NAME)
    monkeypatch.setattr(ri.os, "access", lambda *a, **k: False)
    rows, refreshed = ri.query(folder)
    assert len(rows) == 5 and "read-only" in refreshed.notes[0] and not (folder / ri.INDEX_NAME).exists()


def test_schema_versions_upgrade_and_a_newer_or_damaged_index(folder):
    ri.query(folder)
    with sqlite3.connect(folder / ri.INDEX_NAME) as con:
        assert con.execute("PRAGMA user_version").fetchone()[0] == ri.SCHEMA_VERSION
        assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
        con.execute("PRAGMA user_version = 99")
    rows, refreshed = ri.query(folder)
    assert len(rows) == 5 and "newer" in refreshed.notes[0]
    for f in folder.glob(ri.INDEX_NAME + "*"):
        f.unlink()
    (folder / ri.INDEX_NAME).write_bytes(b"this is not a database" * 100)
    rows, refreshed = ri.query(folder)
    assert len(rows) == 5 and "damaged" in refreshed.notes[0] and refreshed.index is not None


def test_a_batch_that_crashes_the_reader_is_read_again_file_by_file(folder, monkeypatch):
    """Files are read many to a bounded child; a file that kills that child (as a damaged file can crash the HDF5
    library) costs the batch, which is read again one file per child: every file is still listed."""
    real = ri._load_here

    def crashing(path, **kw):
        if path.name == "garbage.h5":
            os.kill(os.getpid(), 11)  # SIGSEGV in the child
        return real(path, **kw)

    monkeypatch.setattr(ri, "_load_here", crashing)
    got = _by_name(ri.query(folder, jobs=1)[0])
    assert set(got) == {"a.h5", "b.h5", "c.h5", "garbage.h5", "cut.h5"}
    assert got["a.h5"]["status"] == "success" and got["garbage.h5"]["status"] == "corrupt"


def test_a_sealed_session_is_indexed_from_its_records_not_its_tables(folder, monkeypatch):
    """Issue 29, speed: a sealed session is indexed from its records, its block digests and the names of its tables'
    columns, without reading the readings and exchanges (a third of a whole read); the row is the one a whole,
    verified read gives."""
    from daq import session_reader

    members = []
    real = session_reader._Reader.node

    def spy(self, name, kind):
        members.append(name)
        return real(self, name, kind)

    monkeypatch.setattr(session_reader._Reader, "node", spy)
    [light] = ri._records_here([folder / "a.h5"])
    assert members and not [m for m in members if m.startswith(("entry/readings/", "entry/exchanges/"))]
    full = ri.session_record(folder / "a.h5")  # load_session: every block's SHA-256 and the whole seal
    assert (light["checked"], full["checked"]) == ("records", "whole")
    assert {k: v for k, v in light.items() if k != "checked"} == {k: v for k, v in full.items() if k != "checked"}


def test_the_index_lists_an_altered_or_damaged_sealed_session_as_corrupt(folder, capsys):
    """A sealed session whose start record was altered, or whose table lost a column, is read whole and listed
    corrupt with the reason; a value altered inside a table is found by a whole read (`contactrig sessions FILE`)."""
    from .hostile import _cell, _copy_then, _delete, _record, _set

    variants = {
        "operator.h5": _record("entry/start/record", _set("operator", "mallory")),
        "no-valid.h5": _delete("entry/readings/valid"),
        "reading.h5": _cell("entry/readings/reading", 3, 1.0),
    }
    for name, edit in variants.items():
        _copy_then(edit)(folder / "a.h5", folder / name)
        _age(folder / name)
    got = _by_name(ri.query(folder)[0])
    assert got["operator.h5"]["status"] == "corrupt" and "start record" in got["operator.h5"]["note"]
    assert got["no-valid.h5"]["status"] == "corrupt" and "readings/valid" in got["no-valid.h5"]["note"]
    assert (got["reading.h5"]["status"], got["reading.h5"]["checked"]) == ("success", "records")
    assert main(["sessions", str(folder / "reading.h5")]) == 0
    assert "CORRUPT" in capsys.readouterr().out


def test_an_index_of_schema_1_is_upgraded_and_its_rows_read_again(folder):
    """An index written by the previous contactrig (schema 1): upgraded in place, its rows read again from the
    files (the cache is rebuilt), nothing lost."""
    index = folder / ri.INDEX_NAME
    with contextlib.closing(sqlite3.connect(index)) as con:
        for statement in ri._UPGRADES[0].split(";"):
            if statement.strip():
                con.execute(statement)
        con.execute("INSERT INTO sessions VALUES ('a.h5', 1, 1, 1, 1, 'x', 'success', '', '', '', '', '', '{}')")
        con.execute("PRAGMA user_version = 1")
        con.commit()
    rows, refreshed = ri.query(folder)
    assert refreshed.read == 5 and len(rows) == 5 and _by_name(rows)["a.h5"]["sample"] == "Bronze ring"
    with contextlib.closing(sqlite3.connect(index)) as con:
        assert con.execute("PRAGMA user_version").fetchone()[0] == ri.SCHEMA_VERSION == 2


def test_sessions_diff_a_b_names_the_one_setting_that_differs(folder, capsys):
    """`contactrig sessions diff A.h5 B.h5` as the issue spells it: a.h5 and c.h5 were written with NPLC 1 and 2
    (write_run's nplc), nothing else of the instruments differs."""
    assert main(["sessions", "diff", str(folder / "a.h5"), str(folder / "c.h5"), "--json"]) == 0
    diff = json.loads(capsys.readouterr().out)
    settings = [d for d in diff["differences"] if d["field"].startswith(("settings", "instruments", "overrides"))]
    assert settings == [{"field": "settings.delta.nplc", "a": 1.0, "b": 2.0}]
    assert main(["sessions", "diff", str(folder / "a.h5"), str(folder / "c.h5")]) == 0
    assert "settings.delta.nplc" in capsys.readouterr().out
    for argv in (["diff", str(folder / "a.h5")], [str(folder), str(folder / "a.h5"), str(folder / "c.h5")]):
        assert main(["sessions", *argv]) == 2
        err = capsys.readouterr().err
        assert "diff A.h5 B.h5" in err and len(err.strip().splitlines()) == 1
