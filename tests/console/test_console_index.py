"""The console's sessions index over the run index (issue 29): served from ``daq.run_index.query`` without waiting
for a scan, searched with the ``--where`` filters, tags and remarks added from the session page (token and origin
checked), and the diff of two sessions."""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from tests.console.conftest import HOSTILE, Client
from tests.daq.run_files import write_run


def indexed(client: Client, **params: Any) -> dict[str, Any]:
    """``/api/sessions`` once a refresh started now has ended."""
    catalog = client.console.catalog
    before = catalog.generation
    catalog.kick()
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        r = client.get("/api/sessions", params={"kick": "0", **params})
        assert r.status_code == 200, r.text
        data: dict[str, Any] = r.json()
        if data["generation"] > before and not data["indexing"]:
            return data
        time.sleep(0.05)
    raise AssertionError("the index refresh did not end")


@pytest.fixture
def lab(folder: Path) -> Path:
    """Four small sessions: two samples, two operators, one with notes, one at NPLC 2 (the rest at 1)."""
    write_run(folder / "a.h5", sample="bronze A", operator="ann", notes="liner re-honed",
              started="2026-01-02T10:00:00.000+00:00")  # fmt: skip
    write_run(folder / "b.h5", sample="bronze A", operator="bob", nplc="2.0", started="2026-01-03T10:00:00.000+01:00")
    write_run(folder / "c.h5", sample="steel", operator="ann", started="2026-01-05T10:00:00.000-05:00")
    (folder / "sub").mkdir()
    write_run(folder / "sub" / "d.h5", sample="steel", operator="chen", started="2026-01-04T10:00:00.000+00:00")
    return folder


def test_index_page_is_the_run_index_query(client: Client, lab: Path):
    """Every filter the page offers is a ``--where`` text, and the rows are ``daq.run_index.query``'s (newest first,
    paths relative to the folder), tags and remarks included."""
    from daq.run_index import query

    for where in ([], ["sample~bronze"], ["operator=ann"], ["start>=2026-01-03", "start<=2026-01-04"],
                  ["text~re-honed"], ["status=success"], ["scene~a"]):  # fmt: skip
        params = {"where": where} if where else {}
        got = indexed(client, **params)["sessions"]
        expected, _ = query(lab, where, refresh=False, descending=True, detail=False)
        assert [r["path"] for r in got] == [Path(e["path"]).relative_to(lab).as_posix() for e in expected], where
        assert got == [{**e, "path": Path(e["path"]).relative_to(lab).as_posix()} for e in expected]
    newest_first = [r["path"] for r in indexed(client)["sessions"]]
    assert newest_first == ["c.h5", "sub/d.h5", "b.h5", "a.h5"]  # the 5th 15:00Z, 4th 10:00Z, 3rd 09:00Z, 2nd
    oldest_first = [r["path"] for r in indexed(client, order="asc")["sessions"]]
    assert oldest_first == newest_first[::-1]


def test_pages_of_the_index_and_the_count(client: Client, lab: Path, monkeypatch: pytest.MonkeyPatch):
    """``offset`` gives the next page (PAGE_ROWS a page), ``matched`` counts every match; a bad offset is a 400."""
    from contactrig.console import catalog

    monkeypatch.setattr(catalog, "PAGE_ROWS", 3)
    first = indexed(client)
    assert [r["path"] for r in first["sessions"]] == ["c.h5", "sub/d.h5", "b.h5"]  # newest first, 3 a page
    assert (first["matched"], first["offset"], first["more"]) == (4, 0, True)
    second = client.get("/api/sessions", params={"kick": "0", "offset": "3"}).json()
    assert [r["path"] for r in second["sessions"]] == ["a.h5"] and (second["matched"], second["more"]) == (4, False)
    steel = client.get("/api/sessions", params={"kick": "0", "where": "sample=steel", "offset": "1"}).json()
    assert [r["path"] for r in steel["sessions"]] == ["sub/d.h5"] and steel["matched"] == 2
    for bad in ("-1", "x", "1e3", "9" * 20):
        r = client.get("/api/sessions", params={"offset": bad})
        assert r.status_code == 400 and "offset" in r.json()["error"] and "\n" not in r.json()["error"], bad


