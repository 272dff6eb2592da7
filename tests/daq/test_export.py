"""``contactrig export``: a session as a Tab. 1-style summary and raw readings (CSV, Excel), a fit as its table;
the summary imports back to the same numbers."""

from __future__ import annotations

import csv
import importlib.util
import json
import math
import re
import sys

import numpy as np
import pandas as pd
import pytest

from contactrig.cli.main import main
from daq.export import ExcelUnavailable, export_fit, export_session, fit_tables, summary_table
from daq.plan import SessionPlan
from daq.table_import import parse_table

from .conftest import small_scene
from .sessions import load_quietly, write_session


@pytest.fixture(scope="module")
def session_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("export") / "s.h5"
    write_session(SessionPlan.from_scene(small_scene(sample='sample = "=HYPERLINK(\\"http://x\\")"')), path)
    return path


def _means(session):
    return {
        (float(w), int(r)): float(m)
        for w, r, m in zip(*(session.summary[c] for c in ("weight_kg", "repeat", "mean_ohm")), strict=True)
    }


def test_csv_summary_round_trips_through_contactrig_import(session_path, tmp_path, capsys):
    out = tmp_path / "out" / "s.csv"
    assert main(["export", str(session_path), "--to", "csv", "-o", str(out)]) == 0
    text = out.read_text(encoding="utf-8")
    header = next(ln for ln in text.splitlines() if not ln.startswith("#"))
    # Tab. 1 layout, unit in the headers, then per weight the statistics of the repeats
    assert header == '"weight_kg","M1_mohm","M2_mohm","mean_mohm","sd_mohm","sem_mohm","n"'
    back = tmp_path / "back.h5"
    assert main(["import", str(out), "-o", str(back)]) == 0
    original, imported = load_quietly(session_path), load_quietly(back)
    a, b = _means(original), _means(imported)
    assert a.keys() == b.keys() and len(a) == 6
    for key in a:
        assert a[key] == b[key], key  # the stored double itself (shortest_text), not a neighbour
    # the order the weights were placed is kept
    assert list(imported.summary["weight_kg"].unique()) == list(original.summary["weight_kg"].unique())


def test_csv_readings_hold_every_reading_exactly(session_path, tmp_path):
    paths = export_session(session_path, "csv", tmp_path / "x.csv")
    assert [p.name for p in paths] == ["x.csv", "x-readings.csv"]
    rows = list(csv.DictReader(paths[1].open(encoding="utf-8")))
    s = load_quietly(session_path)
    assert len(rows) == len(s.readings) == 6 * 8
    assert list(rows[0]) == ["block", "weight_kg", "repeat", "index", "time_s", "reading_V", "resistance_ohm", "valid"]
    np.testing.assert_array_equal([float(r["resistance_ohm"]) for r in rows], s.readings["resistance_ohm"])
    np.testing.assert_array_equal([float(r["time_s"]) for r in rows], s.readings["time_s"])
    assert [int(r["valid"]) for r in rows] == s.readings["valid"].astype(int).tolist()


def test_existing_outputs_are_refused_before_anything_is_written(session_path, tmp_path, capsys):
    (tmp_path / "s-readings.csv").write_text("keep me")
    assert main(["export", str(session_path), "-o", str(tmp_path / "s.csv")]) == 2
    err = capsys.readouterr().err
    assert "s-readings.csv exists; use --force to overwrite it" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "s.csv").exists() and (tmp_path / "s-readings.csv").read_text() == "keep me"
    assert main(["export", str(session_path), "-o", str(tmp_path / "s.csv"), "--force"]) == 0
    assert (tmp_path / "s-readings.csv").read_text().startswith('"block",')
    assert not list(tmp_path.glob("*.tmp")) and not list(tmp_path.glob(".*.tmp"))


