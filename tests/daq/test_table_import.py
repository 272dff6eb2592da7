"""The one table reader (``daq.table_import.read_table`` / ``parse_table``): units in headers, plausibility bounds,
duplicates, empty cells, spreadsheet separators, and that every refusal is a one-line SettingError naming where."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from contactrig.cli.main import main
from contactrig.core.validation import SettingError
from daq.errors import MissingFileError
from daq.session_file import load_session
from daq.table_import import (
    RESISTANCE_BOUNDS_OHM,
    STANDARD_GRAVITY,
    WEIGHT_BOUNDS_KG,
    ResistanceTable,
    TableError,
    parse_table,
    read_table,
    tab1_path,
)


def _write(tmp_path, text, name="t.csv", encoding="utf-8"):
    p = tmp_path / name
    p.write_bytes(text.encode(encoding))
    return p


# ---- units in headers ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("header", "cell", "kg"),
    [
        ("weight_kg", "5.44", 5.44),
        ("Weight_KG", "5.44", 5.44),
        ("weight [kg]", "5.44", 5.44),
        ("mass (kg)", "5.44", 5.44),
        ("weight", "5.44", 5.44),  # no unit: kg
        ("weight_g", "5440", 5.44),
        ("weight [g]", "5440", 5.44),
        ("load_N", "53.348", 53.348 / STANDARD_GRAVITY),
        ("load [n]", "53.348", 53.348 / STANDARD_GRAVITY),
    ],
)
def test_weight_header_units(header, cell, kg):
    t = parse_table(f"{header},M1\n{cell},7.1\n", "mohm")
    assert t.weight_kg[0] == pytest.approx(kg, rel=1e-12)
    assert t.weight_column == header
    if t.weight_unit == "N":
        assert any("g = 9.80665" in n for n in t.notes)  # the conversion is said


@pytest.mark.parametrize(
    ("header", "ohm"),
    [
        ("R_mohm", 7.1e-3),
        ("R_mOhm", 7.1e-3),
        ("R_MOHM", 7.1e-3),  # case-insensitive: MOHM is mΩ (no MΩ contact resistances)
        ("M1 [mΩ]", 7.1e-3),
        ("M1 (mohm)", 7.1e-3),
        ("R_ohm", 7.1),
        ("R [Ω]", 7.1),
        ("R_uohm", 7.1e-6),
        ("R [µΩ]", 7.1e-6),  # micro sign
        ("R [μΩ]", 7.1e-6),  # Greek mu
        ("R_uΩ", 7.1e-6),
    ],
)
def test_resistance_header_units(header, ohm):
    value = "0.0071" if ohm == 7.1 else "7.1"  # 7.1 Ω is implausible: the Ω case is written as 0.0071 Ω
    t = parse_table(f"weight_kg,{header}\n5,{value}\n")
    expect = 7.1e-3 if ohm == 7.1 else ohm
    assert t.resistance_ohm[0, 0] == pytest.approx(expect, rel=1e-12)
    assert t.columns == (header,)


def test_header_without_unit_uses_the_unit_option_a_matching_header_unit_is_fine():
    t = parse_table("weight_kg,M1,M2_mohm\n5,7.1,7.2\n", "mohm")
    assert t.column_units == ("mohm", "mohm") and t.unit == "mohm"
    np.testing.assert_allclose(t.resistance_ohm, [[7.1e-3, 7.2e-3]], rtol=1e-12)


def test_mixed_header_units_are_converted_and_recorded():
    t = parse_table("weight_kg,M1_mohm,M2_uohm\n5,7.1,7100\n")
    assert t.column_units == ("mohm", "uohm") and t.unit == "mixed"
    np.testing.assert_allclose(t.resistance_ohm, [[7.1e-3, 7.1e-3]], rtol=1e-12)


def test_header_unit_is_enough_without_the_option():
    assert parse_table("weight_kg,M1_mohm\n5,7.1\n").unit == "mohm"


@pytest.mark.parametrize(
    ("text", "unit", "column", "message"),
    [
        ("weight_kg,M1\n5,7\n", None, "M1", "--unit is required"),
        ("weight_kg,M1_ohm\n5,0.007\n", "mohm", "M1_ohm", "the header says ohm, --unit says mohm"),
        ("weight_kg,M1 [kohm]\n5,7\n", "mohm", "M1 [kohm]", "ohm, mohm or uohm"),
        ("weight [lb],M1\n5,7\n", "mohm", "weight [lb]", "kg, g or N for the weight"),
        ("R_mohm,M1\n5,7\n", "mohm", "R_mohm", "the first column must be the weight"),
        ("M1,M2\n5,7\n", "mohm", "M1", "the first column must be the weight"),
        ("load,M1\n5,7\n", "mohm", "load", "load_N"),
        ("weight_kg,weight_g,M1\n5,5000,7\n", "mohm", "weight_g", "only the first column is a weight"),
        ("weight_kg,M1,Avg\n5,7,7\n", "mohm", "Avg", "looks like an average"),
        ("weight_kg,M1,SD [mΩ]\n5,7,0.1\n", "mohm", "SD [mΩ]", "looks like an average or statistic"),
        ("weight_kg,M1,m1\n5,7,7\n", "mohm", "m1", "unique column name"),
        ("weight_kg,M1,M1 [mΩ]\n5,7,7\n", "mohm", "M1 [mΩ]", "unique column name"),
        ("weight_kg,,M2\n5,7,7\n", "mohm", "#2", "needs a name"),
    ],
)
def test_bad_headers(text, unit, column, message):
    with pytest.raises(TableError, match=message) as info:
        parse_table(text, unit, source="bad.csv")
    assert info.value.column == column and info.value.path == "bad.csv"
    assert str(info.value).startswith(f"bad.csv: column {column!r}")


# ---- plausibility ------------------------------------------------------------------------------------------------
def _tab1_text():
    return tab1_path().read_text(encoding="utf-8")


def test_tab1_read_in_ohm_is_implausible():
    """Tab. 1 (mΩ) imported with --unit ohm: 7.1 Ω is not a contact resistance of this rig."""
    with pytest.raises(TableError, match=r"is the unit right\?") as info:
        parse_table(_tab1_text(), "ohm", source="tab1.csv")
    assert (info.value.row, info.value.column, info.value.value) == (2, "M1", "7.1124")


def test_ohm_values_in_a_milliohm_table_are_implausible():
    with pytest.raises(TableError, match=r"7100 mohm = 7.1 Ω") as info:
        parse_table("weight_kg,M1,M2\n5,7.1,8\n7,7100,8\n", "mohm", source="t.csv")
    assert (info.value.row, info.value.column) == (3, "M1")


def test_ohm_values_labelled_microohm_are_implausible():
    with pytest.raises(TableError, match=r"\[0.01, 1e\+06\] uohm"):
        parse_table("weight_kg,M1\n5,0.0071\n", "uohm")


@pytest.mark.parametrize("cell", ["10000.5", "20000", "-1", "-0.001"])
def test_weights_outside_the_bounds(cell):
    with pytest.raises(TableError, match=r"weight in \[0, 10000\] kg") as info:
        parse_table(f"weight_kg,M1\n{cell},7\n", "mohm")
    assert info.value.column == "weight_kg" and info.value.row == 2


def test_weight_bounds_apply_after_conversion():
    with pytest.raises(TableError, match=r"200000 N = 20394.3 kg"):
        parse_table("load_N,M1\n200000,7\n", "mohm")
    t = parse_table("weight_kg,M1\n0,7\n10000,1\n", "mohm")  # both bounds are inclusive
    assert t.weight_kg.tolist() == [WEIGHT_BOUNDS_KG[0], WEIGHT_BOUNDS_KG[1]]


def test_resistance_bounds_are_inclusive():
    lo, hi = RESISTANCE_BOUNDS_OHM
    t = parse_table(f"weight_kg,M1\n1,{lo:.17g}\n2,{hi:.17g}\n", "ohm")
    assert t.resistance_ohm[:, 0].tolist() == [lo, hi]


# ---- cells -------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("cell", "message"),
    [
        ("0", "resistance > 0"),
        ("-7.1", "resistance > 0"),
        ("\u22127.1", "resistance > 0"),  # a spreadsheet's minus sign
        ("nan", "finite number"),
        ("NaN", "finite number"),
        ("inf", "finite number"),
        ("-Infinity", "finite number"),
        ("NA", "finite number"),
        ("1e400", "overflows"),
        ("#DIV/0!", "spreadsheet error"),
        ("7.1 mOhm", "expected a number"),
        ("1_000", "expected a number"),
        ("abc", "expected a number"),
        ("٣", "expected a number"),  # Arabic-Indic digit: float() takes it, a table should not
        ("", "empty cell"),
    ],
)
def test_bad_resistance_cells_name_file_row_and_column(cell, message):
    with pytest.raises(TableError, match=message) as info:
        parse_table(f"weight_kg,M1,M2\n5,7.1,8\n7,6.5,{cell}\n", "mohm", source="t.csv")
    e = info.value
    assert (e.path, e.row, e.column, e.value) == ("t.csv", 3, "M2", cell)
    assert str(e).startswith("t.csv: row 3, column 'M2' = ") and "\n" not in str(e)
    assert isinstance(e, SettingError) and e.field == "t.csv: row 3, column 'M2'"


def test_empty_weight_is_refused_even_with_allow_missing():
    with pytest.raises(TableError, match="a weight") as info:
        parse_table("weight_kg,M1\n,7\n", "mohm", allow_missing=True)
    assert info.value.column == "weight_kg"


def test_allow_missing_reads_empty_repeats_as_nan_but_not_empty_rows():
    t = parse_table("weight_kg,M1,M2\n5,7.1,\n7,,6.5\n", "mohm", allow_missing=True)
    assert np.isnan(t.resistance_ohm[0, 1]) and np.isnan(t.resistance_ohm[1, 0]) and not t.complete
    short = parse_table("weight_kg,M1,M2\n5,7.1\n", "mohm", allow_missing=True)  # a short row: missing M2
    assert np.isnan(short.resistance_ohm[0, 1])
    with pytest.raises(TableError, match="at least one resistance per weight") as info:
        parse_table("weight_kg,M1,M2\n5,7.1,8\n7,,\n", "mohm", allow_missing=True)
    assert info.value.row == 3


def test_nan_text_is_refused_even_with_allow_missing():
    with pytest.raises(TableError, match="finite"):
        parse_table("weight_kg,M1,M2\n5,7.1,nan\n", "mohm", allow_missing=True)


def test_duplicate_weights_name_both_rows():
    with pytest.raises(TableError, match=r"5\.44 kg is on row 2 already") as info:
        parse_table("weight_kg,M1\n5.44,7\n# a comment\n6,7\n5.440,8\n", "mohm")
    assert info.value.row == 5


def test_rows_keep_the_file_order_and_their_file_row():
    t = parse_table("# Tab. 1\n\nweight_kg,M1\n10,5\n\n5,7\n", "mohm")
    assert t.weight_kg.tolist() == [10.0, 5.0] and t.rows == (4, 6)


@pytest.mark.parametrize(
    ("text", "row", "message"),
    [
        ("weight_kg,M1\n5,7,8\n", 2, "beyond the header's 2 columns"),
        ("5.44,7.1\n6,8\n", 1, "header row first"),
        ("weight_kg,M1\n", None, "at least one row"),
        ("", None, "at least one row"),
        ("weight_kg\n5\n", 1, "at least one repeat column"),
    ],
)
def test_bad_shapes(text, row, message):
    with pytest.raises(TableError, match=message) as info:
        parse_table(text, "mohm")
    assert info.value.row == row


def test_trailing_empty_columns_of_a_spreadsheet_are_ignored():
    t = parse_table("weight_kg,M1,,\n5,7,,\n", "mohm")
    assert t.columns == ("M1",) and t.resistance_ohm.shape == (1, 1)


# ---- separators and decimal marks ---------------------------------------------------------------------------------
def test_semicolons_and_decimal_commas_are_detected():
    t = parse_table("weight_kg;M1;M2\n5,44;7,1124;9,5167\n7,44;6,5575;9,1613\n", "mohm")
    assert (t.delimiter, t.decimal) == (";", ",")
    np.testing.assert_allclose(t.weight_kg, [5.44, 7.44])
    np.testing.assert_allclose(t.resistance_ohm * 1e3, [[7.1124, 9.5167], [6.5575, 9.1613]], rtol=1e-12)


def test_tabs_and_semicolons_with_decimal_points():
    assert parse_table("weight_kg\tM1\n5.44\t7.1\n", "mohm").delimiter == "\t"
    t = parse_table("weight_kg;M1\n5.44;7.1\n", "mohm")
    assert (t.delimiter, t.decimal) == (";", ".") and t.weight_kg[0] == 5.44


def test_mixed_decimal_marks_are_refused():
    with pytest.raises(TableError, match="decimal comma like the rest") as info:
        parse_table("weight_kg;M1\n5,44;7.1\n", "mohm")
    assert (info.value.row, info.value.column) == (2, "M1")
    with pytest.raises(TableError, match="decimal point") as info:
        parse_table('weight_kg,M1\n5.44,"7,1"\n', "mohm")


def test_forced_delimiter_and_decimal():
    text = "weight_kg;M1\n5;7\n"
    t = parse_table(text, "mohm", delimiter=";", decimal=",")
    assert (t.delimiter, t.decimal) == (";", ",") and t.weight_kg[0] == 5.0
    assert parse_table("weight_kg\tM1\n5\t7\n", "mohm", delimiter="tab").delimiter == "\t"
    with pytest.raises(TableError, match=r"header row and at least one row|repeat column"):
        parse_table(text, "mohm", delimiter=",")  # the whole line is one column
    with pytest.raises(TableError, match="not the column separator"):
        parse_table("weight_kg,M1\n5,7\n", "mohm", decimal=",")
    with pytest.raises(SettingError, match="--delimiter"):
        parse_table(text, "mohm", delimiter="|")
    with pytest.raises(SettingError, match="--decimal"):
        parse_table(text, "mohm", decimal="'")
    with pytest.raises(SettingError, match="--unit"):
        parse_table(text, "kohm")


def test_forced_decimal_point_refuses_commas():
    with pytest.raises(TableError, match="decimal point"):
        parse_table("weight_kg;M1\n5,5;7\n", "mohm", decimal=".")


# ---- files: encodings, missing --------------------------------------------------------------------------------------
@pytest.mark.parametrize(("encoding", "note"), [("utf-8-sig", None), ("utf-16", "UTF-16"), ("cp1252", "Windows-1252")])
def test_spreadsheet_encodings(tmp_path, encoding, note):
    p = _write(tmp_path, "weight_kg;M1 [µohm]\n5,44;7,1\n", encoding=encoding)  # no Ω in Windows-1252
    t = read_table(p)
    assert t.columns == ("M1 [µohm]",) and t.resistance_ohm[0, 0] == pytest.approx(7.1e-6)
    assert (note is None and not t.notes) or any(note in n for n in t.notes)


def test_missing_and_unreadable_files(tmp_path):
    with pytest.raises(MissingFileError, match="no such table"):
        read_table(tmp_path / "missing.csv", "mohm")
    with pytest.raises(TableError, match="a readable file"):
        read_table(tmp_path, "mohm")  # a directory


def test_tab1_is_read_by_the_reader():
    t = read_table(tab1_path(), "mohm")
    assert isinstance(t, ResistanceTable) and t.complete and t.resistance_ohm.shape == (8, 6)
    assert t.columns == ("M1", "M2", "M3", "M4", "M5", "M6") and t.unit == "mohm" and t.notes == ()


# ---- the command ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("text", "args", "message"),
    [
        ("weight_kg,M1\n5,7100\n", ["--unit", "mohm"], "row 2, column 'M1' = '7100'"),
        ("weight_kg,M1,M1\n5,7,7\n", ["--unit", "mohm"], "column 'M1' = 'M1' is not allowed: a unique column"),
        ("weight_kg,M1\n5,7\n5,7\n", ["--unit", "mohm"], "row 3, column 'weight_kg'"),
        ("weight_kg,M1_ohm\n5,0.007\n", ["--unit", "mohm"], "--unit says mohm"),
        ("weight_kg;M1\n5,5;7\n", ["--unit", "mohm", "--decimal", "."], "decimal point"),
        ("weight_kg,M1,M2\n5,7,\n", ["--unit", "mohm"], "--allow-missing"),
    ],
)
def test_command_errors_are_one_line_exit_2(tmp_path, capsys, text, args, message):
    p = _write(tmp_path, text)
    assert main(["import", str(p), *args, "-o", str(tmp_path / "o.h5")]) == 2
    err = capsys.readouterr().err
    assert message in err and str(p) in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "o.h5").exists()


def test_command_reads_a_spreadsheet_export_with_units_and_missing_repeats(tmp_path, capsys):
    p = _write(tmp_path, "load_N;R1 [µohm];R2 [µohm]\n53,348;7100;8200,5\n72,96;6500;\n", encoding="cp1252")
    out = tmp_path / "o.h5"
    assert main(["import", str(p), "--allow-missing", "--delimiter", "semicolon", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "g = 9.80665" in err and "Windows-1252" in err and "1 missing repeat" in err
    s = load_session(out)
    assert len(s.summary) == 3 and s.start["plan"]["blocks_planned"] == 3 and s.complete
    assert s.summary.block.tolist() == [0, 1, 2] and s.summary.repeat.tolist() == [1, 2, 1]
    np.testing.assert_allclose(s.summary.weight_kg, [53.348 / 9.80665] * 2 + [72.96 / 9.80665], rtol=1e-12)
    src = s.start["source"]
    assert src["weight_unit"] == "N" and src["delimiter"] == ";" and src["decimal"] == ","


# ---- property: a table or a SettingError, nothing else --------------------------------------------------------------
_NAMES = st.one_of(
    st.sampled_from(
        ["weight_kg", "weight_g", "load_N", "weight [kg]", "M1", "M2", "m1", "R_mohm", "R_ohm", "R_uohm", "R [µΩ]",
         "Avg", "", "load", "x [furlong]", "M1 [kg]", "R (Ω", "#c", '"q"', "a;b", "a,b"]
    ),
    st.text(min_size=0, max_size=8),
)  # fmt: skip
_CELLS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(min_value=1e-9, max_value=1e5).map(lambda x: f"{x:.6g}"),
    st.floats(min_value=1e-9, max_value=1e5).map(lambda x: f"{x:.4f}".replace(".", ",")),
    st.integers(-(10**30), 10**30).map(str),
    st.sampled_from(["", "nan", "inf", "-0", "0", "1e400", "#N/A", "7,1", "1.2.3", "−3", "٣", " 7 ", "1_0"]),
    st.text(max_size=6),
)


@st.composite
def _tables(draw):
    ncols = draw(st.integers(1, 4))
    header = [draw(_NAMES) for _ in range(ncols)]
    rows = [[draw(_CELLS) for _ in range(draw(st.integers(0, ncols + 1)))] for _ in range(draw(st.integers(0, 4)))]
    sep = draw(st.sampled_from([",", ";", "\t", "|"]))
    end = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    return end.join(sep.join(r) for r in [header, *rows]) + draw(st.sampled_from(["", end]))


@st.composite
def _nearly_good_tables(draw):
    """A plausible table (weight column, M1…Mk, unique weights, mΩ-sized values), then maybe one cell spoilt."""
    k = draw(st.integers(1, 3))
    unit = draw(st.sampled_from(["", "_mohm", " [mΩ]", "_ohm", " (µΩ)"]))
    header = [draw(st.sampled_from(["weight_kg", "weight_g", "load_N", "weight", "W [kg]"]))]
    header += [f"M{i + 1}{unit}" for i in range(k)]
    weights = draw(st.lists(st.floats(0, 9000), min_size=1, max_size=5, unique=True))
    rows = [[f"{w:.17g}"] + [f"{draw(st.floats(0.05, 50)):.6g}" for _ in range(k)] for w in weights]
    if draw(st.booleans()):
        i, j = draw(st.integers(0, len(rows) - 1)), draw(st.integers(0, k))
        rows[i][j] = draw(_CELLS)
    sep = draw(st.sampled_from([",", ";", "\t"]))
    if sep != "," and draw(st.booleans()):
        rows = [[c.replace(".", ",") for c in r] for r in rows]
    return "\n".join(sep.join(r) for r in [header, *rows])


@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    text=st.one_of(_tables(), _nearly_good_tables()),
    unit=st.sampled_from([None, "ohm", "mohm", "uohm"]),
    delimiter=st.sampled_from([None, None, ",", ";", "tab"]),
    decimal=st.sampled_from([None, None, ".", ","]),
    allow_missing=st.booleans(),
)
def test_any_table_gives_a_valid_table_or_a_setting_error(text, unit, delimiter, decimal, allow_missing):
    try:
        t = parse_table(text, unit, source="gen.csv", delimiter=delimiter, decimal=decimal, allow_missing=allow_missing)
    except SettingError as exc:
        assert "\n" not in str(exc)
        return
    n, k = t.resistance_ohm.shape
    assert n == t.weight_kg.size >= 1 and k == len(t.columns) == len(t.column_units) >= 1
    assert np.all(np.isfinite(t.weight_kg)) and len(set(t.weight_kg.tolist())) == n
    assert np.all((t.weight_kg >= WEIGHT_BOUNDS_KG[0]) & (t.weight_kg <= WEIGHT_BOUNDS_KG[1]))
    r = t.resistance_ohm
    assert not np.any(np.isinf(r)) and np.all(np.isfinite(r).any(axis=1))
    assert allow_missing or np.all(np.isfinite(r))
    v = r[np.isfinite(r)]
    assert np.all((v >= RESISTANCE_BOUNDS_OHM[0]) & (v <= RESISTANCE_BOUNDS_OHM[1]))
    assert len(t.rows) == n and all(isinstance(x, int) for x in t.rows)


@settings(max_examples=60, deadline=None)
@given(
    text=st.one_of(_tables(), _nearly_good_tables()),
    encoding=st.sampled_from(["utf-8", "utf-8-sig", "utf-16", "cp1252", "latin-1"]),
)
def test_any_file_gives_a_valid_table_or_a_setting_error(tmp_path_factory, text, encoding):
    p = tmp_path_factory.mktemp("gen") / "t.csv"
    try:
        p.write_bytes(text.encode(encoding))
    except UnicodeEncodeError:
        p.write_bytes(text.encode("utf-8", "surrogatepass")[::-1])  # arbitrary bytes
    try:
        t = read_table(p, "mohm", allow_missing=True)
    except SettingError:
        return
    assert isinstance(t, ResistanceTable) and not math.isnan(float(np.nanmax(t.resistance_ohm)))


def test_import_never_replaces_the_table_it_reads(tmp_path, capsys):
    """``import t.csv -o t.csv --force`` is refused and the table kept (on 66d3b8c the session replaced it)."""
    table = tmp_path / "t.csv"
    text = "weight_kg,R1_mohm,R2_mohm\n1,5.0,5.2\n2,4.1,4.0\n"
    table.write_text(text)
    assert main(["import", str(table), "-o", str(table), "--force"]) == 2
    err = capsys.readouterr().err
    assert "a file other than the input it is made from" in err and "Traceback" not in err
    assert table.read_text() == text
