"""The one reader of tables of resistance per weight (like the seed paper's Tab. 1), and their import as sessions.

:func:`read_table` (a file) and :func:`parse_table` (text) are used by ``contactrig import`` (:func:`import_table`,
a table → a session file marked ``imported``) and by :mod:`analysis.measured` (``contactrig fit tab1``, the measured
curve); there is no other table reader.

Format
------
CSV text with a header row. Blank lines and lines starting with ``#`` are skipped. Rows are numbered as in the
file and in a spreadsheet (the header is normally row 1).

- **First column: the added weight**, in the unit its header names: ``weight_kg``, ``weight_g``, ``load_N``, or
  with brackets ``weight [kg]``, ``mass (g)``. ``N`` is the weight force of the added mass; it is converted to kg
  with standard gravity g = 9.80665 m/s² and the table's notes say so. A header without a unit (``weight``) is kg;
  ``load`` without a unit is refused (N or kg?).
- **Every further column: one repeat/series** (M1 … Mk). Its unit is the header's (``M1_mohm``, ``R [mΩ]``,
  ``R (ohm)``; spellings ohm/Ω, mohm/mΩ, uohm/µohm/μΩ, case-insensitive) or else the ``unit`` argument
  (``--unit``). A header unit that differs from ``unit`` is an error, so is a column with neither. A value is
  converted to Ω exactly (its decimal text shifted by 3 or 6 digits, then rounded once: :data:`DIGITS_PER_OHM`).
- **A table written by** ``contactrig export``: its ``#`` lines give the imported session its sample, operator,
  notes and scene name, and its per-weight statistics columns are left out (:mod:`daq.table_provenance`).
- **Separators**: ``,`` ``;`` or tab, detected from the header row; the decimal mark ``.`` or ``,`` (only with
  ``;`` or tab separators), detected from the cells. ``delimiter`` / ``decimal`` force them (``--delimiter``,
  ``--decimal``). Spreadsheet exports in UTF-16 or Windows-1252 are decoded too (the notes say so).

Refused, each with a :class:`TableError` (a :class:`~contactrig.core.validation.SettingError`) naming the file,
the row and/or the column, the value, and what is allowed:

- no header, no data row, no repeat column; a header that is numbers (the header row is missing); empty, duplicate
  (case-insensitive, unit ignored) or summary column names (``Avg``, ``mean``, ``SD``, ``SEM`` …: repeats only);
  a weight unit in a repeat column or a resistance unit in the weight column; an unknown unit in a header;
- a cell that is not a plain number (``1e-3``, ``-2.5``; no thousands separators, no ``_``), NaN, inf or a
  spreadsheet error (``#DIV/0!``), a decimal mark other than the table's, a cell beyond the header's columns;
- an empty weight; an empty repeat cell, unless ``allow_missing`` (``--allow-missing``): then it is a missing
  repeat (NaN; the import writes no block for it), but every row keeps at least one value;
- the same weight on two rows (one row per weight: repeats go in columns);
- values outside the plausibility bounds below (after unit conversion), which is how a table typed in Ω but
  labelled mΩ (or in g but labelled kg) is caught:

  ===========  =====================  ===============================================================================
  weight       0 … 10 000 kg          :data:`WEIGHT_BOUNDS_KG`; 0 = the piston alone; beyond 10 t is no bench weight
  resistance   10 nΩ … 1 Ω (> 0)      :data:`RESISTANCE_BOUNDS_OHM`; Tab. 1 is 1.5–9.5 mΩ, so Tab. 1 typed in mΩ
                                      but read as Ω (7.1 Ω) is refused; 1 Ω is 100 × Tab. 1's largest value; 10 nΩ
                                      is below what a Delta-mode pair resolves (a table typed in Ω but labelled
                                      µΩ comes out below it)
  ===========  =====================  ===============================================================================

Rows may come in any weight order; the table keeps the file's order (an import records the blocks in it), and
:class:`analysis.measured.MeasuredCurve` sorts by weight.

Import
------
Each cell becomes one block of one reading (n = 1: the standard deviation and standard error are undefined, stored
as NaN; the reading time is unknown, NaN). Nothing is dropped.
"""

from __future__ import annotations

import codecs
import csv
import errno
import hashlib
import io
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path
from typing import Any

import numpy as np

from contactrig.core.validation import SettingError, check_choice
from daq.errors import MissingFileError
from daq.table_provenance import session_metadata, without_statistics