def test_missing_and_compliant_repeats_are_empty_cells_that_import_with_allow_missing():
    summary = pd.DataFrame(
        {
            "block": [0, 1, 2, 3],
            "weight_kg": [5.0, 5.0, 10.0, 10.0],
            "repeat": [1, 2, 1, 2],
            "mean_ohm": [2e-3, 2.1e-3, math.nan, 1.1e-3],
            "compliance": [False, False, True, False],
        }
    )
    t = summary_table(summary.iloc[:2])  # the second weight not measured yet: no row for it
    sd = float(np.std([2.0, 2.1], ddof=1))  # numpy of the mΩ values; the table's from the Ω doubles
    assert t.rows[0][0] == 5.0 and [str(v) for v in t.rows[0][1:3]] == ["2", "2.1"]
    assert float(t.rows[0][3]) == pytest.approx(2.05, rel=1e-15) and float(t.rows[0][4]) == pytest.approx(sd, rel=1e-12)
    assert float(t.rows[0][5]) == pytest.approx(sd / math.sqrt(2), rel=1e-12) and t.rows[0][6] == 2
    assert t.columns == ("weight_kg", "M1_mohm", "M2_mohm", "mean_mohm", "sd_mohm", "sem_mohm", "n")
    t = summary_table(summary)
    assert t.rows[1][1] is None and any("compliance" in n for n in t.notes)
    assert t.rows[1][3:] == [t.rows[1][2], None, None, 1]  # one repeat: its mean, no SD
    text = "weight_kg,M1_mohm,M2_mohm\n" + "\n".join(
        ",".join("" if v is None else str(v) for v in row[:3]) for row in t.rows
    )
    table = parse_table(text, allow_missing=True)
    assert math.isnan(table.resistance_ohm[1, 0]) and table.resistance_ohm[1, 1] == pytest.approx(1.1e-3, rel=1e-15)


