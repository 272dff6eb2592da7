"""Sessions and fits out of contactrig as CSV or Excel (``contactrig export``).

A session gives two tables:

- **summary** — Tab. 1-style: one row per weight (in the order the weights were placed), one column per repeat
  (``M1_mohm`` … ``Mk_mohm``: the block means, with the unit in the header, the unit the data call for — ohm, mohm
  or uohm), then per weight ``mean_<unit>``, ``sd_<unit>`` (n − 1), ``sem_<unit>`` and ``n`` of its repeats. It is
  exactly what ``contactrig import`` reads: importing it gives back the same doubles (each value is the shortest
  text that the import converts back to the stored double, :func:`shortest_text`; the statistics columns are left
  out by the import). A repeat without a value (a block taken in compliance, a skipped or not yet measured block)
  is an empty cell, so importing such a table needs ``--allow-missing``. In CSV, ``#`` lines before the header say
  where the table came from — source, status, start, sample, operator, notes, scene name — and ``contactrig
  import`` takes sample, operator, notes and scene name back into the imported session
  (:mod:`daq.table_provenance`).
- **readings** — every reading: block, weight_kg, repeat, index, time_s, reading (in the instruments' unit, named
  in the header), resistance_ohm, valid.

A fit (the JSON that ``contactrig fit … --json`` prints, :func:`fit_tables`) gives **fits** (one row per model in
ranking order: R_s, s, their standard errors and t-intervals, χ², AIC, ΔAIC, Akaike weight, RMSE, physical or
not; ``delta_aic`` is the Δ of the fit's criterion, QAIC when over-dispersed, named in ``about``), **points** (per
model and weight: area, measured, σ, fitted, residual) and **shares** (per model, weight and term: the term's share of
the measured mean, e.g. the physical conversion's series, film, barber and macro; one row each, so any term fits).

CSV: one file per table, the first at the output path, the others beside it (``out.csv``, ``out-readings.csv``).
Numbers are unquoted (negative ones too: they stay numbers); every text field is quoted, and one that a spreadsheet
would run as a formula (leading ``= + - @``, tab or CR) starts with ``'`` (:func:`csv_field`); the ``#`` lines are
``# key:,"value"`` records, so no string from a file can split into cells or become a formula.
Excel (``.xlsx``, one sheet per table plus ``about``) uses openpyxl (in the base install); should it be missing,
:class:`ExcelUnavailable` says so in one line naming the pip install. None is replaced without ``force``; every
output is checked before anything is written, and the files of one export replace the old ones as one set
(:func:`contactrig.core.files.replace_together`: a kill never leaves a new summary beside old readings).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from decimal import Decimal
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from contactrig.core.files import refuse_existing, replace_together
from contactrig.core.text import escape_terminal, shown
from contactrig.core.validation import SettingError, check_choice
from daq.records import block_number
from daq.table_import import DIGITS_PER_OHM
from daq.table_provenance import EXPORTED_BY, provenance_mapping, statistics_headers

__all__ = [
    "FORMATS",
    "ExcelUnavailable",
    "Table",
    "csv_field",
    "csv_line",
    "export_fit",
    "export_session",
    "fit_tables",
    "neutral_text",
    "output_paths",
    "reading_unit",
    "session_tables",
    "write_tables",
]

#: Output formats.
FORMATS = ("csv", "xlsx")
_UNIT_FACTORS = (("ohm", 1.0), ("mohm", 1e3), ("uohm", 1e6))
#: openpyxl is in the base install (pyproject): this is for an environment where it was removed or broken.
_INSTALL = "pip install 'openpyxl>=3.1'"


class ExcelUnavailable(RuntimeError):
    """``--to xlsx`` without openpyxl installed (it is in the base install; a damaged environment)."""


@dataclass(frozen=True)
class Table:
    """A named table: ``columns`` (headers, with units), ``rows`` (numbers, strings, None = empty cell)."""

    name: str
    columns: tuple[str, ...]
    rows: list[list[Any]]
    notes: tuple[str, ...] = field(default=())


# ---- tables from a session ---------------------------------------------------------------------------------------
def _summary_unit(means: np.ndarray) -> tuple[str, float]:
    """ohm, mohm or uohm: the largest in which the median finite mean is ≥ 1 (as the figures choose)."""
    x = np.abs(means[np.isfinite(means) & (means != 0)])
    typical = float(np.median(x)) if x.size else 1e-3
    for unit, factor in _UNIT_FACTORS:
        if typical * factor >= 1.0:
            return unit, factor
    return _UNIT_FACTORS[-1]


def _number(x: Any) -> float | None:
    """A finite float, or None (an empty cell)."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def shortest_text(value_ohm: float, digits: int) -> Decimal:
    """The shortest decimal text, in a unit ``digits`` decimal digits below the ohm (mΩ: 3), that ``contactrig
    import`` reads back to ``value_ohm`` exactly: ``7.8427035773`` mΩ, not ``7.842703577299999`` (the repr of
    value × 1e3, which carries the rounding of the multiplication).

    Guaranteed for every finite double: the import shifts the cell's decimal text by ``digits`` and rounds once
    (:data:`daq.table_import.DIGITS_PER_OHM`), and a decimal shift changes no significant digit, so the shortest
    decimal that rounds to ``value_ohm`` — Python's ``repr``, shortest and round-trip by the language's guarantee —
    shifted by ``digits`` is the answer."""
    return Decimal(repr(float(value_ohm))).scaleb(digits)