__all__ = [
    "DECIMALS",
    "DELIMITERS",
    "DIGITS_PER_OHM",
    "RESISTANCE_BOUNDS_OHM",
    "STANDARD_GRAVITY",
    "TAB1_MEASURED_BY",
    "UNITS_OHM",
    "WEIGHT_BOUNDS_KG",
    "WEIGHT_UNITS_KG",
    "ResistanceTable",
    "TableError",
    "import_table",
    "parse_table",
    "read_table",
    "tab1_path",
]

#: Accepted ``--unit`` values and their size in Ω.
UNITS_OHM = {"ohm": 1.0, "mohm": 1e-3, "uohm": 1e-6}
#: Decimal digits from ohm to the unit (1 mΩ = 10⁻³ Ω). A cell is converted exactly — its decimal text shifted by
#: these digits, then rounded once to the nearest double (2.1 mΩ is the double nearest 0.0021 Ω, which 2.1 × 1e-3
#: misses by one ulp) — so every stored double has a text that reads back to it, and ``contactrig export`` writes
#: the shortest (:func:`daq.export.shortest_text`).
DIGITS_PER_OHM = {"ohm": 0, "mohm": 3, "uohm": 6}
#: Standard gravity [m/s²], converts a ``load_N`` column to kg.
STANDARD_GRAVITY = 9.80665
#: Units of the weight column and their size in kg.
WEIGHT_UNITS_KG = {"kg": 1.0, "g": 1e-3, "N": 1.0 / STANDARD_GRAVITY}
#: Plausible added weights [kg], inclusive.
WEIGHT_BOUNDS_KG = (0.0, 10_000.0)
#: Plausible contact resistances [Ω], inclusive.
RESISTANCE_BOUNDS_OHM = (1e-8, 1.0)
#: ``delimiter`` values (name → character).
DELIMITERS = {",": ",", ";": ";", "tab": "\t", "\t": "\t", "comma": ",", "semicolon": ";"}
#: ``decimal`` values.
DECIMALS = (".", ",")

_RES_SPELLINGS = {
    "ohm": "ohm", "ohms": "ohm", "ω": "ohm",
    "mohm": "mohm", "mohms": "mohm", "mω": "mohm", "milliohm": "mohm", "milliohms": "mohm",
    "uohm": "uohm", "uohms": "uohm", "µohm": "uohm", "μohm": "uohm", "uω": "uohm", "µω": "uohm", "μω": "uohm",
    "microohm": "uohm", "microohms": "uohm",
}  # fmt: skip
_WEIGHT_SPELLINGS = {"kg": "kg", "g": "g", "n": "N"}
_OTHER_WEIGHT_UNITS = {"lb", "lbs", "kn", "mn", "mg", "t", "kgf", "oz"}
_SUMMARY_NAMES = {
    "avg", "avg.", "average", "mean", "mean value", "median", "sd", "std", "std.", "stdev", "std dev", "sem", "se",
    "n", "count", "min", "max", "sum", "total",
}  # fmt: skip
_NON_FINITE = {"nan", "+nan", "-nan", "inf", "+inf", "-inf", "infinity", "+infinity", "-infinity", "na", "n/a"}
_BRACKETED = re.compile(r"^(.*?)\s*[\[(]\s*([^\])]*?)\s*[\])]\s*$")
_SUFFIXED = re.compile(r"^(.*?)[_ ]+([^\W\d_]+)$")
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_SPREADSHEET_ERROR = re.compile(r"#(N/A|DIV/0!|VALUE!|REF!|NAME\?|NUM!|NULL!|SPILL!|CALC!)", re.IGNORECASE)
_COMMA_NUMBER = re.compile(r"[+-]?[0-9]*,[0-9]+(?:[eE][+-]?[0-9]+)?")


#: Who measured Tab. 1 (recorded as ``measured_by`` of ``import --tab1``; its operator is not known).
TAB1_MEASURED_BY = (
    "Raffai, Maršálek & Nečasová, Numerical modelling of dry friction of piston rings in internal combustion "
    "engines (the seed paper), Tab. 1"
)


def tab1_path() -> Path:
    """The seed paper's Tab. 1 shipped with the package (``daq/data/tab1.csv``: weight_kg, M1 … M6 in mΩ)."""
    from importlib import resources

    return Path(str(resources.files("daq").joinpath("data/tab1.csv")))


