"""Series that are arithmetic copies of others, found so that they are counted once.

A table of repeat series can hold columns computed from other columns: the seed paper's Tab. 1 has M4 = mean(M1,
M2, M3) (to the printed four decimals at 7 of 8 weights) and M5, M6 = M4 plus offsets with at most three decimals.
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


def find_dependence(values: np.ndarray, labels: tuple[str, ...] | None = None) -> SeriesDependence:
    """Find derived columns of a complete weights × series matrix ``values`` [any unit] (module docstring)."""
    v = np.asarray(values, dtype=float)
    m, r = v.shape
    names = tuple(labels) if labels and len(labels) == r else tuple(f"series {k + 1}" for k in range(r))
    if r < 3 or not np.all(np.isfinite(v)):
        return SeriesDependence(tuple(range(r)), (), ())
    q = print_quantum(v)
    tol = np.full(m, 1.0001 * q) if q is not None else 1e-12 * np.abs(v).max(axis=1)
    notes: list[str] = []
    means: dict[int, tuple[int, ...]] = {}
    for j in range(r):
        src = _mean_source(v, j, tol)
        if src:
            means[j] = src
            notes.append(f"{names[j]} is the mean of {', '.join(names[k] for k in src)}")
    pairs = _offset_pairs(v, q)
    dropped: set[int] = set()
    for group in _groups(r, pairs):
        if len(group) > 1:
            head = next((j for j in group if j in means), group[0])
            rest = ", ".join(names[j] for j in group if j != head)
            step = 10 * (q or 0.0)
            notes.append(f"{rest} = {names[head]} + round offsets (whole multiples of {step:.3g}) at every weight")
        if any(j in means for j in group):
            dropped.update(group)
        else:
            dropped.update(group[1:])
    keep = tuple(k for k in range(r) if k not in dropped)
    if len(keep) < 2:  # nothing independent left to estimate a scatter: keep everything and say so
        notes.append("too few independent series would remain: every series is kept")
        return SeriesDependence(tuple(range(r)), (), tuple(notes))
    return SeriesDependence(keep, tuple(sorted(dropped)), tuple(notes))