def _weight_statistics(values_ohm: list[float], digits: int) -> list[Any]:
    """mean, SD (n − 1), SEM = SD/√n (in the table's unit, shortest round-trip text of the double) and n of a
    weight's repeats; SD and SEM empty for one repeat, everything empty for none. The mean is the double nearest
    the repeats' exact mean (rational arithmetic, one rounding): Tab. 1's 5.44 kg row gives ``8.09125``, where
    ``np.mean``'s rounding gave ``8.091250000000001``."""
    x = np.asarray([v for v in values_ohm if math.isfinite(v)], dtype=float)
    if x.size == 0:
        return [None, None, None, 0]
    mean = float(sum(map(Fraction, x.tolist())) / x.size)
    if x.size == 1:
        return [shortest_text(mean, digits), None, None, 1]
    sd = float(np.std(x, ddof=1))
    return [shortest_text(mean, digits), shortest_text(sd, digits), shortest_text(sd / math.sqrt(x.size), digits),
            int(x.size)]  # fmt: skip


def summary_table(summary: Any) -> Table:
    """Tab. 1-style: weight × repeat block means (``summary``: a session's summary DataFrame), each written in the
    table's unit as the shortest text that ``contactrig import`` reads back to the stored double
    (:func:`shortest_text`), then per weight the mean, SD, SEM and n of its repeats
    (:func:`daq.table_provenance.statistics_headers`; ``contactrig import`` leaves them out again)."""
    means = summary["mean_ohm"].to_numpy(dtype=float)
    unit, _ = _summary_unit(means)
    digits = DIGITS_PER_OHM[unit]
    weights: list[float] = []
    for w in summary["weight_kg"].to_numpy(dtype=float):
        if w not in weights:
            weights.append(float(w))
    repeats = sorted({int(r) for r in summary["repeat"]})
    stored: dict[tuple[float, int], float] = {}
    notes = []
    for w, r, m, comp, b in zip(
        summary["weight_kg"], summary["repeat"], means, summary["compliance"], summary["block"], strict=True
    ):
        if not bool(comp) and math.isfinite(float(m)):
            stored[(float(w), int(r))] = float(m)
        if bool(comp):
            where = f"block {block_number(b)} ({float(w):g} kg, repeat {int(r)})"
            notes.append(f"{where} was taken in compliance: left empty")
    rows = []
    for w in weights:
        cells = [stored.get((w, r)) for r in repeats]
        texts = [None if v is None else shortest_text(v, digits) for v in cells]
        rows.append([w, *texts, *_weight_statistics([v for v in cells if v is not None], digits)])
    if any(v is None for row in rows for v in row[1 : 1 + len(repeats)]):
        notes.append("empty cells are missing repeats: import with --allow-missing")
    columns = ("weight_kg", *(f"M{r}_{unit}" for r in repeats), *statistics_headers(unit))
    return Table("summary", columns, rows, tuple(notes))


def readings_table(readings: Any, reading_unit: str) -> Table:
    """Every reading (``readings``: a session's readings DataFrame)."""
    unit = reading_unit or "as_returned"
    cols = ("block", "weight_kg", "repeat", "index", "time_s", f"reading_{unit}", "resistance_ohm", "valid")
    data = [
        [block_number(b) for b in readings["block"].to_numpy(dtype=np.int64)],  # 1-based, as every output
        readings["weight_kg"].to_numpy(dtype=float).tolist(),
        readings["repeat"].to_numpy(dtype=np.int64).tolist(),
        readings["index"].to_numpy(dtype=np.int64).tolist(),
        [_number(x) for x in readings["time_s"]],
        [_number(x) for x in readings["reading"]],
        [_number(x) for x in readings["resistance_ohm"]],
        readings["valid"].to_numpy(dtype=bool).astype(int).tolist(),
    ]
    return Table("readings", cols, [list(r) for r in zip(*data, strict=True)])


