"""``--where`` on any value recorded at a session's start, by the dotted name ``contactrig sessions diff`` shows.

QCoDeS users ask to filter runs by any snapshot value (qcodes #901); here every setting read back at the start, the
instruments' ``*IDN?`` replies, the scene's overrides and the software versions can be searched. The expected sets
come from what each test session was written with (``write_run``'s arguments) and, for random thresholds, from a
comparison written out in Python over the rows' recorded values — not from the index's own earlier output.
"""

from __future__ import annotations

import os
import shutil

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from contactrig.cli.main import main
from daq import run_index as ri

from .run_files import write_run


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """Four sessions that differ in NPLC (1, 2, 0.5, 10) and sample; settled (back-dated) so the index trusts them."""
    base = tmp_path_factory.mktemp("fields")
    for name, nplc, sample in (("a", "1.0", "ring"), ("b", "2.0", "ring"), ("c", "0.5", "steel"), ("d", "10", "x")):
        p = write_run(base / f"{name}.h5", sample=sample, nplc=nplc)
        t = p.stat().st_mtime - 60
        os.utime(p, (t, t))
    ri.refresh(base)
    return base


def names(folder, *where):
    return sorted(os.path.basename(r["path"])[0] for r in ri.query(folder, list(where))[0])


def test_a_setting_by_its_dotted_name(lab):
    assert names(lab, "settings.delta.nplc=2") == ["b"]
    assert names(lab, "settings.delta.nplc=2.0") == ["b"]  # a number equals as a number
    assert names(lab, "settings.delta.nplc>=2") == ["b", "d"]
    assert names(lab, "settings.delta.nplc <= 1") == ["a", "c"]
    assert names(lab, "settings.delta.nplc>=1", "sample=ring") == ["a", "b"]
    assert names(lab, "settings.delta.nplc=3") == []
    assert names(lab, "start<=9999-12-31") == ["a", "b", "c", "d"]  # the last day there is: no overflow
    assert names(lab, "start>=0001-01-01") == ["a", "b", "c", "d"]


def test_text_booleans_nulls_and_contains(lab):
    idn = ri.query(lab, ["settings.delta.nplc=1"])[0][0]["instruments"]["voltmeter"]
    model = idn.split(",")[1].strip()  # IEEE 488.2 *IDN?: maker, model, serial, firmware
    assert names(lab, f"instruments.voltmeter~{model.lower()}") == ["a", "b", "c", "d"]
    assert names(lab, f"instruments.voltmeter={idn.upper()}") == ["a", "b", "c", "d"]  # text: case-insensitive
    assert names(lab, "settings.delta.unit=v") == ["a", "b", "c", "d"]
    assert names(lab, "settings.delta.compliance_abort=true") == ["a", "b", "c", "d"]
    assert names(lab, "settings.delta.compliance_abort=false") == []
    # SCPI's read-back state is text ("1"): "=1" finds the text too
    assert names(lab, "settings.pinned_state.2182A.:SYST:AZER ON=1") == ["a", "b", "c", "d"]
    assert names(lab, "settings~nplc") == ["a", "b", "c", "d"]  # a whole branch searched as its JSON text


def test_a_name_nobody_records_is_said(lab, capsys):
    rows, result = ri.query(lab, ["settings.delta.nplcc=2"])
    assert rows == [] and any("settings.delta.nplcc" in n and "sessions diff" in n for n in result.notes)
    rows, result = ri.query(lab, ["settings.delta.nplc=3"])  # recorded, no match: nothing to say
    assert rows == [] and result.notes == []


@pytest.mark.parametrize("bad", ["settings.delta.nplc>=fast", "settings.delta.nplc<1", "settings.delta.nplc=",
                                 "setting.delta.nplc=1", "settingsx=1",
                                 "start>=9999-12-31T23:00:00-05:00"])  # past year 9999 in UTC  # fmt: skip