def test_a_bad_filter_is_a_one_line_error(client: Client, lab: Path):
    for bad, needle in (("nope=1", "--where"), ("status=great", "status="), ("start>=yesterday", "date")):
        r = client.get("/api/sessions", params={"where": bad})
        assert r.status_code == 400 and needle in r.json()["error"] and "\n" not in r.json()["error"], (bad, r.text)


def test_the_page_never_waits_for_a_scan(client: Client, lab: Path, monkeypatch: pytest.MonkeyPatch):
    """While a refresh is under way (held here), the index answers at once with what it holds and says it is being
    updated; once the refresh ends the next answer has the new session."""
    import daq.run_index as run_index

    indexed(client)
    write_run(lab / "new.h5", sample="new one")
    held, entered = threading.Event(), threading.Event()
    real = run_index.refresh

    def slow_refresh(folder: Any, **kw: Any) -> Any:
        entered.set()
        held.wait(60)
        return real(folder, **kw)

    monkeypatch.setattr(run_index, "refresh", slow_refresh)
    client.console.catalog.kick()
    assert entered.wait(10)
    t = time.perf_counter()
    data = client.get("/api/sessions").json()
    took = time.perf_counter() - t
    assert data["indexing"] and "new.h5" not in [r["path"] for r in data["sessions"]] and took < 2.0
    assert len(data["sessions"]) == 4
    held.set()
    deadline = time.monotonic() + 60
    while (data := client.get("/api/sessions", params={"kick": "0"}).json())["indexing"]:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    assert "new.h5" in [r["path"] for r in data["sessions"]]


def test_tags_and_remarks_from_the_session_page(client: Client, lab: Path):
    """A mark is appended to the folder's sidecar (the session file unchanged), shown on the session page and in
    the index with who and when, found by ``tag=`` and ``text~``; the route has the guards of every state change."""
    before = (lab / "b.h5").read_bytes()
    r = client.post("/api/session/mark", {"path": "b.h5", "kind": "tag", "text": "nplc2", "who": "ann"})
    assert r.status_code == 200, r.text
    remark = "liner re-honed after this run " + HOSTILE["script"]
    r = client.post("/api/session/mark", {"path": "b.h5", "kind": "remark", "text": remark, "who": "bob"})
    assert r.status_code == 200 and r.json()["mark"]["who"] == "bob" and r.json()["mark"]["at"]
    assert (lab / "b.h5").read_bytes() == before
    marks = client.get("/api/session", params={"path": "b.h5"}).json()["marks"]
    assert [(m["kind"], m["text"], m["who"]) for m in marks] == [("tag", "nplc2", "ann"), ("remark", remark, "bob")]
    assert all(m["at"] for m in marks)
    [row] = indexed(client, where=["tag=nplc2"])["sessions"]
    assert row["path"] == "b.h5" and [(t["text"], t["who"]) for t in row["tags"]] == [("nplc2", "ann")]
    assert row["remarks"][0]["text"] == remark and row["remarks"][0]["at"] == marks[1]["at"]
    found = [r["path"] for r in indexed(client, where=["text~re-honed"])["sessions"]]
    assert sorted(found) == ["a.h5", "b.h5"]  # a's notes, b's remark
    assert client.get("/api/session", params={"path": "a.h5"}).json()["marks"] == []
    body = {"path": "a.h5", "kind": "tag", "text": "x", "who": "ann"}
    assert client.http.post("/api/session/mark", json=body).status_code == 403  # no token
    assert client.post("/api/session/mark", body, headers={"origin": "http://evil.example"}).status_code == 403
    assert client.http.post("/api/session/mark", json=body, headers={"x-contactrig-token": client.console.token}
                            ).status_code == 403  # no Origin  # fmt: skip
    for bad, needle in (({"kind": "star"}, "kind"), ({"text": "two words"}, "--tag"), ({"text": ""}, "--tag"),
                        ({"who": ""}, "who"), ({"who": "a\nb"}, "who"), ({"path": "../a.h5"}, "session"),
                        ({"path": "small.toml"}, "FILE"), ({"text": 3}, "text"), ({"text": "x\udcd8"}, "--tag"),
                        ({"who": "\udcd8"}, "who")):  # fmt: skip
        raw = json.dumps({**body, **bad}).encode()  # ASCII with escapes: a lone surrogate as a browser may send it
        headers = {**client.headers, "content-type": "application/json"}
        r = client.http.post("/api/session/mark", content=raw, headers=headers)
        assert r.status_code == 400 and needle in r.json()["error"] and "\n" not in r.json()["error"], (bad, r.text)
    assert client.get("/api/session", params={"path": "a.h5"}).json()["marks"] == []