class TableError(SettingError):
    """A table cannot be read: ``path``, ``row`` (file row, 1 = first line; None: the whole table) and ``column``
    (header text; None: the whole row) say where, ``value`` what was found, ``allowed`` what would do."""

    def __init__(self, path: str, row: int | None, column: str | None, value: Any, allowed: str) -> None:
        where = path
        if row is not None:
            where += f": row {row}"
        if column is not None:
            where += f"{',' if row is not None else ':'} column {column!r}"
        self.field = where
        self.value = value
        self.allowed = allowed
        self.path = path
        self.row = row
        self.column = column
        ValueError.__init__(self, f"{where} = {value!r} is not allowed: {allowed}")


@dataclass(frozen=True)
class ResistanceTable:
    """A parsed, validated table.

    ``weight_kg`` (n,) in the file's row order, ``resistance_ohm`` (n, k) [Ω] (NaN = a missing repeat, only with
    ``allow_missing``), ``columns`` the k repeat headers as written, ``column_units`` their units, ``unit`` the
    common unit of the repeat columns (``"mixed"`` if they differ), ``weight_column`` / ``weight_unit`` the first
    column's header and unit, ``rows`` the file row of each table row, ``delimiter`` / ``decimal`` as read,
    ``notes`` what the reader did that the user should know (conversions, encodings), ``text`` the decoded file,
    ``path`` where it came from.
    """

    weight_kg: np.ndarray
    resistance_ohm: np.ndarray
    columns: tuple[str, ...]
    weight_column: str
    unit: str
    text: str
    column_units: tuple[str, ...] = ()
    weight_unit: str = "kg"
    rows: tuple[int, ...] = ()
    delimiter: str = ","
    decimal: str = "."
    notes: tuple[str, ...] = ()
    path: str = ""

    @property
    def complete(self) -> bool:
        """Every repeat of every weight has a value."""
        return bool(np.all(np.isfinite(self.resistance_ohm)))

    def source_info(self) -> dict[str, Any]:
        """Provenance for a session's start record or a report (JSON-able; a file name that is not UTF-8 with its
        bytes as visible escapes, :func:`contactrig.core.text.shown`)."""
        from contactrig.core.text import shown

        return {
            "path": shown(Path(self.path).resolve()) if self.path else "",
            "sha256": hashlib.sha256(self.text.encode("utf-8")).hexdigest(),
            "unit": self.unit,
            "column_units": list(self.column_units),
            "weight_column": self.weight_column,
            "weight_unit": self.weight_unit,
            "repeat_columns": list(self.columns),
            "delimiter": self.delimiter,
            "decimal": self.decimal,
            "notes": [shown(n) for n in self.notes],
            "text": self.text,
        }


# ---- reading the file ----------------------------------------------------------------------------------------
def read_table(
    path: str | Path,
    unit: str | None = None,
    *,
    delimiter: str | None = None,
    decimal: str | None = None,
    allow_missing: bool = False,
) -> ResistanceTable:
    """Read and validate the table at ``path`` (see the module docstring for the format and the rules).

    ``unit`` (ohm, mohm, uohm) is the unit of repeat columns whose header names none; ``delimiter`` (``,`` ``;``
    ``tab``) and ``decimal`` (``.`` ``,``) override detection; ``allow_missing`` accepts empty repeat cells as
    missing repeats. A missing file is :class:`~daq.errors.MissingFileError`; everything else :class:`TableError`.
    """
    p = Path(path)
    text, notes = _decode(p, _read_bytes(p))
    return parse_table(
        text, unit, source=str(p), delimiter=delimiter, decimal=decimal, allow_missing=allow_missing, notes=notes
    )


def _read_bytes(p: Path) -> bytes:
    try:
        return p.read_bytes()
    except FileNotFoundError:
        raise MissingFileError(errno.ENOENT, f"no such table: {p}") from None
    except OSError as exc:
        raise TableError(str(p), None, None, "<file>", f"a readable file ({exc.strerror or exc})") from None