def test_a_bad_field_condition_is_one_line_exit_2(lab, tmp_path, bad, capsys):
    folder = tmp_path / "copy"
    shutil.copytree(lab, folder)
    assert main(["sessions", str(folder), "--where", bad]) == 2
    err = capsys.readouterr().err
    assert "--where" in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_the_cli_and_its_help(lab, tmp_path, capsys):
    folder = tmp_path / "copy"
    shutil.copytree(lab, folder)
    assert main(["sessions", str(folder), "--where", "settings.delta.nplc>=2"]) == 0
    out = capsys.readouterr().out
    assert "b.h5" in out and "d.h5" in out and "a.h5" not in out and "c.h5" not in out
    assert main(["sessions", "--help"]) == 0
    assert "settings.delta.nplc" in " ".join(capsys.readouterr().out.split())


@settings(max_examples=60, deadline=None)
@given(
    threshold=st.floats(min_value=-1, max_value=20, allow_nan=False),
    op=st.sampled_from([">=", "<=", "="]),
)
def test_numeric_conditions_agree_with_python(lab, threshold, op):
    """Any threshold: the index's answer equals the comparison written out in Python over the recorded NPLC."""
    rows = ri.query(lab, refresh=False)[0]
    values = {os.path.basename(r["path"])[0]: r["settings"]["delta"]["nplc"] for r in rows}
    compare = {">=": lambda v: v >= threshold, "<=": lambda v: v <= threshold, "=": lambda v: v == threshold}[op]
    expected = sorted(k for k, v in values.items() if compare(v))
    got = sorted(os.path.basename(r["path"])[0] for r in ri.query(lab, [f"settings.delta.nplc{op}{threshold!r}"],
                                                                   refresh=False)[0])  # fmt: skip
    assert got == expected


def test_the_last_fit_is_the_latest_instant_whatever_its_utc_offset(tmp_path, monkeypatch):
    """Fits are stamped in local time with the UTC offset. Across the end of daylight saving time a later fit can have
    an earlier-looking text: 02:50+02:00 is 00:50 UTC, 02:10+01:00 (written after it) 01:10 UTC. The last fit is the
    later instant — for the index's verdict column and filter, for ``last_fit`` (the diff) and for the merged
    sidecars — not the larger text."""
    import contactrig.core.provenance as provenance

    folder = tmp_path / "dst"
    folder.mkdir()
    p = write_run(folder / "s.h5", sample="dst")
    for at, discriminates in (("2026-10-25T02:50:00.000+02:00", True), ("2026-10-25T02:10:00.000+01:00", False)):
        monkeypatch.setattr(provenance, "now_iso", lambda at=at: at)
        ri.record_fit(p, discriminates=discriminates, best="hertz", statement="…")
    cid = ri.query(folder)[0][0]["content_id"]
    assert ri.last_fit(p, cid)["at"] == "2026-10-25T02:10:00.000+01:00"
    assert ri.query(folder)[0][0]["fit"]["verdict"] == "undecided"
    assert names(folder, "verdict=undecided") == ["s"] and names(folder, "verdict=discriminates") == []
    assert [f["at"][11:16] for f in ri.fits_in(folder)] == ["02:50", "02:10"]  # in time order, not text order


def test_every_field_the_diff_names_finds_its_session(tmp_path):
    """The names `sessions diff` gives, values as it shows them: each, as a --where condition, finds the session
    that has that value and not the other. The overrides are one flat table with dotted keys (session.notes)."""
    from daq.session_diff import session_diff

    folder = tmp_path / "two"
    folder.mkdir()
    a = write_run(folder / "a.h5", sample="x", overrides={"session.notes": "hello", "instrument.timeout_ms": 5000})
    b = write_run(folder / "b.h5", sample="y", nplc="2.0")
    diff = session_diff(a, b)["differences"]
    fields = [d for d in diff if d["field"].split(".")[0] in ri.DETAIL_KEYS]
    assert {"overrides.session.notes", "settings.delta.nplc"} <= {d["field"] for d in fields}
    for d in fields:
        for side, other in (("a", "b"), ("b", "a")):
            value = d[side]
            if value is None or isinstance(value, (dict, list)):
                continue  # a side without the value (null: nothing recorded there), or an empty table ({})
            text = {True: "true", False: "false"}.get(value, value) if isinstance(value, bool) else str(value)
            found = names(folder, f"{d['field']}={text}")
            assert side in found and other not in found, (d, found)


