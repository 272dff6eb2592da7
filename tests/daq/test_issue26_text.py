"""Files and text as the outside world writes them (issue 26 items 9 and 10, second half).

One rule for text that is not valid Unicode (bytes a UTF-8 terminal did not send as UTF-8; Python keeps them as lone
surrogates, ``$'Kolben-\\xd8'`` → ``'Kolben-\\udcd8'``): typed as content (an option, a form field) it is refused
with one line naming the option, exit 2, no file and no temporary file; a file *name* that is not UTF-8 is opened by
that name and shown wherever it enters a file, figure or page with the bytes as visible ``\\xNN`` escapes; text from
a file (an older contactrig stored such text) is shown the same way, and the index lists every file whatever it
holds. The index sorts by the instant a session started and shows each start with its UTC offset.
"""

from __future__ import annotations

import json
import os
from datetime import datetime

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contactrig.cli.main import main
from contactrig.core.text import check_text, escape_html, escape_markdown, escape_terminal, shown
from contactrig.core.validation import SettingError
from daq.index import format_table, index_sessions
from daq.session_file import load_session
from daq.table_import import import_table, tab1_path

from .conftest import small_scene, small_sim_scene

#: Text with lone surrogates: what Python makes of non-UTF-8 bytes in argv, file names and JSON "\udcxx" escapes.
surrogate = st.characters(min_codepoint=0xD800, max_codepoint=0xDFFF)
with_surrogate = st.tuples(st.text(), surrogate, st.text()).map("".join)
valid = st.text(alphabet=st.characters(blacklist_categories=("Cs",)))


@given(with_surrogate)
def test_text_that_is_not_unicode_is_refused_naming_the_field(text):
    with pytest.raises(SettingError, match=r"^--sample = .* is not allowed: text in UTF-8 \((byte 0x|lone)"):
        check_text("--sample", text)


@given(valid)
def test_valid_text_passes_unchanged(text):
    assert check_text("--sample", text) == text and shown(text) == text


@settings(max_examples=200)
@given(st.one_of(with_surrogate, valid))
def test_every_shown_form_can_be_written_as_utf8(text):
    for out in (shown(text), escape_terminal(text), escape_html(text), escape_markdown(text)):
        out.encode("utf-8")  # no UnicodeEncodeError: a file, a figure or a page takes it


@settings(max_examples=50, deadline=None)
@given(st.sampled_from(["sample", "operator", "notes", "address", "visa_library"]), with_surrogate)
def test_every_text_override_refuses_text_that_is_not_unicode(dest, text):
    """Every option acquire (and the console's form, through apply_overrides) takes as text."""
    from daq.overrides import OVERRIDES, apply_overrides, overrides_by_option

    option = next(o for o in OVERRIDES if o.dest == dest)
    with pytest.raises(SettingError) as by_option:
        overrides_by_option({dest: text})
    with pytest.raises(SettingError) as by_key:
        apply_overrides(small_scene(), {option.key: text})
    assert by_option.value.field == by_key.value.field == option.option
    assert "text in UTF-8" in by_key.value.allowed


@settings(max_examples=25, deadline=None)
@given(with_surrogate)
def test_import_refuses_any_operator_that_is_not_unicode(tmp_path_factory, text):
    out = tmp_path_factory.mktemp("imp") / "t.h5"
    with pytest.raises(SettingError, match=r"^--operator = "):
        import_table(tab1_path(), out, unit="mohm", operator=text)
    assert list(out.parent.iterdir()) == []


def test_an_undecodable_byte_is_shown_as_that_byte():
    assert shown(os.fsdecode(b"name-\xff.h5")) == "name-\\xff.h5"
    assert escape_terminal("Kolben-\udcd8") == "Kolben-\\xd8"


@pytest.mark.parametrize("option", ["--sample", "--operator", "--notes", "--address"])
def test_acquire_refuses_non_utf8_text_at_the_option(tmp_path, option, capsys):
    scene = small_sim_scene(tmp_path, count=8, repeats=1)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    bad = os.fsdecode(b"Kolben-\xd8")  # what a Latin-1 terminal's "Kolben-Ø" becomes in argv
    code = main(["acquire", str(scene), "--sim", "--yes", "--sim-speed", "inf", option, bad,
                 "-o", str(out_dir / "s.h5")])  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith(f"contactrig acquire: error: {option} = 'Kolben-\\udcd8' is not allowed: text in UTF-8")
    assert list(out_dir.iterdir()) == []  # no session, no hidden temporary file