def _decode(p: Path, data: bytes) -> tuple[str, list[str]]:
    """UTF-8 (BOM optional); UTF-16 with a BOM; else Windows-1252 with a note (an older spreadsheet export)."""
    if data.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        try:
            return data.decode("utf-16"), [f"{p.name}: read as UTF-16 (spreadsheet 'Unicode text' export)"]
        except UnicodeDecodeError as exc:
            raise TableError(str(p), None, None, "<file>", f"UTF-8 or UTF-16 text ({exc.reason})") from None
    try:
        return data.decode("utf-8-sig"), []
    except UnicodeDecodeError:
        pass
    try:
        text = data.decode("cp1252")
    except UnicodeDecodeError as exc:
        raise TableError(str(p), None, None, "<file>", f"UTF-8 CSV text ({exc.reason})") from None
    return text, [f"{p.name}: not UTF-8, read as Windows-1252 (save as UTF-8 CSV to be sure of µ and Ω)"]


# ---- parsing text --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Column:
    header: str
    base: str
    unit: str  # canonical: kg, g, N or ohm, mohm, uohm


def parse_table(
    text: str,
    unit: str | None = None,
    *,
    source: str = "<table>",
    delimiter: str | None = None,
    decimal: str | None = None,
    allow_missing: bool = False,
    notes: Sequence[str] = (),
) -> ResistanceTable:
    """Parse and validate the table ``text`` (see the module docstring); ``source`` names it in errors."""
    if unit is not None:
        check_choice("--unit", unit, tuple(UNITS_OHM))
    if decimal is not None:
        check_choice("--decimal", decimal, DECIMALS)
    delim = _delimiter(text, delimiter)
    rows = without_statistics(_csv_rows(text, delim, source), text)  # an exported summary's mean/SD/SEM/n columns
    if len(rows) < 2:
        raise TableError(source, None, None, "<file>", "expected a header row and at least one row of values")
    weight_col, columns = _parse_header(rows[0], source, unit)
    dec = _decimal(rows[1:], delim, decimal, source)
    width = 1 + len(columns)
    weights, values = [], []
    for line, cells in rows[1:]:
        cells = _fit_width(cells, width, line, source)
        weights.append(_weight_cell(cells[0], weight_col, line, dec, source))
        values.append(_repeat_cells(cells[1:], columns, line, dec, source, allow_missing))
    w = np.asarray(weights, dtype=np.float64)
    _check_unique_weights(w, [line for line, _ in rows[1:]], weight_col, source)
    all_notes = [*notes, *_conversion_notes(weight_col)]
    units = {c.unit for c in columns}
    return ResistanceTable(
        weight_kg=w,
        resistance_ohm=np.asarray(values, dtype=np.float64).reshape(len(weights), len(columns)),
        columns=tuple(c.header for c in columns),
        weight_column=weight_col.header,
        unit=units.pop() if len(units) == 1 else "mixed",
        text=text,
        column_units=tuple(c.unit for c in columns),
        weight_unit=weight_col.unit,
        rows=tuple(line for line, _ in rows[1:]),
        delimiter=delim,
        decimal=dec,
        notes=tuple(all_notes),
        path=source,
    )


