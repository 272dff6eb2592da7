"""Import a table of resistances per weight (like the seed paper's Tab. 1) as a session file marked ``imported``.

The table is CSV with a header row: the first column is the weight in kg, every further column one repeat
(M1 … Mk), in ``ohm``, ``mohm`` or ``uohm``. Each cell becomes one block of one reading (n = 1: the standard
deviation and standard error are undefined, stored as NaN; the reading time is unknown, NaN). A column that looks
like an average (``avg``, ``mean``, ``average``) is refused rather than imported as a repeat. Nothing is dropped:
an empty or non-numeric cell is an error naming its row and column.
"""

from __future__ import annotations

import csv
import errno
import hashlib
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from contactrig.core.provenance import host_name, login_name
from contactrig.core.validation import SettingError, check_choice
from daq.errors import MissingFileError
from daq.records import BlockRecord, StopRecord, now_iso
from daq.session_file import SCHEMA_VERSION, SessionFile, software_versions

__all__ = ["UNITS_OHM", "ResistanceTable", "import_table", "read_table", "tab1_path"]

#: Accepted ``--unit`` values and their size in Ω.
UNITS_OHM = {"ohm": 1.0, "mohm": 1e-3, "uohm": 1e-6}
_AVERAGE_NAMES = {"avg", "average", "mean", "avg.", "mean value"}


def tab1_path() -> Path:
    """The seed paper's Tab. 1 shipped with the package (``daq/data/tab1.csv``: weight_kg, M1 … M6 in mΩ)."""
    from importlib import resources

    return Path(str(resources.files("daq").joinpath("data/tab1.csv")))


@dataclass(frozen=True)
class ResistanceTable:
    """A parsed table: ``weight_kg`` (n,), ``resistance_ohm`` (n, k) and the repeat column names."""

    weight_kg: np.ndarray
    resistance_ohm: np.ndarray
    columns: tuple[str, ...]
    weight_column: str
    unit: str
    text: str


def read_table(path: str | Path, unit: str) -> ResistanceTable:
    """Read and validate the CSV table at ``path`` with values in ``unit`` (ohm, mohm, uohm)."""
    check_choice("--unit", unit, tuple(UNITS_OHM))
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise MissingFileError(errno.ENOENT, f"no such table: {p}") from None
    except UnicodeDecodeError as exc:
        raise SettingError(str(p), "<file>", f"expected UTF-8 CSV text ({exc.reason})") from None
    rows = [r for r in csv.reader(io.StringIO(text)) if any(cell.strip() for cell in r)]
    if len(rows) < 2:
        raise SettingError(str(p), "<file>", "expected a header row and at least one row of values")
    header = [h.strip() for h in rows[0]]
    if len(header) < 2:
        raise SettingError(str(p), header, "expected a weight column and at least one repeat column")
    for name in header[1:]:
        if name.lower() in _AVERAGE_NAMES:
            raise SettingError(
                f"{p}: column {name!r}", name, "looks like an average, not a repeat: remove it from the table"
            )
    factor = UNITS_OHM[unit]
    weights = []
    values = []
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise SettingError(f"{p}: line {i}", row, f"expected {len(header)} cells like the header")
        cells = []
        for name, cell in zip(header, row, strict=True):
            field = f"{p}: line {i}, column {name!r}"
            try:
                x = float(cell)
            except ValueError:
                raise SettingError(field, cell, "expected a number (empty cells are not allowed)") from None
            if not math.isfinite(x):
                raise SettingError(field, cell, "expected a finite number")
            cells.append(x)
        if cells[0] <= 0:
            raise SettingError(f"{p}: line {i}, column {header[0]!r}", cells[0], "expected a weight > 0 kg")
        weights.append(cells[0])
        values.append([x * factor for x in cells[1:]])
    return ResistanceTable(
        weight_kg=np.asarray(weights, dtype=np.float64),
        resistance_ohm=np.asarray(values, dtype=np.float64),
        columns=tuple(header[1:]),
        weight_column=header[0],
        unit=unit,
        text=text,
    )


def import_table(path: str | Path, output: str | Path, *, unit: str, force: bool = False, operator: str = "") -> Path:
    """Write the table at ``path`` as a session file at ``output`` (marked imported); return ``output``."""
    table = read_table(path, unit)
    out = Path(output)
    started = now_iso()
    start = {
        "format": "contactrig-session",
        "schema_version": SCHEMA_VERSION,
        "software": software_versions(),
        "started": started,
        "operator": operator or login_name(),
        "operator_source": "--operator" if operator else "login",
        "host": host_name(),
        "imported": True,
        "sim": False,
        "source": {
            "path": str(Path(path).resolve()),
            "sha256": hashlib.sha256(table.text.encode("utf-8")).hexdigest(),
            "unit": unit,
            "weight_column": table.weight_column,
            "repeat_columns": list(table.columns),
            "text": table.text,
        },
        "plan": {
            "session": {"weights_kg": table.weight_kg.tolist(), "repeats": len(table.columns)},
            "blocks_planned": int(table.resistance_ohm.size),
        },
        "instrument": {},
        "run": 0,
    }
    k = len(table.columns)
    with SessionFile.create(out, reading_unit="ohm", force=force) as sf:
        sf.write_start(start, "")
        for i, weight in enumerate(table.weight_kg):
            for j in range(k):
                r = np.array([table.resistance_ohm[i, j]])
                sf.append_block(
                    BlockRecord(
                        block=i * k + j,
                        run=0,
                        weight_kg=float(weight),
                        repeat=j + 1,
                        unit="ohm",
                        reading=r,
                        time_s=np.array([math.nan]),
                        resistance_ohm=r,
                        valid=np.array([True]),
                        started=started,
                    )
                )
        n = int(table.resistance_ohm.size)
        sf.write_stop(
            StopRecord(
                status="success",
                reason=f"imported {n} values from {Path(path).name} ({unit})",
                stopped=now_iso(),
                blocks_planned=n,
                blocks_done=n,
                readings_done=n,
            )
        )
    return out
