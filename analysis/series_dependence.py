"""Series that are arithmetic copies of others, found so that they are counted once.

A table of repeat series can hold columns computed from other columns: the seed paper's Tab. 1 has M4 = mean(M1,
M2, M3) (to the printed four decimals at 7 of 8 weights; at 5.44 kg M4 reads 7.8624 mΩ where the mean is 7.7624 mΩ,
one digit off: a print error in the paper) and M5, M6 = M4 plus offsets with at most three decimals that change
with weight (M5 − M4 from 0.2 to 1.1 mΩ).
Such a column adds no independent scatter: counting it as a repeat shrinks every standard error, inflates the
degrees of freedom and lets the bootstrap resample one measurement several times. Two rules, both exact in the
table's own print resolution ``q`` (the largest power of ten of which every value is an integer multiple):

* **mean**: column j equals the mean of a set S (≥ 2) of other columns within one quantum at all weights but one
  (one misprint allowed when there are ≥ 4 weights);
* **offset**: column j − column k is a whole multiple of 10·q at every weight (≥ 5 weights) and not zero
  everywhere — by chance that happens with probability 10^−m per pair.

A group of columns linked by offsets counts once (its first column is kept); a group that contains a mean of other
columns counts zero times, its information being already in those columns. Values read from a session (full float
precision) have no print resolution: only an exact mean (within 1e-12 relative) is found there.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

__all__ = ["SeriesDependence", "find_dependence", "print_quantum"]

#: Columns beyond which subsets are not searched for the mean rule (2^(r−1) subsets per column).
_MAX_SUBSET_COLUMNS = 12
#: Values gathered at a time when testing many subsets at once (8 MB).
_BATCH_VALUES = 1_000_000


@dataclass(frozen=True)
class SeriesDependence:
    """Which of r series are independent: ``keep`` (indices kept), ``dropped`` (indices left out) and ``notes``
    (one sentence per finding, naming the columns)."""

    keep: tuple[int, ...]
    dropped: tuple[int, ...]
    notes: tuple[str, ...]

    @property
    def n_independent(self) -> int:
        """Number of independent series."""
        return len(self.keep)


def print_quantum(values: np.ndarray) -> float | None:
    """The print resolution of ``values`` (e.g. 1e-7 Ω for mΩ printed to four decimals), None for full precision."""
    v = np.abs(np.asarray(values, dtype=float))
    v = v[np.isfinite(v) & (v > 0)]
    if v.size == 0:
        return None
    top = int(np.floor(np.log10(v.max())))
    for k in range(top, top - 9, -1):  # at most 9 significant digits: beyond that the values are not printed
        q = 10.0**k
        x = v / q
        if np.all(np.abs(x - np.round(x)) < 1e-3):
            return q
    return None


def _mean_source(v: np.ndarray, j: int, tol: np.ndarray) -> tuple[int, ...]:
    """The smallest set of other columns whose mean column j equals (within ``tol``), () when none."""
    m, r = v.shape
    others = [k for k in range(r) if k != j]
    if len(others) > _MAX_SUBSET_COLUMNS:
        others = others[:_MAX_SUBSET_COLUMNS]
    allowed_off = 1 if m >= 4 else 0
    for size in range(2, len(others) + 1):
        subsets = itertools.combinations(others, size)
        # many subsets at once, in the same order, each mean along the contiguous axis as one at a time (same bits):
        # 4 000 subsets of 12 columns one by one took 10 s for 125 series
        while batch := list(itertools.islice(subsets, max(1, _BATCH_VALUES // (m * size)))):
            means = v[:, np.array(batch)].mean(axis=2)  # (m, subsets)
            off = np.abs(v[:, j : j + 1] - means) > tol[:, None]
            hit = np.flatnonzero(np.sum(off, axis=0) <= allowed_off)
            if hit.size:
                return batch[int(hit[0])]
    return ()


def _offset_pairs(v: np.ndarray, q: float | None) -> list[tuple[int, int]]:
    """Pairs (k, j), k < j, whose difference is a whole multiple of 10·q at every weight (≥ 5 weights)."""
    m, r = v.shape
    if q is None or m < 5:
        return []
    out = []
    for k, j in itertools.combinations(range(r), 2):
        d = (v[:, j] - v[:, k]) / (10.0 * q)
        if np.all(np.abs(d - np.round(d)) < 1e-3) and not np.all(np.round(d) == 0):
            out.append((k, j))
    return out


def _groups(r: int, pairs: list[tuple[int, int]]) -> list[list[int]]:
    """Connected components of the offset relation (union–find), each sorted."""
    parent = list(range(r))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in pairs:
        parent[root(b)] = root(a)
    comp: dict[int, list[int]] = {}
    for i in range(r):
        comp.setdefault(root(i), []).append(i)
    return [sorted(c) for c in comp.values()]


class _Shown:
    """Values in words: ``unit`` (factor, name) scales them (e.g. (1e3, "mΩ") for values in Ω), printed to the
    table's print resolution ``q`` when there is one, else to 6 significant digits; ``rows`` names each row."""

    def __init__(self, q: float | None, unit: tuple[float, str], rows: tuple[str, ...]) -> None:
        self.factor, self.unit = unit
        self.decimals = None if q is None else max(0, -int(np.floor(np.log10(q * self.factor) + 1e-9)))
        self.rows = rows

    def __call__(self, value: float, coarser: int = 0) -> str:
        """``value`` in the unit, to the print resolution (``coarser`` decimals fewer: offsets are whole 10·q)."""
        x = float(value) * self.factor
        text = f"{x:.6g}" if self.decimals is None else f"{x:.{max(0, self.decimals - coarser)}f}"
        return f"{text} {self.unit}".rstrip()