def reading_unit(start: Mapping[str, Any]) -> str:
    """The unit of a session's readings as its plan names it (``V``, ``ohm`` for ``OHMS`` or an imported table;
    empty when none is named)."""
    plan = start.get("plan") if isinstance(start, Mapping) else None
    for table in (plan or {}).values():
        if isinstance(table, Mapping) and isinstance(table.get("unit"), str):
            unit = str(table["unit"]).upper()
            return "ohm" if unit in ("OHMS", "OHM") else str(table["unit"])
    return "ohm" if start.get("imported") else ""


def _about(session: Any) -> list[tuple[str, str]]:
    start = session.start if isinstance(session.start, Mapping) else {}
    # sample, operator, notes, scene: `contactrig import` reads them back (daq.table_provenance)
    meta = provenance_mapping(start, str(getattr(session, "scene_text", "") or ""))
    about = [
        ("source", str(session.path)),
        ("status", str(session.status)),
        ("started", str(start.get("started", ""))),
        *meta.items(),
        ("kind", "imported" if session.imported else ("simulated" if start.get("sim") else "real")),
        ("blocks", str(len(session.summary))),
        ("exported by", EXPORTED_BY),
    ]
    return [(k, shown(v)) for k, v in about]  # a file name (or older text) that is not UTF-8: visible escapes


def session_tables(session: Any) -> tuple[list[Table], list[tuple[str, str]]]:
    """The summary and readings tables of a loaded :class:`~daq.session_file.Session`, and its ``about`` lines."""
    if len(session.summary) == 0:
        raise SettingError("SESSION", str(session.path), "a session with at least one block on disk")
    tables = [summary_table(session.summary), readings_table(session.readings, reading_unit(session.start))]
    return tables, _about(session)


# ---- tables from a fit ---------------------------------------------------------------------------------------------
_FIT_COLUMNS = (
    "rank", "model", "R_series_ohm", "R_series_se_ohm", "R_series_t_low_ohm", "R_series_t_high_ohm", "scale_ohm_m",
    "scale_se_ohm_m", "chi2", "dof", "reduced_chi2", "p_value", "aic", "delta_aic", "akaike_weight", "rmse_ohm",
    "conversion", "weighting", "physical", "unphysical",
)  # fmt: skip
_POINT_COLUMNS = (
    "model", "weight_kg", "area_m2", "regressor_per_m", "measured_ohm", "sigma_ohm", "fitted_ohm", "residual_ohm",
    "normalised_residual",
)  # fmt: skip


def _get(d: Any, *keys: str) -> Any:
    for k in keys:
        if not isinstance(d, Mapping):
            return None
        d = d.get(k)
    return d


def _fit_row(rank: int, name: str, fit: Mapping[str, Any], fit_json: Mapping[str, Any]) -> list[Any]:
    t_ci = _get(fit, "intervals", "t", "R_series_ohm")
    lo, hi = (t_ci[0], t_ci[1]) if isinstance(t_ci, list) and len(t_ci) == 2 else (None, None)
    unphysical = fit.get("unphysical") or []
    goodness = [_number(_get(fit, "goodness", k)) for k in ("chi2", "dof", "reduced_chi2", "p_value", "aic")]
    return [
        rank, name,
        *(_number(_get(fit, "estimate", k)) for k in ("R_series_ohm", "R_series_se")),
        _number(lo), _number(hi),
        *(_number(_get(fit, "estimate", k)) for k in ("scale", "scale_se")),
        *goodness,
        _number(_get(fit_json, "delta_aic", name)), _number(_get(fit_json, "akaike_weights", name)),
        _number(_get(fit, "goodness", "rmse_ohm")),
        str(fit.get("conversion", "")), str(fit.get("weighting", "")),
        "no" if unphysical else "yes", "; ".join(str(u) for u in unphysical),
    ]  # fmt: skip