def test_import_refuses_a_non_utf8_operator(tmp_path, capsys):
    code = main(["import", "--tab1", "--operator", os.fsdecode(b"op\xff"), "-o", str(tmp_path / "t.h5")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("contactrig import: error: --operator = 'op\\udcff'")
    assert list(tmp_path.iterdir()) == []


def _older_session(path, monkeypatch, *, sample: str = "", started: str = "") -> None:
    """A session as an older contactrig wrote it: ``sample`` stored whatever it holds (the start record is JSON, so
    the old writer kept a lone surrogate as a "\\udcd8" escape), or started at ``started``."""
    import daq.overrides
    import daq.records

    with monkeypatch.context() as m:
        m.setattr(daq.overrides, "check_text", lambda field, value: value)  # the check this issue added
        if started:
            m.setattr(daq.records, "now_iso", lambda: started)
        if not sample:
            import_table(tab1_path(), path, unit="mohm")
            return
        from daq.acquire import acquire
        from daq.link import VisaBench
        from instruments.simulated import SimulatedBench, simulated_resource_manager

        bench = VisaBench(simulated_resource_manager(SimulatedBench(resistance_ohm=5e-3, seed=1, time_scale=0.0)))
        acquire(small_scene(), path, yes=True, bench=bench, quiet=True, overrides={"session.sample": sample})


def test_one_file_with_bad_text_or_a_bad_name_never_breaks_the_index(tmp_path, monkeypatch, capsys):
    folder = tmp_path / "sessions"
    folder.mkdir()
    _older_session(folder / "old.h5", monkeypatch, sample="Kolben-\udcd8")
    assert load_session(folder / "old.h5").start["sample"] == "Kolben-\udcd8"  # as the old version left it
    _older_session(folder / os.fsdecode(b"name-\xff.h5"), monkeypatch)
    (folder / "broken.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + b"\xff" * 100)
    rows = {r.path.rsplit("/", 1)[-1]: r for r in index_sessions(folder)}
    assert set(rows) == {"old.h5", "name-\\xff.h5", "broken.h5"}
    assert rows["old.h5"].sample == "Kolben-\\xd8" and rows["old.h5"].status == "success"
    assert rows["name-\\xff.h5"].status == "success" and "file name is not UTF-8" in rows["name-\\xff.h5"].note
    assert rows["broken.h5"].status == "corrupt" and rows["broken.h5"].note
    json.dumps([r.as_dict() for r in rows.values()], ensure_ascii=False).encode("utf-8")  # what a page is sent
    assert main(["sessions", str(folder), "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert len(listed) == 3 and listed[-1]["status"] == "corrupt"  # every file listed, the unreadable one last
    assert main(["sessions", str(folder)]) == 0
    assert "Kolben-\\xd8" in capsys.readouterr().out


@pytest.mark.slow
@pytest.mark.parametrize("command", ["report", "export", "figures"])
def test_commands_take_a_session_file_whose_name_is_not_utf8(tmp_path, command, monkeypatch):
    monkeypatch.chdir(tmp_path)
    name = os.fsdecode(b"name-\xff.h5")
    assert main(["import", "--tab1", "-o", name]) == 0
    args = {"report": ["--no-compare-models", "-o", "rep"], "export": ["-o", "x.csv"], "figures": ["-o", "figs"]}
    assert main([command, name, *args[command]]) == 0
    written = [p for p in tmp_path.rglob("*") if p.is_file() and p.suffix in (".md", ".html", ".csv")]
    for p in written:
        text = p.read_text(encoding="utf-8")  # valid UTF-8 throughout
        assert "\udcff" not in text
    if command != "figures":
        assert any("name-\\xff.h5" in p.read_text(encoding="utf-8") for p in written)


def test_the_index_sorts_by_the_instant_and_shows_the_offset(tmp_path, monkeypatch):
    """Two sessions: A at 10:00 in UTC+01:00 (09:00 UTC), B at 09:30 in UTC. By the text B ("09:30") comes first;
    by the instant A does. Offsets checked with datetime (the standard library), not with our own formatting."""
    a, b = "2026-01-01T10:00:00.000+01:00", "2026-01-01T09:30:00.000+00:00"
    assert datetime.fromisoformat(a) < datetime.fromisoformat(b) and b < a  # instant order ≠ text order
    _older_session(tmp_path / "a.h5", monkeypatch, started=a)
    _older_session(tmp_path / "b.h5", monkeypatch, started=b)
    rows = index_sessions(tmp_path)
    assert [os.path.basename(r.path) for r in rows] == ["a.h5", "b.h5"]
    assert [r.start_shown for r in rows] == ["2026-01-01 10:00:00 +01:00", "2026-01-01 09:30:00 +00:00"]
    assert [datetime.fromisoformat(r.start_utc) for r in rows] == sorted(datetime.fromisoformat(t) for t in (a, b))
    table = format_table(rows)
    assert "10:00:00 +01:00" in table and "09:30:00 +00:00" in table