def test_diff_names_the_setting_that_differs(client: Client, lab: Path):
    """a.h5 and b.h5 differ in the voltmeter's NPLC (and so the scene's text and hash) and their operator."""
    r = client.get("/api/diff", params={"a": "a.h5", "b": "b.h5"})
    assert r.status_code == 200, r.text
    d = r.json()
    assert d["a"] == "a.h5" and d["b"] == "b.h5"
    fields = {x["field"]: (x["a"], x["b"]) for x in d["differences"]}
    assert {k: v for k, v in fields.items() if k.startswith("settings.")} == {"settings.delta.nplc": (1.0, 2.0)}
    assert fields["operator"] == ("ann", "bob") and "scene_sha256" in fields
    assert any("nplc" in ln for ln in d["scene_lines"]) and d["same"] > 10
    assert client.get("/api/diff", params={"a": "c.h5", "b": "sub/d.h5"}).json()["differences"] == [
        {"field": "operator", "a": "ann", "b": "chen"}
    ]
    for a, b in (("a.h5", "../x.h5"), ("a.h5", ""), ("a.h5", "small.toml")):
        r = client.get("/api/diff", params={"a": a, "b": b})
        assert r.status_code == 400 and "\n" not in r.json()["error"], (a, b, r.text)


def test_the_last_fit_is_shown_stale_and_searched(client: Client, lab: Path, monkeypatch: pytest.MonkeyPatch):
    """The last fit's verdict (daq.run_index.record_fit, as `contactrig fit` writes it) on the index page, found by
    the page's "last fit" filter (--where verdict=), stale once the analysis version changes."""
    from contactrig.core import provenance
    from daq.run_index import record_fit

    record_fit(lab / "b.h5", discriminates=False, best="hertz", statement="Verdict: x", who="ann")
    record_fit(lab / "b.h5", discriminates=True, best="lagemann", statement="Verdict: y", who="bob")  # the last
    [row] = indexed(client, where=["verdict=discriminates"])["sessions"]
    assert row["path"] == "b.h5" and (row["fit"]["best"], row["fit"]["who"], row["fit"]["stale"]) == (
        "lagemann", "bob", False
    )  # fmt: skip
    assert indexed(client, where=["verdict=undecided"])["sessions"] == []
    assert {r["path"] for r in indexed(client, where=["verdict=none"])["sessions"]} == {"a.h5", "c.h5", "sub/d.h5"}
    monkeypatch.setattr(provenance, "software_version", lambda: "99.0")
    [row] = indexed(client, where=["verdict=stale"])["sessions"]
    assert row["path"] == "b.h5" and row["fit"]["stale"] is True


def test_a_refresh_that_ends_while_the_rows_are_read_is_still_said_to_be_running(client: Client, folder: Path,
                                                                                 monkeypatch: pytest.MonkeyPatch):
    """A CI run (27 Nov 2026) once found no session in the first index page after a console run had ended. The
    answer read ``indexing`` *after* the rows: a refresh that ended while the rows were read was claimed for rows
    read before it had written them, and the page (or a test) stopped polling on a stale table. ``generation`` and
    ``indexing`` are now read together, before the rows."""
    from contactrig.console.catalog import Catalog

    indexed(client)  # the console's first refresh has ended; nothing else runs
    catalog = client.console.catalog
    with catalog._lock:
        catalog._busy = True  # a refresh under way, as the refresh thread marks it
    before = catalog.generation
    real_rows = Catalog.rows

    def rows_then_the_refresh_ends(self: Catalog, *args: Any, **kwargs: Any) -> Any:
        out = real_rows(self, *args, **kwargs)  # the index as it is: the refresh has not written its rows yet
        with self._lock:  # ... and it ends before the page is answered
            self._busy = False
            self.generation += 1
        return out

    monkeypatch.setattr(Catalog, "rows", rows_then_the_refresh_ends)
    data = client.get("/api/sessions", params={"kick": "0"}).json()
    assert data["generation"] == before and data["indexing"], "rows read during a refresh claimed as after it"
    data = client.get("/api/sessions", params={"kick": "0"}).json()  # the next poll: after it, and said so
    assert data["generation"] == before + 1 and not data["indexing"]
