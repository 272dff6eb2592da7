"""Overlapping Allan deviation of a reading series: how the scatter of an average falls with averaging time.

For white noise the Allan deviation at ``m`` readings equals σ/√m (the standard error of an m-reading mean);
where drift or 1/f noise sets in it flattens or rises, and averaging longer stops paying. A user reads off how
many Delta readings buy a target precision.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contactrig.core.validation import SettingError, check_range

__all__ = ["AllanResult", "allan_deviation"]


@dataclass(frozen=True)
class AllanResult:
    """``tau_s[i]`` averaging time, ``m[i]`` readings per average, ``adev[i]`` Allan deviation (reading units),
    ``n_pairs[i]`` the number of overlapping difference pairs behind it."""

    tau_s: np.ndarray
    m: np.ndarray
    adev: np.ndarray
    n_pairs: np.ndarray


def allan_deviation(y: np.ndarray, interval_s: float, m: np.ndarray | None = None) -> AllanResult:
    """Overlapping Allan deviation of the readings ``y`` taken every ``interval_s`` seconds.

    σ²(m) = ½ ⟨(ȳ_{k+m} − ȳ_k)²⟩ over all k, ȳ_k the mean of y[k:k+m]. ``m`` defaults to octaves 1, 2, 4, …
    up to N/3 (so at least N/3 pairs). NaN readings (invalid, overflow) are an error: remove them first.
    """
    y = np.asarray(y, dtype=float)
    check_range("interval_s", interval_s, 0.0, None, lo_open=True, unit="s")
    if y.ndim != 1 or y.size < 3:
        raise SettingError("y", f"array of shape {y.shape}", "expected a 1-D series of at least 3 readings")
    if not np.all(np.isfinite(y)):
        raise SettingError("y", "NaN/inf readings", "expected finite readings (drop invalid ones first)")
    n = y.size
    if m is None:
        m = 2 ** np.arange(int(np.floor(np.log2(max(n // 3, 1)))) + 1)
    m = np.asarray(m, dtype=int)
    if np.any(m < 1) or np.any(2 * m > n):
        raise SettingError("m", m.tolist(), f"expected 1 <= m <= {n // 2} for {n} readings")
    c = np.concatenate(([0.0], np.cumsum(y - y.mean())))
    adev = np.empty(m.size)
    pairs = np.empty(m.size, dtype=int)
    for i, mi in enumerate(m):
        means = (c[mi:] - c[:-mi]) / mi  # ȳ_k for k = 0 … n − m
        d = means[mi:] - means[:-mi]
        adev[i] = np.sqrt(0.5 * np.mean(d * d))
        pairs[i] = d.size
    return AllanResult(tau_s=m * interval_s, m=m, adev=adev, n_pairs=pairs)
