"""Measured resistance against weight with every repeat kept: the input of normalisation, fits and figures.

A :class:`MeasuredCurve` holds a weights × repeats matrix of block means [Ω] (NaN where a repeat is missing).
It is built from a session's summary table (``daq.load_session(...).summary``), from a table of resistance per
weight read by :func:`daq.table_import.read_table` — the one reader of such tables, shared with ``contactrig
import``, with its rules for headers, units and plausible values — such as the seed paper's Tab. 1
(``daq/data/tab1.csv``, series M1…M6 in mΩ), or from plain arrays. Repeat ``k`` at two weights belongs to the same
measurement series when ``paired`` is true (Tab. 1's columns are series; a session's repeats are paired when every
weight has the same set of repeat numbers), and then the scatter between series is correlated across weights.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from contactrig.core.validation import SettingError
from daq.table_import import ResistanceTable, read_table, tab1_path

__all__ = ["TAB1_RESOURCE", "MeasuredCurve", "load_tab1", "load_table"]

#: Where Tab. 1 of the seed paper ships (package ``daq``).
TAB1_RESOURCE = ("daq", "data/tab1.csv")


@dataclass(frozen=True)
class MeasuredCurve:
    """Resistance against weight, every repeat kept.

    ``weight_kg`` shape (m,), strictly increasing; ``values_ohm`` shape (m, r) block means [Ω], NaN = missing;
    ``repeat_labels`` the r series/repeat names; ``block_sem_ohm`` optional (m, r) within-block standard errors
    [Ω] (instrument noise of each block); ``paired`` whether column k is one series across all weights;
    ``source`` a description for reports.
    """

    weight_kg: np.ndarray
    values_ohm: np.ndarray
    repeat_labels: tuple[str, ...] = ()
    block_sem_ohm: np.ndarray | None = None
    paired: bool = False
    source: str = ""
    provenance: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        w = _weights(self.weight_kg)
        v = _values(self.values_ohm, w)
        labels = _labels(self.repeat_labels, v.shape[1])
        sem = _block_sem(self.block_sem_ohm, v.shape)
        for name, value in (("weight_kg", w), ("values_ohm", v), ("block_sem_ohm", sem)):
            if value is not None:
                value = value.copy()
                value.flags.writeable = False
            object.__setattr__(self, name, value)
        object.__setattr__(self, "repeat_labels", labels)
        object.__setattr__(self, "paired", bool(self.paired) and bool(np.all(np.isfinite(v))))

    # -- statistics over repeats, per weight ------------------------------------------------------------------
    @property
    def n(self) -> np.ndarray:
        """Valid repeats per weight."""
        return np.sum(np.isfinite(self.values_ohm), axis=1)

    @property
    def mean_ohm(self) -> np.ndarray:
        """Mean over repeats [Ω]."""
        return np.nanmean(self.values_ohm, axis=1)

    @property
    def sd_ohm(self) -> np.ndarray:
        """Sample SD over repeats [Ω] (ddof 1; NaN where fewer than two repeats)."""
        n = self.n
        out = np.full(n.shape, np.nan)
        ok = n >= 2
        out[ok] = np.nanstd(self.values_ohm[ok], axis=1, ddof=1)
        return out

    @property
    def sem_ohm(self) -> np.ndarray:
        """Standard error of the mean over repeats [Ω] (NaN where fewer than two repeats)."""
        return self.sd_ohm / np.sqrt(self.n)

    # -- constructors ------------------------------------------------------------------------------------------
    @classmethod
    def from_session(cls, session: Any, *, source: str = "") -> MeasuredCurve:
        """From a loaded session (:func:`daq.session_file.load_session`): its summary, with an adaptive session's
        blocks at one seating taken as one repeat (the start record's ``adaptive``; see :meth:`from_summary`)."""
        adaptive = isinstance(session.start, dict) and bool(session.start.get("adaptive"))
        return cls.from_summary(session.summary, source=source, seatings=adaptive)

    @classmethod
    def from_summary(
        cls,
        summary: Any,
        *,
        source: str = "",
        provenance: dict[str, Any] | None = None,
        seatings: bool = False,
    ):
        """From a session summary DataFrame (columns weight_kg, repeat, mean_ohm, sem_ohm, …; one row per block).

        Blocks with no valid reading (NaN mean) count as missing repeats. ``seatings`` (an adaptive session, whose
        ``repeat`` numbers the seatings at a weight): consecutive blocks with the same weight and repeat are blocks
        at one seating (a repeat at the present seating, the weight not lifted: they share the seating's contact, so
        they are one repeat): their mean is the mean of their valid block means, its within-block standard error
        √(Σ sem²)/n. Any other two blocks with the same weight and repeat are an error (a fixed plan or an imported
        table never has them: they would be a mix-up, never averaged silently).
        """
        for col in ("weight_kg", "repeat", "mean_ohm"):
            if col not in summary.columns:
                raise SettingError("summary", list(summary.columns), f"expected a column {col!r}")
        if len(summary) == 0:
            raise SettingError("summary", "empty", "expected at least one block")
        if seatings:
            summary = _seatings(summary)
        dup = summary.duplicated(["weight_kg", "repeat"])
        if dup.any():
            row = summary[dup].iloc[0]
            raise SettingError("summary", f"weight {row['weight_kg']} kg, repeat {row['repeat']}", "duplicate block")
        weights = np.sort(summary["weight_kg"].astype(float).unique())
        repeats = sorted(summary["repeat"].unique())
        values = np.full((weights.size, len(repeats)), np.nan)
        sem = np.full_like(values, np.nan)
        wi = np.searchsorted(weights, summary["weight_kg"].astype(float).to_numpy())
        ri = np.searchsorted(np.asarray(repeats), summary["repeat"].to_numpy())
        values[wi, ri] = summary["mean_ohm"].astype(float).to_numpy()
        if "sem_ohm" in summary.columns:
            sem[wi, ri] = summary["sem_ohm"].astype(float).to_numpy()
        return cls(
            weight_kg=weights,
            values_ohm=values,
            repeat_labels=tuple(str(r) for r in repeats),
            block_sem_ohm=sem,
            paired=True,
            source=source,
            provenance=dict(provenance or {}),
        )

    @classmethod
    def from_table(cls, table: ResistanceTable, *, source: str = "") -> MeasuredCurve:
        """From a table read by :func:`daq.table_import.read_table` (the one table reader): rows sorted by weight,
        columns are series (``paired``; a table with missing repeats is not)."""
        order = np.argsort(table.weight_kg, kind="stable")
        return cls(
            weight_kg=table.weight_kg[order],
            values_ohm=table.resistance_ohm[order],
            repeat_labels=table.columns,
            paired=True,
            source=source or table.path,
            provenance={"table": {k: v for k, v in table.source_info().items() if k != "text"}},
        )


def load_table(path: str | Path, unit: str | None = None, **options: Any) -> MeasuredCurve:
    """The table at ``path`` read by :func:`daq.table_import.read_table` (``unit`` and ``options``: delimiter,
    decimal, allow_missing), as a curve."""
    return MeasuredCurve.from_table(read_table(path, unit, **options), source=str(path))


def load_tab1(path: str | Path | None = None) -> MeasuredCurve:
    """The seed paper's Tab. 1 (shipped as ``daq/data/tab1.csv``, or a table like it at ``path``), in mΩ."""
    if path is None:
        ref = resources.files(TAB1_RESOURCE[0]).joinpath(TAB1_RESOURCE[1])
        if not ref.is_file():
            raise FileNotFoundError(f"{TAB1_RESOURCE[0]}/{TAB1_RESOURCE[1]} is not installed")
        return MeasuredCurve.from_table(read_table(tab1_path(), "mohm"), source="seed paper Tab. 1")
    return load_table(path, "mohm")


# ---- the checks of MeasuredCurve, one step each ----------------------------------------------------------------
def _weights(weight_kg: Any) -> np.ndarray:
    w = np.asarray(weight_kg, dtype=float).reshape(-1)
    if w.size < 1 or not np.all(np.isfinite(w)) or np.any(w < 0):
        raise SettingError("weight_kg", w.tolist(), "expected finite weights >= 0 kg")
    if w.size > 1 and np.any(np.diff(w) <= 0):
        raise SettingError("weight_kg", w.tolist(), "expected strictly increasing weights (one row per weight)")
    return w


def _values(values_ohm: Any, w: np.ndarray) -> np.ndarray:
    v = np.asarray(values_ohm, dtype=float)
    if v.ndim == 1:
        v = v[:, None]
    if v.ndim != 2 or v.shape[0] != w.size:
        raise SettingError("values_ohm", f"array of shape {v.shape}", f"expected shape ({w.size}, repeats)")
    if np.any(np.isinf(v)) or np.any(v[np.isfinite(v)] <= 0):
        raise SettingError("values_ohm", "values <= 0 or inf", "expected resistances > 0 Ω (NaN marks missing)")
    n = np.sum(np.isfinite(v), axis=1)
    if np.any(n == 0):
        raise SettingError("values_ohm", f"no valid repeat at {w[n == 0][0]:g} kg", "expected >= 1 per weight")
    return v


def _seatings(summary: Any) -> Any:
    """``summary`` with each run of consecutive blocks of one weight and repeat (one seating) as one row: mean of
    the valid block means, √(Σ sem²)/n of their SEMs (NaN when none is valid)."""
    key = summary[["weight_kg", "repeat"]]
    start = (key != key.shift()).any(axis=1).to_numpy()
    if start.all():
        return summary
    group = np.cumsum(start)
    cols = ["weight_kg", "repeat", "mean_ohm"] + (["sem_ohm"] if "sem_ohm" in summary.columns else [])
    frame = summary[cols].reset_index(drop=True).assign(_seating=group)
    frame["_valid"] = np.isfinite(frame["mean_ohm"].astype(float).to_numpy())
    if "sem_ohm" in cols:
        frame["sem_ohm"] = np.where(frame["_valid"], frame["sem_ohm"].astype(float) ** 2, np.nan)
    grouped = frame.groupby("_seating", sort=False)
    out = grouped[["weight_kg", "repeat"]].first()
    out["mean_ohm"] = grouped["mean_ohm"].mean()  # NaN means skipped; all NaN: NaN
    if "sem_ohm" in cols:
        n = grouped["_valid"].sum()
        out["sem_ohm"] = np.sqrt(grouped["sem_ohm"].sum(min_count=1)) / n.where(n > 0)
    return out.reset_index(drop=True)


def _labels(repeat_labels: Any, r: int) -> tuple[str, ...]:
    labels = tuple(repeat_labels) or tuple(str(k + 1) for k in range(r))
    if len(labels) != r:
        raise SettingError("repeat_labels", labels, f"expected {r} labels")
    return labels


def _block_sem(block_sem_ohm: Any, shape: tuple[int, ...]) -> np.ndarray | None:
    if block_sem_ohm is None:
        return None
    sem = np.asarray(block_sem_ohm, dtype=float)
    if sem.shape != shape:
        raise SettingError("block_sem_ohm", f"array of shape {sem.shape}", f"expected shape {shape}")
    return sem