def _point_rows(name: str, fit: Mapping[str, Any]) -> list[list[Any]]:
    p = fit.get("points")
    if not isinstance(p, Mapping) or not isinstance(p.get("weight_kg"), list):
        return []
    keys = (
        "area_m2", "regressor_per_m", "measured_ohm", "sigma_ohm", "fitted_ohm", "residuals_ohm",
        "normalised_residuals",
    )  # fmt: skip
    columns = [p[k] if isinstance(p.get(k), list) else [] for k in keys]
    rows = []
    for i, w in enumerate(p["weight_kg"]):
        rows.append([name, _number(w), *(_number(c[i]) if i < len(c) else None for c in columns)])
    return rows


_SHARE_COLUMNS = ("model", "weight_kg", "term", "share_of_measured_mean")


def _share_rows(name: str, fit: Mapping[str, Any]) -> list[list[Any]]:
    """One row per weight and term of the fit's ``shares`` (each term's share of the measured mean) [-]."""
    shares, weights = fit.get("shares"), _get(fit, "points", "weight_kg")
    if not isinstance(shares, Mapping) or not isinstance(weights, list):
        return []
    rows = []
    for i, w in enumerate(weights):
        for term, values in shares.items():
            if isinstance(values, list) and i < len(values):
                rows.append([name, _number(w), str(term), _number(values[i])])
    return rows


def fit_tables(fit_json: Mapping[str, Any], source: str = "") -> tuple[list[Table], list[tuple[str, str]]]:
    """The fits, points and shares tables of a fit (the dict ``contactrig fit … --json`` prints), and its ``about``
    lines."""
    models = fit_json.get("models") if isinstance(fit_json, Mapping) else None
    if not isinstance(models, Mapping) or not models:
        raise SettingError("fit", source or "<fit>", "the JSON of `contactrig fit … --json` (a 'models' object)")
    ranking = [m for m in (fit_json.get("ranking") or []) if m in models]
    ranking += [m for m in models if m not in ranking]
    fits = [_fit_row(i + 1, m, models[m], fit_json) for i, m in enumerate(ranking) if isinstance(models[m], Mapping)]
    points = [row for m in ranking if isinstance(models[m], Mapping) for row in _point_rows(m, models[m])]
    shares = [row for m in ranking if isinstance(models[m], Mapping) for row in _share_rows(m, models[m])]
    about = [
        ("source", source),
        ("measured", str(_get(fit_json, "measured", "path") or "")),
        ("simulation", str(fit_json.get("simulation") or "")),
        ("statement", str(fit_json.get("statement") or "")),
        ("criterion", f"delta_aic and akaike_weight are {fit_json.get('criterion') or 'AIC'} (c_hat = "
                      f"{_number(fit_json.get('c_hat'))})"),
        ("exported by", "contactrig export"),
    ]  # fmt: skip
    tables = [Table("fits", _FIT_COLUMNS, fits), Table("points", _POINT_COLUMNS, points)]
    return [*tables, Table("shares", _SHARE_COLUMNS, shares)], [(k, shown(v)) for k, v in about]


# ---- writing -------------------------------------------------------------------------------------------------------
def output_paths(output: str | Path, to: str, tables: Sequence[str]) -> list[Path]:
    """The files an export writes: xlsx → ``output``; csv → ``output`` for the first table and
    ``<stem>-<name>.csv`` beside it for the others."""
    check_choice("--to", to, FORMATS)
    out = Path(output)
    if to == "xlsx":
        return [out]
    return [out] + [out.with_name(f"{out.stem}-{name}{out.suffix or '.csv'}") for name in tables[1:]]


#: A text cell that starts with one of these is run as a formula by a spreadsheet ("CSV injection"; tab and CR too,
#: which some strip before looking).
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def neutral_text(value: str) -> str:
    """A text cell as a spreadsheet must show it: control characters as visible escapes, and a leading ``'`` when
    it (or its first non-blank character) would start a formula."""
    text = escape_terminal(value)
    if value[:1] in FORMULA_START or text.lstrip()[:1] in FORMULA_START:
        return "'" + text
    return text


def csv_field(v: Any) -> str:
    """One CSV field: a finite number as its shortest exact text (unquoted, so it stays a number, negative ones
    too), None as an empty field, anything else as quoted, neutralised text (:func:`neutral_text`)."""
    if v is None:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return "1" if v else "0"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, Decimal):  # an exact text chosen for its round trip (shortest_text)
        return format(v, "f") if -7 <= v.adjusted() < 16 else str(v)
    if isinstance(v, (float, np.floating)) and math.isfinite(v):
        return repr(float(v))  # shortest text that reads back as the same float
    return '"' + neutral_text(str(v)).replace('"', '""') + '"'