def test_instants_in_other_iso_forms_and_out_of_range_dates(tmp_path):
    """A hand-edited sidecar line: the index, ``last_fit`` and the merged sidecars agree on which fit is the last
    whatever ISO-8601 form its time takes (+0000, microseconds), and a date past year 9999 in UTC is read, not
    fatal."""
    import json

    folder = tmp_path / "forms"
    folder.mkdir()
    p = write_run(folder / "s.h5", sample="forms")
    cid = ri.query(folder)[0][0]["content_id"]
    base = {"content_id": cid, "best": "hertz", "statement": "…", "analysis_version": "0", "who": "x", "file": "s.h5"}
    lines = [dict(base, verdict="discriminates", at="2026-01-01T10:00:00.000+00:00"),
             dict(base, verdict="undecided", at="2026-01-01T12:00:00+0000"),  # later, another form
             dict(base, verdict="discriminates", at="2026-01-01T11:59:59.999900+00:00")]  # fmt: skip
    (folder / ri.FITS_NAME).write_text("".join(json.dumps(x) + "\n" for x in lines), encoding="utf-8")
    mark = dict(content_id=cid, kind="tag", text="far", who="x", at="9999-12-31T23:00:00-05:00", file="s.h5")
    (folder / ri.SIDECAR_NAME).write_text(json.dumps(mark) + "\n", encoding="utf-8")
    assert ri.last_fit(p, cid)["verdict"] == "undecided"
    row = ri.query(folder)[0][0]
    assert row["fit"]["verdict"] == "undecided" and [t["text"] for t in row["tags"]] == ["far"]
    assert names(folder, "verdict=undecided") == ["s"]
    assert [m["text"] for m in ri.marks_in(folder)] == ["far"]


def test_a_detail_that_is_not_strict_json_does_not_fail_a_search(lab, tmp_path):
    """An index row written before non-finite numbers were made null holds NaN, which SQLite's JSON functions refuse:
    a search on a recorded value passes over that row instead of failing for the whole folder."""
    import sqlite3

    folder = tmp_path / "nan"
    shutil.copytree(lab, folder)
    ri.refresh(folder)
    index = ri.index_location(folder)[0]
    with sqlite3.connect(index) as con:
        (path, detail), = con.execute("SELECT path, detail FROM sessions WHERE path LIKE 'a.h5'").fetchall()
        con.execute("UPDATE sessions SET detail = ? WHERE path = ?",
                    (detail.replace('"compliance_v": 10.0', '"compliance_v": NaN'), path))  # fmt: skip
    assert names(folder, "settings.delta.nplc>=1") == ["b", "d"]  # a: passed over; b, d: found
    rows = ri.query(folder, refresh=False)[0]
    assert len(rows) == 4


_WHERE_TEXT = (
    st.text(max_size=40)
    | st.from_regex(r"(start|settings\.delta\.nplc|overrides\.session\.notes|sample|verdict|text)(>=|<=|=|~).{0,30}",
                    fullmatch=True)
    | st.builds(lambda op, t: f"start{op}{t.isoformat()}", st.sampled_from([">=", "<="]),
                st.datetimes(timezones=st.timezones()))
    | st.builds(lambda op, d: f"start{op}{d.isoformat()}", st.sampled_from([">=", "<="]), st.dates())
)


@settings(max_examples=300, deadline=None)
@given(text=_WHERE_TEXT)
@example(text="start<=9999-12-31")  # the calendar's last day: its end is past any datetime
@example(text="start>=9999-12-31T23:00:00-05:00")  # past year 9999 once in UTC
@example(text="start>=0001-01-01T00:30:00+01:00")  # before year 1 in UTC
def test_any_where_text_is_a_condition_or_a_one_line_error(lab, text):
    """Whatever an operator types: a condition the index answers, or a one-line SettingError naming --where; never
    another exception (dates at the ends of the calendar, offsets that leave it in UTC, odd names and values)."""
    from contactrig.core.validation import SettingError

    try:
        condition = ri.parse_where(text)
    except SettingError as err:
        assert err.field == "--where" and "\n" not in str(err)
        return
    rows, _ = ri.query(lab, [condition], refresh=False)
    assert isinstance(rows, list)