def _one_digit_differs(a: float, b: float, q: float | None) -> bool:
    """Whether ``a`` and ``b`` printed to the resolution ``q`` differ in exactly one digit (a print error's mark)."""
    if q is None:
        return False
    x, y = str(abs(round(a / q))), str(abs(round(b / q)))
    return len(x) == len(y) and sum(c != d for c, d in zip(x, y, strict=True)) == 1


def _mean_note(v: np.ndarray, j: int, src: tuple[int, ...], tol: np.ndarray, q: float | None, names: tuple[str, ...],
               show: _Shown) -> str:  # fmt: skip
    """ "X is the mean of A, B, C", and where it is not (the one row the rule allows off), by how much."""
    text = f"{names[j]} is the mean of {', '.join(names[k] for k in src)}"
    mean = v[:, list(src)].mean(axis=1)
    off = np.flatnonzero(np.abs(v[:, j] - mean) > tol)
    if off.size == 0:
        return text + " at every weight" + (" (to the print resolution)" if q is not None else "")
    i = int(off[0])
    printed = show(round(mean[i] / q) * q) if q is not None else show(mean[i])
    digit = " (one printed digit differs: a print error)" if _one_digit_differs(v[i, j], mean[i], q) else ""
    return (
        f"{text} at {v.shape[0] - 1} of {v.shape[0]} weights; at {show.rows[i]} it reads {show(v[i, j])} where the "
        f"mean is {printed}, {show(abs(v[i, j] - mean[i]))} off{digit}"
    )


def _offset_note(v: np.ndarray, head: int, group: list[int], q: float | None, names: tuple[str, ...],
                 show: _Shown) -> str:  # fmt: skip
    """ "X, Y = H + offsets …": each column's offset from the group's head, constant or changing with weight."""
    parts = []
    for j in group:
        if j == head:
            continue
        d = v[:, j] - v[:, head]
        if np.ptp(d) <= 1e-9 * max(float(np.abs(v).max()), 1e-300):
            parts.append(f"{names[j]} = {names[head]} + {show(d[0], 1)} at every weight")
        else:
            parts.append(
                f"{names[j]} − {names[head]} changes with weight, from {show(d.min(), 1)} to {show(d.max(), 1)}"
            )
    step = show(10 * (q or 0.0), 1)
    return (
        f"{'; '.join(parts)}: offsets that are whole multiples of {step} at every weight, as a column typed in as "
        f"{names[head]} + an offset (by chance 1 in 10^{v.shape[0]} per column)"
    )


def find_dependence(
    values: np.ndarray,
    labels: tuple[str, ...] | None = None,
    *,
    rows: tuple[str, ...] | None = None,
    unit: tuple[float, str] = (1.0, ""),
) -> SeriesDependence:
    """Find derived columns of a complete weights × series matrix ``values`` [any unit] (module docstring).

    ``labels`` name the columns, ``rows`` the rows (e.g. "5.44 kg"), ``unit`` (factor, name) how the notes show
    values (e.g. (1e3, "mΩ") for values in Ω)."""
    v = np.asarray(values, dtype=float)
    m, r = v.shape
    names = tuple(labels) if labels and len(labels) == r else tuple(f"series {k + 1}" for k in range(r))
    if r < 3 or not np.all(np.isfinite(v)):
        return SeriesDependence(tuple(range(r)), (), ())
    q = print_quantum(v)
    show = _Shown(q, unit, tuple(rows) if rows and len(rows) == m else tuple(f"row {i + 1}" for i in range(m)))
    tol = np.full(m, 1.0001 * q) if q is not None else 1e-12 * np.abs(v).max(axis=1)
    notes: list[str] = []
    means: dict[int, tuple[int, ...]] = {}
    for j in range(r):
        src = _mean_source(v, j, tol)
        if src:
            means[j] = src
            notes.append(_mean_note(v, j, src, tol, q, names, show))
    pairs = _offset_pairs(v, q)
    dropped: set[int] = set()
    for group in _groups(r, pairs):
        if len(group) > 1:
            head = next((j for j in group if j in means), group[0])
            notes.append(_offset_note(v, head, group, q, names, show))
        if any(j in means for j in group):
            dropped.update(group)
        else:
            dropped.update(group[1:])
    keep = tuple(k for k in range(r) if k not in dropped)
    if len(keep) < 2:  # nothing independent left to estimate a scatter: keep everything and say so
        notes.append("too few independent series would remain: every series is kept")
        return SeriesDependence(tuple(range(r)), (), tuple(notes))
    return SeriesDependence(keep, tuple(sorted(dropped)), tuple(notes))
