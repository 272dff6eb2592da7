"""One block of readings, whatever instrument pair took it, and the one function that summarises it.

Every instrument pair (:mod:`instruments.pairs`) returns its blocks as a :class:`Block`: the readings as the
instrument returned them (invalid ones NaN), their timestamps, their unit, and the same readings in Ω. The block
statistics — mean, sample SD, standard error over the valid readings — are computed by :func:`block_statistics`
and nowhere else: the driver's summary, the session file, replay and the checks on load all call it, so their
results are bit-identical (replay compares them with ``==``). This module imports only numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

__all__ = ["Block", "BlockStatistics", "block_statistics"]


@dataclass(frozen=True)
class BlockStatistics:
    """Mean, sample standard deviation (ddof = 1) and standard error of the valid readings of one block.

    In the unit of the values they were computed from (V or Ω); ``n`` valid readings, ``n_invalid`` invalid ones.
    """

    mean: float
    sd: float
    sem: float
    n: int
    n_invalid: int


def block_statistics(values: np.ndarray, valid: np.ndarray) -> BlockStatistics:
    """Statistics of one block over its valid readings: mean, SD = √(Σ(x − x̄)²/(n − 1)), SEM = SD/√n.

    With no valid reading the mean is NaN; with one, SD and SEM are NaN (undefined, not zero).
    """
    x = np.asarray(values, dtype=np.float64)
    good = x[np.asarray(valid, dtype=bool)]
    n = int(good.size)
    mean = float(good.mean()) if n else math.nan
    sd = float(good.std(ddof=1)) if n > 1 else math.nan
    sem = sd / math.sqrt(n) if n > 1 else math.nan
    return BlockStatistics(mean=mean, sd=sd, sem=sem, n=n, n_invalid=int(x.size - n))


class Block(Protocol):
    """What every instrument pair's block gives (e.g. :class:`instruments.delta.DeltaBlock`).

    readings: as the instrument returned them, in ``unit``; invalid readings are NaN.
    timestamps_s: the instrument's timestamps in s (the first is 0). valid: boolean mask of valid readings.
    resistance_ohm(): the readings in Ω.
    """

    @property
    def readings(self) -> np.ndarray: ...

    @property
    def timestamps_s(self) -> np.ndarray: ...

    @property
    def unit(self) -> str: ...

    @property
    def valid(self) -> np.ndarray: ...

    def resistance_ohm(self) -> np.ndarray: ...
