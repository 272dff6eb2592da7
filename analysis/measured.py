"""Measured resistance against weight with every repeat kept: the input of normalisation, fits and figures.

A :class:`MeasuredCurve` holds a weights × repeats matrix of block means [Ω] (NaN where a repeat is missing).
It is built from a session's summary table (``daq.load_session(...).summary``), from the seed paper's Tab. 1
(``daq/data/tab1.csv``, series M1…M6 in mΩ) or from plain arrays. Repeat ``k`` at two weights belongs to the same
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

__all__ = ["TAB1_RESOURCE", "MeasuredCurve", "load_tab1"]

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
        w = np.asarray(self.weight_kg, dtype=float).reshape(-1)
        v = np.asarray(self.values_ohm, dtype=float)
        if v.ndim == 1:
            v = v[:, None]
        if v.ndim != 2 or v.shape[0] != w.size:
            raise SettingError("values_ohm", f"array of shape {v.shape}", f"expected shape ({w.size}, repeats)")
        if w.size < 1 or not np.all(np.isfinite(w)) or np.any(w < 0):
            raise SettingError("weight_kg", w.tolist(), "expected finite weights >= 0 kg")
        if w.size > 1 and np.any(np.diff(w) <= 0):
            raise SettingError("weight_kg", w.tolist(), "expected strictly increasing weights (one row per weight)")
        if np.any(np.isinf(v)) or np.any(v[np.isfinite(v)] <= 0):
            raise SettingError("values_ohm", "values <= 0 or inf", "expected resistances > 0 Ω (NaN marks missing)")
        n = np.sum(np.isfinite(v), axis=1)
        if np.any(n == 0):
            raise SettingError("values_ohm", f"no valid repeat at {w[n == 0][0]:g} kg", "expected >= 1 per weight")
        labels = tuple(self.repeat_labels) or tuple(str(k + 1) for k in range(v.shape[1]))
        if len(labels) != v.shape[1]:
            raise SettingError("repeat_labels", labels, f"expected {v.shape[1]} labels")
        sem = self.block_sem_ohm
        if sem is not None:
            sem = np.asarray(sem, dtype=float)
            if sem.shape != v.shape:
                raise SettingError("block_sem_ohm", f"array of shape {sem.shape}", f"expected shape {v.shape}")
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
    def from_summary(cls, summary: Any, *, source: str = "", provenance: dict[str, Any] | None = None):
        """From a session summary DataFrame (columns weight_kg, repeat, mean_ohm, sem_ohm, …; one row per block).

        Blocks with no valid reading (NaN mean) count as missing repeats. Two blocks with the same weight and
        repeat are an error.
        """
        for col in ("weight_kg", "repeat", "mean_ohm"):
            if col not in summary.columns:
                raise SettingError("summary", list(summary.columns), f"expected a column {col!r}")
        if len(summary) == 0:
            raise SettingError("summary", "empty", "expected at least one block")
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
    def from_tab1(cls, table: Any, *, source: str = "seed paper Tab. 1") -> MeasuredCurve:
        """From Tab. 1 as a DataFrame: weight_kg and series columns M1…Mn in mΩ (an ``Avg`` column is ignored)."""
        if "weight_kg" not in table.columns:
            raise SettingError("tab1", list(table.columns), "expected a column 'weight_kg'")
        series = [c for c in table.columns if str(c).upper().startswith("M") and str(c)[1:].isdigit()]
        if not series:
            raise SettingError("tab1", list(table.columns), "expected series columns M1, M2, …")
        return cls(
            weight_kg=table["weight_kg"].astype(float).to_numpy(),
            values_ohm=table[series].astype(float).to_numpy() * 1e-3,
            repeat_labels=tuple(series),
            paired=True,
            source=source,
        )


def load_tab1(path: str | Path | None = None) -> MeasuredCurve:
    """The seed paper's Tab. 1 (shipped as ``daq/data/tab1.csv``, or the CSV at ``path``)."""
    import pandas as pd

    if path is None:
        ref = resources.files(TAB1_RESOURCE[0]).joinpath(TAB1_RESOURCE[1])
        if not ref.is_file():
            raise FileNotFoundError(f"{TAB1_RESOURCE[0]}/{TAB1_RESOURCE[1]} is not installed")
        with ref.open("r", encoding="utf-8") as fh:
            table = pd.read_csv(fh, comment="#")
        return MeasuredCurve.from_tab1(table)
    return MeasuredCurve.from_tab1(pd.read_csv(path, comment="#"), source=str(path))