def test_xlsx_workbook_keeps_numbers_and_strings_as_text(session_path, tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    out = tmp_path / "s.xlsx"
    assert export_session(session_path, "xlsx", out) == [out]
    wb = openpyxl.load_workbook(out)
    assert wb.sheetnames == ["summary", "readings", "about"]
    rows = list(wb["summary"].iter_rows(values_only=True))
    assert rows[0] == ("weight_kg", "M1_mohm", "M2_mohm", "mean_mohm", "sd_mohm", "sem_mohm", "n")
    s = load_quietly(session_path)
    means = _means(s)
    for w, *values in rows[1:]:
        for r, v in enumerate(values[:2], start=1):
            assert v == pytest.approx(means[(w, r)] * 1e3, rel=1e-14)  # openpyxl writes 15 digits
    about = dict(wb["about"].iter_rows(values_only=True))
    assert about["sample"] == '=HYPERLINK("http://x")'  # a string from the file, not a formula
    assert wb["about"]["B4"].data_type == "s"


def test_xlsx_without_the_extra_is_one_line_naming_it(session_path, tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "openpyxl", None)  # import openpyxl → ImportError
    with pytest.raises(ExcelUnavailable, match=r"needs openpyxl.*: pip install 'openpyxl>=3.1'"):
        export_session(session_path, "xlsx", tmp_path / "s.xlsx")
    assert main(["export", str(session_path), "--to", "xlsx", "-o", str(tmp_path / "s.xlsx")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "pip install 'openpyxl>=3.1'" in err
    assert not (tmp_path / "s.xlsx").exists()


FIT = {
    "models": {
        name: {
            "conversion": "bulk",
            "weighting": "relative",
            "estimate": {"R_series_ohm": rs, "R_series_se": 1e-4, "scale": 4e-7, "scale_se": 1e-8},
            "intervals": {"t": {"R_series_ohm": [rs - 2e-4, rs + 2e-4]}},
            "goodness": {"chi2": 1.0, "dof": 4, "reduced_chi2": 0.25, "p_value": 0.9, "aic": aic, "rmse_ohm": 5e-5},
            "points": {"weight_kg": [5.0, 10.0], "measured_ohm": [2e-3, 1e-3], "fitted_ohm": [2.1e-3, 0.9e-3]},
            "unphysical": unphys,
        }
        for name, rs, aic, unphys in (("hertz", -4e-3, 3.0, ["R_s < 0"]), ("greenwood_tripp", 3e-4, 5.0, []))
    },
    "ranking": ["greenwood_tripp", "hertz"],
    "delta_aic": {"greenwood_tripp": 0.0, "hertz": -2.0},
    "statement": "the data do not tell the models apart",
}


def test_fit_table_from_a_saved_fit_json(tmp_path, capsys):
    tables, _ = fit_tables(FIT, "fit.json")
    fits = tables[0]
    assert [r[1] for r in fits.rows] == ["greenwood_tripp", "hertz"]  # ranking order
    col = dict(zip(fits.columns, fits.rows[1], strict=True))
    assert col["R_series_ohm"] == -4e-3 and col["physical"] == "no" and col["unphysical"] == "R_s < 0"
    assert col["R_series_t_low_ohm"] == pytest.approx(-4.2e-3)
    saved = tmp_path / "fit.json"
    saved.write_text(json.dumps(FIT))
    assert main(["export", str(saved), "--to", "csv", "-o", str(tmp_path / "f.csv")]) == 0
    rows = [r for r in csv.reader((tmp_path / "f.csv").open(encoding="utf-8")) if not r[0].startswith("#")]
    assert rows[0][:4] == ["rank", "model", "R_series_ohm", "R_series_se_ohm"]
    assert float(rows[2][2]) == -4e-3
    points = list(csv.DictReader((tmp_path / "f-points.csv").open(encoding="utf-8")))
    assert len(points) == 4 and points[0]["model"] == "greenwood_tripp" and float(points[0]["fitted_ohm"]) == 2.1e-3
    with pytest.raises(ValueError, match="models"):
        export_fit({"ranking": []}, "csv", tmp_path / "g.csv")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert main(["export", str(bad)]) == 2 and "not the JSON of" in capsys.readouterr().err


def test_export_fit_of_a_session_fits_now(tmp_path, capsys):
    """``export SESSION --fit``: the same numbers as ``fit --json`` on the same inputs."""
    src = tmp_path / "t.h5"
    assert main(["import", "--tab1", "-o", str(src)]) == 0
    assert main(["fit", str(src), "--json", "--bootstrap", "0", "--models", "hertz"]) == 0
    fit = json.loads(capsys.readouterr().out)
    args = ["export", str(src), "--fit", "--bootstrap", "0", "--models", "hertz", "-o", str(tmp_path / "fit.csv")]
    assert main(args) == 0
    rows = list(csv.DictReader(line for line in (tmp_path / "fit.csv").open(encoding="utf-8") if line[0] != "#"))
    hertz = next(r for r in rows if r["model"] == "hertz")
    assert float(hertz["R_series_ohm"]) == pytest.approx(fit["models"]["hertz"]["estimate"]["R_series_ohm"], rel=1e-9)


# ---- hostile strings in every CSV we write (CSV injection) ---------------------------------------------------------
HOSTILE = [
    "a,=1+2,@SUM(1+1)",
    "=HYPERLINK(\"http://x\",\"y\")",
    "+1+cmd|' /C calc'!A0",
    "-2+3",
    "@SUM(A1:A9)",
    "\t=1+1",
    "\r=1+1",
    "  =1+1",
    'x"y,z\nnext line',
]
_TRIGGERS = ("=", "+", "-", "@", "\t", "\r")


def _cells(path):
    """Every cell as a spreadsheet splits the file (RFC 4180 quoting, comma separator), with its raw field text."""
    text = path.read_text(encoding="utf-8")
    return [cell for row in csv.reader(text.splitlines()) for cell in row], text


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


_RAW_FIELD = re.compile(r'"(?:[^"]|"")*"|[^,]*')


def _raw_fields(line: str) -> list[str]:
    out, pos = [], 0
    while True:
        m = _RAW_FIELD.match(line, pos)
        out.append(m.group(0))
        pos = m.end()
        if pos >= len(line):
            return out
        assert line[pos] == ",", line
        pos += 1


def _assert_inert(path):
    cells, text = _cells(path)
    for cell in cells:
        if not _is_number(cell):  # text never starts a formula, even after leading blanks
            assert not cell.lstrip(" ").startswith(_TRIGGERS), (path.name, cell)
    for line in text.splitlines():  # every text field is quoted; numbers, empty fields and the "# key:" are not
        for raw in _raw_fields(line):
            assert raw == "" or _is_number(raw) or raw.startswith(('"', "# ")), (path.name, line)


@pytest.mark.parametrize("hostile", HOSTILE)
def test_csv_export_of_a_session_keeps_hostile_strings_in_one_inert_cell(hostile, tmp_path):
    toml = json.dumps(hostile)  # a TOML basic string is a JSON string
    path = tmp_path / "h.h5"
    write_session(SessionPlan.from_scene(small_scene(sample=f"sample = {toml}")), path)
    paths = export_session(path, "csv", tmp_path / "h.csv")
    for p in paths:
        _assert_inert(p)
    cells, _ = _cells(paths[0])
    i = cells.index("# sample:")
    shown = cells[i + 1]
    escaped = hostile.replace("\t", "\\x09").replace("\r", "\\x0d").replace("\n", "\\n")  # one line
    formula = hostile.lstrip(" ").startswith(_TRIGGERS)
    assert shown == ("'" if formula else "") + escaped  # one cell, the whole text, never split
    # the summary still imports to the same numbers
    back = tmp_path / "back.h5"
    assert main(["import", str(paths[0]), "-o", str(back)]) == 0
    a, b = _means(load_quietly(path)), _means(load_quietly(back))
    assert a.keys() == b.keys() and all(math.isclose(a[k], b[k], rel_tol=1e-15, abs_tol=0) for k in a)


def test_csv_export_of_a_fit_quotes_text_and_keeps_negative_numbers_numbers(tmp_path):
    fit = json.loads(json.dumps(FIT))
    fit["models"]["hertz"]["unphysical"] = HOSTILE
    fit["models"]["hertz"]["conversion"] = "=1+1"
    fit["statement"] = "@SUM(1+1),-3"
    paths = export_fit(fit, "csv", tmp_path / "f.csv", source="=evil.json")
    for p in paths:
        _assert_inert(p)
    line = next(ln for ln in paths[0].read_text(encoding="utf-8").splitlines() if ln.startswith("2,"))
    assert ",-0.004," in line  # a negative number is written as a number, unquoted and without a '
    assert ',"\'=1+1",' in line  # a text cell: quoted, neutralised
    rows = list(csv.reader(ln for ln in paths[0].open(encoding="utf-8") if ln[0] != "#"))
    assert float(rows[2][2]) == -4e-3


def test_export_fit_writes_the_physical_conversions_shares(tmp_path, capsys):
    """``export SESSION --fit --conversion physical``: a shares table (CSV beside the fits, a sheet in xlsx) with each
    term's share of the measured mean per weight, the numbers of ``fit --json``; term names are text cells, quoted and
    neutralised like every other."""
    src = tmp_path / "t.h5"
    assert main(["import", "--tab1", "-o", str(src)]) == 0
    opts = ["--bootstrap", "0", "--models", "greenwood_tripp", "--conversion", "physical"]
    assert main(["fit", str(src), "--json", *opts]) == 0
    shares = json.loads(capsys.readouterr().out)["models"]["greenwood_tripp"]["shares"]
    assert main(["export", str(src), "--fit", *opts, "-o", str(tmp_path / "fit.csv")]) == 0
    rows = list(csv.DictReader(ln for ln in (tmp_path / "fit-shares.csv").open(encoding="utf-8") if ln[0] != "#"))
    assert {r["term"] for r in rows} == {"series", "film", "barber", "macro", "residual"} and len(rows) == 5 * 8
    for r in rows:
        assert r["model"] == "greenwood_tripp"
    barber = [float(r["share_of_measured_mean"]) for r in rows if r["term"] == "barber"]
    np.testing.assert_allclose(barber, shares["barber"], rtol=1e-15)
    fit = json.loads(json.dumps(FIT))
    fit["models"]["hertz"]["shares"] = {"=cmd|' /C calc'!A0": [0.5, 0.5]}
    paths = export_fit(fit, "csv", tmp_path / "h.csv")
    assert paths[-1].name == "h-shares.csv"
    for p in paths:
        _assert_inert(p)
    if importlib.util.find_spec("openpyxl") is not None:
        import openpyxl

        export_fit(fit, "xlsx", tmp_path / "h.xlsx")
        assert "shares" in openpyxl.load_workbook(tmp_path / "h.xlsx").sheetnames


@pytest.mark.parametrize("to", ["csv", "xlsx"])
def test_an_export_never_replaces_its_own_session_even_with_force(session_path, tmp_path, capsys, to):
    """``export S.h5 -o S.h5 --force`` (or through a link to it) is refused, the session untouched: on 66d3b8c the
    CSV or workbook replaced the session."""
    session = tmp_path / "run.h5"
    session.write_bytes(session_path.read_bytes())
    before = session.read_bytes()
    link = tmp_path / "link.csv"
    link.symlink_to(session)
    for out in (session, link):
        assert main(["export", str(session), "--to", to, "-o", str(out), "--force"]) == 2
        err = capsys.readouterr().err
        assert "a file other than the input it is made from" in err and "Traceback" not in err
    assert session.read_bytes() == before
    assert main(["export", str(session), "--fit", "--to", to, "-o", str(session), "--force"]) == 2
    assert session.read_bytes() == before