def csv_line(values: Sequence[Any]) -> str:
    """One CSV record (CRLF-ended, RFC 4180) of :func:`csv_field` fields."""
    return ",".join(csv_field(v) for v in values) + "\r\n"


def _csv_text(table: Table, about: Sequence[tuple[str, str]], first: bool) -> str:
    lines = []
    if first:  # provenance as `#` records (`contactrig import` skips them): a constant first field, quoted text
        lines += [f"# {key}:," + csv_line([value]) for key, value in about]
        lines += ["# note:," + csv_line([note]) for note in table.notes]
    lines.append(csv_line(table.columns))
    lines += [csv_line(row) for row in table.rows]
    return "".join(lines)


def _openpyxl() -> Any:
    import importlib

    try:
        openpyxl = importlib.import_module("openpyxl")
    except ImportError:
        raise ExcelUnavailable(f"--to xlsx needs openpyxl, which is not installed: {_INSTALL}") from None
    return openpyxl


def _xlsx(tables: Sequence[Table], about: Sequence[tuple[str, str]], path: Path) -> None:
    openpyxl = _openpyxl()
    WriteOnlyCell = openpyxl.cell.WriteOnlyCell

    wb = openpyxl.Workbook(write_only=True)

    def text(ws: Any, value: str) -> Any:  # always a text cell: a string from a file never becomes a formula
        cell = WriteOnlyCell(ws, value=escape_terminal(value))  # stored as text: no leading ' needed
        cell.data_type = "s"
        return cell

    for t in tables:
        ws = wb.create_sheet(t.name)
        ws.append([text(ws, c) for c in t.columns])
        for row in t.rows:
            ws.append([text(ws, v) if isinstance(v, str) else float(v) if isinstance(v, Decimal) else v for v in row])
    ws = wb.create_sheet("about")
    for key, value in [*about, *(("note", n) for t in tables for n in t.notes)]:
        ws.append([text(ws, key), text(ws, value)])
    wb.save(path)


def write_tables(
    tables: Sequence[Table], about: Sequence[tuple[str, str]], output: str | Path, to: str, *, force: bool = False
) -> list[Path]:
    """Write ``tables`` as CSV files or one workbook (see :func:`output_paths`); every path is checked first (none
    replaced without ``force``), every file written atomically. Returns the paths written."""
    if to == "xlsx":
        _openpyxl()  # the one-line error before anything else
    paths = refuse_existing(output_paths(output, to, [t.name for t in tables]), force=force)
    with replace_together(paths[0].parent, paths, force=force) as stage:  # the files replace the old ones as one
        if to == "xlsx":
            _xlsx(tables, about, stage / paths[0].name)
        else:
            for i, (table, path) in enumerate(zip(tables, paths, strict=True)):
                (stage / path.name).write_bytes(_csv_text(table, about, first=i == 0).encode("utf-8"))
    return paths


def default_output(source: str | Path, to: str, suffix: str = "") -> Path:
    """``SESSION.h5`` → ``SESSION<suffix>.csv`` / ``.xlsx`` beside it."""
    p = Path(source)
    return p.with_name(f"{p.stem}{suffix}.{to}")


def export_session(
    path: str | Path, to: str = "csv", output: str | Path | None = None, *, force: bool = False
) -> list[Path]:
    """Export the session file at ``path`` (summary and readings; see the module docstring). Returns the paths."""
    import warnings

    from daq.session_file import load_session

    check_choice("--to", to, FORMATS)
    if to == "xlsx":
        _openpyxl()
    out = Path(output) if output is not None else default_output(path, to)
    refuse_existing(output_paths(out, to, ["summary", "readings"]), force=force, inputs=[path])  # before reading
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # an incomplete or running session is exported as it stands (about: status)
        session = load_session(path)
    tables, about = session_tables(session)
    return write_tables(tables, about, out, to, force=force)


def export_fit(
    fit_json: Mapping[str, Any],
    to: str = "csv",
    output: str | Path = "fit.csv",
    *,
    source: str = "",
    force: bool = False,
) -> list[Path]:
    """Export a fit (the dict ``contactrig fit … --json`` prints): fits, points and shares tables. Returns the paths."""
    check_choice("--to", to, FORMATS)
    tables, about = fit_tables(fit_json, source)
    return write_tables(tables, about, output, to, force=force)