def _delimiter(text: str, forced: str | None) -> str:
    """The forced delimiter, else tab / ``;`` / ``,`` — the first of them in the header row."""
    if forced is not None:
        check_choice("--delimiter", forced, tuple(DELIMITERS))
        return DELIMITERS[forced]
    header = next((ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")), "")
    for d in ("\t", ";"):
        if d in header:
            return d
    return ","


def _csv_rows(text: str, delim: str, source: str) -> list[tuple[int, list[str]]]:
    """(file row, cells) of every row that is neither blank nor a ``#`` comment."""
    reader = csv.reader(io.StringIO(text, newline=""), delimiter=delim)
    rows: list[tuple[int, list[str]]] = []
    try:
        start = 1
        for cells in reader:
            cells = [c.strip() for c in cells]
            if any(cells) and not (cells[0].startswith("#") and not _SPREADSHEET_ERROR.match(cells[0])):
                rows.append((start, cells))
            start = reader.line_num + 1
    except csv.Error as exc:
        raise TableError(source, reader.line_num, None, "<row>", f"valid CSV ({exc})") from None
    return rows


# ---- the header ----------------------------------------------------------------------------------------------
def _split_unit(header: str) -> tuple[str, str | None]:
    """``"M1 [mΩ]"`` → (``"M1"``, ``"mΩ"``); ``"weight_kg"`` → (``"weight"``, ``"kg"``); no unit → (header, None).

    A bracketed part is always a unit; a ``_``/space suffix only when it reads as one."""
    m = _BRACKETED.match(header)
    if m and m.group(1):
        return m.group(1).strip(), m.group(2)
    m = _SUFFIXED.match(header)
    if m and m.group(1) and _looks_like_unit(m.group(2)):
        return m.group(1).strip(), m.group(2)
    return header, None


def _looks_like_unit(token: str) -> bool:
    t = token.lower()
    return t in _RES_SPELLINGS or t in _WEIGHT_SPELLINGS or t in _OTHER_WEIGHT_UNITS or t.endswith(("ohm", "ohms", "ω"))


def _unit_kind(token: str, source: str, header: str) -> tuple[str, str]:
    """("resistance" | "weight", canonical unit) of a header's unit, or a TableError for an unknown unit."""
    t = token.lower()
    if t in _RES_SPELLINGS:
        return "resistance", _RES_SPELLINGS[t]
    if t in _WEIGHT_SPELLINGS:
        return "weight", _WEIGHT_SPELLINGS[t]
    allowed = "a known unit: kg, g or N for the weight (first column); ohm, mohm or uohm (Ω, mΩ, µΩ) for repeats"
    raise TableError(source, None, header, token, allowed)


def _parse_header(line_cells: tuple[int, list[str]], source: str, unit: str | None) -> tuple[_Column, list[_Column]]:
    line, cells = line_cells
    while len(cells) > 1 and not cells[-1]:
        cells = cells[:-1]  # trailing empty columns of a spreadsheet export (their cells are checked per row)
    if all(_is_number(c) for c in cells):
        raise TableError(source, line, None, cells, "expected a header row first (weight_kg, M1, M2, …)")
    if len(cells) < 2:
        raise TableError(source, line, None, cells, "expected a weight column and at least one repeat column")
    weight = _weight_column(cells[0], source)
    columns = [_repeat_column(h, k, source, unit) for k, h in enumerate(cells[1:], start=2)]
    _check_unique_names([weight, *columns], source)
    return weight, columns


def _weight_column(header: str, source: str) -> _Column:
    if not header:
        raise TableError(source, None, "", header, "the first column needs a name like weight_kg")
    base, token = _split_unit(header)
    if token is None:
        if base.lower() in ("load", "force"):
            raise TableError(source, None, header, header, "name the unit: load_N (newtons) or weight_kg")
        if re.fullmatch(r"(?i)(m|s)\s*_?\d+|r\s*_?\d*|(series|repeat|run|resistance)\s*_?\d*", base):
            raise TableError(source, None, header, header, "the first column must be the weight (weight_kg)")
        return _Column(header, base, "kg")
    kind, canonical = _unit_kind(token, source, header)
    if kind != "weight":
        raise TableError(source, None, header, token, "the first column must be the weight: kg, g or N")
    return _Column(header, base, canonical)


def _repeat_column(header: str, k: int, source: str, unit: str | None) -> _Column:
    if not header:
        raise TableError(source, None, f"#{k}", header, "every repeat column needs a name (M1, M2, …)")
    base, token = _split_unit(header)
    if base.lower() in _SUMMARY_NAMES:
        raise TableError(source, None, header, header, "looks like an average or statistic, not a repeat: remove it")
    if token is None:
        if unit is None:
            raise TableError(
                source, None, header, header,
                "--unit is required (ohm, mohm or uohm), or a unit in the header (M1_mohm, M1 [mΩ])",
            )  # fmt: skip
        return _Column(header, base, unit)
    kind, canonical = _unit_kind(token, source, header)
    if kind != "resistance":
        raise TableError(source, None, header, token, "only the first column is a weight; repeats are resistances")
    if unit is not None and unit != canonical:
        raise TableError(source, None, header, token, f"the header says {canonical}, --unit says {unit}: drop one")
    return _Column(header, base, canonical)


def _check_unique_names(columns: list[_Column], source: str) -> None:
    seen: dict[str, str] = {}
    for c in columns:
        key = c.base.casefold()
        if key in seen:
            raise TableError(source, None, c.header, c.header, f"a unique column name (same as {seen[key]!r})")
        seen[key] = c.header


def _conversion_notes(weight: _Column) -> list[str]:
    if weight.unit == "N":
        return [f"column {weight.header!r}: N converted to kg with g = {STANDARD_GRAVITY} m/s² (added weight only)"]
    if weight.unit == "g":
        return [f"column {weight.header!r}: g converted to kg"]
    return []


# ---- the cells -----------------------------------------------------------------------------------------------
def _decimal(rows: list[tuple[int, list[str]]], delim: str, forced: str | None, source: str) -> str:
    """The forced decimal mark, else ``,`` when a cell is written with a decimal comma (``;``/tab tables only)."""
    if forced is not None:
        if forced == delim:
            raise TableError(source, None, None, forced, "a decimal mark that is not the column separator")
        return forced
    if delim == ",":
        return "."
    return "," if any(_COMMA_NUMBER.fullmatch(c) for _, cells in rows for c in cells) else "."


def _fit_width(cells: list[str], width: int, line: int, source: str) -> list[str]:
    """Pad a short row with empty cells (checked as such); refuse values beyond the header's last column."""
    if len(cells) > width and any(cells[width:]):
        extra = next(c for c in cells[width:] if c)
        raise TableError(source, line, None, extra, f"a value beyond the header's {width} columns: name its column")
    return (cells + [""] * width)[:width]


def _is_number(cell: str) -> bool:
    return bool(_NUMBER.fullmatch(cell) or _COMMA_NUMBER.fullmatch(cell))


def _number(cell: str, dec: str, line: int, header: str, source: str) -> float:
    """The value of a cell written as a plain number with decimal mark ``dec``; TableError otherwise."""
    text = cell.replace("\u2212", "-")  # the minus sign of some spreadsheets
    plain = text.replace(",", ".") if dec == "," and "." not in text else text
    if _NUMBER.fullmatch(plain) and not (dec == "," and "." in text):
        x = float(plain)
        if not math.isfinite(x):
            raise TableError(source, line, header, cell, "a finite number (this one overflows)")
        return x
    raise TableError(source, line, header, cell, _why_not_a_number(text, dec))


def _why_not_a_number(text: str, dec: str) -> str:
    if text.lower() in _NON_FINITE:
        return "a finite number (NaN, inf and NA are not values)"
    if text.startswith("#"):
        return "a number, not a spreadsheet error"
    if dec == "." and _COMMA_NUMBER.fullmatch(text):
        return "a number with a decimal point (decimal commas need ';' or tab column separators)"
    if dec == "," and _NUMBER.fullmatch(text):
        return "a number with a decimal comma like the rest of the table (or force --decimal .)"
    return "expected a number like 7.1124 or 1.5e-3 (no units, thousands separators or text in cells)"


def _weight_cell(cell: str, col: _Column, line: int, dec: str, source: str) -> float:
    if not cell:
        raise TableError(source, line, col.header, cell, "a weight (empty cells are not allowed here)")
    x = _number(cell, dec, line, col.header, source)
    kg = x * WEIGHT_UNITS_KG[col.unit]
    lo, hi = WEIGHT_BOUNDS_KG
    if not lo <= kg <= hi:
        conv = f" ({x:g} {col.unit} = {kg:g} kg)" if col.unit != "kg" else ""
        raise TableError(source, line, col.header, cell, f"expected a weight in [{lo:g}, {hi:g}] kg{conv}")
    return kg + 0.0  # no -0.0


def _repeat_cells(
    cells: list[str], columns: list[_Column], line: int, dec: str, source: str, allow_missing: bool
) -> list[float]:
    out = []
    for cell, col in zip(cells, columns, strict=True):
        if not cell:
            if not allow_missing:
                raise TableError(
                    source, line, col.header, cell, "a resistance (empty cell; --allow-missing reads it as missing)"
                )
            out.append(math.nan)
        else:
            out.append(_resistance(cell, col, line, dec, source))
    if all(math.isnan(v) for v in out):
        raise TableError(source, line, None, cells, "at least one resistance per weight")
    return out


def _resistance(cell: str, col: _Column, line: int, dec: str, source: str) -> float:
    x = _number(cell, dec, line, col.header, source)
    factor = UNITS_OHM[col.unit]
    if x <= 0:
        raise TableError(source, line, col.header, cell, "a resistance > 0")
    lo, hi = RESISTANCE_BOUNDS_OHM
    plain = cell.replace("\u2212", "-")
    r = float(Decimal(plain.replace(",", ".") if dec == "," else plain).scaleb(-DIGITS_PER_OHM[col.unit]))
    if not lo <= r <= hi:
        raise TableError(
            source, line, col.header, cell,
            f"a contact resistance in [{lo:g}, {hi:g}] Ω = [{lo / factor:g}, {hi / factor:g}] {col.unit}; "
            f"{x:g} {col.unit} = {r:g} Ω: is the unit right?",
        )  # fmt: skip
    return r


def _check_unique_weights(w: np.ndarray, lines: list[int], col: _Column, source: str) -> None:
    first: dict[float, int] = {}
    for x, line in zip(w.tolist(), lines, strict=True):
        if x in first:
            raise TableError(
                source, line, col.header, x,
                f"one row per weight: {x:g} kg is on row {first[x]} already (put repeats in columns)",
            )  # fmt: skip
        first[x] = line


# ---- import as a session -------------------------------------------------------------------------------------
def import_table(
    path: str | Path,
    output: str | Path,
    *,
    unit: str | None = None,
    force: bool = False,
    operator: str = "",
    delimiter: str | None = None,
    decimal: str | None = None,
    allow_missing: bool = False,
    measured_by: str = "",
) -> Path:
    """Write the table at ``path`` as a session file at ``output`` (marked imported); return ``output``.

    ``unit``, ``delimiter``, ``decimal``, ``allow_missing`` as for :func:`read_table`. A missing repeat gets no block.

    Who measured: ``operator`` (``import --operator``), else the operator an exported table names in its ``#``
    lines, else nobody known — the start record's ``operator`` is then empty with ``operator_source`` ``"unknown"``:
    the login name of whoever imports is not the operator of the data; it is recorded as ``imported_by``.
    ``measured_by``: where the values come from when that is known but no operator is (``import --tab1``:
    :data:`TAB1_MEASURED_BY`), recorded as such.
    """
    from contactrig.core.provenance import host_name, login_name
    from contactrig.core.text import check_text
    from daq.records import now_iso
    from daq.session_file import SCHEMA_VERSION, SessionFile, software_versions

    check_text("--operator", operator)  # not UTF-8 (a Latin-1 terminal): refused before any file is made
    table = read_table(path, unit, delimiter=delimiter, decimal=decimal, allow_missing=allow_missing)
    meta = session_metadata(table.text)  # sample, operator, notes, scene_name of an exported session (# lines)
    n = int(np.isfinite(table.resistance_ohm).sum())
    started = now_iso()
    start = {
        "format": "contactrig-session",
        "schema_version": SCHEMA_VERSION,
        "software": software_versions(),
        "started": started,
        **meta,
        "operator": operator or meta.get("operator") or "",
        "operator_source": "--operator" if operator else ("table" if meta.get("operator") else "unknown"),
        **({"measured_by": measured_by} if measured_by else {}),
        "imported_by": login_name(),
        "host": host_name(),
        "imported": True,
        "sim": False,
        "source": table.source_info(),
        "plan": {
            "session": {"weights_kg": table.weight_kg.tolist(), "repeats": len(table.columns)},
            "blocks_planned": n,
        },
        "instrument": {},
        "run": 0,
    }
    out = Path(output)
    from contactrig.core.files import refuse_existing

    refuse_existing([out], force=force, inputs=[path])  # the session never replaces the table it is made from
    with SessionFile.create(out, reading_unit="ohm", force=force) as sf:
        sf.publish_on_start = False  # the session takes its name complete, or not at all
        sf.write_start(start, "")
        _write_blocks(sf, table, started)
        _write_stop(sf, n, f"imported {n} values from {Path(path).name} ({table.unit})")
        sf.publish()
    return out


def _write_blocks(sf: Any, table: ResistanceTable, started: str) -> None:
    """One block per value (weight, repeat), written in one batch: a table is one measurement."""
    from daq.session_writer import BlockBatch

    values = np.asarray(table.resistance_ohm, dtype=np.float64)
    rows, cols = np.nonzero(np.isfinite(values))  # row-major: weight by weight, repeat by repeat
    r = values[rows, cols]  # a missing repeat (allow_missing): no block
    k = r.size
    sf.append_blocks(
        BlockBatch(
            block=np.arange(k, dtype=np.int32), weight_kg=np.asarray(table.weight_kg, dtype=np.float64)[rows],
            repeat=(cols + 1).astype(np.int32), count=np.ones(k, dtype=np.int32), reading=r,
            time_s=np.full(k, math.nan), resistance_ohm=r, valid=np.ones(k, dtype=bool), started=started,
        )
    )  # fmt: skip


def _write_stop(sf: Any, n: int, reason: str) -> None:
    from daq.records import StopRecord, now_iso

    sf.write_stop(
        StopRecord(status="success", reason=reason, stopped=now_iso(), blocks_planned=n, blocks_done=n, readings_done=n)
    )
