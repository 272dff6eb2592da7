"""Issue 29: the verdict of the last `contactrig fit` of each session, with the analysis version it was made with,
kept beside the sessions (append-only .contactrig-fits.jsonl, never in the sealed file, never in the index alone)
and shown by the run index, stale when the analysis version changes."""

from __future__ import annotations

import hashlib
import json
import multiprocessing
import os
from importlib import resources
from types import SimpleNamespace

import pytest

from contactrig.cli.main import main
from contactrig.core import provenance
from daq import run_index as ri


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """A folder with a session (Tab. 1 imported) and a simulation of a small scene to fit it against."""
    folder = tmp_path_factory.mktemp("fits")
    text = resources.files("contactrig").joinpath("scenes/default.toml").read_text(encoding="utf-8")
    scene = folder / "small.toml"
    scene.write_text(text.replace("n = 512", "n = 64"), encoding="utf-8")
    sim = folder / "sim.h5"
    assert main(["simulate", str(scene), "--weights", "5,10,20,26", "-o", str(sim), "--models", "hertz,lagemann"]) == 0
    session = folder / "runs" / "s.h5"
    session.parent.mkdir()
    assert main(["import", "--tab1", "-o", str(session)]) == 0
    return session, sim


def _digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_fit_records_its_verdict_and_the_index_shows_it(fitted, capsys, monkeypatch):
    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads(resources.files("contactrig").joinpath("schemas", "sessions.json").read_text("utf-8"))
    session, sim = fitted
    folder = session.parent
    before = _digest(session)
    assert main(["fit", str(session), "--sim", str(sim), "--bootstrap", "20", "--allow-mismatch", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)  # what the fit itself says
    assert _digest(session) == before  # the sealed session is never touched
    verdict = "discriminates" if result["discriminates"] else "undecided"

    assert main(["sessions", str(folder), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    jsonschema.validate(rows, schema)
    [row] = rows
    fit = row["fit"]
    assert (fit["verdict"], fit["best"]) == (verdict, result["ranking"][0])
    assert fit["analysis_version"] == provenance.software_version() and fit["stale"] is False
    assert fit["statement"] and fit["statement"] in result["statement"]
    assert main(["sessions", str(folder), "--where", f"verdict={verdict}"]) == 0
    table = capsys.readouterr().out
    assert "fit" in table.splitlines()[0] and f"{verdict} {result['ranking'][0]}" in table and "s.h5" in table
    assert main(["sessions", str(folder), "--where", "verdict=none"]) == 0
    assert "s.h5" not in capsys.readouterr().out

    for f in folder.glob(ri.INDEX_NAME + "*"):  # the index is a cache: the verdict lives beside the session
        f.unlink()
    monkeypatch.setattr(provenance, "software_version", lambda: "99.0")  # a newer analysis
    rows, _ = ri.query(folder, ["verdict=stale"])
    assert [r["fit"]["stale"] for r in rows] == [True]
    assert main(["sessions", str(folder)]) == 0
    assert "(stale: " in capsys.readouterr().out
    argv = ["fit", str(session), "--sim", str(sim), "--bootstrap", "0", "--allow-mismatch", "--no-record"]
    assert main(argv) == 0  # (the console's second fit, for its plot's curves)
    lines = (folder / ri.FITS_NAME).read_text().splitlines()
    assert len(lines) == 1 and json.loads(lines[0])["who"]


def _append(args):
    session, k = args
    for i in range(k):
        who = f"w{os.getpid()}"
        ri.record_fit(session, discriminates=bool(i % 2), best="hertz", statement=f"Verdict: {i}", who=who)


def test_the_fits_file_is_append_only_safe_for_concurrent_writers_and_never_follows_a_link(fitted, tmp_path, capsys):
    session, _ = fitted
    own = tmp_path / "own"
    own.mkdir()
    copy = own / "s.h5"
    copy.write_bytes(session.read_bytes())
    writers = [multiprocessing.get_context("fork").Process(target=_append, args=((copy, 5),)) for _ in range(3)]
    for w in writers:
        w.start()
    for w in writers:
        w.join(timeout=120)
        assert w.exitcode == 0
    fits = ri.read_fits(own / ri.FITS_NAME)
    assert len(fits) == 15 and len({f["who"] for f in fits}) == 3  # every line whole, none lost
    # the last fit wins: one appended now is the one shown
    ri.record_fit(copy, discriminates=True, best="lagemann", statement="Verdict: last", who="me")
    [row] = ri.query(own)[0]
    assert (row["fit"]["best"], row["fit"]["who"]) == ("lagemann", "me")
    # a link in place of the fits file is never followed: refused, the fit itself stands (a note)
    linked = tmp_path / "linked"
    linked.mkdir()
    (linked / "s.h5").write_bytes(session.read_bytes())
    target = tmp_path / "target.jsonl"
    os.symlink(target, linked / ri.FITS_NAME)
    with pytest.raises(OSError):
        ri.record_fit(linked / "s.h5", discriminates=True, best="hertz", statement="x")
    from contactrig.cli.analysis import _record_verdict

    _record_verdict(str(linked / "s.h5"), SimpleNamespace(statement="Verdict: x", discriminates=True, ranking=["h"]))
    assert "not recorded" in capsys.readouterr().err and not target.exists()
    # the diff of two copies of one session: only their last fits differ
    from daq.session_diff import session_diff

    diff = session_diff(copy, linked / "s.h5")
    assert {d["field"]: (d["a"], d["b"]) for d in diff["differences"]} == {
        "fit.analysis_version": (provenance.software_version(), None), "fit.best": ("lagemann", None),
        "fit.verdict": ("discriminates", None),
    }  # fmt: skip
